#include "image/image.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "core/error.h"
#include "core/fs.h"
#include "testing/testing.h"

namespace relight {
namespace {
namespace fs = std::filesystem;

Image Gradient(int w, int h, int c) {
  Image img(w, h, c);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int k = 0; k < c; ++k) img.at(x, y, k) = static_cast<float>((x + 2 * y + 3 * k) % 256) / 255.0f;
  return img;
}

void ExpectThrowsMentioning(const std::function<void()>& fn, const std::string& needle) {
  try {
    fn();
    FAIL() << "expected UserError mentioning " << needle;
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

TEST(ImageTest, RoundTripsPngExactly) {
  testing::TempDir dir;
  const Image img = Gradient(37, 21, 3);
  WriteImage(dir / "a.png", img);
  ImageMetadata meta;
  const Image back = ReadImage(dir / "a.png", &meta);
  ASSERT_EQ(back.width, 37);
  ASSERT_EQ(back.height, 21);
  EXPECT_EQ(meta.bits_per_sample, 8);
  EXPECT_FALSE(meta.is_float);
  for (size_t i = 0; i < img.pixels.size(); ++i) EXPECT_NEAR(back.pixels[i], img.pixels[i], 1e-6);
}

TEST(ImageTest, SixteenBitAndFloatKeepPrecision) {
  testing::TempDir dir;
  Image img(8, 4, 3);
  for (size_t i = 0; i < img.pixels.size(); ++i) img.pixels[i] = static_cast<float>(i) / 1000.0f;
  WriteImage(dir / "a.png", img, {PixelType::kUint16});
  const Image b16 = ReadImage(dir / "a.png");
  for (size_t i = 0; i < img.pixels.size(); ++i) EXPECT_NEAR(b16.pixels[i], img.pixels[i], 1.0 / 65535.0);
  Image hdr = img;
  hdr.pixels[5] = 1234.5f;  // HDR values above 1 survive EXR
  WriteImage(dir / "a.exr", hdr, {PixelType::kFloat});
  ImageMetadata meta;
  const Image bf = ReadImage(dir / "a.exr", &meta);
  EXPECT_TRUE(meta.is_float);
  for (size_t i = 0; i < hdr.pixels.size(); ++i) EXPECT_FLOAT_EQ(bf.pixels[i], hdr.pixels[i]);
}

TEST(ImageTest, ExifCarriedOverAndOrientationApplied) {
  testing::TempDir dir;
  ImageMetadata exif;
  exif.focal_length_mm = 35.0;
  exif.exposure_time_s = 1.0 / 250.0;
  exif.f_number = 8.0;
  WriteImage(dir / "a.jpg", Gradient(40, 20, 3), {PixelType::kUint8, 95, &exif});
  const ImageMetadata meta = ReadImageMetadata(dir / "a.jpg");
  ASSERT_TRUE(meta.focal_length_mm.has_value());
  EXPECT_NEAR(*meta.focal_length_mm, 35.0, 1e-3);
  ASSERT_TRUE(meta.exposure_time_s.has_value());
  EXPECT_NEAR(*meta.exposure_time_s, 0.004, 1e-6);
  EXPECT_NEAR(meta.f_number.value_or(0), 8.0, 1e-4);

  // A camera held upright stores a landscape buffer with Orientation 6 (rotate 90° clockwise).
  const Image landscape = Gradient(40, 20, 3);
  OIIO::ImageSpec spec(40, 20, 3, OIIO::TypeDesc::UINT8);
  spec.attribute("Orientation", 6);
  auto out = OIIO::ImageOutput::create(dir / "rot.jpg");
  ASSERT_TRUE(out->open(dir / "rot.jpg", spec));
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, landscape.pixels.data()));
  out->close();
  ImageMetadata rot_meta;
  const Image upright = ReadImage(dir / "rot.jpg", &rot_meta);
  EXPECT_EQ(rot_meta.orientation, 6);
  ASSERT_EQ(upright.width, 20);
  ASSERT_EQ(upright.height, 40);
  // Rotating clockwise moves the stored top-left pixel to the top-right.
  EXPECT_NEAR(upright.at(19, 0, 0), landscape.at(0, 0, 0), 0.03);
  EXPECT_NEAR(upright.at(0, 39, 0), landscape.at(39, 19, 0), 0.03);
  EXPECT_EQ(ReadImage(dir / "rot.jpg", nullptr, false).width, 40);
}

TEST(ImageTest, BadFilesGiveClearErrors) {
  testing::TempDir dir;
  std::ofstream(dir / "text.jpg") << "this is not a photo";
  std::ofstream(dir / "empty.jpg");
  ExpectThrowsMentioning([&] { ReadImage(dir / "text.jpg"); }, "text.jpg");
  ExpectThrowsMentioning([&] { ReadImage(dir / "empty.jpg"); }, "empty");
  ExpectThrowsMentioning([&] { ReadImage(dir / "missing.jpg"); }, "does not exist");
  // A JPEG cut in half.
  WriteImage(dir / "full.jpg", Gradient(256, 256, 3));
  const std::string bytes = ReadFileToString(dir / "full.jpg");
  std::ofstream(dir / "cut.jpg", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  ExpectThrowsMentioning([&] { ReadImage(dir / "cut.jpg"); }, "cut.jpg");
}

TEST(ImageTest, ResizeKeepsMeanOfSmoothImage) {
  Image img(64, 32, 1);
  double mean = 0;
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 64; ++x) mean += img.at(x, y) = 0.25f + 0.5f * x / 63.0f;
  mean /= 64 * 32;
  const Image small = ResizeImage(img, 16, 8);
  double small_mean = 0;
  for (float v : small.pixels) small_mean += v;
  small_mean /= small.pixels.size();
  EXPECT_NEAR(small_mean, mean, 2e-3);
}

TEST(ImageTest, BilinearSampleOfLinearRampIsExact) {
  Image img(10, 10, 1);
  for (int y = 0; y < 10; ++y)
    for (int x = 0; x < 10; ++x) img.at(x, y) = static_cast<float>(x + 0.5) * 2.0f + static_cast<float>(y + 0.5);
  float v;
  SampleBilinear(img, 3.25, 6.75, &v);
  EXPECT_NEAR(v, 3.25 * 2 + 6.75, 1e-5);
}

}  // namespace
}  // namespace relight
