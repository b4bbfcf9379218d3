#include "mvs/ncc_cost.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define RELIGHT_MVS_AVX2 1
#endif

namespace relight {

WindowPattern MakeWindowPattern(int radius, int step, float sigma_spatial) {
  RELIGHT_CHECK(radius >= 1 && step >= 1 && step <= radius) << "radius " << radius << " step " << step;
  WindowPattern p;
  p.radius = radius;
  p.step = step;
  for (int dj = -radius; dj <= radius; dj += step) {
    for (int di = -radius; di <= radius; di += step) {
      p.di.push_back(di);
      p.dj.push_back(dj);
      p.du.push_back(float(di));
      p.dv.push_back(float(dj));
      p.spatial_weight.push_back(std::exp(-float(di * di + dj * dj) / (2.0f * sigma_spatial * sigma_spatial)));
    }
  }
  p.num_samples = static_cast<int>(p.du.size());
  while (p.du.size() % 8 != 0) {
    p.di.push_back(0);
    p.dj.push_back(0);
    p.du.push_back(0.0f);
    p.dv.push_back(0.0f);
    p.spatial_weight.push_back(0.0f);
  }
  return p;
}

void PrepareRefWindow(const Image& ref, int col, int row, const WindowPattern& pattern, float sigma_color,
                      RefWindow* window) {
  const int n = pattern.padded_size();
  window->u = col + 0.5f;
  window->v = row + 0.5f;
  window->w.resize(n);
  window->w_centred.resize(n);
  const float* img = ref.pixels.data();
  const int width = ref.width;
  const float center = img[size_t(row) * width + col];
  const float inv_2sc2 = 1.0f / (2.0f * sigma_color * sigma_color);
  float values[1024 + 8];
  std::vector<float> heap_values;
  float* r = values;
  if (n > 1024) {
    heap_values.resize(n);
    r = heap_values.data();
  }
  float sum_w = 0.0f;
  for (int k = 0; k < n; ++k) {
    const int x = std::clamp(col + pattern.di[k], 0, width - 1);
    const int y = std::clamp(row + pattern.dj[k], 0, ref.height - 1);
    r[k] = img[size_t(y) * width + x];
    const float dc = r[k] - center;
    window->w[k] = pattern.spatial_weight[k] * std::exp(-dc * dc * inv_2sc2);
    sum_w += window->w[k];
  }
  const float inv_sum = 1.0f / sum_w;
  float mean = 0.0f;
  for (int k = 0; k < n; ++k) {
    window->w[k] *= inv_sum;
    mean += window->w[k] * r[k];
  }
  float variance = 0.0f;
  for (int k = 0; k < n; ++k) {
    const float c = r[k] - mean;
    window->w_centred[k] = window->w[k] * c;
    variance += window->w_centred[k] * c;
  }
  window->variance = variance;
}

SamplingImage MakeSamplingImage(const Image& gray) {
  RELIGHT_CHECK_EQ(gray.channels, 1);
  SamplingImage out;
  out.width = gray.width;
  out.height = gray.height;
  out.quads.resize(size_t(gray.width) * gray.height * 4);
  for (int y = 0; y < gray.height; ++y) {
    const int y1 = std::min(y + 1, gray.height - 1);
    for (int x = 0; x < gray.width; ++x) {
      const int x1 = std::min(x + 1, gray.width - 1);
      float* q = &out.quads[(size_t(y) * gray.width + x) * 4];
      q[0] = gray.at(x, y);
      q[1] = gray.at(x1, y);
      q[2] = gray.at(x, y1);
      q[3] = gray.at(x1, y1);
    }
  }
  return out;
}

namespace {

// Arguments of the sample loop: Σ w s, Σ w s², Σ w (r - r̄) s over the window warped by H.
struct WarpArgs {
  const float* w;         // normalised weights (padded to a multiple of 8)
  const float* wc;        // weights × centred reference values
  const float* du;        // sample offsets
  const float* dv;
  int n;                  // padded sample count
  const float* h;         // row-major homography
  float b0, b1, b2;       // H · (u, v, 1)
  const float* quads;     // SamplingImage::quads
  int width, height;
};

void WarpedSumsPortable(const WarpArgs& a, float* out) {
  const float x_max = float(a.width - 1), y_max = float(a.height - 1);
  float sw = 0.0f, sww = 0.0f, swr = 0.0f;
  for (int k = 0; k < a.n; ++k) {
    const float hx = a.b0 + a.du[k] * a.h[0] + a.dv[k] * a.h[1];
    const float hy = a.b1 + a.du[k] * a.h[3] + a.dv[k] * a.h[4];
    const float hz = a.b2 + a.du[k] * a.h[6] + a.dv[k] * a.h[7];
    const float iz = 1.0f / hz;
    float x = hx * iz - 0.5f;
    float y = hy * iz - 0.5f;
    // Clamp to the border; written so that NaN (a sample behind the camera) also clamps.
    x = x > 0.0f ? x : 0.0f;
    x = x < x_max ? x : x_max;
    y = y > 0.0f ? y : 0.0f;
    y = y < y_max ? y : y_max;
    const int xi = static_cast<int>(x), yi = static_cast<int>(y);
    const float fx = x - float(xi), fy = y - float(yi);
    const float* q = a.quads + (size_t(yi) * a.width + xi) * 4;
    const float top = q[0] + fx * (q[1] - q[0]);
    const float bottom = q[2] + fx * (q[3] - q[2]);
    const float s = top + fy * (bottom - top);
    sw += a.w[k] * s;
    sww += a.w[k] * s * s;
    swr += a.wc[k] * s;
  }
  out[0] = sw;
  out[1] = sww;
  out[2] = swr;
}

#ifdef RELIGHT_MVS_AVX2
__attribute__((target("avx2,fma"))) float HorizontalSum(__m256 v) {
  const __m128 s = _mm_add_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps(v, 1));
  const __m128 t = _mm_add_ps(s, _mm_movehl_ps(s, s));
  return _mm_cvtss_f32(_mm_add_ss(t, _mm_shuffle_ps(t, t, 1)));
}

// Eight samples per step; each sample's 2×2 footprint is one 16-byte load, transposed into four vectors.
__attribute__((target("avx2,fma"))) void WarpedSumsAvx2(const WarpArgs& a, float* out) {
  const __m256 h0 = _mm256_set1_ps(a.h[0]), h1 = _mm256_set1_ps(a.h[1]);
  const __m256 h3 = _mm256_set1_ps(a.h[3]), h4 = _mm256_set1_ps(a.h[4]);
  const __m256 h6 = _mm256_set1_ps(a.h[6]), h7 = _mm256_set1_ps(a.h[7]);
  const __m256 b0 = _mm256_set1_ps(a.b0), b1 = _mm256_set1_ps(a.b1), b2 = _mm256_set1_ps(a.b2);
  const __m256 half = _mm256_set1_ps(0.5f), zero = _mm256_setzero_ps();
  const __m256 x_max = _mm256_set1_ps(float(a.width - 1)), y_max = _mm256_set1_ps(float(a.height - 1));
  const __m256i width = _mm256_set1_epi32(a.width);
  __m256 sw = zero, sww = zero, swr = zero;
  alignas(32) int idx[8];
  for (int k = 0; k < a.n; k += 8) {
    const __m256 du = _mm256_loadu_ps(a.du + k), dv = _mm256_loadu_ps(a.dv + k);
    const __m256 hx = _mm256_fmadd_ps(dv, h1, _mm256_fmadd_ps(du, h0, b0));
    const __m256 hy = _mm256_fmadd_ps(dv, h4, _mm256_fmadd_ps(du, h3, b1));
    const __m256 hz = _mm256_fmadd_ps(dv, h7, _mm256_fmadd_ps(du, h6, b2));
    // 1/hz: reciprocal estimate refined by one Newton step (relative error ~1e-7).
    const __m256 r = _mm256_rcp_ps(hz);
    const __m256 iz = _mm256_mul_ps(r, _mm256_fnmadd_ps(hz, r, _mm256_set1_ps(2.0f)));
    // max(x, 0) returns 0 for NaN (the second operand), then clamp above.
    const __m256 x = _mm256_min_ps(_mm256_max_ps(_mm256_fmsub_ps(hx, iz, half), zero), x_max);
    const __m256 y = _mm256_min_ps(_mm256_max_ps(_mm256_fmsub_ps(hy, iz, half), zero), y_max);
    const __m256i xi = _mm256_cvttps_epi32(x), yi = _mm256_cvttps_epi32(y);
    const __m256 fx = _mm256_sub_ps(x, _mm256_cvtepi32_ps(xi));
    const __m256 fy = _mm256_sub_ps(y, _mm256_cvtepi32_ps(yi));
    _mm256_store_si256(reinterpret_cast<__m256i*>(idx), _mm256_add_epi32(_mm256_mullo_epi32(yi, width), xi));
    const float* q = a.quads;
    const __m256 r0 = _mm256_set_m128(_mm_loadu_ps(q + 4 * size_t(idx[4])), _mm_loadu_ps(q + 4 * size_t(idx[0])));
    const __m256 r1 = _mm256_set_m128(_mm_loadu_ps(q + 4 * size_t(idx[5])), _mm_loadu_ps(q + 4 * size_t(idx[1])));
    const __m256 r2 = _mm256_set_m128(_mm_loadu_ps(q + 4 * size_t(idx[6])), _mm_loadu_ps(q + 4 * size_t(idx[2])));
    const __m256 r3 = _mm256_set_m128(_mm_loadu_ps(q + 4 * size_t(idx[7])), _mm_loadu_ps(q + 4 * size_t(idx[3])));
    // 4×4 transpose per 128-bit lane: rows are samples, columns s00, s01, s10, s11.
    const __m256 t0 = _mm256_unpacklo_ps(r0, r1), t1 = _mm256_unpackhi_ps(r0, r1);
    const __m256 t2 = _mm256_unpacklo_ps(r2, r3), t3 = _mm256_unpackhi_ps(r2, r3);
    const __m256 s00 = _mm256_castpd_ps(_mm256_unpacklo_pd(_mm256_castps_pd(t0), _mm256_castps_pd(t2)));
    const __m256 s01 = _mm256_castpd_ps(_mm256_unpackhi_pd(_mm256_castps_pd(t0), _mm256_castps_pd(t2)));
    const __m256 s10 = _mm256_castpd_ps(_mm256_unpacklo_pd(_mm256_castps_pd(t1), _mm256_castps_pd(t3)));
    const __m256 s11 = _mm256_castpd_ps(_mm256_unpackhi_pd(_mm256_castps_pd(t1), _mm256_castps_pd(t3)));
    const __m256 top = _mm256_fmadd_ps(fx, _mm256_sub_ps(s01, s00), s00);
    const __m256 bottom = _mm256_fmadd_ps(fx, _mm256_sub_ps(s11, s10), s10);
    const __m256 s = _mm256_fmadd_ps(fy, _mm256_sub_ps(bottom, top), top);
    const __m256 w = _mm256_loadu_ps(a.w + k);
    const __m256 ws = _mm256_mul_ps(w, s);
    sw = _mm256_add_ps(sw, ws);
    sww = _mm256_fmadd_ps(ws, s, sww);
    swr = _mm256_fmadd_ps(_mm256_loadu_ps(a.wc + k), s, swr);
  }
  out[0] = HorizontalSum(sw);
  out[1] = HorizontalSum(sww);
  out[2] = HorizontalSum(swr);
}

bool CpuHasAvx2() {
  __builtin_cpu_init();  // runs during static initialisation
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
}
#else
bool CpuHasAvx2() { return false; }
#endif

using WarpedSumsFn = void (*)(const WarpArgs&, float*);
const WarpedSumsFn kWarpedSums =
#ifdef RELIGHT_MVS_AVX2
    CpuHasAvx2() ? &WarpedSumsAvx2 :
#endif
                 &WarpedSumsPortable;

// Window centre maps in front of the camera and inside the image (pixel-centre coordinates); no division.
inline bool CenterVisible(float b0, float b1, float b2, int width, int height) {
  return b2 > 0.0f && b0 >= 0.0f && b0 <= float(width) * b2 && b1 >= 0.0f && b1 <= float(height) * b2;
}

template <typename T>
inline float CostFromStats(T cov, T var_r, T var_s) {
  if (!(var_r >= T(kMinNccVariance)) || !(var_s >= T(kMinNccVariance))) return kMaxNccCost;
  const T ncc = cov / std::sqrt(var_r * var_s);
  return static_cast<float>(std::clamp(T(1) - ncc, T(0), T(kMaxNccCost)));
}

}  // namespace

