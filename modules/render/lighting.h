// The light a scene is rendered under: a distant environment map (radiance per
// world direction, sphere/envmap.h) plus optional delta lights.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "sphere/envmap.h"

namespace relight {

// A distant light from one direction (the sun as a delta light).
struct DirectionalLight {
  Eigen::Vector3d dir_world = Eigen::Vector3d::UnitZ();      // towards the light, unit
  Eigen::Vector3d irradiance_rgb = Eigen::Vector3d::Ones();  // on a surface facing the light [W m^-2]
};

// An isotropic point light.
struct PointLight {
  Eigen::Vector3d position_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d intensity_rgb = Eigen::Vector3d::Ones();  // radiant intensity [W sr^-1]; irradiance I cos / r^2
};

// All light of one rendering.
struct Lighting {
  std::shared_ptr<const EnvMap> env;  // distant environment; null: none (black)
  std::vector<DirectionalLight> directional;
  std::vector<PointLight> points;

  // Lighting by an environment map alone (prepares its importance sampling).
  static Lighting FromEnvMap(EnvMap env);
  // Radiance arriving from world direction `dir_world` from the environment (0 without one).
  Eigen::Vector3d Background(const Eigen::Vector3d& dir_world) const {
    return env ? env->Lookup(dir_world) : Eigen::Vector3d::Zero();
  }
};

inline Lighting Lighting::FromEnvMap(EnvMap env) {
  env.PrepareSampling();
  Lighting lighting;
  lighting.env = std::make_shared<const EnvMap>(std::move(env));
  return lighting;
}

}  // namespace relight
