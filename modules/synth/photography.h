// From rendered radiance to a downloaded-looking photo: white balance, exposure,
// sensor noise, clipping, sRGB encoding (the JPEG is written by the caller).
//
//   sensor_c = exposure * white_balance_c * radiance_c          (linear, full scale 1)
//   raw_c    = sensor_c + N(0, noise_shot * max(sensor_c, 0) + noise_read^2)
//   encoded_c = srgb(clamp(raw_c, 0, 1))                         (IEC 61966-2-1)
//
// Auto white balance is grey world over the pixels below the 95th luminance
// percentile (so the sun and highlights do not tint the estimate), normalised
// to green; auto exposure maps the log-average luminance of the white-balanced
// frame to `exposure_key` (Reinhard et al. 2002's key value), then offsets it by
// a random number of stops.
#pragma once

#include <Eigen/Core>

#include "image/color.h"
#include "image/image.h"
#include "render/rng.h"

namespace relight {

// The camera's processing of one photo.
struct PhotoSettings {
  double exposure = 1.0;                                    // sensor value per unit radiance (after white balance)
  Eigen::Vector3d white_balance = Eigen::Vector3d::Ones();  // per-channel gains, green = 1
  double exposure_offset_ev = 0;                            // the random offset already in `exposure` [stops]
  double noise_shot = 0;                                    // shot-noise variance per unit sensor value
  double noise_read = 0;                                    // read-noise standard deviation
  int jpeg_quality = 90;                                    // quality of the written JPEG
};

// Parameters of the automatic choices.
struct PhotoStyle {
  bool auto_white_balance = true;         // grey world; false: gains 1
  double white_balance_jitter_ev = 0.15;  // std. dev. of the red and blue gains' random error [stops]
  double exposure_key = 0.18;             // sensor value the log-average luminance is mapped to
  double exposure_jitter_ev = 0.7;        // exposure offset uniform in [-jitter, jitter] [stops]
  double noise_shot = 4e-4;               // shot-noise variance per unit sensor value
  double noise_read = 2e-3;               // read-noise standard deviation
  int jpeg_quality_min = 80;              // JPEG quality uniform integer in [min, max]
  int jpeg_quality_max = 95;
};

// The settings a camera would choose for `radiance` (linear RGB), with random jitter from `rng`.
PhotoSettings ChoosePhotoSettings(const Image& radiance, const PhotoStyle& style, Pcg32* rng);
// The noise-free, unclipped sensor image exposure * white_balance * radiance.
Image SensorImage(const Image& radiance, const PhotoSettings& settings);
// The encoded photo (sRGB, [0, 1]) with noise drawn from `rng`; `clipped_fraction`
// (if given) receives the fraction of pixel channels that clipped at 1.
Image DevelopPhoto(const Image& radiance, const PhotoSettings& settings, Pcg32* rng,
                   double* clipped_fraction = nullptr);


}  // namespace relight
