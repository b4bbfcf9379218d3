// The `linearize` stage: encoded photos to linear radiance plus a per-pixel
// confidence (0 where a channel is over-exposed or black-clipped). The seed
// assumes sRGB for Internet photos (Haber et al. 2009, §6.3); float inputs
// (EXR/HDR) pass through unchanged. Per-photo outputs are written atomically,
// so a killed run resumes photo by photo.
#pragma once

#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "image/image.h"
#include "radiometry/linearize_options.h"

namespace relight {


// Linear radiance and confidence of one encoded image.
struct LinearImage {
  Image radiance;    // RGB, linear
  Image confidence;  // 1 channel, in [0, 1]
  double clipped_fraction = 0;  // pixels with an over-exposed channel
  double black_fraction = 0;    // pixels with a black-clipped channel
  // Linear value at and above which a channel was over-exposed (the transfer
  // curve at saturation_level); infinity for float inputs, which do not clip.
  double overexposed_linear = std::numeric_limits<double>::infinity();
};

// Linearizes `encoded` (values as read from an 8/16-bit file, in [0,1]) or
// passes a float image through (`is_float`), and computes the confidence.
LinearImage Linearize(const Image& encoded, bool is_float, const LinearizeOptions& options);

// Relative exposure of a photo from EXIF: t · ISO / N² (proportional to the
// recorded value of a fixed scene radiance), or nullopt when a field is missing.
std::optional<double> ExifExposure(std::optional<double> exposure_time_s, std::optional<double> f_number,
                                   std::optional<double> iso);

struct LinearizeSummary {
  int photos = 0;
  int reused = 0;          // photos already linearized by an earlier (killed) run
  bool exposure_normalized = false;
  std::string exposure_note;  // why exposure normalisation was or was not applied
  double seconds = 0;

  // One line for the log.
  std::string BriefReport() const;
};

// Runs the stage on an ingest output folder; writes linear/, confidence/,
// stats/ and linearize_summary.json into `output_dir`. A photo's stats hold
// `overexposed_linear`: the linear radiance (after exposure normalisation) at
// and above which a channel of linear/ was over-exposed, null for float inputs;
// `observe` uses it to tell which channels of a clipped footprint clipped.
// With an active `shard` (one pass: step 0) only that shard's photos, and no summary.
struct LinearizeInputs {
  std::string ingest_dir;  // the ingest stage's folder
};
LinearizeSummary RunLinearize(const LinearizeOptions& options, const LinearizeInputs& inputs,
                              const std::string& output_dir, const ShardSpec& shard = {});

}  // namespace relight
