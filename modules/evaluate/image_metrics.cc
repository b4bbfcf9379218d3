#include "evaluate/image_metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/stats.h"

namespace relight {

ImageComparison CompareScaleInvariant(const Image& ref, const Image& est, const Image& mask,
                                      const ImageCompareOptions& o, const std::string& what) {
  if (ref.width != est.width || ref.height != est.height || ref.channels < 3 || est.channels < 3) {
    RELIGHT_USER_ERROR() << what << ": the reference is " << ref.width << "x" << ref.height << "x" << ref.channels
                         << " but the estimate " << est.width << "x" << est.height << "x" << est.channels
                         << "; both must be RGB images of one size";
  }
  if (mask.width != ref.width || mask.height != ref.height) {
    RELIGHT_USER_ERROR() << what << ": the mask is " << mask.width << "x" << mask.height << " but the images "
                         << ref.width << "x" << ref.height;
  }
  ImageComparison r;
  std::vector<double> values;
  for (int y = 0; y < ref.height; ++y)
    for (int x = 0; x < ref.width; ++x) {
      if (mask.at(x, y) <= 0.5f) continue;
      ++r.pixels;
      for (int c = 0; c < 3; ++c) values.push_back(ref.at(x, y, c));
    }
  if (r.pixels == 0) {
    RELIGHT_USER_ERROR() << what << ": the comparison mask is empty (the object is not in view, or every pixel "
                         << "was masked out); nothing to compare";
  }
  r.peak = Percentile(&values, o.peak_percentile);
  if (!(r.peak > 0)) r.peak = 1.0;  // a black reference: errors in absolute units
  const double hi = o.clip_to_peak ? r.peak : std::numeric_limits<double>::infinity();
  // Least-squares scale per channel over the pixels the clip leaves alone (highlights above the peak do not
  // steer it); over all pixels when every pixel has a value above the peak.
  Eigen::Vector3d re = Eigen::Vector3d::Zero(), ee = Eigen::Vector3d::Zero();
  for (int pass = 0; pass < 2 && !(ee.minCoeff() > 0); ++pass) {
    re.setZero();
    ee.setZero();
    for (int y = 0; y < ref.height; ++y)
      for (int x = 0; x < ref.width; ++x) {
        if (mask.at(x, y) <= 0.5f) continue;
        if (pass == 0 && std::max({ref.at(x, y, 0), ref.at(x, y, 1), ref.at(x, y, 2)}) > hi) continue;
        for (int c = 0; c < 3; ++c) {
          const double R = ref.at(x, y, c), E = est.at(x, y, c);
          re[c] += R * E;
          ee[c] += E * E;
        }
      }
  }
  for (int c = 0; c < 3; ++c) r.scale[c] = ee[c] > 0 ? re[c] / ee[c] : 1.0;
  double se = 0, ss = 0, rr = 0;
  for (int y = 0; y < ref.height; ++y)
    for (int x = 0; x < ref.width; ++x) {
      if (mask.at(x, y) <= 0.5f) continue;
      for (int c = 0; c < 3; ++c) {
        const double R = ref.at(x, y, c), E = r.scale[c] * est.at(x, y, c);
        const double d = std::clamp(E, 0.0, hi) - std::clamp(R, 0.0, hi);
        se += d * d;
        ss += (E - R) * (E - R);
        rr += R * R;
      }
    }
  r.mse = se / (3.0 * r.pixels);
  r.rmse = std::sqrt(r.mse);
  r.relative_rmse = rr > 0 ? std::sqrt(ss / rr) : 0.0;
  r.psnr_db = r.mse > 0 ? std::min(kMaxPsnrDb, 10.0 * std::log10(r.peak * r.peak / r.mse)) : kMaxPsnrDb;
  return r;
}

Image RelativeErrorImage(const Image& ref, const Image& est, const Eigen::Vector3d& scale, double peak) {
  RELIGHT_CHECK(ref.width == est.width && ref.height == est.height);
  Image out(ref.width, ref.height, 1);
  for (int y = 0; y < ref.height; ++y)
    for (int x = 0; x < ref.width; ++x) {
      double s = 0;
      for (int c = 0; c < 3; ++c) {
        const double d = scale[c] * est.at(x, y, c) - ref.at(x, y, c);
        s += d * d;
      }
      out.at(x, y) = static_cast<float>(std::sqrt(s / 3) / peak);
    }
  return out;
}

Image ScaleChannels(const Image& image, const Eigen::Vector3d& scale) {
  Image out = image;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < std::min(3, image.channels); ++c) out.at(x, y, c) = float(scale[c] * image.at(x, y, c));
  return out;
}

}  // namespace relight
