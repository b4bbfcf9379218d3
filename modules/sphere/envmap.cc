#include "sphere/envmap.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/log.h"
#include "sphere/octahedral.h"

namespace relight {

Eigen::Vector3d BrightestLobeDirection(const Image& octahedral, double threshold_fraction) {
  const int n = octahedral.width;
  RELIGHT_CHECK(octahedral.height == n && IsPowerOfTwo(n) && octahedral.channels >= 3)
      << "a square RGB octahedral image, got " << octahedral.width << "x" << octahedral.height << "x"
      << octahedral.channels;
  std::vector<double> luminance(size_t(n) * n);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      luminance[size_t(j) * n + i] = Luminance(octahedral.at(i, j, 0), octahedral.at(i, j, 1), octahedral.at(i, j, 2));
  return BrightestLobeDirection(luminance, n, threshold_fraction);
}
namespace {

Image ToRgb(Image image, const std::string& what) {
  RELIGHT_CHECK(!image.empty()) << what << ": empty image";
  if (image.channels == 3) return image;
  RELIGHT_CHECK(image.channels >= 1) << what;
  Image rgb(image.width, image.height, 3);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < 3; ++c) rgb.at(x, y, c) = image.at(x, y, image.channels >= 3 ? c : 0);
  return rgb;
}

// Index of the first cdf entry > u (cdf is increasing with cdf.back() == 1), in [0, size-2].
int FindInterval(const std::vector<double>& cdf, double u) {
  const auto it = std::upper_bound(cdf.begin(), cdf.end(), u);
  return std::clamp(int(it - cdf.begin()) - 1, 0, int(cdf.size()) - 2);
}

}  // namespace

// Piecewise-constant 2D distribution over the stored pixels.
struct EnvMap::Sampler {
  int width = 0, height = 0;
  std::vector<double> pixel_prob;  // probability of each pixel, row-major
  std::vector<double> row_cdf;     // marginal over rows, height + 1 entries
  std::vector<double> col_cdf;     // per row, width + 1 entries each
};

EnvMap EnvMap::FromLatLong(Image image) {
  EnvMap env;
  env.image_ = ToRgb(std::move(image), "EnvMap::FromLatLong");
  RELIGHT_CHECK_EQ(env.image_.width, 2 * env.image_.height) << "lat-long maps are 2:1";
  env.layout_ = Layout::kLatLong;
  return env;
}

EnvMap EnvMap::FromOctahedral(Image image) {
  EnvMap env;
  env.image_ = ToRgb(std::move(image), "EnvMap::FromOctahedral");
  RELIGHT_CHECK_EQ(env.image_.width, env.image_.height) << "octahedral maps are square";
  RELIGHT_CHECK(IsPowerOfTwo(env.image_.width)) << "octahedral side " << env.image_.width << " is not a power of two";
  env.layout_ = Layout::kOctahedral;
  env.oct_solid_angles_ = OctTexelSolidAngles(env.image_.width);
  return env;
}

EnvMap EnvMap::Load(const std::string& path) {
  Image image = ReadImage(path, nullptr, /*apply_orientation=*/false);
  if (image.width != 2 * image.height) {
    RELIGHT_USER_ERROR() << "environment map " << path << " is " << image.width << "x" << image.height
                         << ", not a 2:1 lat-long image: convert it to an equirectangular (lat-long) map";
  }
  // Radiance is finite: one NaN texel turns every render that samples it into NaN, so NaN and infinity are
  // errors. Small negative values are common in real HDR files (lossy EXR compression, resampling filters:
  // Blender's own city.exr has 506): they are clamped to zero, with a warning.
  size_t bad = 0, first = 0, negative = 0;
  float most_negative = 0;
  for (size_t i = 0; i < image.pixels.size(); ++i) {
    float& v = image.pixels[i];
    if (!std::isfinite(v)) {
      if (bad++ == 0) first = i;
    } else if (v < 0.0f) {
      ++negative;
      most_negative = std::min(most_negative, v);
      v = 0.0f;
    }
  }
  if (bad > 0) {
    const size_t pixel = first / image.channels;
    RELIGHT_USER_ERROR() << "environment map " << path << " has " << bad << " NaN or infinite "
                         << (bad == 1 ? "value" : "values") << " (the first at pixel ("
                         << pixel % image.width << ", " << pixel / image.width << "), channel "
                         << first % image.channels << ": " << image.pixels[first]
                         << "); radiance must be finite: repair or replace the map";
  }
  if (negative > 0) {
    RLOG_WARN("environment map {}: {} negative values (down to {:.3g}) clamped to zero", path, negative,
              most_negative);
  }
  return FromLatLong(std::move(image));
}

