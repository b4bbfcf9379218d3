// Tests of the log-chromaticity features (chroma_features.h) against closed
// forms: shading and white balance cancel, a known shift is recovered, and
// keypoints are in COLMAP's pixel convention.
#include "sfm/chroma_features.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

namespace relight {
namespace {

// A colour texture of two colours of nearly equal luminance (terracotta and a blue-green), as smooth blobs.
cv::Mat IsoluminantTexture(int width, int height, uint32_t seed) {
  std::mt19937 rng(seed);
  cv::Mat noise(height / 8, width / 8, CV_32F);
  std::uniform_real_distribution<float> u(0, 1);
  for (int y = 0; y < noise.rows; ++y) {
    for (int x = 0; x < noise.cols; ++x) noise.at<float>(y, x) = u(rng);
  }
  cv::Mat field;
  cv::resize(noise, field, cv::Size(width, height), 0, 0, cv::INTER_CUBIC);
  cv::GaussianBlur(field, field, cv::Size(0, 0), 3);
  const cv::Vec3f a(90, 120, 200), b(170, 160, 85);  // BGR; luminance 140 and 139 (of 255)
  cv::Mat image(height, width, CV_32FC3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const float t = std::clamp((field.at<float>(y, x) - 0.5f) * 8 + 0.5f, 0.0f, 1.0f);
      image.at<cv::Vec3f>(y, x) = a * (1 - t) + b * t;
    }
  }
  return image;
}

// Applies a shading that varies smoothly over the image (0.35 .. 1) and per-channel gains, then rounds to 8 bit.
cv::Mat Shade(const cv::Mat& image, double phase, cv::Vec3f gains) {
  cv::Mat out(image.size(), CV_8UC3);
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      const double s = 0.675 + 0.325 * std::sin(phase + 0.02 * x + 0.013 * y);
      const cv::Vec3f v = image.at<cv::Vec3f>(y, x);
      for (int c = 0; c < 3; ++c) out.at<cv::Vec3b>(y, x)[c] = cv::saturate_cast<uint8_t>(s * gains[c] * v[c]);
    }
  }
  return out;
}

TEST(LogChromaticity, ShadingAndWhiteBalanceCancel) {
  const cv::Mat texture = IsoluminantTexture(256, 192, 1);
  const std::vector<cv::Mat> a = LogChromaticityChannels(Shade(texture, 0, {1, 1, 1}));
  const std::vector<cv::Mat> b = LogChromaticityChannels(Shade(texture, 2.0, {0.8f, 1.0f, 1.25f}));
  ASSERT_EQ(a.size(), 2u);
  // Exact invariance up to the offset of 8 levels and 8-bit rounding: where every channel of both photos is at
  // least 48, the offset moves log(c/g) by at most log(1 + 8/48) - log(1 + 8/255) ~ 0.12 (31 levels) in the worst
  // case and much less on average; rounding adds ~0.02. The mean over such pixels stays within 3 levels.
  cv::Mat bright_a, bright_b;
  cv::inRange(Shade(texture, 0, {1, 1, 1}), cv::Scalar(48, 48, 48), cv::Scalar(255, 255, 255), bright_a);
  cv::inRange(Shade(texture, 2.0, {0.8f, 1.0f, 1.25f}), cv::Scalar(48, 48, 48), cv::Scalar(255, 255, 255), bright_b);
  const cv::Mat bright = bright_a & bright_b;
  ASSERT_GT(cv::countNonZero(bright), 5000);
  for (int c = 0; c < 2; ++c) {
    cv::Mat diff;
    cv::absdiff(a[c], b[c], diff);
    EXPECT_LT(cv::mean(diff, bright)[0], 3.0) << "channel " << c;
    double lo, hi;
    cv::minMaxLoc(a[c], &lo, &hi);
    // The two colours differ by 1.08 in log(R/G) and 0.33 in log(B/G): 273 (saturated) and 84 levels.
    EXPECT_GT(hi - lo, 70) << "the chromatic texture spans the channel";
  }
  // Grey images of the same two photos differ by the shading itself.
  cv::Mat grey_a, grey_b, diff;
  cv::cvtColor(Shade(texture, 0, {1, 1, 1}), grey_a, cv::COLOR_BGR2GRAY);
  cv::cvtColor(Shade(texture, 2.0, {0.8f, 1.0f, 1.25f}), grey_b, cv::COLOR_BGR2GRAY);
  cv::absdiff(grey_a, grey_b, diff);
  EXPECT_GT(cv::mean(diff)[0], 20.0);
}

