// Lighting conditions: the sky/file mix, per-condition rotation and intensity
// applied as documented (a feature at azimuth phi appears at phi + rotation),
// the sky path equals the sky model, and unreadable files are user errors.
#include "synth/illumination.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "testing/testing.h"

namespace relight {
namespace {

TEST(IlluminationTest, SkyFractionMixesSourcesInTurn) {
  SynthesizeOptions o;
  o.envmaps = {"a.hdr", "b.hdr"};
  o.sky_fraction = 0.5;
  Pcg32 rng(1);
  const auto c = DrawPhotoLightings(o, 8, &rng);
  int skies = 0;
  for (int i = 0; i < 8; ++i) {
    skies += c[i].source == "sky";
    EXPECT_GE(c[i].intensity, o.intensity_min);
    EXPECT_LE(c[i].intensity, o.intensity_max);
    if (c[i].source == "sky") {
      const double elevation = std::asin(c[i].sky.sun_dir_world.normalized().z()) * 180 / M_PI;
      EXPECT_GE(elevation, o.sun_elevation_min_deg - 1e-9);
      EXPECT_LE(elevation, o.sun_elevation_max_deg + 1e-9);
    }
  }
  EXPECT_EQ(skies, 4);
  EXPECT_EQ(c[0].file, "a.hdr");
  EXPECT_EQ(c[2].file, "b.hdr");
  EXPECT_EQ(c[4].file, "a.hdr");
  o.envmaps.clear();
  for (const auto& x : DrawPhotoLightings(o, 5, &rng)) EXPECT_EQ(x.source, "sky");
  o.envmaps = {"a.hdr"};
  o.sky_fraction = 0;
  for (const auto& x : DrawPhotoLightings(o, 5, &rng)) EXPECT_EQ(x.source, "file");
}

TEST(IlluminationTest, FileMapsAreRotatedAboutZAndScaled) {
  testing::TempDir dir;
  // A dark map with a bright patch around azimuth 0 on the horizon.
  Image image(128, 64, 3, 0.1f);
  for (int y = 30; y < 34; ++y)
    for (int x = 0; x < 3; ++x)
      for (int c = 0; c < 3; ++c) image.at(x, y, c) = 50.0f;
  WriteOptions w;
  w.type = PixelType::kFloat;
  const std::string path = dir / "spot.exr";
  WriteImage(path, image, w);
  LightingCondition c;
  c.source = "file";
  c.file = path;
  c.rotation_z_deg = 90;
  c.intensity = 2.0;
  EnvMapCache cache;
  const Image out = RenderLightingLatLong(c, 64, &cache);
  ASSERT_EQ(out.width, 128);
  // Brightest column: azimuth about 90 degrees (+Y), i.e. column 32 of 128.
  int best_x = 0;
  float best = 0;
  for (int x = 0; x < 128; ++x)
    if (out.at(x, 32, 0) > best) best = out.at(x, 32, 0), best_x = x;
  EXPECT_NEAR(best_x, 32, 2);
  // Far from the patch the radiance is the background times the intensity.
  EXPECT_NEAR(out.at(100, 10, 1), 0.2f, 1e-4f);
  c.file = dir / "missing.hdr";
  EnvMapCache fresh;
  try {
    RenderLightingLatLong(c, 64, &fresh);
    FAIL() << "expected a UserError";
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find("missing.hdr"), std::string::npos) << e.what();
  }
}

TEST(IlluminationTest, SkyConditionIsTheSkyModel) {
  LightingCondition c;
  c.source = "sky";
  c.sky.sun_dir_world = Eigen::Vector3d(0.3, 0.4, 0.6).normalized();
  c.sky.turbidity = 4;
  EnvMapCache cache;
  const Image a = RenderLightingLatLong(c, 32, &cache);
  const Image b = MakeSunSky(c.sky, 32).image();
  EXPECT_EQ(a.pixels, b.pixels);
  const OrderedJson j = LightingConditionToJson(c);
  EXPECT_EQ(j["source"], "sky");
  EXPECT_NEAR(j["turbidity"].get<double>(), 4, 1e-12);
}

TEST(IlluminationTest, HeldOutNamesAreUnique) {
  SynthesizeOptions o;
  o.relight_envmaps = {"/x/grace.hdr", "/y/grace.hdr"};
  o.relight_skies = 2;
  Pcg32 rng(2);
  const auto held = DrawHeldOutLightings(o, &rng);
  ASSERT_EQ(held.size(), 4u);
  EXPECT_EQ(held[0].name, "grace");
  EXPECT_EQ(held[1].name, "grace_2");
  EXPECT_EQ(held[2].name, "sky_0");
  EXPECT_EQ(held[3].name, "sky_1");
}

}  // namespace
}  // namespace relight
