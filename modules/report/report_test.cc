// The report's building blocks: HTML escaping, CSV fields, gnuplot charts
// (CSV + script + SVG), and a page from no upstream output at all (every
// section says why it is empty; no image tag points nowhere).
#include "report/report.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "core/fs.h"
#include "core/log.h"
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
  const ReportSummary s = RunReport(o, {}, dir.path());
  const std::string page = ReadFileToString(dir / "index.html");
  EXPECT_NE(page.find("id=\"selfcheck\""), std::string::npos);
  EXPECT_NE(page.find("the evaluate stage did not run"), std::string::npos);
  EXPECT_EQ(page.find("<img"), std::string::npos) << "no image without a file behind it";
  EXPECT_EQ(s.images, 0);
  EXPECT_FALSE(fs::exists(dir / "metrics.json"));
}

}  // namespace
}  // namespace relight
