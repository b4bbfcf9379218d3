// Log-chromaticity SIFT features (see chroma_features.h).
#include "sfm/chroma_features.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <tuple>

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace relight {
namespace {

// OpenCV's contrast threshold (divided by its 3 layers per octave inside): lower than its default 0.04, since the
// chromatic channels have less contrast than grey ones.
constexpr double kContrastThreshold = 0.01;

// COLMAP's coordinate of an OpenCV SIFT position: OpenCV puts a pixel's centre at integer coordinates (COLMAP at
// +0.5), and OpenCV 4.6's SIFT reports positions 0.25 px too far right and down (it doubles the image for its first
// octave without the half-pixel shift; OpenCV 4.8 added `enable_precise_upscale` for it). Measured on Gaussian
// blobs (test KeypointsAreInColmapPixelCoordinates).
constexpr double kColmapFromOpenCvSift = 0.5 - 0.25;

float MedianOf(const cv::Mat& m) {
  std::vector<float> v(m.begin<float>(), m.end<float>());
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// Upright SIFT on one channel: keypoints detected with their orientation, deduplicated by position and size
// (SIFT repeats a keypoint once per dominant orientation), then described at orientation 0.
void AddUprightFeatures(const cv::Mat& channel, int max_features, double scale_to_full, FeatureSet* out) {
  cv::Ptr<cv::SIFT> sift = cv::SIFT::create(max_features, 3, kContrastThreshold);
  std::vector<cv::KeyPoint> detected;
  sift->detect(channel, detected);
  std::map<std::tuple<int, int, int>, cv::KeyPoint> unique;
  for (const auto& k : detected) {
    const auto key = std::make_tuple(int(std::lround(k.pt.x * 10)), int(std::lround(k.pt.y * 10)),
                                     int(std::lround(k.size * 10)));
    if (unique.count(key) == 0) unique.emplace(key, cv::KeyPoint(k.pt, k.size, 0, k.response, k.octave));
  }
  std::vector<cv::KeyPoint> upright;
  upright.reserve(unique.size());
  for (const auto& [key, k] : unique) upright.push_back(k);
  cv::Mat descriptors;
  sift->compute(channel, upright, descriptors);
  if (descriptors.empty()) return;
  RELIGHT_CHECK_EQ(descriptors.cols, 128);
  RELIGHT_CHECK_EQ(descriptors.rows, static_cast<int>(upright.size()));
  for (int r = 0; r < descriptors.rows; ++r) {
    // RootSIFT (L1-normalise, square root), then COLMAP's byte scaling.
    const float* d = descriptors.ptr<float>(r);
    double l1 = 0;
    for (int c = 0; c < 128; ++c) l1 += std::abs(d[c]);
    if (l1 <= 0) continue;
    for (int c = 0; c < 128; ++c) {
      const double v = 512.0 * std::sqrt(std::abs(d[c]) / l1);
      out->descriptors.push_back(static_cast<uint8_t>(std::min(255.0, std::round(v))));
    }
    const cv::KeyPoint& k = upright[r];
    const float s = static_cast<float>(0.5 * k.size * scale_to_full);
    const float x = static_cast<float>((k.pt.x + kColmapFromOpenCvSift) * scale_to_full);
    const float y = static_cast<float>((k.pt.y + kColmapFromOpenCvSift) * scale_to_full);
    out->keypoints.insert(out->keypoints.end(), {x, y, s, 0.0f, 0.0f, s});
  }
}

}  // namespace

std::vector<cv::Mat> LogChromaticityChannels(const cv::Mat& bgr8) {
  RELIGHT_CHECK(bgr8.type() == CV_8UC3) << "LogChromaticityChannels needs an 8-bit BGR image";
  cv::Mat f;
  bgr8.convertTo(f, CV_32FC3, 1.0, 8.0);
  std::vector<cv::Mat> bgr;
  cv::split(f, bgr);
  cv::Mat log_b, log_g, log_r;
  cv::log(bgr[0], log_b);
  cv::log(bgr[1], log_g);
  cv::log(bgr[2], log_r);
  std::vector<cv::Mat> out;
  for (const cv::Mat& log_c : {log_r, log_b}) {
    const cv::Mat ratio = log_c - log_g;
    cv::Mat channel;
    ratio.convertTo(channel, CV_8U, kChromaGain, 128.0 - kChromaGain * MedianOf(ratio));  // saturates
    out.push_back(channel);
  }
  return out;
}

FeatureSet ChromaFeatures(const cv::Mat& bgr8, int max_features, int max_image_size) {
  FeatureSet out;
  if (bgr8.empty() || max_features <= 0) return out;
  cv::Mat image = bgr8;
  double scale_to_full = 1;
  const int longer = std::max(bgr8.cols, bgr8.rows);
  if (max_image_size > 0 && longer > max_image_size) {
    scale_to_full = double(longer) / max_image_size;
    cv::resize(bgr8, image, cv::Size(), 1 / scale_to_full, 1 / scale_to_full, cv::INTER_AREA);
  }
  for (const cv::Mat& channel : LogChromaticityChannels(image)) {
    AddUprightFeatures(channel, std::max(1, max_features / 2), scale_to_full, &out);
  }
  return out;
}

}  // namespace relight
