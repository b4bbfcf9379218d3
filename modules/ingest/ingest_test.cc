#include "ingest/ingest.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "core/error.h"
#include "core/fs.h"
#include "core/json.h"
#include "core/log.h"
#include "testing/testing.h"

namespace relight {
namespace {
namespace fs = std::filesystem;

// A colourful random-texture photo (distinct per seed).
Image Photo(int w, int h, int seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  Image img(w, h, 3);
  const int block = 8;
  for (int by = 0; by < h; by += block)
    for (int bx = 0; bx < w; bx += block) {
      const float r = u(rng), g = u(rng), b = u(rng);
      for (int y = by; y < std::min(h, by + block); ++y)
        for (int x = bx; x < std::min(w, bx + block); ++x) {
          img.at(x, y, 0) = r;
          img.at(x, y, 1) = g;
          img.at(x, y, 2) = b;
        }
    }
  return img;
}

class IngestTest : public ::testing::Test {
 protected:
  void SetUp() override {
    InitLogging("ingest_test", "", LogLevel::kError);
    setenv("RELIGHT_PROGRESS", "off", 1);
    fs::create_directories(dir_ / "photos");
  }
  testing::TempDir dir_;
  std::string photos() { return dir_ / "photos"; }
  std::string out() { return dir_ / "out"; }
  // The stage on `photo_dir` (ingest.images) and `ground_truth` (ingest.ground_truth).
  static IngestSummary Ingest(IngestOptions options, const std::string& photo_dir, const std::string& ground_truth,
                              const std::string& output_dir) {
    options.images = photo_dir;
    options.ground_truth = ground_truth;
    return RunIngest(options, {}, output_dir);
  }
};

TEST_F(IngestTest, BadFilesAreSkippedWithReasons) {
  for (int i = 0; i < 3; ++i) WriteImage(photos() + "/good" + std::to_string(i) + ".jpg", Photo(80, 64, i));
  WriteImage(dir_ / "full.jpg", Photo(256, 256, 99));
  const std::string bytes = ReadFileToString(dir_ / "full.jpg");
  std::ofstream(photos() + "/truncated.jpg", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  std::ofstream(photos() + "/notes.jpg") << "not a jpeg at all";
  std::ofstream(photos() + "/empty.jpg");
  std::ofstream(photos() + "/readme.txt") << "hello";  // not a photo by its name: not read at all
  const IngestSummary s = Ingest(IngestOptions{}, photos(), "", out());
  ASSERT_EQ(s.photos.size(), 3u);
  ASSERT_EQ(s.skipped.size(), 3u);
  std::map<std::string, std::string> reasons;
  for (const auto& k : s.skipped) reasons[k.name] = k.reason;
  EXPECT_NE(reasons["truncated.jpg"].find("truncated"), std::string::npos) << reasons["truncated.jpg"];
  EXPECT_NE(reasons["empty.jpg"].find("empty"), std::string::npos);
  EXPECT_NE(reasons["notes.jpg"].find("notes.jpg"), std::string::npos);
  EXPECT_EQ(reasons.count("readme.txt"), 0u);
  // The manifest round-trips.
  const IngestSummary m = ReadIngestManifest(out());
  ASSERT_EQ(m.photos.size(), 3u);
  EXPECT_EQ(m.photos[0].name, "good0.jpg");
  EXPECT_TRUE(fs::exists(out() + "/" + m.photos[0].file));
  EXPECT_EQ(m.skipped.size(), 3u);
}

TEST_F(IngestTest, EmptyFolderAndTooFewPhotosAreClearErrors) {
  try {
    Ingest(IngestOptions{}, photos(), "", out());
    FAIL();
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find("contains no photos (files ending in .jpg .jpeg"), std::string::npos)
        << e.what();
  }
  std::ofstream(photos() + "/a.jpg") << "junk";
  WriteImage(photos() + "/b.png", Photo(64, 64, 1));
  try {
    Ingest(IngestOptions{}, photos(), "", out());
    FAIL();
  } catch (const UserError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("only 1 usable photo"), std::string::npos) << msg;
    EXPECT_NE(msg.find("a.jpg"), std::string::npos) << msg;
    EXPECT_NE(msg.find("ingest.min_photos"), std::string::npos) << msg;
  }
  EXPECT_THROW(Ingest(IngestOptions{}, dir_ / "missing", "", out()), UserError);
}

TEST_F(IngestTest, DownscalesGrayscaleAndDuplicatesAreDropped) {
  WriteImage(photos() + "/a_big.png", Photo(800, 400, 1));
  WriteImage(photos() + "/b.png", Photo(200, 100, 2));
  WriteImage(photos() + "/c_copy.png", Photo(200, 100, 2));          // exact duplicate of b
  Image near = Photo(200, 100, 2);
  for (float& v : near.pixels) v = std::min(1.0f, v * 0.97f + 0.01f);  // re-processed copy
  WriteImage(photos() + "/d_near.png", near);
  Image gray = Photo(200, 100, 3);
  for (size_t p = 0; p < gray.pixels.size(); p += 3) gray.pixels[p + 1] = gray.pixels[p + 2] = gray.pixels[p];
  WriteImage(photos() + "/e_gray.png", gray);
  WriteImage(photos() + "/f.png", Photo(100, 200, 4));
  IngestOptions options;
  options.max_image_size = 256;
  const IngestSummary s = Ingest(options, photos(), "", out());
  std::map<std::string, std::string> reasons;
  for (const auto& k : s.skipped) reasons[k.name] = k.reason;
  EXPECT_NE(reasons["c_copy.png"].find("exact duplicate of b.png"), std::string::npos) << reasons["c_copy.png"];
  EXPECT_NE(reasons["d_near.png"].find("near-duplicate of b.png"), std::string::npos) << reasons["d_near.png"];
  EXPECT_NE(reasons["e_gray.png"].find("black-and-white"), std::string::npos) << reasons["e_gray.png"];
  ASSERT_EQ(s.photos.size(), 3u);
  EXPECT_EQ(s.photos[0].width, 256);
  EXPECT_EQ(s.photos[0].height, 128);
  EXPECT_DOUBLE_EQ(s.photos[0].scale, 256.0 / 800.0);
  const Image written = ReadImage(out() + "/" + s.photos[0].file);
  EXPECT_EQ(written.width, 256);
  // Untouched photos are copied bit-exactly.
  EXPECT_EQ(s.photos[1].file, "images/b.png");
  EXPECT_TRUE(ReadFileToString(out() + "/" + s.photos[1].file) == ReadFileToString(photos() + "/b.png"));
}

// A JPEG whose SOF0 header claims `width` x `height` (the pixel data stays that of a small image).
void WriteJpegClaimingSize(const std::string& path, int width, int height) {
  const std::string tmp = path + ".small.jpg";
  WriteImage(tmp, Photo(64, 64, 7));
  std::string bytes = ReadFileToString(tmp);
  std::filesystem::remove(tmp);
  const size_t sof = bytes.find("\xFF\xC0");
  ASSERT_NE(sof, std::string::npos);
  bytes[sof + 5] = static_cast<char>(height >> 8);
  bytes[sof + 6] = static_cast<char>(height & 255);
  bytes[sof + 7] = static_cast<char>(width >> 8);
  bytes[sof + 8] = static_cast<char>(width & 255);
  std::ofstream(path, std::ios::binary) << bytes;
}

TEST_F(IngestTest, AbsurdHeaderSizeIsSkippedBeforeDecoding) {
  for (int i = 0; i < 3; ++i) WriteImage(photos() + "/good" + std::to_string(i) + ".jpg", Photo(80, 64, i));
  WriteJpegClaimingSize(photos() + "/huge.jpg", 60000, 60000);
  // Before: decoding allocated 43 GB of floats and the whole stage ended in "out of memory", naming no file.
  const IngestSummary s = Ingest(IngestOptions{}, photos(), "", out());
  ASSERT_EQ(s.photos.size(), 3u);
  ASSERT_EQ(s.skipped.size(), 1u);
  EXPECT_EQ(s.skipped[0].name, "huge.jpg");
  EXPECT_EQ(s.skipped[0].reason,
            "its header claims 60000x60000 pixels (3600 megapixels, more than ingest.max_megapixels = 250); not decoded");
}

TEST_F(IngestTest, TinyAndStripPhotosAreSkippedWithTheirSize) {
  for (int i = 0; i < 3; ++i) WriteImage(photos() + "/good" + std::to_string(i) + ".png", Photo(80, 64, i));
  WriteImage(photos() + "/tiny.png", Photo(4, 4, 5));
  WriteImage(photos() + "/strip.png", Photo(6000, 3, 6));
  WriteImage(photos() + "/banner.png", Photo(1200, 100, 8));
  IngestOptions options;
  const IngestSummary s = Ingest(options, photos(), "", out());
  ASSERT_EQ(s.photos.size(), 3u);
  std::map<std::string, std::string> reasons;
  for (const auto& k : s.skipped) reasons[k.name] = k.reason;
  ASSERT_EQ(reasons.size(), 3u);
  EXPECT_EQ(reasons["tiny.png"], "4x4 pixels is too small for feature matching (ingest.min_image_side = 64)");
  EXPECT_EQ(reasons["strip.png"],
            "6000x3 pixels is a strip, not a photo (sides more than ingest.max_aspect_ratio = 10 apart)");
  EXPECT_EQ(reasons["banner.png"],
            "1200x100 pixels is a strip, not a photo (sides more than ingest.max_aspect_ratio = 10 apart)");
  // The shorter side counts after downscaling to max_image_size.
  options.max_aspect_ratio = 20;
  options.max_image_size = 400;
  const IngestSummary scaled = Ingest(options, photos(), "", dir_ / "out2");
  for (const auto& k : scaled.skipped) reasons[k.name] = k.reason;
  EXPECT_EQ(reasons["banner.png"],
            "1200x100 pixels (shorter side 33 after downscaling) is too small for feature matching "
            "(ingest.min_image_side = 64)");
}

TEST_F(IngestTest, NonUtf8FileNamesBecomeTextInTheManifest) {
  WriteImage(photos() + "/Sacr\xe9 C\x9cur.jpg", Photo(80, 64, 1));  // a Latin-1 name
  for (int i = 0; i < 2; ++i) WriteImage(photos() + "/p" + std::to_string(i) + ".jpg", Photo(80, 64, 2 + i));
  std::ofstream(photos() + "/d\xe9" "faut.jpg") << "broken";
  const IngestSummary s = Ingest(IngestOptions{}, photos(), "", out());  // threw json type_error 316 before
  ASSERT_EQ(s.photos.size(), 3u);
  const IngestSummary m = ReadIngestManifest(out());
  EXPECT_EQ(m.photos[0].name, "Sacr\\xE9 C\\x9Cur.jpg");
  EXPECT_EQ(m.photos[0].file, "images/Sacr_xE9 C_x9Cur.jpg");  // valid UTF-8 for COLMAP and the report
  EXPECT_TRUE(fs::exists(out() + "/" + m.photos[0].file));
  ASSERT_EQ(m.skipped.size(), 1u);
  EXPECT_EQ(m.skipped[0].name, "d\\xE9faut.jpg");
  EXPECT_NE(m.skipped[0].reason.find("d\\xE9faut.jpg' is not a readable image"), std::string::npos)
      << m.skipped[0].reason;
}

TEST_F(IngestTest, TooFewPhotosErrorIsShortAndGroupsTheReasons) {
  // Issue 34: every photo black-and-white repeated a 1,500-character line.
  for (int i = 0; i < 12; ++i) {
    Image gray = Photo(80, 64, 20 + i);
    for (size_t p = 0; p < gray.pixels.size(); p += 3) gray.pixels[p + 1] = gray.pixels[p + 2] = gray.pixels[p];
    WriteImage(photos() + "/a_rather_long_file_name_of_a_grey_photo_" + std::to_string(i) + ".png", gray);
  }
  std::ofstream(photos() + "/broken.jpg") << "junk";
  try {
    Ingest(IngestOptions{}, photos(), "", out());
    FAIL();
  } catch (const UserError& e) {
    const std::string msg = e.what();
    EXPECT_LT(msg.size(), 700u) << msg;
    EXPECT_NE(msg.find("only 0 usable photo(s) in '" + photos() + "' (need at least 3); 1 unreadable (replace or "
                       "remove them), e.g. broken.jpg: "),
              std::string::npos)
        << msg;
    EXPECT_NE(msg.find("; 12 black-and-white (set ingest.drop_grayscale: false to keep them), e.g. "
                       "a_rather_long_file_name_of_a_grey_photo_0.png: black-and-white photo (mean chroma"),
              std::string::npos)
        << msg;
    EXPECT_NE(msg.find("every skipped file and its reason is in the stage log; add more photos of the object or "
                       "lower ingest.min_photos"),
              std::string::npos)
        << msg;
  }
}

TEST_F(IngestTest, FocalFromExif35mm) {
  ImageMetadata exif;
  exif.focal_length_35mm = 50.0;
  // A 3:2 photo: the 35 mm frame's diagonal maps onto the image diagonal.
  const auto f = FocalPixelsFromExif(exif, 3000, 2000, 1500);
  ASSERT_TRUE(f.has_value());
  EXPECT_NEAR(*f, 50.0 / 36.0 * 1500.0, 1e-9);
  exif.focal_length_35mm.reset();
  EXPECT_FALSE(FocalPixelsFromExif(exif, 3000, 2000, 1500).has_value());
}

TEST_F(IngestTest, GroundTruthIsCarriedAlong) {
  for (int i = 0; i < 3; ++i) WriteImage(photos() + "/p" + std::to_string(i) + ".png", Photo(64, 64, 10 + i));
  fs::create_directories(dir_ / "gt/sub");
  std::ofstream(dir_ / "gt/sub/cameras.txt") << "# cameras";
  Ingest(IngestOptions{}, photos(), dir_ / "gt", out());
  EXPECT_EQ(ReadFileToString(out() + "/ground_truth/sub/cameras.txt"), "# cameras");
  EXPECT_EQ(ReadJsonFile(out() + "/manifest.json")["ground_truth"], "ground_truth");
}

}  // namespace
}  // namespace relight
