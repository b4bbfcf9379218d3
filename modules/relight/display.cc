#include "relight/display.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "core/error.h"

namespace relight {

double PercentileExposure(const Image& image, const Image* mask, double percentile) {
  RELIGHT_CHECK(image.channels >= 3) << "PercentileExposure needs an RGB image";
  const bool use_mask = mask != nullptr && !mask->empty();
  if (use_mask) {
    RELIGHT_CHECK(mask->width == image.width && mask->height == image.height);
  }
  std::vector<float> lum;
  lum.reserve(size_t(image.width) * image.height);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      if (use_mask && mask->at(x, y) <= 0.5f) continue;
      const float l = static_cast<float>(Luminance(image.at(x, y, 0), image.at(x, y, 1), image.at(x, y, 2)));
      if (std::isfinite(l)) lum.push_back(l);
    }
  if (lum.empty()) return 1.0;
  const double pos = std::clamp(percentile, 0.0, 100.0) / 100.0 * (lum.size() - 1);
  const size_t k = static_cast<size_t>(std::floor(pos));
  std::nth_element(lum.begin(), lum.begin() + k, lum.end());
  double value = lum[k];
  if (k + 1 < lum.size()) {
    const float next = *std::min_element(lum.begin() + k + 1, lum.end());
    value += (pos - k) * (next - value);
  }
  if (!(value > 0)) {
    const float peak = *std::max_element(lum.begin(), lum.end());
    return peak > 0 ? 1.0 / peak : 1.0;
  }
  return 1.0 / value;
}

Image ToneMapSrgb(const Image& image, double exposure) {
  RELIGHT_CHECK(image.channels >= 3) << "ToneMapSrgb needs an RGB image";
  Image out(image.width, image.height, 3);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < 3; ++c) {
        const double v = exposure * image.at(x, y, c);
        out.at(x, y, c) = static_cast<float>(SrgbEncode(std::isfinite(v) ? v : 0.0));
      }
  return out;
}

Image HeatMap(const Image& value, double max_value, const Image* mask) {
  RELIGHT_CHECK(max_value > 0) << "HeatMap needs a positive range";
  cv::Mat gray(value.height, value.width, CV_8UC1);
  for (int y = 0; y < value.height; ++y)
    for (int x = 0; x < value.width; ++x) {
      const double v = std::clamp(double(value.at(x, y)) / max_value, 0.0, 1.0);
      gray.at<uint8_t>(y, x) = static_cast<uint8_t>(std::lround(255 * (std::isfinite(v) ? v : 1.0)));
    }
  cv::Mat colour;
  cv::applyColorMap(gray, colour, cv::COLORMAP_INFERNO);  // BGR
  Image out(value.width, value.height, 3);
  const bool use_mask = mask != nullptr && !mask->empty();
  for (int y = 0; y < value.height; ++y)
    for (int x = 0; x < value.width; ++x) {
      const cv::Vec3b bgr = colour.at<cv::Vec3b>(y, x);
      const bool in = !use_mask || mask->at(x, y) > 0.5f;
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = in ? bgr[2 - c] / 255.0f : 0.5f;
    }
  return out;
}

Image ErodeMask(const Image& mask, int radius_px) {
  cv::Mat m(mask.height, mask.width, CV_8UC1);
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x) m.at<uint8_t>(y, x) = mask.at(x, y) > 0.5f ? 255 : 0;
  if (radius_px > 0) {
    const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * radius_px + 1, 2 * radius_px + 1));
    cv::erode(m, m, kernel, cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(0));
  }
  Image out(mask.width, mask.height, 1);
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x) out.at(x, y) = m.at<uint8_t>(y, x) ? 1.0f : 0.0f;
  return out;
}

Image ReadMask(const std::string& path) {
  const Image image = ReadImage(path);
  Image out(image.width, image.height, 1);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) out.at(x, y) = image.at(x, y, 0) > 0.5f ? 1.0f : 0.0f;
  return out;
}

size_t CountMask(const Image& mask) {
  size_t n = 0;
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x) n += mask.at(x, y) > 0.5f;
  return n;
}

void WritePng(const std::string& path, const Image& image) {
  WriteOptions o;
  o.type = PixelType::kUint8;
  WriteImage(path, image, o);
}

void WriteExr(const std::string& path, const Image& image) {
  WriteOptions o;
  o.type = PixelType::kFloat;
  // Rendered radiance (every float bit significant) barely compresses: ZIP saved about a tenth of the renders'
  // bytes for a tenth of the relight stage's time.
  o.exr_compression = "none";
  WriteImage(path, image, o);
}

}  // namespace relight
