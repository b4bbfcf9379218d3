// The photometric matching cost of PatchMatch stereo: one minus the
// bilateral-weighted normalised cross-correlation between a window of the
// reference image and its warp into a source image by the homography that a
// plane hypothesis induces (Schönberger et al., "Pixelwise View Selection for
// Unstructured Multi-View Stereo", ECCV 2016, §4.1 and eq. 2; bilateral
// weights as in Yoon & Kweon 2006):
//
//   w_k   = exp(-(I_r(p_k) - I_r(p))² / 2σ_c² - |p_k - p|² / 2σ_s²),  Σ w_k = 1
//   cost  = 1 - cov_w(r, s) / sqrt(var_w(r) · var_w(s))     ∈ [0, 2]
//
// The reference side (weights, centred values, variance) depends only on the
// reference pixel, so `RefWindow` computes it once per pixel and every
// hypothesis and source view reuses it. The source side is one loop over the
// window samples (homography, bilinear fetch, three weighted sums): an AVX2 +
// FMA kernel chosen at run time when the CPU has them (8 samples per step;
// each sample's 2×2 bilinear footprint is one 16-byte load from a
// `SamplingImage`, transposed in registers), else a portable loop over the
// same layout. `NccCostPlain` is the same cost as a straightforward loop, the
// baseline of benchmarks and tests. Hand-written: OpenCV's matchTemplate
// correlates axis-aligned windows only, not homography-warped, weighted ones.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "image/image.h"

namespace relight {

// Cost of a view that cannot see a hypothesis or a textureless window (1 - NCC is at most 2).
inline constexpr float kMaxNccCost = 2.0f;
// Weighted grey-level variance (images in [0, 1]) below which a window counts as textureless.
inline constexpr float kMinNccVariance = 1e-5f;

// Sample offsets of the matching window around a pixel, padded to a multiple of 8 with zero-weight samples.
struct WindowPattern {
  int radius = 0;                      // pixels
  int step = 1;                        // pixels between samples
  int num_samples = 0;                 // real samples
  std::vector<float> du, dv;           // offsets in pixels (padded entries 0)
  std::vector<int> di, dj;             // the same as integers (column, row)
  std::vector<float> spatial_weight;   // exp(-(du² + dv²) / 2σ_s²); padded entries 0
  int padded_size() const { return static_cast<int>(du.size()); }
};
// Offsets -radius, -radius + step, ... ≤ radius along each axis (COLMAP's window_radius / window_step).
WindowPattern MakeWindowPattern(int radius, int step, float sigma_spatial);

// The reference side of the cost at one pixel.
struct RefWindow {
  float u = 0, v = 0;        // pixel-centre coordinates of the pixel
  float variance = 0;        // weighted variance of the reference samples
  std::vector<float> w;      // normalised bilateral weights (padded)
  std::vector<float> w_centred;  // w_k · (r_k - weighted mean)
  // True when the window has enough texture to match.
  bool textured() const { return variance >= kMinNccVariance; }
};
// Fills `window` for pixel (col, row) of `ref` (1 channel); samples outside the image clamp to the border.
void PrepareRefWindow(const Image& ref, int col, int row, const WindowPattern& pattern, float sigma_color,
                      RefWindow* window);

// A source image laid out for warped sampling: pixel (x, y) stores I(x, y), I(x+1, y), I(x, y+1),
// I(x+1, y+1) (border-clamped), so a bilinear footprint is one contiguous load.
struct SamplingImage {
  int width = 0;
  int height = 0;
  std::vector<float> quads;  // 4 floats per pixel, row-major
  bool empty() const { return quads.empty(); }
};
// Builds the layout from a 1-channel image.
SamplingImage MakeSamplingImage(const Image& gray);

// Row-major 3×3 homography taking reference pixel coordinates (centres at +0.5) to source pixel coordinates.
using Homography = Eigen::Matrix<float, 3, 3, Eigen::RowMajor>;

// 1 - weighted NCC of the window against `src` (1 channel) warped by `H`. kMaxNccCost when the window
// centre maps behind the source camera or outside its image, or either side is textureless.
float NccCost(const RefWindow& window, const WindowPattern& pattern, const Homography& H, const SamplingImage& src);
// The same with the portable loop regardless of the CPU (for tests of both code paths).
float NccCostPortable(const RefWindow& window, const WindowPattern& pattern, const Homography& H,
                      const SamplingImage& src);
// True when NccCost runs the AVX2 + FMA kernel on this CPU.
bool NccCostUsesAvx2();

// The same cost as a plain loop: weights, means and variances recomputed per call in double precision,
// std::exp/std::floor per sample. Agrees with NccCost to float round-off.
float NccCostPlain(const Image& ref, int col, int row, int radius, int step, float sigma_color, float sigma_spatial,
                   const Homography& H, const Image& src);

}  // namespace relight
