// Options of the `linearize` stage: photos to linear radiance with per-pixel confidence.
#pragma once

#include <string>

#include "core/error.h"
#include "core/options.h"
#include "core/stage.h"

namespace relight {

inline const StageInfo kLinearizeStage{
    "linearize", "Photos to linear radiance (inverse sRGB/gamma) with per-pixel confidence", 2, /*shardable=*/true};

struct LinearizeOptions {
  std::string transfer = "srgb";      // Transfer curve of 8/16-bit photos: srgb, gamma or linear.
  double gamma = 2.2;                 // Exponent when transfer = gamma.
  double saturation_level = 0.98;     // Encoded value at or above which a channel counts as clipped.
  double black_level = 0.004;         // Encoded value at or below which a channel counts as black-clipped.
  double black_confidence = 0.0;      // Confidence of black-clipped pixels (0: distrusted like over-exposed ones).
  int clip_dilation_px = 1;           // Also distrust pixels this close to a clipped pixel (blooming, JPEG ringing).
  bool normalize_exposure = true;     // Bring photos to a common scale with EXIF exposure when every photo has it.

  void Declare(OptionTable* t) {
    t->Add("transfer", &transfer,
           "Transfer curve of 8/16-bit photos: srgb (Internet photos), gamma (pure power law), linear (raw data). "
           "Float inputs (EXR/HDR) are always linear.")
        .Choices({"srgb", "gamma", "linear"});
    t->Add("gamma", &gamma, "Exponent of the power law when transfer = gamma.")
        .Range(1.0, 4.0)
        .OnlyWhen("transfer", {"gamma"});
    t->Add("saturation_level", &saturation_level,
           "Encoded value (0..1) at or above which a channel counts as over-exposed; such pixels get confidence 0.")
        .Range(0.5, 1.0);
    t->Add("black_level", &black_level,
           "Encoded value (0..1) at or below which a channel counts as black-clipped; such pixels get confidence "
           "linearize.black_confidence.")
        .Range(0.0, 0.2);
    t->Add("black_confidence", &black_confidence,
           "Confidence of black-clipped pixels. 0 distrusts them like over-exposed ones (Internet "
           "photos: crushed shadows hide their value); 1 keeps them as measurements of 'no light' "
           "(linear raw data, where an attached shadow is real darkness).")
        .Range(0.0, 1.0);
    t->Add("clip_dilation_px", &clip_dilation_px,
           "Pixels within this distance of a clipped pixel also get confidence 0 (blooming, JPEG ringing).")
        .Range(0, 16)
        .Advanced();
    t->Add("normalize_exposure", &normalize_exposure,
           "Scale photos to a common exposure (EXIF exposure time, f-number, ISO) when every photo has them.");
  }
  void Check() const {}
};

}  // namespace relight
