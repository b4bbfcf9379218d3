#include "core/config.h"

#include <gtest/gtest.h>

#include <fstream>

#include "core/error.h"
#include "testing/testing.h"

namespace relight {
namespace {

struct StageAOptions {
  int n = 1;
  std::string photos;
  void Declare(OptionTable* t) {
    t->Add("n", &n, "n").Min(0);
    t->Add("photos", &photos, "photos").InputDir();
  }
};

void Write(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

TEST(ConfigTest, NestedAndFlatKeysAndBaseChain) {
  testing::TempDir dir;
  Write(dir / "base.yaml", "a:\n  n: 2\n  photos: pics\n");
  Write(dir / "top.yaml", "base: base.yaml\na.n: 5\n");
  ConfigDocument doc = ConfigDocument::Load(dir / "top.yaml");
  StageAOptions o;
  OptionTable t = MakeOptionTable("a", &o);
  doc.Apply(&t);
  EXPECT_EQ(o.n, 5);                        // top overrides base
  EXPECT_EQ(o.photos, dir / "pics");        // relative to the file naming it
  EXPECT_EQ(doc.stem(), "top");
  doc.AddOverride("a.n=7");
  doc.Apply(&t);
  EXPECT_EQ(o.n, 7);
}

TEST(ConfigTest, UnknownSectionNamesLine) {
  testing::TempDir dir;
  Write(dir / "c.yaml", "a:\n  n: 1\n\nsynthesise:\n  n: 2\n");
  ConfigDocument doc = ConfigDocument::Load(dir / "c.yaml");
  try {
    doc.CheckSections({"a", "synthesize"});
    FAIL();
  } catch (const UserError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("c.yaml:4"), std::string::npos) << msg;
    EXPECT_NE(msg.find("unknown section 'synthesise'"), std::string::npos) << msg;
    EXPECT_NE(msg.find("a, synthesize"), std::string::npos) << msg;
  }
}

TEST(ConfigTest, FlatKeyErrorsKeepLine) {
  testing::TempDir dir;
  Write(dir / "c.yaml", "a.n: 1\na.m: 2\n");
  ConfigDocument doc = ConfigDocument::Load(dir / "c.yaml");
  StageAOptions o;
  OptionTable t = MakeOptionTable("a", &o);
  try {
    doc.Apply(&t);
    FAIL();
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find("c.yaml:2"), std::string::npos) << e.what();
  }
}

TEST(ConfigTest, SyntaxErrorAndMissingFile) {
  testing::TempDir dir;
  Write(dir / "bad.yaml", "a:\n  n: [1, 2\n");
  EXPECT_THROW(ConfigDocument::Load(dir / "bad.yaml"), UserError);
  EXPECT_THROW(ConfigDocument::Load(dir / "missing.yaml"), UserError);
  Write(dir / "list.yaml", "- a\n- b\n");
  EXPECT_THROW(ConfigDocument::Load(dir / "list.yaml"), UserError);
}

using testing::ErrorOf;

TEST(ConfigTest, ScalarAtTopLevelIsAnUnknownSectionNotAMappingError) {
  testing::TempDir dir;
  Write(dir / "c.yaml", "a:\n  n: 1\nfoo: 3\n");
  const ConfigDocument doc = ConfigDocument::Load(dir / "c.yaml");  // threw "must be a mapping" before
  EXPECT_EQ(ErrorOf([&] { doc.CheckSections({"a"}); }), dir / "c.yaml:3: unknown section 'foo'; allowed sections: a");
  // A known section with a scalar value is still "must be a mapping", with its line.
  Write(dir / "d.yaml", "a: 3\n");
  const ConfigDocument known = ConfigDocument::Load(dir / "d.yaml");
  EXPECT_EQ(ErrorOf([&] { known.CheckSections({"a"}); }),
            dir / "d.yaml:1: section 'a' must be a mapping of option: value (or write 'a.OPTION: value')");
  StageAOptions o;
  OptionTable t = MakeOptionTable("a", &o);
  EXPECT_NE(ErrorOf([&] { known.Apply(&t); }).find("d.yaml:1: section 'a' must be a mapping"), std::string::npos);
}

TEST(ConfigTest, RepeatedSectionOrOptionInOneFileIsAnError) {
  testing::TempDir dir;
  Write(dir / "c.yaml", "a:\n  n: 1\nb:\n  x: 1\na:\n  photos: p\n");
  EXPECT_EQ(ErrorOf([&] { ConfigDocument::Load(dir / "c.yaml"); }),
            dir / "c.yaml:5: section 'a' appears twice in this file (first at " + dir / "c.yaml:1); merge the two into one");
  Write(dir / "d.yaml", "a:\n  n: 1\na.n: 2\n");
  EXPECT_EQ(ErrorOf([&] { ConfigDocument::Load(dir / "d.yaml"); }),
            dir / "d.yaml:3: option 'a.n' is set twice in this file (first at " + dir / "d.yaml:2); keep one of them");
  // Across a base chain a later file overrides an earlier one, as documented.
  Write(dir / "base.yaml", "a:\n  n: 1\n");
  Write(dir / "top.yaml", "base: base.yaml\na:\n  n: 2\n");
  StageAOptions o;
  OptionTable t = MakeOptionTable("a", &o);
  ConfigDocument::Load(dir / "top.yaml").Apply(&t);
  EXPECT_EQ(o.n, 2);
}

}  // namespace
}  // namespace relight
