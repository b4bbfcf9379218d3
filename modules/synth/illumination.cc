#include "synth/illumination.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>

#include "core/error.h"

namespace relight {
namespace {

SunSkyParams DrawSky(const SynthesizeOptions& o, Pcg32* rng) {
  SunSkyParams sky;
  const double azimuth = rng->Uniform(0, 2 * M_PI);
  const double elevation = rng->Uniform(o.sun_elevation_min_deg, o.sun_elevation_max_deg) * M_PI / 180;
  sky.sun_dir_world = Eigen::Vector3d(std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth),
                                      std::sin(elevation));
  sky.turbidity = rng->Uniform(o.turbidity_min, o.turbidity_max);
  sky.ground_albedo = o.sky_ground_albedo;
  sky.sun_radius_deg = o.sun_radius_deg;
  sky.intensity = 1.0;
  return sky;
}

double DrawIntensity(const SynthesizeOptions& o, Pcg32* rng) {
  return std::exp(rng->Uniform(std::log(o.intensity_min), std::log(o.intensity_max)));
}

}  // namespace

std::vector<LightingCondition> DrawPhotoLightings(const SynthesizeOptions& o, int count, Pcg32* rng) {
  std::vector<LightingCondition> out;
  int files_used = 0;
  for (int i = 0; i < count; ++i) {
    LightingCondition c;
    char name[32];
    std::snprintf(name, sizeof(name), "light_%02d", i);
    c.name = name;
    // Condition i is a sky when the running count of skies, floor(i * fraction), steps up.
    const bool sky =
        o.envmaps.empty() || std::floor((i + 1) * o.sky_fraction + 1e-9) > std::floor(i * o.sky_fraction + 1e-9);
    c.intensity = DrawIntensity(o, rng);
    if (sky) {
      c.source = "sky";
      c.sky = DrawSky(o, rng);
      c.sky.intensity = c.intensity;
    } else {
      c.source = "file";
      c.file = o.envmaps[files_used++ % o.envmaps.size()];
      c.rotation_z_deg = rng->Uniform(0, o.env_rotation_deg);
    }
    out.push_back(c);
  }
  return out;
}

std::vector<LightingCondition> DrawHeldOutLightings(const SynthesizeOptions& o, Pcg32* rng) {
  std::vector<LightingCondition> out;
  std::set<std::string> names;
  for (const std::string& file : o.relight_envmaps) {
    LightingCondition c;
    c.source = "file";
    c.file = file;
    std::string stem = std::filesystem::path(file).stem().string();
    std::string name = stem;
    for (int k = 2; names.count(name); ++k) name = stem + "_" + std::to_string(k);
    names.insert(name);
    c.name = name;
    out.push_back(c);
  }
  for (int i = 0; i < o.relight_skies; ++i) {
    LightingCondition c;
    c.name = "sky_" + std::to_string(i);
    c.source = "sky";
    c.sky = DrawSky(o, rng);
    out.push_back(c);
  }
  return out;
}

const EnvMap& EnvMapCache::Get(const std::string& path) {
  auto it = maps_.find(path);
  if (it == maps_.end()) it = maps_.emplace(path, std::make_shared<EnvMap>(EnvMap::Load(path))).first;
  return *it->second;
}

Image RenderLightingLatLong(const LightingCondition& c, int latlong_height, EnvMapCache* cache) {
  if (c.source == "sky") return MakeSunSky(c.sky, latlong_height).image();
  RELIGHT_CHECK(c.source == "file") << c.source;
  const EnvMap& source = cache->Get(c.file);
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(c.rotation_z_deg * M_PI / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  // Texel averages from bilinear lookups spaced half a source pixel apart: enough to keep the
  // energy of small bright sources, and 16x cheaper than EnvMap's default (an eighth of a pixel).
  const int supersampling = std::clamp(int(std::ceil(2.0 * source.image().height / latlong_height)), 2, 64);
  return source.Transformed(rotation, c.intensity).ToLatLong(latlong_height, supersampling);
}

OrderedJson LightingConditionToJson(const LightingCondition& c) {
  OrderedJson j;
  j["name"] = c.name;
  j["source"] = c.source;
  j["intensity"] = c.intensity;
  if (c.source == "file") {
    j["file"] = std::filesystem::path(c.file).filename().string();
    j["path"] = c.file;
    j["rotation_z_deg"] = c.rotation_z_deg;
    const Eigen::Matrix3d r =
        Eigen::AngleAxisd(c.rotation_z_deg * M_PI / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    j["rotation_world"] = {{r(0, 0), r(0, 1), r(0, 2)}, {r(1, 0), r(1, 1), r(1, 2)}, {r(2, 0), r(2, 1), r(2, 2)}};
  } else {
    const Eigen::Vector3d s = c.sky.sun_dir_world.normalized();
    j["sun_dir_world"] = {s.x(), s.y(), s.z()};
    j["sun_elevation_deg"] = std::asin(std::clamp(s.z(), -1.0, 1.0)) * 180 / M_PI;
    j["sun_azimuth_deg"] = std::fmod(std::atan2(s.y(), s.x()) * 180 / M_PI + 360, 360);
    j["turbidity"] = c.sky.turbidity;
    j["ground_albedo"] = c.sky.ground_albedo;
    j["sun_radius_deg"] = c.sky.sun_radius_deg;
  }
  return j;
}

}  // namespace relight
