// The whole chain on a tiny synthetic scene (synthesize → ingest → sfm and
// mesh from the ground truth → linearize → visibility → observe → inverse →
// relight → evaluate → report) through `pipeline report`, then the page in
// headless Chromium (Debian `chromium`): every image decodes, no script error,
// and the numbers of metrics.json are in the ranges this scene gives.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>

#include "core/fs.h"
#include "core/json.h"
#include "image/image.h"
#include "testing/testing.h"

namespace relight {
namespace {
namespace fs = std::filesystem;

constexpr char kChromium[] = "/usr/bin/chromium";

// A scene small enough for the whole chain to run in well under a minute on 2 cores.
std::string TinyConfig(const std::string& hdr) {
  std::string c = R"(synthesize:
  shape: blob
  object_vertices: 2500
  num_materials: 2
  ground_cells: 32
  sky_fraction: 1
  envmap_height: 32
  gt_oct_size: 16
  num_photos: 6
  image_size_min: 112
  image_size_max: 128
  light_samples: 4
  brdf_samples: 4
  relight_views: 1
  relight_envmaps: []
  relight_skies: 1
  relight_image_size: 64
  relight_light_samples: 8
  relight_brdf_samples: 8
  seed: 3
sfm:
  mode: ground_truth
mesh:
  source: ground_truth
visibility:
  resolution: 16
inverse:
  env_resolution: 16
  basis: [lambertian, "phong:50"]
  materials: 2
  max_iterations: 3
relight:
  rerender_max_size: 128
  views: 1
  image_size: 64
  turntable_frames: 4
  turntable_size: 48
  light_samples: 4
  brdf_samples: 4
evaluate:
  leave_one_out: always
  loo_max_photos: 1
  loo_max_iterations: 2
  mesh_samples: 2000
)";
  c += "relight.envmaps: [" + (hdr.empty() ? std::string() : "\"" + hdr + "\"") + "]\n";
  return c;
}

TEST(ReportBrowser, TinySyntheticChainPageLoadsInHeadlessChromium) {
  ASSERT_TRUE(fs::exists(kChromium)) << "install Debian's chromium (tools/setup_debian.sh)";
  setenv("RELIGHT_PROGRESS", "plain", 1);
  testing::TempDir dir;
  const std::string hdr =
      testing::HasSharedData("envmaps/grace.hdr") ? testing::SharedDataDir() + "/envmaps/grace.hdr" : "";
  std::ofstream(dir / "tiny.yaml") << TinyConfig(hdr);
  std::string out;
  const int rc = testing::RunCommand(
      testing::BinDir() + "/pipeline report " + (dir / "tiny.yaml") + " --workspace " + (dir / "ws"), &out);
  ASSERT_EQ(rc, 0) << out;
  const std::string page = dir / "ws/report/index.html";
  ASSERT_TRUE(fs::is_regular_file(page)) << out;
  EXPECT_NE(out.find("report/index.html"), std::string::npos) << out;

  // metrics.json beside the page: the headline keys; numbers in the ranges of this scene (ground-truth
  // geometry and cameras, 3 solver iterations, 4+4 render samples).
  const Json m = ReadJsonFile(dir / "ws/report/metrics.json");
  for (const char* key : {"relight_psnr_db", "rerender_psnr_db", "rerender_rmse", "envmap_rel_error",
                          "light_dir_error_deg", "albedo_psnr_db", "loo_psnr_db", "seconds"}) {
    ASSERT_TRUE(m.contains(key)) << key;
    EXPECT_TRUE(m[key].is_number() || m[key].is_object()) << key << " = " << m[key].dump();
  }
  // Measured with this config (seed 3): relight 20.4 dB, re-render 18.2 dB (relative RMSE 0.42), env maps
  // 0.88, sun direction 11.1 deg, albedo 16.3 dB, leave-one-out 15.2 dB. The bounds leave room for Monte
  // Carlo and solver changes but catch a broken frame, mask or scale (those give < 10 dB / > 60 deg).
  EXPECT_GT(m["rerender_psnr_db"].get<double>(), 15.0);
  EXPECT_LT(m["rerender_rmse"].get<double>(), 0.6);
  EXPECT_GT(m["relight_psnr_db"].get<double>(), 16.0);
  EXPECT_LT(m["envmap_rel_error"].get<double>(), 0.97);
  EXPECT_LT(m["light_dir_error_deg"].get<double>(), 30.0);
  EXPECT_GT(m["albedo_psnr_db"].get<double>(), 13.0);
  EXPECT_GT(m["loo_psnr_db"].get<double>(), 12.0);
  for (const char* stage : {"synthesize", "ingest", "inverse", "relight", "evaluate"})
    EXPECT_TRUE(m["seconds"].contains(stage)) << stage;

  // Headless Chromium with the network closed (flags from the project's brief), fresh profile.
  const std::string profile = dir / "chromium-profile";
  fs::create_directories(profile);
  const std::string dom = dir / "dom.html", log = dir / "chromium.log";
  const std::string cmd = std::string(kChromium) +
                          " --headless --no-sandbox --disable-gpu --disable-quic --no-first-run"
                          " --disable-background-networking --disable-component-update --disable-sync"
                          " --user-data-dir=" +
                          profile + " --enable-logging=stderr --v=0 --dump-dom --virtual-time-budget=5000 file://" +
                          page + " > " + dom + " 2> " + log;
  ASSERT_EQ(testing::RunCommand("timeout 60 " + cmd), 0) << ReadFileToString(log);
  const std::string html = ReadFileToString(dom);
  const std::string console = ReadFileToString(log);
  std::smatch match;
  ASSERT_TRUE(std::regex_search(html, match, std::regex("<p id=\"selfcheck\"[^>]*>"))) << html.substr(0, 2000);
  const std::string tag = match.str();
  EXPECT_NE(tag.find("data-status=\"ok\""), std::string::npos) << tag << "\n" << console;
  EXPECT_NE(tag.find("data-broken=\"0\""), std::string::npos) << tag;
  EXPECT_NE(tag.find("data-js-errors=\"0\""), std::string::npos) << tag;
  ASSERT_TRUE(std::regex_search(tag, match, std::regex("data-images=\"([0-9]+)\"")));
  EXPECT_GE(std::stoi(match[1].str()), 40) << "photos, re-renderings, heat maps, env maps, renders, charts";
  EXPECT_EQ(console.find("Uncaught"), std::string::npos) << console;
  // Self-contained: no absolute or remote source in the page.
  const std::string source = ReadFileToString(page);
  EXPECT_EQ(source.find("src=\"/"), std::string::npos);
  EXPECT_EQ(source.find("http://"), std::string::npos);
  EXPECT_EQ(source.find("https://"), std::string::npos);
  for (const char* section :
       {"id=\"photos\"", "id=\"envmaps\"", "id=\"materials\"", "id=\"heldout\"", "id=\"relit\"", "id=\"turntable\"",
        "id=\"export\"", "id=\"convergence\"", "id=\"loo\"", "id=\"timings\""})
    EXPECT_NE(source.find(section), std::string::npos) << section;
  // The glTF export is linked and copied beside the page with its maps (scene.json's paths resolve).
  EXPECT_NE(source.find("href=\"export/model.glb\""), std::string::npos);
  EXPECT_NE(source.find("href=\"export/scene.json\""), std::string::npos);
  EXPECT_GT(fs::file_size(dir / "ws/report/export/model.glb"), 20000u) << "about 2500 vertices of 40 bytes";
  const Json exported = ReadJsonFile(dir / "ws/report/export/scene.json");
  ASSERT_EQ(exported["photos"].size(), 6u);
  for (const auto& p : exported["photos"])
    EXPECT_TRUE(fs::is_regular_file(dir / ("ws/report/export/" + p["envmap"].get<std::string>()))) << p.dump();
  // What the photos determine of each map (inverse.map_resolution, on at 16² maps): in lighting.json per
  // photo, its levels adding up, and in the env-map table as "N of 256".
  const Json lighting = ReadJsonFile(dir / "ws/stages/inverse/lighting.json");
  for (const Json& p : lighting["photos"]) {
    ASSERT_TRUE(p.contains("determined_coefficients")) << p.dump();
    const double dof = p["determined_coefficients"].get<double>();
    double sum = 0;
    int count = 0;
    for (const Json& d : p["determined_per_level"]) sum += d.get<double>();
    for (const Json& c : p["coefficients_per_level"]) count += c.get<int>();
    EXPECT_NEAR(sum, dof, 1e-6 * dof);
    EXPECT_EQ(count, 16 * 16);
    EXPECT_GT(dof, 1.0);
    EXPECT_LT(dof, 256.0);
    // The seen-or-prior map: a 16² grey PNG beside the map, copied beside the page.
    ASSERT_TRUE(p.contains("determined_map")) << p.dump();
    const Image share = ReadImage(dir / ("ws/stages/inverse/" + p["determined_map"].get<std::string>()));
    EXPECT_EQ(share.width, 16);
    EXPECT_EQ(share.height, 16);
    EXPECT_GT(p["data_share_mean"].get<double>(), 0.0);
    EXPECT_LT(p["data_share_mean"].get<double>(), 1.0);
    const std::string stem = fs::path(p["determined_map"].get<std::string>()).filename().string();
    EXPECT_TRUE(fs::is_regular_file(dir / ("ws/report/images/inverse/" + stem))) << stem;
    // The fitted daylight model's sun: a unit direction above the horizon, its elevation, its share.
    ASSERT_TRUE(p.contains("sun")) << p.dump();
    const std::vector<double> sun = p["sun"]["direction_world"].get<std::vector<double>>();
    ASSERT_EQ(sun.size(), 3u);
    EXPECT_NEAR(std::hypot(sun[0], sun[1], sun[2]), 1.0, 1e-9);
    EXPECT_GE(sun[2], 0.0);
    EXPECT_NEAR(p["sun"]["elevation_deg"].get<double>(), std::asin(sun[2]) * 180 / M_PI, 1e-9);
    EXPECT_GE(p["sun"]["irradiance_share"].get<double>(), 0.0);
    EXPECT_LE(p["sun"]["irradiance_share"].get<double>(), 1.0);
    EXPECT_GE(p["sun"]["daylight_explained_variation"].get<double>(), 0.0);
    EXPECT_LE(p["sun"]["daylight_explained_variation"].get<double>(), 1.0);
  }
  EXPECT_TRUE(std::regex_search(
      source, match,
      std::regex("<br>[0-9]+ of 256(, detail to [0-9]+&deg;|, the mean only)<br>sun [0-9]+&deg; high, azimuth "
                 "[0-9]+&deg; from \\+X, [0-9]+% of the light on the ground; the daylight model explains [0-9]+% of "
                 "the seen part<br>unseen directions filled by the (daylight model|smoothness prior|"
                 "daylight model \\([0-9]+%\\) and the smoothness prior)</td>")))
      << "the env-map table's 'determined by the photos' column, with the fitted sun and how well it fits";
  EXPECT_TRUE(fs::exists(dir / "ws/report/charts/convergence.svg"));
  EXPECT_TRUE(fs::exists(dir / "ws/report/charts/convergence.csv"));
  // Accuracy against time: every start's iterations at increasing wall clock, then the kept iterate, which
  // is one of them.
  EXPECT_TRUE(fs::exists(dir / "ws/report/charts/accuracy_time.svg"));
  std::ifstream csv(dir / "ws/report/charts/accuracy_time.csv");
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line, "series,label,solve_seconds,holdout_rmse");
  std::map<int, double> last_seconds;
  std::set<std::pair<double, double>> iterates;
  int kept = 0;
  while (std::getline(csv, line)) {
    std::vector<std::string> f;
    std::stringstream fields(line);
    for (std::string x; std::getline(fields, x, ',');) f.push_back(x);
    ASSERT_EQ(f.size(), 4u) << line;
    const double seconds = std::stod(f[2]), error = std::stod(f[3]);
    EXPECT_GT(error, 0) << line;
    if (f[1] == "kept") {
      ++kept;
      EXPECT_EQ(iterates.count({seconds, error}), 1u) << "the kept point is an iterate: " << line;
      continue;
    }
    const int series = std::stoi(f[0]);
    EXPECT_GT(seconds, last_seconds.count(series) ? last_seconds[series] : 0.0) << line;
    last_seconds[series] = seconds;
    iterates.insert({seconds, error});
  }
  EXPECT_EQ(kept, 1);
  EXPECT_GE(last_seconds.size(), 1u);
  // The leave-one-out headline beside the re-rendering of the same photo.
  EXPECT_TRUE(m["leave_one_out"]["rerender_psnr_db"].is_number()) << m["leave_one_out"].dump();
  EXPECT_NE(source.find("(the same photos re-rendered: "), std::string::npos);
}

}  // namespace
}  // namespace relight