namespace {

float NccCostWith(WarpedSumsFn fn, const RefWindow& window, const WindowPattern& pattern, const Homography& H,
                  const SamplingImage& src) {
  if (!window.textured()) return kMaxNccCost;
  const float* h = H.data();
  WarpArgs args;
  args.b0 = h[0] * window.u + h[1] * window.v + h[2];
  args.b1 = h[3] * window.u + h[4] * window.v + h[5];
  args.b2 = h[6] * window.u + h[7] * window.v + h[8];
  if (!CenterVisible(args.b0, args.b1, args.b2, src.width, src.height)) return kMaxNccCost;
  args.w = window.w.data();
  args.wc = window.w_centred.data();
  args.du = pattern.du.data();
  args.dv = pattern.dv.data();
  args.n = pattern.padded_size();
  args.h = h;
  args.quads = src.quads.data();
  args.width = src.width;
  args.height = src.height;
  float sums[3];
  fn(args, sums);
  const float var_s = sums[1] - sums[0] * sums[0];
  return CostFromStats(sums[2], window.variance, var_s);
}

}  // namespace

float NccCost(const RefWindow& window, const WindowPattern& pattern, const Homography& H, const SamplingImage& src) {
  return NccCostWith(kWarpedSums, window, pattern, H, src);
}

