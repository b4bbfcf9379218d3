// SIFT features on the log-chromaticity of a photo, added to COLMAP's grey
// SIFT features before matching.
//
// Why: two photos of the same surface under different light differ mostly in
// shading (a scalar per pixel) and in the light's colour (a scalar per
// channel). Grey SIFT sees both; the log-chromaticity channels log(R/G) and
// log(B/G) cancel the shading exactly for a Lambertian surface and turn the
// light's colour into an offset that SIFT's gradients ignore. On colour-
// textured objects whose light differs per photo they give several times the
// correct matches of grey SIFT (tools/match_oracle.py against ground truth,
// docs/RESULTS.md "Cameras"). Grey features stay: plaster, stone and grey
// surfaces carry no chromatic texture, and there the channels are flat and
// SIFT's contrast threshold finds little in them.
//
// Hand-written on OpenCV's SIFT because COLMAP's extractor works on grey
// images only. Features are upright (orientation 0): ingest turns photos
// upright, and a fixed orientation keeps matches that an orientation
// estimated on a weak chromatic gradient would lose.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace relight {

// Features in COLMAP's database layout: keypoints as rows of
// (x, y, a11, a12, a21, a22) in COLMAP pixel coordinates (the top-left corner
// of the image is (0, 0), the first pixel's centre (0.5, 0.5)), descriptors as
// rows of 128 bytes, RootSIFT scaled as COLMAP's own (512 x, clamped to 255).
struct FeatureSet {
  std::vector<float> keypoints;     // 6 floats per feature
  std::vector<uint8_t> descriptors;  // 128 bytes per feature
  int size() const { return static_cast<int>(descriptors.size() / 128); }
};

// The two log-chromaticity channels of an 8-bit BGR image as 8-bit images:
// 128 + kChromaGain * (log(c / g) - median over the image), c = r or b, each
// channel offset by 8 (of 255) so dark pixels do not blow up. The median
// removes the light's colour; the fixed gain keeps the same chromatic contrast
// a feature in every photo.
std::vector<cv::Mat> LogChromaticityChannels(const cv::Mat& bgr8);
inline constexpr double kChromaGain = 254;  // a log-ratio of +-0.5 spans the 8-bit range

// Upright SIFT features of both log-chromaticity channels of `bgr8`, at most
// `max_features` in all (the strongest of each channel, half each); the image
// is downscaled to `max_image_size` on its longer side first (coordinates are
// given in the full image).
FeatureSet ChromaFeatures(const cv::Mat& bgr8, int max_features, int max_image_size);

}  // namespace relight
