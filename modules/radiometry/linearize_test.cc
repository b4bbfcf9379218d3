#include "radiometry/linearize.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>

#include "core/fs.h"
#include "core/json.h"
#include "image/color.h"
#include "core/log.h"
#include "ingest/ingest.h"
#include "testing/testing.h"

namespace relight {
namespace {
namespace fs = std::filesystem;

TEST(LinearizeTest, SrgbRoundTrip) {
  for (int i = 0; i <= 1000; ++i) {
    const double e = i / 1000.0;
    EXPECT_NEAR(SrgbEncode(SrgbDecode(e)), e, 1e-6);
  }
  // Reference points of the sRGB curve (IEC 61966-2-1).
  EXPECT_NEAR(SrgbDecode(0.5), 0.21404114, 1e-7);
  EXPECT_NEAR(SrgbDecode(0.04045), 0.04045 / 12.92, 1e-12);
  EXPECT_DOUBLE_EQ(SrgbDecode(1.0), 1.0);
}

TEST(LinearizeTest, ClippedAndBlackPixelsGetZeroConfidence) {
  Image img(10, 10, 3, 0.5f);
  img.at(2, 2, 1) = 1.0f;     // one saturated channel
  img.at(7, 7, 0) = 0.0f;     // one black-clipped channel
  LinearizeOptions o;
  o.clip_dilation_px = 1;
  const LinearImage lin = Linearize(img, false, o);
  EXPECT_EQ(lin.confidence.at(2, 2), 0.0f);
  EXPECT_EQ(lin.confidence.at(3, 3), 0.0f);  // dilated neighbour
  EXPECT_EQ(lin.confidence.at(4, 4), 1.0f);
  EXPECT_EQ(lin.confidence.at(7, 7), 0.0f);
  EXPECT_NEAR(lin.clipped_fraction, 0.01, 1e-12);
  EXPECT_NEAR(lin.radiance.at(5, 5, 0), SrgbDecode(0.5), 1e-6);
  // The over-exposure level in linear units tells which channel of a distrusted pixel clipped.
  EXPECT_NEAR(lin.overexposed_linear, SrgbDecode(o.saturation_level), 1e-12);
  EXPECT_GE(lin.radiance.at(2, 2, 1), lin.overexposed_linear);
  EXPECT_LT(lin.radiance.at(2, 2, 0), lin.overexposed_linear);
  // Kept black pixels (linear raw data): their own confidence, no dilation; clipped pixels still win.
  o.black_confidence = 0.5;
  img.at(3, 2, 2) = 0.0f;  // black, beside the saturated pixel
  const LinearImage kept = Linearize(img, false, o);
  EXPECT_EQ(kept.confidence.at(7, 7), 0.5f);
  EXPECT_EQ(kept.confidence.at(8, 8), 1.0f);
  EXPECT_EQ(kept.confidence.at(3, 2), 0.0f);
  EXPECT_EQ(kept.radiance.at(7, 7, 0), 0.0f);
  o.black_confidence = 0.0;
  o.transfer = "gamma";
  EXPECT_NEAR(Linearize(img, false, o).radiance.at(5, 5, 0), std::pow(0.5, 2.2), 1e-6);
  o.transfer = "linear";
  EXPECT_NEAR(Linearize(img, false, o).radiance.at(5, 5, 0), 0.5, 1e-7);
  // Float inputs pass through; only non-finite or negative values are distrusted.
  Image hdr(4, 4, 3, 7.5f);
  hdr.at(1, 1, 2) = -1.0f;
  const LinearImage pass = Linearize(hdr, true, LinearizeOptions{});
  EXPECT_EQ(pass.radiance.at(3, 3, 0), 7.5f);
  EXPECT_EQ(pass.confidence.at(3, 3), 1.0f);
  EXPECT_EQ(pass.confidence.at(1, 1), 0.0f);
  EXPECT_TRUE(std::isinf(pass.overexposed_linear));  // floats do not clip
}

TEST(LinearizeTest, ExifExposure) {
  EXPECT_NEAR(*ExifExposure(1.0 / 100, 4.0, 200.0), 0.01 * 200 / 16, 1e-12);
  EXPECT_FALSE(ExifExposure(std::nullopt, 4.0, 100.0).has_value());
}

TEST(LinearizeTest, StageWritesOutputsNormalizesExposureAndResumes) {
  InitLogging("linearize_test", "", LogLevel::kError);
  setenv("RELIGHT_PROGRESS", "off", 1);
  testing::TempDir dir;
  fs::create_directories(dir / "photos");
  // Same scene, two exposures: the second photo got twice the light (2x exposure time).
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> u(0.05f, 0.4f);
  Image linear(24, 16, 3);
  for (float& v : linear.pixels) v = u(rng);
  for (int k = 0; k < 3; ++k) {
    const double t = k == 1 ? 2.0 / 100 : 1.0 / 100;
    Image enc = linear;
    for (float& v : enc.pixels) v = static_cast<float>(SrgbEncode(v * t * 100));
    // Distinct content per photo so ingest keeps all three (not near-duplicates).
    for (int x = 0; x < 24; ++x) enc.at(x, 3 * k, 0) = 0.9f;
    ImageMetadata exif;
    exif.exposure_time_s = t;
    exif.f_number = 4.0;
    exif.iso = 100;
    WriteImage(dir / ("photos/p" + std::to_string(k) + ".png"), enc, {PixelType::kUint16, 95, &exif});
  }
  // PNG has no EXIF: write the manifest's exposure by hand through ingest, then patch it.
  IngestOptions ingest_options;
  ingest_options.min_image_side = 8;  // tiny test photos
  ingest_options.images = dir / "photos";
  RunIngest(ingest_options, {}, dir / "ingest");
  Json manifest = ReadJsonFile(dir / "ingest/manifest.json");
  for (int k = 0; k < 3; ++k) {
    manifest["photos"][k]["exif"]["exposure_time_s"] = k == 1 ? 0.02 : 0.01;
    manifest["photos"][k]["exif"]["f_number"] = 4.0;
    manifest["photos"][k]["exif"]["iso"] = 100.0;
  }
  WriteJsonAtomic(dir / "ingest/manifest.json", manifest);

  const LinearizeSummary s = RunLinearize(LinearizeOptions{}, {dir / "ingest"}, dir / "out");
  EXPECT_TRUE(s.exposure_normalized);
  EXPECT_EQ(s.reused, 0);
  const Image a = ReadImage(dir / "out/linear/p0.exr");
  const Image b = ReadImage(dir / "out/linear/p1.exr");
  // After normalisation both photos agree (16-bit quantisation tolerance) away from the marked rows.
  EXPECT_NEAR(a.at(10, 10, 1), b.at(10, 10, 1), 2e-4);
  EXPECT_NEAR(a.at(10, 10, 1), linear.at(10, 10, 1), 2e-4);
  // The over-exposure level follows the photo's exposure scale (p1 was scaled by 1/2).
  const Json stats = ReadJsonFile(dir / "out/stats/p1.json");
  EXPECT_NEAR(stats["exposure_scale"].get<double>(), 0.5, 1e-12);
  EXPECT_NEAR(stats["overexposed_linear"].get<double>(), 0.5 * SrgbDecode(LinearizeOptions{}.saturation_level),
              1e-12);

  // A rerun (as after a killed run) reuses every finished photo.
  fs::remove(dir / "out/linear/p2.exr");
  const LinearizeSummary again = RunLinearize(LinearizeOptions{}, {dir / "ingest"}, dir / "out");
  EXPECT_EQ(again.reused, 2);
  EXPECT_TRUE(fs::exists(dir / "out/linear/p2.exr"));
  EXPECT_EQ(ReadJsonFile(dir / "out/linearize_summary.json")["photos"].size(), 3u);
}

}  // namespace
}  // namespace relight
