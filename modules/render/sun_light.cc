#include "render/sun_light.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/stats.h"
#include "image/color.h"

namespace relight {
namespace {

Eigen::Vector3d LatLongDirection(int x, int y, int w, int h) {
  const double theta = M_PI * (y + 0.5) / h, phi = 2 * M_PI * (x + 0.5) / w;
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

}  // namespace

SunSplit SplitSun(const EnvMap& env, double max_radius_rad) {
  SunSplit out;
  if (env.empty() || env.layout() != EnvMap::Layout::kLatLong || env.intensity() <= 0) return out;
  const Image& img = env.image();
  const int w = img.width, h = img.height;
  auto rgb = [&](int x, int y) {
    return Eigen::Vector3d(img.at(x, y, 0), img.at(x, y, std::min(1, img.channels - 1)),
                           img.at(x, y, std::min(2, img.channels - 1)));
  };
  // Peak and integral.
  int px = 0, py = 0;
  double peak = -1, total = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double lum = Luminance(rgb(x, y));
      total += lum * env.PixelSolidAngle(x, y);
      if (lum > peak) peak = lum, px = x, py = y;
    }
  if (!(peak > 0) || !(total > 0)) return out;
  const Eigen::Vector3d centre = LatLongDirection(px, py, w, h);
  const double cos_inner = std::cos(max_radius_rad), cos_outer = std::cos(std::min(M_PI, 2 * max_radius_rad));
  // Rows that can hold directions within 2R of the peak.
  const double theta_c = M_PI * (py + 0.5) / h;
  const int y0 = std::max(0, int(std::floor((theta_c - 2 * max_radius_rad) / M_PI * h)) - 1);
  const int y1 = std::min(h - 1, int(std::ceil((theta_c + 2 * max_radius_rad) / M_PI * h)) + 1);
  std::vector<double> ring_lum, ring_r, ring_g, ring_b;
  std::vector<std::pair<int, int>> inner;
  for (int y = y0; y <= y1; ++y)
    for (int x = 0; x < w; ++x) {
      const double c = LatLongDirection(x, y, w, h).dot(centre);
      if (c >= cos_inner) {
        inner.emplace_back(x, y);
      } else if (c >= cos_outer) {
        const Eigen::Vector3d v = rgb(x, y);
        ring_lum.push_back(Luminance(v));
        ring_r.push_back(v.x());
        ring_g.push_back(v.y());
        ring_b.push_back(v.z());
      }
    }
  if (ring_lum.empty()) return out;  // R is below a pixel: nothing to tell the lobe from its surroundings
  if (Median(ring_lum) * kSunPeakOverRing > peak) return out;  // not compact: a wide lobe or no sun
  const Eigen::Vector3d level(Median(ring_r), Median(ring_g), Median(ring_b));
  Image residual = img;
  Eigen::Vector3d irradiance = Eigen::Vector3d::Zero(), weighted_dir = Eigen::Vector3d::Zero();
  double excess_lum = 0;
  for (const auto& [x, y] : inner) {
    const Eigen::Vector3d v = rgb(x, y);
    const Eigen::Vector3d excess = (v - level).cwiseMax(0.0);
    const double omega = env.PixelSolidAngle(x, y);
    irradiance += omega * excess;
    const double lum = Luminance(excess) * omega;
    excess_lum += lum;
    weighted_dir += lum * LatLongDirection(x, y, w, h);
    for (int c = 0; c < std::min(3, img.channels); ++c)
      residual.at(x, y, c) = static_cast<float>(std::min(v[c], level[c]));
  }
  if (excess_lum < kSunMinShare * total || weighted_dir.norm() <= 0) return out;
  out.found = true;
  out.share = excess_lum / total;
  out.sun.dir_world = (env.rotation_world() * weighted_dir).normalized();
  out.sun.irradiance_rgb = env.intensity() * irradiance;
  out.residual = EnvMap::FromLatLong(std::move(residual)).Transformed(env.rotation_world(), env.intensity());
  return out;
}

}  // namespace relight
