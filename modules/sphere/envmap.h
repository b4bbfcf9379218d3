// Distant environment lighting (world frame, +Z up) stored as a lat-long (2:1)
// or octahedral (square, power of two) float RGB image, conventions of
// docs/FORMATS.md. Bilinear lookup that is seamless across the lat-long seam and
// poles and across the octahedral folds; resampling to either layout with
// texel averages (solid-angle weighted supersampling); rotation and scaling
// without resampling; importance sampling for Monte Carlo references.
//
// Radiance L(d) of an EnvMap is, by definition, `Lookup(d)`: the bilinear
// interpolation of the stored pixels, rotated and scaled (Transformed()).
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "image/color.h"  // Luminance, used with the maps
#include "image/image.h"

namespace relight {

// BrightestLobeDirection (sphere/octahedral.h) of a square octahedral RGB image, on its luminance.
Eigen::Vector3d BrightestLobeDirection(const Image& octahedral, double threshold_fraction = 0.5);

// An environment map: radiance as a function of the world direction it comes from.
class EnvMap {
 public:
  // Storage layout of the image.
  enum class Layout { kLatLong, kOctahedral };

  EnvMap() = default;
  // Wraps a lat-long RGB image (width = 2 height; 1 or 4 channels are converted to RGB).
  static EnvMap FromLatLong(Image image);
  // Wraps an octahedral RGB image (square, side a power of two).
  static EnvMap FromOctahedral(Image image);
  // Reads a lat-long .hdr/.exr; throws UserError naming the file if unreadable, not 2:1, or
  // holding NaN, infinite or negative values.
  static EnvMap Load(const std::string& path);

  // Storage layout.
  Layout layout() const { return layout_; }
  // The stored image (before rotation and intensity).
  const Image& image() const { return image_; }
  // Rotation applied to the stored map: L(d) = intensity * stored(R^T d).
  const Eigen::Matrix3d& rotation_world() const { return rotation_world_; }
  // Scale applied to the stored map.
  double intensity() const { return intensity_; }
  // True when no image is held.
  bool empty() const { return image_.empty(); }

  // Radiance arriving from world direction `dir_world` (any length > 0); bilinear.
  Eigen::Vector3d Lookup(const Eigen::Vector3d& dir_world) const;
  // Piecewise-constant reading: the stored pixel holding the direction (rotated, scaled). This is
  // the function an octahedral map of texel averages represents in the Haar domain.
  Eigen::Vector3d LookupNearest(const Eigen::Vector3d& dir_world) const;

  // Lat-long image of the given height (width 2 height); each pixel is the
  // solid-angle-weighted average of Lookup over the pixel (supersampling^2
  // samples; 0 = automatic: sample spacing at most an eighth of a stored pixel).
  Image ToLatLong(int height, int supersampling = 0) const;
  // Octahedral n x n image (n a power of two); each texel is the
  // solid-angle-weighted average of Lookup over the texel (supersampling^2
  // samples; 0 = automatic as for ToLatLong).
  Image ToOctahedral(int n, int supersampling = 0) const;
  // The least supersampling (2 to 64 per axis) whose samples lie at most one stored pixel apart over target
  // pixels spanning `target_pixel_rad` radians: enough for a texel average of the bilinear reading, far fewer
  // samples than the automatic factor (which resolves each stored pixel eightfold).
  int CoveringSupersampling(double target_pixel_rad) const;

  // Rotated and scaled copy, new(d) = intensity * old(R^-1 d): a feature seen
  // in direction d0 before is seen in direction R d0 afterwards. No resampling.
  EnvMap Transformed(const Eigen::Matrix3d& rotation_world, double intensity) const;

  // Builds the importance-sampling tables (density ~ luminance x solid angle
  // of each stored pixel, blended half-and-half with the maximum luminance of
  // its 3x3 neighbourhood so the bilinear lookup has bounded variance).
  void PrepareSampling();
  // True once PrepareSampling() has run (copies share the tables).
  bool sampling_prepared() const { return sampler_ != nullptr; }
  // Samples a world direction from two uniform numbers in [0, 1); density in 1/sr.
  Eigen::Vector3d Sample(double u1, double u2, double* pdf_sr) const;
  // Density [1/sr] with which Sample() returns `dir_world`.
  double Pdf(const Eigen::Vector3d& dir_world) const;

  // Integral of L = Lookup over the sphere [radiance * sr], supersampled quadrature over the stored pixels.
  Eigen::Vector3d Integral(int supersampling = 4) const;
  // Integral of the piecewise-constant reading of the stored pixels, sum L_pixel * solid_angle_pixel
  // (exact; what texel-average maps such as ToOctahedral() carry into the wavelet domain).
  Eigen::Vector3d PixelIntegral() const;
  // Irradiance on a surface with world normal `normal_world`: integral of
  // Lookup(w) max(0, n.w) dw by supersampled quadrature over the stored pixels.
  Eigen::Vector3d Irradiance(const Eigen::Vector3d& normal_world, int supersampling = 4) const;
  // Integral of Lookup(w) weight(w) dw by supersampled quadrature over the stored pixels.
  template <typename Weight>
  Eigen::Vector3d Integrate(Weight weight, int supersampling = 4) const;

  // Writes ToLatLong(height) as float EXR/HDR (format by extension), atomically.
  void SaveLatLong(const std::string& path, int height) const;
  // Writes ToOctahedral(n) as float EXR, atomically.
  void SaveOctahedral(const std::string& path, int n) const;

  // Exact solid angle [sr] of stored pixel (x, y).
  double PixelSolidAngle(int x, int y) const;

 private:
  struct Sampler;
  Eigen::Vector3d LookupStored(const Eigen::Vector3d& dir_map) const;
  Eigen::Vector3d Fetch(int x, int y) const;
  // Supersampling factor for a target map whose pixels span `target_pixel_rad` radians.
  int AutoSupersampling(double target_pixel_rad) const;
  // Direction (stored frame) at continuous image position (u, v) in [0,1]^2, and d(omega)/(du dv).
  Eigen::Vector3d StoredDirection(double u, double v, double* jacobian) const;

  Layout layout_ = Layout::kLatLong;
  Image image_;
  Eigen::Matrix3d rotation_world_ = Eigen::Matrix3d::Identity();
  double intensity_ = 1.0;
  std::vector<double> oct_solid_angles_;  // octahedral layout: per texel
  std::shared_ptr<const Sampler> sampler_;
};

template <typename Weight>
Eigen::Vector3d EnvMap::Integrate(Weight weight, int supersampling) const {
  const int w = image_.width, h = image_.height;
  Eigen::Vector3d total = Eigen::Vector3d::Zero();
  for (int y = 0; y < h; ++y) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int x = 0; x < w; ++x) {
      for (int sy = 0; sy < supersampling; ++sy) {
        for (int sx = 0; sx < supersampling; ++sx) {
          const double u = (x + (sx + 0.5) / supersampling) / w, v = (y + (sy + 0.5) / supersampling) / h;
          double jac;
          const Eigen::Vector3d d = rotation_world_ * StoredDirection(u, v, &jac);
          const double f = weight(d);
          if (f != 0) sum += (f * jac) * Lookup(d);
        }
      }
    }
    total += sum / (double(w) * h * supersampling * supersampling);
  }
  return total;
}

}  // namespace relight