float NccCostPortable(const RefWindow& window, const WindowPattern& pattern, const Homography& H,
                      const SamplingImage& src) {
  return NccCostWith(&WarpedSumsPortable, window, pattern, H, src);
}

bool NccCostUsesAvx2() { return kWarpedSums != &WarpedSumsPortable; }

float NccCostPlain(const Image& ref, int col, int row, int radius, int step, float sigma_color, float sigma_spatial,
                   const Homography& H, const Image& src) {
  const double u = col + 0.5, v = row + 0.5;
  const Eigen::Vector3d c = H.cast<double>() * Eigen::Vector3d(u, v, 1.0);
  if (!CenterVisible(float(c[0]), float(c[1]), float(c[2]), src.width, src.height)) return kMaxNccCost;
  const double center = ref.at(col, row);
  double sum_w = 0, sum_wr = 0, sum_ws = 0, sum_wrr = 0, sum_wss = 0, sum_wrs = 0;
  for (int dj = -radius; dj <= radius; dj += step) {
    for (int di = -radius; di <= radius; di += step) {
      const int rx = std::clamp(col + di, 0, ref.width - 1);
      const int ry = std::clamp(row + dj, 0, ref.height - 1);
      const double r = ref.at(rx, ry);
      const double w = std::exp(-(r - center) * (r - center) / (2.0 * sigma_color * sigma_color) -
                                double(di * di + dj * dj) / (2.0 * sigma_spatial * sigma_spatial));
      const Eigen::Vector3d p = H.cast<double>() * Eigen::Vector3d(u + di, v + dj, 1.0);
      double x = p[0] / p[2] - 0.5, y = p[1] / p[2] - 0.5;
      if (!(x > 0.0)) x = 0.0;
      if (!(y > 0.0)) y = 0.0;
      x = std::min(x, src.width - 1.0);
      y = std::min(y, src.height - 1.0);
      const int xi = static_cast<int>(std::floor(x)), yi = static_cast<int>(std::floor(y));
      const int xj = std::min(xi + 1, src.width - 1), yj = std::min(yi + 1, src.height - 1);
      const double fx = x - xi, fy = y - yi;
      const double s = (1 - fx) * (1 - fy) * src.at(xi, yi) + fx * (1 - fy) * src.at(xj, yi) +
                       (1 - fx) * fy * src.at(xi, yj) + fx * fy * src.at(xj, yj);
      sum_w += w;
      sum_wr += w * r;
      sum_ws += w * s;
      sum_wrr += w * r * r;
      sum_wss += w * s * s;
      sum_wrs += w * r * s;
    }
  }
  const double mean_r = sum_wr / sum_w, mean_s = sum_ws / sum_w;
  const double var_r = sum_wrr / sum_w - mean_r * mean_r;
  const double var_s = sum_wss / sum_w - mean_s * mean_s;
  const double cov = sum_wrs / sum_w - mean_r * mean_s;
  return CostFromStats(cov, var_r, var_s);
}

}  // namespace relight
