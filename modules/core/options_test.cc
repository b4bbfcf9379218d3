#include "core/options.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <fstream>

#include "core/error.h"
#include "testing/testing.h"

namespace relight {
namespace {

struct DemoOptions {
  int count = 16;
  double scale = 0.5;
  bool flag = false;
  std::string mode = "fast";
  std::string mesh;
  std::vector<double> rgb = {1, 1, 1};
  std::vector<std::string> maps;
  int threads = 0;
  void Declare(OptionTable* t) {
    t->Add("count", &count, "How many.").Min(1).Max(100);
    t->Add("scale", &scale, "Scale.").Min(0);
    t->Add("flag", &flag, "A flag.");
    t->Add("mode", &mode, "Mode.").Choices({"fast", "exact"});
    t->Add("mesh", &mesh, "Mesh.").InputFile();
    t->Add("rgb", &rgb, "Colour.").Size(3);
    t->Add("maps", &maps, "Maps.").InputFile();
    t->Add("threads", &threads, "Threads.").NotInKey();
    t->Retired("samples", "use demo.count");
  }
};

std::string NoDigest(const std::string& p, const FileSelection&) { return "digest(" + p + ")"; }

TEST(OptionsTest, DefaultsAreDeclarationValues) {
  DemoOptions o;
  OptionTable t = MakeOptionTable("demo", &o);
  EXPECT_EQ(t.Find("count")->default_text(), "16");
  EXPECT_EQ(t.Find("scale")->default_text(), "0.5");
  EXPECT_EQ(t.Find("rgb")->default_text(), "[1, 1, 1]");
}

TEST(OptionsTest, CanonicalTextIsSortedAndExcludesNotInKey) {
  DemoOptions o;
  OptionTable t = MakeOptionTable("demo", &o);
  const std::string text = t.CanonicalText(NoDigest);
  EXPECT_EQ(text,
            "demo.count=16\ndemo.flag=false\ndemo.maps=[]\ndemo.mesh=<none>\ndemo.mode=fast\ndemo.rgb=[1, 1, 1]\n"
            "demo.scale=0.5\n");
  o.threads = 8;  // not in key
  EXPECT_EQ(t.CanonicalText(NoDigest), text);
  o.scale = 0.25;
  EXPECT_NE(t.CanonicalText(NoDigest), text);
}

TEST(OptionsTest, InputPathsEnterKeyByDigest) {
  DemoOptions o;
  OptionTable t = MakeOptionTable("demo", &o);
  o.mesh = "/a/b.ply";
  EXPECT_NE(t.CanonicalText(NoDigest).find("demo.mesh=sha256:digest(/a/b.ply)"), std::string::npos);
  t.ApplyYaml(YAML::Load("maps: [x.hdr, /abs/y.exr]"), "c.yaml", "/cfg");
  EXPECT_EQ(o.maps, (std::vector<std::string>{"/cfg/x.hdr", "/abs/y.exr"}));
  EXPECT_NE(t.CanonicalText(NoDigest).find("demo.maps=[sha256:digest(/cfg/x.hdr), sha256:digest(/abs/y.exr)]"),
            std::string::npos);
}

TEST(OptionsTest, InputFileThatIsAFolderAndFolderThatIsAFileNameTheOption) {
  testing::TempDir dir;
  std::ofstream(dir / "photo.jpg") << "x";
  struct Paths {
    std::string folder;
    std::vector<std::string> maps;
    void Declare(OptionTable* t) {
      t->Add("folder", &folder, "Photo folder.").InputDir();
      t->Add("maps", &maps, "Lat-long HDR maps.").InputFile();
    }
  } o;
  OptionTable t = MakeOptionTable("demo", &o);
  o.folder = dir / "photo.jpg";
  try {
    t.CanonicalText(NoDigest);
    FAIL();
  } catch (const UserError& e) {
    EXPECT_EQ(std::string(e.what()), "demo.folder: '" + (dir / "photo.jpg") +
                                         "' is a file, not a folder; set it to the folder that holds the files");
  }
  o.folder = dir.path();
  o.maps = {dir.path()};
  try {
    t.CanonicalText(NoDigest);
    FAIL();
  } catch (const UserError& e) {
    EXPECT_EQ(std::string(e.what()), "demo.maps: '" + dir.path() +
                                         "' is a folder, not a file; name the file itself (Lat-long HDR maps.)");
  }
}

TEST(OptionsTest, FolderOptionsPassTheirFileSelectionToTheDigest) {
  struct Folder {
    std::string photos;
    bool recursive = false;
    void Declare(OptionTable* t) {
      t->Add("photos", &photos, "Photos.").InputDir().Reads([this] { return FileSelection{recursive, {".jpg"}}; });
      t->Add("recursive", &recursive, "Sub-folders too.");
    }
  } o;
  OptionTable t = MakeOptionTable("demo", &o);
  o.photos = "/p";
  auto digest = [](const std::string& path, const FileSelection& s) {
    return path + (s.recursive ? ":tree" : ":top") + ":" + s.extensions.at(0);
  };
  EXPECT_NE(t.CanonicalText(digest).find("demo.photos=sha256:/p:top:.jpg"), std::string::npos);
  o.recursive = true;
  EXPECT_NE(t.CanonicalText(digest).find("demo.photos=sha256:/p:tree:.jpg"), std::string::npos);
}

TEST(OptionsTest, YamlValuesParsedAndValidated) {
  DemoOptions o;
  OptionTable t = MakeOptionTable("demo", &o);
  t.ApplyYaml(YAML::Load("count: 3\nscale: 1e-3\nflag: yes\nmode: exact\nrgb: [0.5, 1, 2]\nmesh: m.ply"),
              "c.yaml", "/base");
  EXPECT_EQ(o.count, 3);
  EXPECT_DOUBLE_EQ(o.scale, 1e-3);
  EXPECT_TRUE(o.flag);
  EXPECT_EQ(o.mode, "exact");
  EXPECT_EQ(o.rgb, (std::vector<double>{0.5, 1, 2}));
  EXPECT_EQ(o.mesh, "/base/m.ply");  // relative to the config's folder
}

TEST(OptionsTest, ErrorsNameFileLineAndAllowedValues) {
  DemoOptions o;
  OptionTable t = MakeOptionTable("demo", &o);
  auto expect_error = [&](const std::string& yaml, const std::vector<std::string>& needles) {
    try {
      t.ApplyYaml(YAML::Load(yaml), "cfg.yaml", "/");
      FAIL() << "no error for " << yaml;
    } catch (const UserError& e) {
      for (const auto& n : needles) EXPECT_NE(std::string(e.what()).find(n), std::string::npos) << e.what();
    }
  };
  expect_error("count: 1\ncolour: 3", {"cfg.yaml:2", "unknown option 'demo.colour'", "count, scale"});
  expect_error("\n\ncount: 500", {"cfg.yaml:3", "out of range", "in [1, 100]"});
  expect_error("mode: slow", {"cfg.yaml:1", "'slow' is not allowed", "fast, exact"});
  expect_error("count: many", {"cfg.yaml:1", "expects an integer"});
  expect_error("rgb: [1, 2]", {"needs exactly 3 entries"});
  expect_error("count: [1, 2]", {"got a list"});
  expect_error("count: 2\nsamples: 8", {"cfg.yaml:2", "option 'demo.samples' was removed: use demo.count"});
  try {
    t.ApplyText("samples", "8", "--set");
    FAIL() << "no error for a retired key";
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find("--set: option 'demo.samples' was removed: use demo.count"),
              std::string::npos)
        << e.what();
  }
}

TEST(OptionsTest, TextOverrides) {
  DemoOptions o;
  OptionTable t = MakeOptionTable("demo", &o);
  t.ApplyText("rgb", "0.1,0.2,0.3", "--set");
  EXPECT_EQ(o.rgb, (std::vector<double>{0.1, 0.2, 0.3}));
  // Quoted items as in a YAML flow list lose their quotes.
  t.ApplyText("maps", "[a.hdr, \"b c.exr\", 'd.exr']", "--set");
  ASSERT_EQ(o.maps.size(), 3u);
  EXPECT_EQ(o.maps[1].substr(o.maps[1].size() - 7), "b c.exr");
  EXPECT_EQ(o.maps[2].substr(o.maps[2].size() - 5), "d.exr");
  EXPECT_EQ(o.maps[2].find('\''), std::string::npos);
  EXPECT_THROW(t.ApplyText("nope", "1", "--set"), UserError);
}

// Options a mode ignores: `order` matters only for mode exact, `trace` only for a true flag.
struct ModalOptions {
  std::string mode = "fast";
  int order = 2;
  bool flag = false;
  double trace = 0;
  bool truth = false;
  void Declare(OptionTable* t) {
    t->Add("mode", &mode, "Mode.").Choices({"fast", "exact"});
    t->Add("order", &order, "Order.").OnlyWhen("mode", {"exact"}).Advanced();
    t->Add("flag", &flag, "A flag.");
    t->Add("trace", &trace, "Trace.").OnlyWhen("flag", {"true"}).OnlyWhen("mode", {"fast", "exact"});
    t->Add("truth", &truth, "Known answer.").Experimental();
  }
};

TEST(OptionsTest, OptionTheModeIgnoresIsAnErrorNamingBothOptions) {
  ModalOptions o;
  OptionTable t = MakeOptionTable("demo", &o);
  t.ApplyYaml(YAML::Load("mode: fast\norder: 3"), "cfg.yaml", "/");
  try {
    t.Validate("cfg.yaml");
    FAIL() << "no error for an ignored option";
  } catch (const UserError& e) {
    const std::string what = e.what();
    for (const char* needle :
         {"cfg.yaml:2", "'demo.order' = 3 has no effect while demo.mode is 'fast'", "set demo.mode: exact"}) {
      EXPECT_NE(what.find(needle), std::string::npos) << what;
    }
  }
  // The mode that uses it, or the default value, passes.
  t.ApplyText("mode", "exact", "--set demo.mode");
  EXPECT_NO_THROW(t.Validate("cfg.yaml"));
  ModalOptions defaults;
  OptionTable u = MakeOptionTable("demo", &defaults);
  u.ApplyYaml(YAML::Load("mode: fast\norder: 2\nflag: true\ntrace: 0.5"), "cfg.yaml", "/");
  EXPECT_NO_THROW(u.Validate("cfg.yaml"));
  u.ApplyText("flag", "false", "--set demo.flag");
  EXPECT_THROW(u.Validate("cfg.yaml"), UserError);
}

TEST(OptionsTest, ReferenceListsPublicThenAdvancedAndLeavesOutExperimental) {
  ModalOptions o;
  OptionTable t = MakeOptionTable("demo", &o);
  const std::string md = t.MarkdownReference();
  const size_t advanced = md.find("#### demo — advanced");
  ASSERT_NE(advanced, std::string::npos) << md;
  EXPECT_LT(md.find("`demo.flag`"), advanced);
  EXPECT_GT(md.find("`demo.order`"), advanced);
  EXPECT_NE(md.find("only when mode: exact"), std::string::npos) << md;
  EXPECT_NE(md.find("only when flag: true and mode: fast or exact"), std::string::npos) << md;
  EXPECT_EQ(md.find("demo.truth"), std::string::npos) << md;
  EXPECT_NE(t.MarkdownExperimentalRows().find("`demo.truth`"), std::string::npos);
  EXPECT_TRUE(t.ExperimentalInUse().empty());
  o.truth = true;
  EXPECT_EQ(t.ExperimentalInUse(), std::vector<std::string>{"demo.truth"});
}

TEST(OptionsTest, CanonicalDoubleRoundTrips) {
  for (double v : {0.1, 1.0 / 3.0, 1e-300, 123456789.125, -2.5}) {
    EXPECT_EQ(std::strtod(CanonicalDouble(v).c_str(), nullptr), v);
  }
  EXPECT_EQ(CanonicalDouble(0.1), "0.1");
  EXPECT_EQ(CanonicalDouble(-0.0), "0");
}

}  // namespace
}  // namespace relight
