#include "datasets/light_evaluation.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "core/error.h"
#include "core/fs.h"
#include "core/json.h"
#include "core/stats.h"
#include "image/color.h"
#include "sphere/envmap.h"
#include "sphere/octahedral.h"

namespace relight {
namespace {
double Pearson(const std::vector<double>& a, const std::vector<double>& b) {
  const size_t n = a.size();
  double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
  for (size_t k = 0; k < n; ++k) {
    sa += a[k];
    sb += b[k];
    saa += a[k] * a[k];
    sbb += b[k] * b[k];
    sab += a[k] * b[k];
  }
  const double cov = sab / n - sa / n * sb / n;
  const double va = saa / n - sa / n * sa / n, vb = sbb / n - sb / n * sb / n;
  return va > 0 && vb > 0 ? cov / std::sqrt(va * vb) : 0.0;
}
}  // namespace

Eigen::Vector3d OctahedralPower(const Image& oct) {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (int j = 0; j < oct.height; ++j)
    for (int i = 0; i < oct.width; ++i) {
      const double w = OctTexelSolidAngle(i, j, oct.width);
      for (int c = 0; c < 3; ++c) p[c] += w * oct.at(i, j, c);
    }
  return p;
}

LightEvaluation EvaluateDirectionalLights(const std::string& inverse_dir, const std::vector<KnownDirectionalLight>& lights) {
  std::map<std::string, const KnownDirectionalLight*> by_name;
  for (const auto& l : lights) by_name[l.photo] = &l;
  const Json j = ReadJsonFile(JoinPath(inverse_dir, "lighting.json"));
  LightEvaluation e;
  for (const auto& p : j.at("photos")) {
    const std::string name = p.at("name");
    auto it = by_name.find(name);
    if (it == by_name.end()) continue;
    const Image oct = ReadImage(JoinPath(inverse_dir, p.at("envmap_oct").get<std::string>()));
    const Eigen::Vector3d dir = BrightestLobeDirection(oct);
    e.photos.push_back(name);
    e.direction_world.push_back(dir);
    e.true_direction_world.push_back(it->second->direction_world);
    e.angle_error_deg.push_back(std::acos(std::clamp(dir.dot(it->second->direction_world), -1.0, 1.0)) * 180 / M_PI);
    e.power_rgb.push_back(OctahedralPower(oct));
    e.true_rgb.push_back(it->second->intensity_rgb);
  }
  if (e.photos.empty()) return e;
  e.median_angle_deg = Median(e.angle_error_deg);
  e.p90_angle_deg = PercentileOf(e.angle_error_deg, 90);
  double ab = 0, bb = 0, mean_true = 0;
  for (size_t k = 0; k < e.photos.size(); ++k) {
    ab += e.power_rgb[k].dot(e.true_rgb[k]);
    bb += e.power_rgb[k].squaredNorm();
    mean_true += e.true_rgb[k].mean();
  }
  const double scale = bb > 0 ? ab / bb : 1.0;
  mean_true /= e.photos.size();
  double sse = 0;
  for (size_t k = 0; k < e.photos.size(); ++k) sse += (scale * e.power_rgb[k] - e.true_rgb[k]).squaredNorm() / 3;
  e.relative_intensity_rmse = std::sqrt(sse / e.photos.size()) / std::max(1e-30, mean_true);
  for (int c = 0; c < 3; ++c) {
    std::vector<double> a, b;
    for (size_t k = 0; k < e.photos.size(); ++k) {
      a.push_back(e.power_rgb[k][c]);
      b.push_back(e.true_rgb[k][c]);
    }
    e.pearson[c] = Pearson(a, b);
  }
  return e;
}

}  // namespace relight
