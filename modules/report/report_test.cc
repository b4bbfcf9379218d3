// The report's building blocks: HTML escaping, CSV fields, gnuplot charts
// (CSV + script + SVG), and a page from no upstream output at all (every
// section says why it is empty; no image tag points nowhere).
#include "report/report.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "core/fs.h"
#include "core/log.h"
#include "image/image.h"
#include "report/charts.h"
#include "report/html.h"
#include "testing/testing.h"

namespace relight {
namespace {
namespace fs = std::filesystem;

TEST(Html, EscapingAndNumbers) {
  EXPECT_EQ(html::Escape("a<b & \"c\" 'd'>"), "a&lt;b &amp; &quot;c&quot; &#39;d&#39;&gt;");
  EXPECT_EQ(html::Number(3.14159, 2), "3.14");
  EXPECT_EQ(html::Number(NAN), "n/a");
  EXPECT_NE(html::Img("images/a b.png", "x<y", 100).find("alt=\"x&lt;y\""), std::string::npos);
  EXPECT_EQ(CsvField("plain"), "plain");
  EXPECT_EQ(CsvField("a,b"), "\"a,b\"");
  EXPECT_EQ(CsvField("say \"hi\""), "\"say \"\"hi\"\"\"");
}

TEST(Charts, CsvScriptAndSvg) {
  testing::TempDir dir;
  const ChartFiles f = WriteChart(dir.path(), "demo", {"x", "y"}, {{"1", "2"}, {"2", "NaN"}, {"3", "5"}},
                                  "plot 'demo.csv' skip 1 using 1:2 with linespoints notitle", true);
  EXPECT_EQ(ReadFileToString(dir / "demo.csv"), "x,y\n1,2\n2,NaN\n3,5\n");
  EXPECT_NE(ReadFileToString(dir / "demo.gp").find("set output out"), std::string::npos);
  ASSERT_EQ(f.error, "") << "gnuplot (Debian gnuplot-nox) is installed by tools/setup_debian.sh";
  ASSERT_EQ(f.svg, "demo.svg");
  const std::string svg = ReadFileToString(dir / "demo.svg");
  EXPECT_NE(svg.find("<svg"), std::string::npos);
  EXPECT_NE(svg.find("width=\"640\""), std::string::npos);
  for (const auto& e : fs::directory_iterator(dir.path()))
    EXPECT_EQ(e.path().filename().string().find(".relight-tmp-"), std::string::npos) << e.path();
  // A script error is reported, not thrown.
  const ChartFiles bad = WriteChart(dir.path(), "bad", {"x"}, {{"1"}}, "plot nosuchfunction(x)", true);
  EXPECT_TRUE(bad.svg.empty());
  EXPECT_NE(bad.error.find("gnuplot failed"), std::string::npos) << bad.error;
}

TEST(Report, PageWithoutUpstreamOutputs) {
  InitLogging("report_test", "", LogLevel::kWarning);
  testing::TempDir dir;
  ReportOptions o;
  const ReportSummary s = RunReport(o, ReportInputs{}, dir.path());
  const std::string page = ReadFileToString(dir / "index.html");
  EXPECT_NE(page.find("id=\"selfcheck\""), std::string::npos);
  EXPECT_NE(page.find("the evaluate stage did not run"), std::string::npos);
  EXPECT_EQ(page.find("<img"), std::string::npos) << "no image without a file behind it";
  EXPECT_EQ(s.images, 0);
  EXPECT_FALSE(fs::exists(dir / "metrics.json"));
}

// The cameras and geometry section from the sfm summary and the mesh stage's views: the photos that did not
// register with their reasons, the mapper runs, and photo / points / mesh side by side.
TEST(Report, CamerasAndGeometrySection) {
  InitLogging("report_test", "", LogLevel::kWarning);
  testing::TempDir dir;
  for (const char* d : {"sfm", "mesh/views", "ingest/images", "out"}) fs::create_directories(dir / d);
  WriteFileAtomic(dir / "sfm/sfm_summary.json", R"({"mode": "colmap", "num_photos": 3, "num_registered": 2,
    "consensus": "agreed", "mapper_runs": [{"first_pair": "a.png + b.png", "num_registered": 2,
    "photo_pairs_checked": 1, "photo_pairs_agreeing": 1, "kept": true}],
    "photos": [{"name": "a.png", "registered": true}, {"name": "b.png", "registered": true},
               {"name": "c.png", "registered": false, "reason": "no verified matches with any other photo"}]})");
  Image grey(8, 6, 3, 0.5f);
  WriteImage(dir / "ingest/images/a.png", grey);
  WriteImage(dir / "mesh/views/a_mesh.png", grey);
  WriteImage(dir / "mesh/views/a_points.png", grey);
  WriteFileAtomic(dir / "ingest/manifest.json",
                  R"({"photos": [{"name": "a.png", "file": "images/a.png", "linear": false}]})");
  WriteFileAtomic(dir / "mesh/views.json",
                  R"({"views": [{"photo": "a.png", "mesh": "views/a_mesh.png", "points": "views/a_points.png"}]})");
  ReportInputs inputs;
  inputs.ingest_dir = dir / "ingest";
  inputs.sfm_dir = dir / "sfm";
  inputs.mesh_dir = dir / "mesh";
  const ReportSummary s = RunReport(ReportOptions(), inputs, dir / "out");
  const std::string page = ReadFileToString(dir / "out/index.html");
  EXPECT_NE(page.find("id=\"geometry\""), std::string::npos);
  EXPECT_NE(page.find("2 of 3 photos registered"), std::string::npos);
  EXPECT_NE(page.find("no verified matches with any other photo"), std::string::npos);
  EXPECT_NE(page.find("a.png + b.png"), std::string::npos);
  EXPECT_EQ(s.images, 3);  // photo, points, mesh
  EXPECT_TRUE(fs::exists(dir / "out/images/geometry/a_mesh.png"));
}

}  // namespace
}  // namespace relight