Eigen::Vector3d EnvMap::Fetch(int x, int y) const {
  const int w = image_.width, h = image_.height;
  if (layout_ == Layout::kLatLong) {
    if (y < 0) {  // across the north pole: the opposite azimuth
      y = -1 - y;
      x += w / 2;
    } else if (y >= h) {
      y = 2 * h - 1 - y;
      x += w / 2;
    }
    x %= w;
    if (x < 0) x += w;
  } else {
    const Eigen::Vector2i ij = OctWrapTexel(x, y, w);
    x = ij.x();
    y = ij.y();
  }
  const float* p = &image_.pixels[(size_t(y) * w + x) * 3];
  return {p[0], p[1], p[2]};
}

Eigen::Vector3d EnvMap::LookupStored(const Eigen::Vector3d& d) const {
  double u, v;
  if (layout_ == Layout::kLatLong) {
    const double r = d.norm();
    const double theta = std::acos(std::clamp(d.z() / r, -1.0, 1.0));
    double phi = std::atan2(d.y(), d.x());
    if (phi < 0) phi += 2 * M_PI;
    u = phi / (2 * M_PI);
    v = theta / M_PI;
  } else {
    const Eigen::Vector2d st = OctEncode(d);
    u = st.x();
    v = st.y();
  }
  const double x = u * image_.width - 0.5, y = v * image_.height - 0.5;
  const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
  const double fx = x - x0, fy = y - y0;
  return (1 - fy) * ((1 - fx) * Fetch(x0, y0) + fx * Fetch(x0 + 1, y0)) +
         fy * ((1 - fx) * Fetch(x0, y0 + 1) + fx * Fetch(x0 + 1, y0 + 1));
}

Eigen::Vector3d EnvMap::Lookup(const Eigen::Vector3d& dir_world) const {
  RELIGHT_CHECK(!empty()) << "EnvMap::Lookup on an empty map";
  return intensity_ * LookupStored(rotation_world_.transpose() * dir_world);
}

Eigen::Vector3d EnvMap::LookupNearest(const Eigen::Vector3d& dir_world) const {
  RELIGHT_CHECK(!empty()) << "EnvMap::LookupNearest on an empty map";
  const Eigen::Vector3d d = rotation_world_.transpose() * dir_world;
  int x, y;
  if (layout_ == Layout::kLatLong) {
    const double theta = std::acos(std::clamp(d.z() / d.norm(), -1.0, 1.0));
    double phi = std::atan2(d.y(), d.x());
    if (phi < 0) phi += 2 * M_PI;
    x = std::clamp(int(phi / (2 * M_PI) * image_.width), 0, image_.width - 1);
    y = std::clamp(int(theta / M_PI * image_.height), 0, image_.height - 1);
  } else {
    const Eigen::Vector2i ij = OctTexelOf(d, image_.width);
    x = ij.x();
    y = ij.y();
  }
  return intensity_ * Fetch(x, y);
}

Eigen::Vector3d EnvMap::StoredDirection(double u, double v, double* jacobian) const {
  if (layout_ == Layout::kLatLong) {
    const double theta = M_PI * v, phi = 2 * M_PI * u;
    const double st = std::sin(theta);
    *jacobian = 2 * M_PI * M_PI * st;
    return {st * std::cos(phi), st * std::sin(phi), std::cos(theta)};
  }
  *jacobian = OctJacobian({u, v});
  return OctDecode({u, v});
}

double EnvMap::PixelSolidAngle(int x, int y) const {
  if (layout_ == Layout::kLatLong) {
    const double h = image_.height;
    return 2 * M_PI / image_.width * (std::cos(M_PI * y / h) - std::cos(M_PI * (y + 1) / h));
  }
  return oct_solid_angles_[size_t(y) * image_.width + x];
}

int EnvMap::AutoSupersampling(double target_pixel_rad) const {
  // Angular size of a stored pixel: lat-long pi / h; octahedral about pi / (sqrt(2) n) at the zenith.
  const double stored_rad = layout_ == Layout::kLatLong ? M_PI / image_.height : M_PI / (std::sqrt(2.0) * image_.width);
  return std::clamp(int(std::ceil(8.0 * target_pixel_rad / stored_rad)), 2, 64);
}

int EnvMap::CoveringSupersampling(double target_pixel_rad) const {
  // A stored pixel's mean angular size: lat-long pi / h, octahedral sqrt(4 pi) / n.
  const double stored_rad = layout_ == Layout::kLatLong ? M_PI / image_.height : std::sqrt(4 * M_PI) / image_.width;
  return std::clamp(static_cast<int>(std::ceil(target_pixel_rad / stored_rad)) + 1, 2, 64);
}

