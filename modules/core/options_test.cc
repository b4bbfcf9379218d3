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

TEST(OptionsTest, CanonicalDoubleRoundTrips) {
  for (double v : {0.1, 1.0 / 3.0, 1e-300, 123456789.125, -2.5}) {
    EXPECT_EQ(std::strtod(CanonicalDouble(v).c_str(), nullptr), v);
  }
  EXPECT_EQ(CanonicalDouble(0.1), "0.1");
  EXPECT_EQ(CanonicalDouble(-0.0), "0");
}

}  // namespace
}  // namespace relight
