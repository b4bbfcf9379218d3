// Recovered environment maps against known directional lights (DiLiGenT):
// per photo, the direction of the map's brightest lobe (solid-angle weighted
// centroid of the connected texels brighter than half the peak, grown from the
// brightest texel on the octahedral grid) against the true direction, and the
// map's total power ∫L dω per channel against the true RGB intensity after one
// global least-squares scale.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "datasets/diligent.h"
#include "image/image.h"

namespace relight {

// ∫ L dω per channel of an octahedral RGB map (texel solid angles).
Eigen::Vector3d OctahedralPower(const Image& octahedral);

struct LightEvaluation {
  std::vector<std::string> photos;
  std::vector<double> angle_error_deg;                // per photo
  std::vector<Eigen::Vector3d> direction_world;       // recovered brightest-lobe direction per photo
  std::vector<Eigen::Vector3d> true_direction_world;  // calibrated light direction per photo
  std::vector<Eigen::Vector3d> power_rgb;             // recovered ∫L dω per photo
  std::vector<Eigen::Vector3d> true_rgb;              // true intensities per photo
  double median_angle_deg = 0;
  double p90_angle_deg = 0;
  Eigen::Vector3d pearson = Eigen::Vector3d::Zero();  // per channel, recovered vs true intensity
  double relative_intensity_rmse = 0;                 // after one global scale, relative to the mean true intensity
};

// Compares the maps listed in `<inverse>/lighting.json` with `lights` (matched by photo name).
LightEvaluation EvaluateDirectionalLights(const std::string& inverse_dir,
                                          const std::vector<KnownDirectionalLight>& lights);

}  // namespace relight
