#include "core/hash.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "core/error.h"
#include "testing/testing.h"

namespace relight {
namespace {
namespace fs = std::filesystem;

TEST(HashTest, KnownVectors) {
  // FIPS 180-2 test vectors.
  EXPECT_EQ(Sha256Hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(Sha256Hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

TEST(HashTest, FolderDigestDependsOnContentAndNamesNotLocation) {
  testing::TempDir a, b;
  for (const auto* d : {&a, &b}) {
    fs::create_directories(*d / "sub");
    std::ofstream(*d / "x.jpg") << "pixels";
    std::ofstream(*d / "sub/y.jpg") << "more";
    std::ofstream(*d / ".hidden") << "ignored";
  }
  DigestCache cache;
  const std::string da = cache.Digest(a.path());
  EXPECT_EQ(da, cache.Digest(b.path()));
  std::ofstream(b / ".hidden") << "changed";  // hidden files ignored
  EXPECT_EQ(da, DigestCache().Digest(b.path()));
  std::ofstream(b / "sub/y.jpg") << "MORE";
  EXPECT_NE(da, DigestCache().Digest(b.path()));
  EXPECT_THROW(cache.Digest(a / "nope"), UserError);
}

TEST(HashTest, PersistentCacheReusesAndDetectsChange) {
  testing::TempDir dir;
  std::ofstream(dir / "f.bin") << "abc";
  {
    DigestCache cache(dir / "digests.json");
    EXPECT_EQ(cache.Digest(dir / "f.bin"), Sha256Hex("abc"));
    cache.Save();
  }
  EXPECT_TRUE(fs::exists(dir / "digests.json"));
  std::ofstream(dir / "f.bin") << "abcd";  // size changes -> stamp changes
  DigestCache cache(dir / "digests.json");
  EXPECT_EQ(cache.Digest(dir / "f.bin"), Sha256Hex("abcd"));
}

TEST(HashTest, FolderDigestCoversOnlyTheSelectedFiles) {
  testing::TempDir dir;
  fs::create_directories(dir / "sub");
  std::ofstream(dir / "a.jpg") << "photo a";
  std::ofstream(dir / "sub/b.JPG") << "photo b";
  const FileSelection top{false, {".jpg"}}, tree{true, {".jpg"}};
  const std::string top_digest = DigestCache().Digest(dir.path(), top);
  const std::string tree_digest = DigestCache().Digest(dir.path(), tree);
  EXPECT_NE(top_digest, tree_digest);  // sub/b.JPG is read only when recursive
  // Files the reader never opens do not change the key (issue 34: notes.txt, Thumbs.db).
  std::ofstream(dir / "notes.txt") << "notes";
  std::ofstream(dir / "Thumbs.db") << "thumbnails";
  std::ofstream(dir / "sub/c.png") << "not selected";
  EXPECT_EQ(DigestCache().Digest(dir.path(), top), top_digest);
  EXPECT_EQ(DigestCache().Digest(dir.path(), tree), tree_digest);
  std::ofstream(dir / "sub/b.JPG") << " changed";
  EXPECT_EQ(DigestCache().Digest(dir.path(), top), top_digest);
  EXPECT_NE(DigestCache().Digest(dir.path(), tree), tree_digest);
  EXPECT_EQ(ListFiles(dir.path(), tree), (std::vector<std::string>{dir / "a.jpg", dir / "sub/b.JPG"}));
}

TEST(HashTest, RootFolderIsListedWithoutDescending) {
  // ingest.images: / hashed all of /proc and ended in "Permission denied", exit 3.
  const FileSelection top{false, {".jpg", ".png"}};
  EXPECT_NO_THROW(DigestCache().Digest("/", top));
}

TEST(HashTest, NonUtf8FileNamesArePersisted) {
  testing::TempDir dir;
  fs::create_directories(dir / "photos");
  std::ofstream(dir / "photos/Sacr\xe9 C\x9cur.jpg") << "pixels";
  {
    DigestCache cache(dir / "digests.json");
    cache.Digest(dir / "photos");
    cache.Save();  // threw json type_error 316 before
  }
  EXPECT_NE(ReadFileToString(dir / "digests.json").find("Sacr\\\\xE9 C\\\\x9Cur.jpg"), std::string::npos);
}

}  // namespace
}  // namespace relight
