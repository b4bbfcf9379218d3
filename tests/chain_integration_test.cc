// The whole chain on the CI scene (issue 10): `pipeline run
// configs/synthetic_tiny.yaml` renders a 20-photo collection with ground
// truth, then runs sfm -> mvs -> mesh -> linearize -> visibility -> observe ->
// inverse -> relight -> evaluate -> report as subprocesses (about 4 minutes on
// an idle 2-core machine). The test checks the camera, mesh and relighting
// accuracy in report/metrics.json against ranges, that a second run reruns
// nothing, that `pipeline render` renders the photos' cameras under a new map without rerunning a stage,
// and that a changed solver option reuses everything before `inverse`.
//
// Measured on 2026-11-22 over eight runs (docs/RESULTS.md@15cf301, "The whole chain"):
// rotation 0.10-0.14 deg, centre 0.27-0.45% of the scene radius, mesh Chamfer
// 0.99-1.07% of the object's diagonal, sun direction 1.2-2.1 deg, relighting
// 17.7-18.3 dB and re-rendering 18.7-19.2 dB (scale-invariant HDR-PSNR on the
// object's pixels). The bounds: the issue-8 camera targets; Chamfer 2%; light
// direction 10 deg; PSNR about 3 dB under the measured values. The chain is
// deterministic since mvs 7 (COLMAP's fusion and Poisson on one thread): two runs
// from scratch gave byte-identical meshes and results. Before, fusion order
// alone moved the env-map error between 0.708 and 0.809 over three CI runs. A mesh stage that crops part of the object fails all of them at
// once (Chamfer 4-9%, sun 97-125 deg off, 12-13 dB: RESULTS@15cf301, "Why two CI runs
// failed"). Environment maps (inverse 14, light_prior natural, mvs 7, 2026-12-05): relative error 0.710
// over the whole sphere against 0.828 with light_prior smooth; bound 0.78, so a prior that stops filling
// the unseen directions with daylight fails. Since 2026-12-06 the scene is rendered with one bounce of light
// (synthesize.interreflection) and solved with the mesh's bounce (inverse 15): rotation 0.26 deg, centre 0.68%,
// Chamfer 0.91%, sun 1.6 deg, env-map error 0.744, relighting 18.1 dB, re-rendering 20.3 dB, shadow contrast
// error 0.133 (0.353 with inverse.interreflection off on this scene; docs/RESULTS.md, "Light that bounces").
//
// Set RELIGHT_CHAIN_WORKSPACE to keep the workspace (and reuse it across runs). RELIGHT_CHAIN_EXPORT names a
// folder the test runs in from scratch and leaves behind: ctest sets it for slurm_integration_test, which runs
// at the same time and compares its Slurm run with this local one once RELIGHT_CHAIN_EXPORT.done (the first
// run's exit status) exists.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <set>

#include "core/fs.h"
#include "core/json.h"
#include "testing/testing.h"

