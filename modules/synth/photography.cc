#include "synth/photography.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/error.h"

namespace relight {
namespace {

double Lum(const float* p) { return Luminance(p); }

}  // namespace

PhotoSettings ChoosePhotoSettings(const Image& radiance, const PhotoStyle& style, Pcg32* rng) {
  RELIGHT_CHECK_EQ(radiance.channels, 3);
  const size_t n = size_t(radiance.width) * radiance.height;
  RELIGHT_CHECK_GT(n, size_t(0));
  PhotoSettings s;
  s.noise_shot = style.noise_shot;
  s.noise_read = style.noise_read;
  s.jpeg_quality =
      style.jpeg_quality_min + int(rng->UniformInt(uint32_t(style.jpeg_quality_max - style.jpeg_quality_min + 1)));
  // Grey world over the pixels below the 95th luminance percentile.
  std::vector<double> lum(n);
  for (size_t i = 0; i < n; ++i) lum[i] = Lum(&radiance.pixels[3 * i]);
  std::vector<double> sorted = lum;
  const size_t k = std::min(n - 1, size_t(0.95 * n));
  std::nth_element(sorted.begin(), sorted.begin() + k, sorted.end());
  const double cap = sorted[k];
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < n; ++i) {
    if (lum[i] > cap) continue;
    for (int c = 0; c < 3; ++c) mean[c] += std::max(0.0f, radiance.pixels[3 * i + c]);
  }
  Eigen::Vector3d wb = Eigen::Vector3d::Ones();
  if (style.auto_white_balance && mean.minCoeff() > 0) {
    wb = Eigen::Vector3d(mean.y() / mean.x(), 1.0, mean.y() / mean.z());
    wb = wb.cwiseMax(0.25).cwiseMin(4.0);
  }
  wb.x() *= std::exp2(style.white_balance_jitter_ev * rng->Normal());
  wb.z() *= std::exp2(style.white_balance_jitter_ev * rng->Normal());
  s.white_balance = wb;
  // Log-average luminance of the white-balanced frame (delta keeps black pixels finite).
  double mean_lum = 0;
  for (size_t i = 0; i < n; ++i) {
    const float* p = &radiance.pixels[3 * i];
    mean_lum += 0.2126 * wb.x() * p[0] + 0.7152 * p[1] + 0.0722 * wb.z() * p[2];
  }
  mean_lum /= n;
  double log_sum = 0;
  const double delta = std::max(1e-12, 1e-3 * mean_lum);
  for (size_t i = 0; i < n; ++i) {
    const float* p = &radiance.pixels[3 * i];
    log_sum += std::log(delta + std::max(0.0, 0.2126 * wb.x() * p[0] + 0.7152 * p[1] + 0.0722 * wb.z() * p[2]));
  }
  const double log_average = std::exp(log_sum / n);
  s.exposure_offset_ev = rng->Uniform(-1, 1) * style.exposure_jitter_ev;
  s.exposure = (log_average > 0 ? style.exposure_key / log_average : 1.0) * std::exp2(s.exposure_offset_ev);
  return s;
}

Image SensorImage(const Image& radiance, const PhotoSettings& s) {
  Image out = radiance;
  const size_t n = size_t(out.width) * out.height;
  for (size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c)
      out.pixels[3 * i + c] = float(s.exposure * s.white_balance[c] * radiance.pixels[3 * i + c]);
  return out;
}

Image DevelopPhoto(const Image& radiance, const PhotoSettings& s, Pcg32* rng, double* clipped_fraction) {
  Image out = SensorImage(radiance, s);
  size_t clipped = 0;
  for (float& v : out.pixels) {
    const double sensor = v;
    const double sigma = std::sqrt(s.noise_shot * std::max(sensor, 0.0) + s.noise_read * s.noise_read);
    const double raw = sensor + sigma * rng->Normal();
    if (raw >= 1.0) ++clipped;
    v = float(SrgbEncode(std::clamp(raw, 0.0, 1.0)));
  }
  if (clipped_fraction != nullptr) *clipped_fraction = out.pixels.empty() ? 0.0 : double(clipped) / out.pixels.size();
  return out;
}

}  // namespace relight