// Nearest-neighbour matches with the ratio test between two feature sets.
std::vector<std::pair<int, int>> Match(const FeatureSet& a, const FeatureSet& b) {
  const cv::Mat da(a.size(), 128, CV_8U, const_cast<uint8_t*>(a.descriptors.data()));
  const cv::Mat db(b.size(), 128, CV_8U, const_cast<uint8_t*>(b.descriptors.data()));
  cv::Mat fa, fb;
  da.convertTo(fa, CV_32F);
  db.convertTo(fb, CV_32F);
  std::vector<std::vector<cv::DMatch>> knn;
  cv::BFMatcher(cv::NORM_L2).knnMatch(fa, fb, knn, 2);
  std::vector<std::pair<int, int>> out;
  for (const auto& m : knn) {
    if (m.size() == 2 && m[0].distance < 0.8f * m[1].distance) out.emplace_back(m[0].queryIdx, m[0].trainIdx);
  }
  return out;
}

// The same isoluminant texture, shifted by (17, 9) px, under different shading and white balance: the chromatic
// features match at the shift.
TEST(ChromaFeatures, MatchAcrossShadingAtAKnownShift) {
  const cv::Mat texture = IsoluminantTexture(320, 240, 2);
  const cv::Mat a = Shade(texture(cv::Rect(0, 0, 280, 220)), 0, {1, 1, 1});
  const cv::Mat b = Shade(texture(cv::Rect(17, 9, 280, 220)), 2.5, {0.75f, 1.0f, 1.3f});
  const FeatureSet fa = ChromaFeatures(a, 4000, 1600), fb = ChromaFeatures(b, 4000, 1600);
  ASSERT_GT(fa.size(), 50);
  ASSERT_EQ(fa.keypoints.size(), 6u * fa.size());
  const auto matches = Match(fa, fb);
  int correct = 0;
  for (const auto& [i, j] : matches) {
    const double dx = fa.keypoints[6 * i] - fb.keypoints[6 * j], dy = fa.keypoints[6 * i + 1] - fb.keypoints[6 * j + 1];
    correct += std::hypot(dx - 17, dy - 9) < 1.5;
  }
  EXPECT_GE(correct, 40);
  EXPECT_GE(correct, 0.8 * matches.size()) << correct << " of " << matches.size();
  // Upright: a11 = a22 = scale, a12 = a21 = 0.
  EXPECT_EQ(fa.keypoints[3], 0.0f);
  EXPECT_EQ(fa.keypoints[4], 0.0f);
  EXPECT_GT(fa.keypoints[2], 0.0f);
  EXPECT_EQ(fa.keypoints[2], fa.keypoints[5]);
}

// One chromatic blob centred on pixel (60, 45), i.e. COLMAP coordinates (60.5, 45.5); the same blob at twice the
// size in a twice larger image that is downscaled for SIFT is found at (121, 91).
TEST(ChromaFeatures, KeypointsAreInColmapPixelCoordinates) {
  for (int factor : {1, 2}) {
    const int width = 120 * factor, height = 90 * factor;
    cv::Mat image(height, width, CV_8UC3, cv::Scalar(128, 128, 128));
    const double cx = 60 * factor + 0.5 * (factor - 1), cy = 45 * factor + 0.5 * (factor - 1), sigma = 4.0 * factor;
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        const double g = std::exp(-((x - cx) * (x - cx) + (y - cy) * (y - cy)) / (2 * sigma * sigma));
        image.at<cv::Vec3b>(y, x) = cv::Vec3b(cv::saturate_cast<uint8_t>(128 - 90 * g), 128,
                                              cv::saturate_cast<uint8_t>(128 + 110 * g));
      }
    }
    const FeatureSet features = ChromaFeatures(image, 100, 120);
    ASSERT_GT(features.size(), 0) << "factor " << factor;
    double best = 1e9;
    for (int i = 0; i < features.size(); ++i) {
      best = std::min(best, std::hypot(features.keypoints[6 * i] - (cx + 0.5), features.keypoints[6 * i + 1] - (cy + 0.5)));
    }
    EXPECT_LT(best, 0.1 * factor) << "factor " << factor;
  }
}

}  // namespace
}  // namespace relight