namespace relight {
namespace {
namespace fs = std::filesystem;

const Json& StageEntry(const Json& summary, const std::string& name) {
  for (const Json& stage : summary["stages"]) {
    if (stage["name"] == name) return stage;
  }
  static const Json kNull;
  ADD_FAILURE() << "no stage '" << name << "' in summary.json";
  return kNull;
}

TEST(ChainIntegrationTest, SyntheticTinyEndToEndIsAccurateAndCached) {
  setenv("RELIGHT_PROGRESS", "plain", 1);
  testing::TempDir temp;
  const char* keep = std::getenv("RELIGHT_CHAIN_WORKSPACE");
  const char* exported = std::getenv("RELIGHT_CHAIN_EXPORT");
  std::string ws = keep != nullptr ? std::string(keep) : temp / "ws";
  if (exported != nullptr) {
    ws = exported;
    fs::remove(ws + ".done");
    fs::remove_all(ws);
  }
  const std::string config = testing::SourceDir() + "/configs/synthetic_tiny.yaml";
  const std::string pipeline = testing::BinDir() + "/pipeline ";
  std::string out;
  const int status = testing::RunCommand(pipeline + "run " + config + " --workspace " + ws, &out);
  if (exported != nullptr) WriteFileAtomic(ws + ".done", std::to_string(status));  // slurm_integration_test waits
  ASSERT_EQ(status, 0) << out;

  const std::vector<std::string> chain = {"synthesize", "ingest",  "sfm",     "mvs",      "mesh",   "linearize",
                                          "visibility", "observe", "inverse", "relight", "evaluate", "report"};
  {
    const Json summary = ReadJsonFile(ws + "/summary.json");
    for (const std::string& stage : chain) {
      const std::string status = StageEntry(summary, stage).value("status", "");
      EXPECT_TRUE(status == "done" || status == "cached") << stage << ": " << status;
    }
  }

  const Json m = ReadJsonFile(ws + "/report/metrics.json");
  // Cameras: every photo registered; after similarity alignment the issue-8 targets.
  ASSERT_TRUE(m.contains("cameras")) << m.dump(2);
  EXPECT_EQ(m["cameras"]["missing"].get<int>(), 0);
  EXPECT_LE(m["cameras"]["median_rotation_deg"].get<double>(), 0.5);
  EXPECT_LE(m["cameras"]["median_center_error_relative"].get<double>(), 0.01);
  // Mesh from our MVS + Poisson + CGAL clean-up against the true object.
  ASSERT_TRUE(m.contains("mesh")) << m.dump(2);
  EXPECT_LE(m["mesh"]["chamfer_relative"].get<double>(), 0.02);
  // Lighting: the brightest direction of the recovered maps against the truth's (sunny photos).
  EXPECT_LE(m["light_dir_error_deg"].get<double>(), 10.0);
  // The whole recovered maps, the directions the photos do not see included, against the true maps.
  EXPECT_LE(m["envmap_rel_error"].get<double>(), 0.78);
  // Relighting: held-out views under held-out light, and the input photos re-rendered.
  EXPECT_GE(m["relight_psnr_db"].get<double>(), 15.0);
  EXPECT_GE(m["rerender_psnr_db"].get<double>(), 16.0);
  // Albedo of the object alone, and of the reconstruction's ground against the true ground (evaluate 7,
  // inverse 15, the scene rendered with one bounce, 2026-12-06: 16.0 and 21.6 dB; bounds about 3 dB under).
  EXPECT_GE(m["albedo_psnr_db"].get<double>(), 12.0);
  ASSERT_TRUE(m["albedo"]["surroundings_psnr_db"].is_number()) << m["albedo"].dump();
  EXPECT_GE(m["albedo"]["surroundings_psnr_db"].get<double>(), 18.0);
  // Shadows under the held-out sky's sun: the relit sunlit/shadow contrast within 20 % of the truth's
  // (shading baked into the albedo, or a blurred sun, washes it out; docs/METRICS.md).
  ASSERT_TRUE(m["shadow_contrast_error"].is_number()) << m["not_available"].dump();
  EXPECT_LE(m["shadow_contrast_error"].get<double>(), 0.2);
  EXPECT_TRUE(fs::exists(ws + "/report/index.html"));
  std::printf(
      "chain metrics: rotation %.3f deg, centre %.4f, chamfer %.4f, light direction %.2f deg, env-map error %.3f, "
      "relight %.2f dB, shadow contrast error %.3f, rerender %.2f dB, albedo %.2f dB (surroundings %.2f dB)\n",
      m["cameras"]["median_rotation_deg"].get<double>(), m["cameras"]["median_center_error_relative"].get<double>(),
      m["mesh"]["chamfer_relative"].get<double>(), m["light_dir_error_deg"].get<double>(),
      m.value("envmap_rel_error", -1.0), m["relight_psnr_db"].get<double>(), m.value("shadow_contrast_error", -1.0),
      m["rerender_psnr_db"].get<double>(), m["albedo_psnr_db"].get<double>(),
      m["albedo"]["surroundings_psnr_db"].get<double>());

  // A second run reruns nothing.
  ASSERT_EQ(testing::RunCommand(pipeline + "run " + config + " --workspace " + ws, &out), 0) << out;
  {
    const Json summary = ReadJsonFile(ws + "/summary.json");
    for (const std::string& stage : chain) EXPECT_EQ(StageEntry(summary, stage).value("status", ""), "cached") << stage;
  }

  // `pipeline render`: the model from the photos' cameras under a Blender-convention map, turned and scaled,
  // with every stage cached (nothing reruns) and one image per registered photo.
  const std::string envmap = "/usr/share/blender/datafiles/studiolights/world/sunset.exr";
  ASSERT_TRUE(fs::is_regular_file(envmap)) << "blender-data is missing (tools/setup_debian.sh installs it)";
  ASSERT_EQ(testing::RunCommand(pipeline + "render " + config + " --workspace " + ws + " --cameras " + ws +
                                    "/stages/sfm/sparse --envmap " + envmap +
                                    " --envmap-convention blender --rotate-deg 45 --strength 2 --max-size 64 --out " +
                                    ws + "/render_test",
                                &out),
            0)
      << out;
  {
    const Json summary = ReadJsonFile(ws + "/summary.json");
    for (const char* stage : {"sfm", "mvs", "visibility", "inverse"})
      EXPECT_EQ(StageEntry(summary, stage).value("status", ""), "cached") << stage;
    const Json render = ReadJsonFile(ws + "/render_test/render_summary.json");
    EXPECT_EQ(render["convention"], "blender");
    ASSERT_EQ(render["images"].size(), 20u);
    for (const Json& image : render["images"]) {
      EXPECT_TRUE(fs::is_regular_file(ws + "/render_test/" + image["png"].get<std::string>())) << image.dump();
      EXPECT_LE(image["camera"]["width"].get<int>(), 64);
    }
  }

  // A changed solver option reruns the inverse rendering only (up to --until). The option is
  // one that makes the rerun short: the first run already measured the solve.
  ASSERT_EQ(testing::RunCommand(pipeline + "run " + config + " --workspace " + ws +
                                    " --set inverse.max_iterations=2 --until inverse",
                                &out),
            0)
      << out;
  {
    const Json summary = ReadJsonFile(ws + "/summary.json");
    for (const std::string& stage : chain) {
      const std::string status = StageEntry(summary, stage).value("status", "");
      if (stage == "inverse") {
        EXPECT_EQ(status, "done");
      } else if (stage == "relight" || stage == "evaluate" || stage == "report") {
        EXPECT_EQ(status, "skipped") << stage;
      } else {
        EXPECT_EQ(status, "cached") << stage;
      }
    }
  }
}

}  // namespace
}  // namespace relight