Image EnvMap::ToLatLong(int height, int supersampling) const {
  RELIGHT_CHECK_GT(height, 0);
  if (supersampling == 0) supersampling = AutoSupersampling(M_PI / height);
  RELIGHT_CHECK_GT(supersampling, 0);
  const int width = 2 * height;
  Image out(width, height, 3);
  tbb::parallel_for(0, height, [&](int y) {
    for (int x = 0; x < width; ++x) {
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      double wsum = 0;
      for (int sy = 0; sy < supersampling; ++sy) {
        const double theta = M_PI * (y + (sy + 0.5) / supersampling) / height;
        const double w = std::sin(theta);
        for (int sx = 0; sx < supersampling; ++sx) {
          const double phi = 2 * M_PI * (x + (sx + 0.5) / supersampling) / width;
          const Eigen::Vector3d d(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
          sum += w * Lookup(d);
          wsum += w;
        }
      }
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = float(sum[c] / wsum);
    }
  });
  return out;
}

Image EnvMap::ToOctahedral(int n, int supersampling) const {
  RELIGHT_CHECK(IsPowerOfTwo(n)) << "octahedral side " << n << " is not a power of two";
  if (supersampling == 0) supersampling = AutoSupersampling(M_PI / (std::sqrt(2.0) * n));
  Image out(n, n, 3);
  tbb::parallel_for(0, n, [&](int j) {
    for (int i = 0; i < n; ++i) {
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      double wsum = 0;
      for (int sy = 0; sy < supersampling; ++sy) {
        for (int sx = 0; sx < supersampling; ++sx) {
          const Eigen::Vector2d st((i + (sx + 0.5) / supersampling) / n, (j + (sy + 0.5) / supersampling) / n);
          const double w = OctJacobian(st);
          sum += w * Lookup(OctDecode(st));
          wsum += w;
        }
      }
      for (int c = 0; c < 3; ++c) out.at(i, j, c) = float(sum[c] / wsum);
    }
  });
  return out;
}

EnvMap EnvMap::Transformed(const Eigen::Matrix3d& rotation_world, double intensity) const {
  RELIGHT_CHECK((rotation_world * rotation_world.transpose() - Eigen::Matrix3d::Identity()).norm() < 1e-6)
      << "EnvMap::Transformed needs a rotation matrix";
  EnvMap out = *this;
  out.rotation_world_ = rotation_world * rotation_world_;
  out.intensity_ = intensity * intensity_;
  return out;
}

void EnvMap::PrepareSampling() {
  RELIGHT_CHECK(!empty());
  auto s = std::make_shared<Sampler>();
  const int w = image_.width, h = image_.height;
  s->width = w;
  s->height = h;
  std::vector<double> lum(size_t(w) * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) lum[size_t(y) * w + x] = std::max(0.0, Luminance(Fetch(x, y)));
  s->pixel_prob.resize(size_t(w) * h);
  double total = 0;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      double neighbourhood = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
          neighbourhood = std::max(neighbourhood, std::max(0.0, Luminance(Fetch(x + dx, y + dy))));
      const double weight = (0.5 * lum[size_t(y) * w + x] + 0.5 * neighbourhood) * PixelSolidAngle(x, y);
      s->pixel_prob[size_t(y) * w + x] = weight;
      total += weight;
    }
  }
  if (!(total > 0)) {  // black map: sample by solid angle
    total = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) total += s->pixel_prob[size_t(y) * w + x] = PixelSolidAngle(x, y);
  }
  for (double& p : s->pixel_prob) p /= total;
  s->row_cdf.assign(h + 1, 0.0);
  s->col_cdf.assign(size_t(h) * (w + 1), 0.0);
  for (int y = 0; y < h; ++y) {
    double* cdf = &s->col_cdf[size_t(y) * (w + 1)];
    for (int x = 0; x < w; ++x) cdf[x + 1] = cdf[x] + s->pixel_prob[size_t(y) * w + x];
    s->row_cdf[y + 1] = s->row_cdf[y] + cdf[w];
    if (cdf[w] > 0) {
      for (int x = 1; x <= w; ++x) cdf[x] /= cdf[w];
    } else {
      for (int x = 1; x <= w; ++x) cdf[x] = double(x) / w;
    }
  }
  for (int y = 1; y <= h; ++y) s->row_cdf[y] /= s->row_cdf[h];
  sampler_ = std::move(s);
}

