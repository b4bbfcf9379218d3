// Colour conventions every module shares (docs/FORMATS.md): the sRGB transfer curves of IEC 61966-2-1 and the
// relative luminance of linear Rec. 709 / sRGB primaries. One definition, so that photos decoded by ingest and
// linearize, tone-mapped pictures of relight and report, and the synthetic generator's JPEGs agree.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>

namespace relight {

// Linear value -> sRGB-encoded value; the input is clamped to [0, 1] first (NaN gives 0).
inline double SrgbEncode(double linear) {
  if (!(linear > 0)) return 0.0;
  if (linear >= 1) return 1.0;
  return linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1.0 / 2.4) - 0.055;
}

// sRGB-encoded value -> linear value; the input is clamped to [0, 1] first (NaN gives 0).
inline double SrgbDecode(double encoded) {
  if (!(encoded > 0)) return 0.0;
  if (encoded >= 1) return 1.0;
  return encoded <= 0.04045 ? encoded / 12.92 : std::pow((encoded + 0.055) / 1.055, 2.4);
}

// Relative luminance Y of linear RGB (Rec. 709 primaries, D65).
inline double Luminance(double r, double g, double b) { return 0.2126 * r + 0.7152 * g + 0.0722 * b; }
inline double Luminance(const Eigen::Vector3d& rgb) { return Luminance(rgb.x(), rgb.y(), rgb.z()); }
// The same for three consecutive values (an RGB pixel) or anything indexable by 0, 1, 2.
template <typename RGB>
inline double Luminance(const RGB& rgb) {
  return Luminance(double(rgb[0]), double(rgb[1]), double(rgb[2]));
}

}  // namespace relight
