// Real spherical harmonics up to order 8 (all bands l <= order, (order+1)^2
// coefficients): evaluation, projection, reconstruction, rotation and the
// clamped-cosine convolution -- the classical low-frequency lighting baseline
// (Ramamoorthi & Hanrahan, "An Efficient Representation for Irradiance
// Environment Maps", SIGGRAPH 2001, eqs. 8-12) that the wavelet results are
// compared against.
//
// Basis: Y_lm orthonormal over the sphere, index l (l + 1) + m, no
// Condon-Shortley phase (Y_1,-1 ~ y, Y_1,0 ~ z, Y_1,1 ~ x). Rotation matrices
// are obtained per band by least squares from the band's values at fixed
// sample directions (exact, since every band is closed under rotation).
// Written by hand: Eigen has no SH, and the Debian SH libraries do not provide
// rotations for the project's frame conventions.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "sphere/envmap.h"
#include "sphere/frame.h"

namespace relight {

// Highest supported order.
inline constexpr int kMaxShOrder = 8;
// Number of coefficients of an order (bands 0..order).
inline constexpr int ShNumCoefficients(int order) { return (order + 1) * (order + 1); }
// Index of Y_lm in a coefficient vector.
inline constexpr int ShIndex(int l, int m) { return l * (l + 1) + m; }

// Writes Y_lm(dir) for all l <= order into values[ShNumCoefficients(order)]; dir need not be unit.
void ShEvaluate(int order, const Eigen::Vector3d& dir, double* values);
// Y_lm(dir) for all l <= order.
Eigen::VectorXd ShEvaluate(int order, const Eigen::Vector3d& dir);

// Sum_lm c_lm Y_lm(dir) of one channel.
double ShReconstruct(const Eigen::VectorXd& coeffs, const Eigen::Vector3d& dir);
// RGB reconstruction; coeffs has one column per channel.
Eigen::Vector3d ShReconstructRgb(const Eigen::MatrixXd& coeffs, const Eigen::Vector3d& dir);
// Order of a coefficient count (throws InternalError when not a square <= 81).
int ShOrderOf(int num_coefficients);

// Projection of an environment map's radiance (EnvMap::Lookup) onto the SH
// basis by supersampled quadrature over its stored pixels; one column per channel.
Eigen::MatrixXd ShProjectEnvMap(const EnvMap& env, int order, int supersampling = 2);
// Projection of an n x n octahedral array (row-major texel averages, world frame).
Eigen::VectorXd ShProjectOct(const float* texel_averages, int n, int order);
// Projection of values at directions with quadrature weights [sr]: sum_k w_k f_k Y(d_k).
Eigen::VectorXd ShProjectSamples(const std::vector<Eigen::Vector3d>& dirs_world, const std::vector<double>& weights_sr,
                                 const float* values, int order);
// n x n octahedral texel values of a band-limited function (point values at texel centres).
std::vector<float> ShToOct(const Eigen::VectorXd& coeffs, int n);

// Clamped-cosine convolution weights A_l (pi, 2pi/3, pi/4, 0, -pi/24, ...), Ramamoorthi & Hanrahan eq. 9.
double ShClampedCosineWeight(int l);
// Irradiance integral L(w) max(0, n.w) dw from the lighting's SH coefficients (one column per channel).
Eigen::Vector3d ShIrradiance(const Eigen::MatrixXd& lighting_coeffs, const Eigen::Vector3d& normal_world);
// SH coefficients (world frame) of the transport max(0, n.w) of a Lambertian point with normal n.
Eigen::VectorXd ShClampedCosineTransport(int order, const Eigen::Vector3d& normal_world);

// Rotation of SH coefficients: for g(d) = f(R^-1 d), coefficients of g from those of f.
class ShRotation {
 public:
  // `rotation` is R (e.g. world_from_local = LocalFrame::LocalFromWorld().transpose()).
  ShRotation(int order, const Eigen::Matrix3d& rotation);
  // out = D in (in, out: ShNumCoefficients(order) entries; may not alias).
  void Apply(const double* in, double* out) const;
  // The rotation as a dense block-diagonal matrix.
  Eigen::MatrixXd Matrix() const;
  // Highest band.
  int order() const { return order_; }

 private:
  int order_;
  std::vector<Eigen::MatrixXd> bands_;  // (2l+1) x (2l+1) per band
};

// Projects per-vertex functions given on the hemi-octahedral map of a local
// frame (visibility x BRDF slice, ...) onto world-frame SH, for the SH lighting
// baseline: y = sum_lm t_lm L_lm. Precomputes the local basis table once.
class ShHemiOctProjector {
 public:
  ShHemiOctProjector(int n, int order);
  // World-frame coefficients of a function given by texel *averages* (multiplied by texel solid angle here).
  void ProjectAverages(const float* texel_averages, const LocalFrame<double>& frame, double* coeffs_world) const;
  // World-frame coefficients of a function given by texel *integrals* (d omega already folded in, as BRDF slices).
  void ProjectIntegrals(const float* texel_integrals, const LocalFrame<double>& frame, double* coeffs_world) const;
  // Local-frame coefficients of texel integrals: one dense matrix-vector product.
  void ProjectIntegralsLocal(const float* texel_integrals, double* coeffs_local) const;
  // Side of the hemi-octahedral map.
  int n() const { return n_; }
  // Highest band.
  int order() const { return order_; }

 private:
  int n_, order_;
  Eigen::MatrixXf basis_;              // coefficients x texels: Y_lm(texel centre, local)
  std::vector<float> solid_angle_sr_;  // per texel
};

}  // namespace relight