Eigen::Vector3d EnvMap::Sample(double u1, double u2, double* pdf_sr) const {
  RELIGHT_CHECK(sampler_) << "EnvMap::Sample before PrepareSampling()";
  const Sampler& s = *sampler_;
  const int y = FindInterval(s.row_cdf, u2);
  const double row_p = s.row_cdf[y + 1] - s.row_cdf[y];
  const double fy = std::clamp((u2 - s.row_cdf[y]) / row_p, 0.0, 1.0);
  const double* cdf = &s.col_cdf[size_t(y) * (s.width + 1)];
  const double* it = std::upper_bound(cdf, cdf + s.width + 1, u1);
  const int x = std::clamp(int(it - cdf) - 1, 0, s.width - 1);
  const double fx = std::clamp((u1 - cdf[x]) / (cdf[x + 1] - cdf[x]), 0.0, 1.0);
  const double p = s.pixel_prob[size_t(y) * s.width + x];
  Eigen::Vector3d d_map;
  if (layout_ == Layout::kLatLong) {
    // Uniform in solid angle inside the pixel: uniform in phi and in cos(theta).
    const double c0 = std::cos(M_PI * y / s.height), c1 = std::cos(M_PI * (y + 1) / s.height);
    const double cos_t = c0 + fy * (c1 - c0);
    const double sin_t = std::sqrt(std::max(0.0, 1 - cos_t * cos_t));
    const double phi = 2 * M_PI * (x + fx) / s.width;
    d_map = {sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t};
    *pdf_sr = p / PixelSolidAngle(x, y);
  } else {
    // Uniform in (s, t) inside the texel.
    const Eigen::Vector2d st((x + fx) / s.width, (y + fy) / s.height);
    d_map = OctDecode(st);
    *pdf_sr = p * double(s.width) * s.height / OctJacobian(st);
  }
  return rotation_world_ * d_map;
}

double EnvMap::Pdf(const Eigen::Vector3d& dir_world) const {
  RELIGHT_CHECK(sampler_) << "EnvMap::Pdf before PrepareSampling()";
  const Sampler& s = *sampler_;
  const Eigen::Vector3d d = (rotation_world_.transpose() * dir_world).normalized();
  if (layout_ == Layout::kLatLong) {
    const double theta = std::acos(std::clamp(d.z(), -1.0, 1.0));
    double phi = std::atan2(d.y(), d.x());
    if (phi < 0) phi += 2 * M_PI;
    const int x = std::clamp(int(phi / (2 * M_PI) * s.width), 0, s.width - 1);
    const int y = std::clamp(int(theta / M_PI * s.height), 0, s.height - 1);
    return s.pixel_prob[size_t(y) * s.width + x] / PixelSolidAngle(x, y);
  }
  const Eigen::Vector2d st = OctEncode(d);
  const int x = std::clamp(int(st.x() * s.width), 0, s.width - 1);
  const int y = std::clamp(int(st.y() * s.height), 0, s.height - 1);
  return s.pixel_prob[size_t(y) * s.width + x] * double(s.width) * s.height / OctJacobian(st);
}

Eigen::Vector3d EnvMap::Integral(int supersampling) const {
  return Integrate([](const Eigen::Vector3d&) { return 1.0; }, supersampling);
}

Eigen::Vector3d EnvMap::PixelIntegral() const {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int y = 0; y < image_.height; ++y)
    for (int x = 0; x < image_.width; ++x) sum += PixelSolidAngle(x, y) * Fetch(x, y);
  return intensity_ * sum;
}

Eigen::Vector3d EnvMap::Irradiance(const Eigen::Vector3d& normal_world, int supersampling) const {
  RELIGHT_CHECK(!empty());
  const Eigen::Vector3d n = normal_world.normalized();
  const int w = image_.width, h = image_.height;
  std::vector<Eigen::Vector3d> rows(h, Eigen::Vector3d::Zero());
  tbb::parallel_for(0, h, [&](int y) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int x = 0; x < w; ++x) {
      for (int sy = 0; sy < supersampling; ++sy) {
        for (int sx = 0; sx < supersampling; ++sx) {
          const double u = (x + (sx + 0.5) / supersampling) / w, v = (y + (sy + 0.5) / supersampling) / h;
          double jac;
          const Eigen::Vector3d d = rotation_world_ * StoredDirection(u, v, &jac);
          const double c = n.dot(d);
          if (c > 0) sum += (c * jac) * Lookup(d);
        }
      }
    }
    rows[y] = sum / (double(w) * h * supersampling * supersampling);
  });
  Eigen::Vector3d total = Eigen::Vector3d::Zero();
  for (const auto& r : rows) total += r;
  return total;
}

void EnvMap::SaveLatLong(const std::string& path, int height) const {
  WriteOptions options;
  options.type = PixelType::kFloat;
  WriteImage(path, ToLatLong(height), options);
}

void EnvMap::SaveOctahedral(const std::string& path, int n) const {
  WriteOptions options;
  options.type = PixelType::kFloat;
  WriteImage(path, ToOctahedral(n), options);
}

}  // namespace relight
