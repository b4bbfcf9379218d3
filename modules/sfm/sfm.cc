// The sfm stage (see sfm.h). COLMAP does the work (feature extraction,
// matching, incremental mapping, undistortion); this file chooses its options
// from the collection, feeds it 8-bit images, checks every output itself (an
// exit code of 0 does not mean success, ../shared/COLMAP.md) and converts the
// result into the project's frame and naming.
#include "sfm/sfm.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "core/error.h"
#include "core/fs.h"
#include "core/json.h"
#include "core/log.h"
#include "core/path_text.h"
#include "core/progress.h"
#include "core/stats.h"
#include "core/timer.h"
#include "image/color.h"
#include "image/image.h"
#include "sfm/chroma_features.h"
#include "sfm/colmap_command.h"
#include "sfm/colmap_database.h"
#include "sfm/descriptor_matching.h"
#include "sfm/image_retrieval.h"
#include "sfm/model_consensus.h"
#include "sfm/two_view_verification.h"

namespace relight {
namespace fs = std::filesystem;

namespace {

// Minimum inliers for a pair to count as "matched" in diagnostics (COLMAP's
// two-view geometry default min_num_inliers).
constexpr int kMinPairInliers = 15;

// A verified pair's match fits a model's epipolar geometry within this Sampson distance (pixels).
constexpr double kTwoViewMaxErrorPx = 4.0;

// What a user can change when photos do not register.
constexpr const char* kWhatToChange =
    "What to change: photos of neighbouring viewpoints should be at most about 15-20 degrees apart and show the "
    "object at a similar size; photos of at least 1000 pixels give more features than small ones; photos taken "
    "under very different light (sun and shadow moving) match poorly, so add photos in between. If the cameras "
    "are known, give them (sfm.mode: model); stage.log has COLMAP's output";

// Tone-maps a linear (EXR/HDR) photo to an 8-bit sRGB PNG for SIFT: the 99th
// percentile of luminance maps to white.
void ToneMapForColmap(const std::string& in_path, const std::string& out_path) {
  Image image = ReadImage(in_path);
  std::vector<float> luminance;
  const size_t n = size_t(image.width) * image.height;
  const size_t step = std::max<size_t>(1, n / 100000);
  for (size_t p = 0; p < n; p += step) {
    const float* px = &image.pixels[p * image.channels];
    luminance.push_back(image.channels >= 3 ? static_cast<float>(Luminance(px)) : px[0]);
  }
  const size_t k = std::min(luminance.size() - 1, luminance.size() * 99 / 100);
  std::nth_element(luminance.begin(), luminance.begin() + k, luminance.end());
  const float white = luminance[k] > 0 ? luminance[k] : 1.0f;
  for (float& v : image.pixels) v = SrgbEncode(v / white);
  WriteOptions w;
  w.type = PixelType::kUint8;
  WriteImage(out_path, image, w);
}

// Links (or copies) the ingested photos into COLMAP's image folder under
// COLMAP-friendly names; float photos are tone-mapped to PNG.
void PrepareColmapImages(const std::string& ingest_dir, const std::vector<IngestedPhoto>& photos,
                         const std::string& image_dir, std::vector<SfmPhoto>* status) {
  std::error_code ec;
  fs::remove_all(image_dir, ec);
  EnsureDir(image_dir);
  Progress progress("prepare images for COLMAP", static_cast<int64_t>(photos.size()));
  for (size_t i = 0; i < photos.size(); ++i) {
    const IngestedPhoto& p = photos[i];
    const fs::path source = fs::path(ingest_dir) / p.file;
    if (!fs::is_regular_file(source)) {
      RELIGHT_USER_ERROR() << "photo '" << p.name << "' is listed in " << ingest_dir << "/manifest.json but its file '"
                           << source.string() << "' is missing; rerun the ingest stage (pipeline run --force ingest)";
    }
    SfmPhoto& s = (*status)[i];
    if (p.linear) {
      s.colmap_name = source.stem().string() + ".png";
      ToneMapForColmap(source.string(), JoinPath(image_dir, s.colmap_name));
    } else {
      s.colmap_name = source.filename().string();
      const std::string target = JoinPath(image_dir, s.colmap_name);
      fs::create_symlink(fs::absolute(source), target, ec);
      if (ec) {
        ec.clear();
        fs::copy_file(source, target, fs::copy_options::overwrite_existing, ec);
        if (ec)
          RELIGHT_USER_ERROR() << "cannot copy '" << source.string() << "' to '" << target << "': " << ec.message();
      }
    }
    progress.Advance();
  }
  progress.Finish();
}

// Runs one COLMAP step with a progress display fed by COLMAP's own lines.
// `marker` selects the "[i/n" counter to follow (empty: none).
ProcessResult RunStep(const std::string& label, const ColmapCommand& command, const std::string& marker,
                     int64_t expected_total, std::vector<std::pair<std::string, double>>* step_seconds,
                     bool throw_on_failure = true) {
  RLOG_INFO("{}: {}", label, command.ToString());
  Progress progress(label, std::max<int64_t>(1, expected_total));
  int64_t shown = 0;
  const ProcessResult result = RunColmap(command, [&](const std::string& line) {
    int done = 0, total = 0;
    if (!marker.empty() && ParseBracketCount(line, marker, &done, &total)) {
      const int64_t target = expected_total > 0 ? std::min<int64_t>(done, expected_total) : done;
      if (target > shown) {
        progress.Advance(target - shown);
        shown = target;
      }
    } else if (marker.empty()) {
      // mapper: "Initializing with image pair #a and #b", then "Registering image #id (k)" (k-th registration).
      int64_t target = shown;
      if (line.rfind("Initializing with image pair", 0) == 0) target = std::max<int64_t>(shown, 2);
      const size_t paren = line.rfind('(');
      int k = 0;
      if (line.rfind("Registering image #", 0) == 0 && paren != std::string::npos &&
          std::sscanf(line.c_str() + paren, "(%d)", &k) == 1) {
        target = std::max<int64_t>(shown, k - 1);
      }
      target = std::min(target, expected_total);
      if (target > shown) {
        progress.Advance(target - shown);
        shown = target;
      }
    }
  });
  progress.Finish();
  step_seconds->emplace_back(label, result.seconds);
  if (!result.ok() && throw_on_failure) {
    RELIGHT_USER_ERROR() << "COLMAP " << command.command << " failed (" << result.Describe()
                         << "): " << result.TailText(4) << " (full output in stage.log)";
  }
  return result;
}

bool AllSame(const std::vector<IngestedPhoto>& photos, std::string* difference) {
  for (const auto& p : photos) {
    const auto& q = photos.front();
    if (p.width != q.width || p.height != q.height) {
      *difference = q.name + " is " + std::to_string(q.width) + "x" + std::to_string(q.height) + ", " + p.name +
                    " is " + std::to_string(p.width) + "x" + std::to_string(p.height);
      return false;
    }
    if (p.exif.camera_make != q.exif.camera_make || p.exif.camera_model != q.exif.camera_model) {
      *difference = q.name + " and " + p.name + " come from different cameras";
      return false;
    }
    if (p.focal_px.has_value() != q.focal_px.has_value() ||
        (p.focal_px && std::abs(*p.focal_px - *q.focal_px) > 1e-3 * *q.focal_px)) {
      *difference = q.name + " and " + p.name + " have different EXIF focal lengths";
      return false;
    }
  }
  return true;
}

// Sets each camera's focal length from the EXIF prior (ingest's focal_px), or
// to COLMAP's default guess without a prior when EXIF is not to be used.
void ApplyFocalPriors(const SfmOptions& options, const std::string& database_path,
                      const std::vector<IngestedPhoto>& photos, const std::vector<SfmPhoto>& status) {
  ColmapDatabase db(database_path);
  std::map<std::string, const IngestedPhoto*> by_colmap_name;
  for (size_t i = 0; i < photos.size(); ++i) by_colmap_name[status[i].colmap_name] = &photos[i];
  std::map<int, std::vector<double>> focal_by_camera;
  std::set<int> used_cameras;
  for (const auto& im : db.ReadImages()) {
    auto it = by_colmap_name.find(im.name);
    if (it == by_colmap_name.end()) continue;
    used_cameras.insert(im.camera_id);
    if (it->second->focal_px) focal_by_camera[im.camera_id].push_back(*it->second->focal_px);
  }
  const bool single_focal = options.camera_model == "SIMPLE_PINHOLE" || options.camera_model == "SIMPLE_RADIAL" ||
                            options.camera_model == "RADIAL";
  int with_prior = 0;
  for (auto [id, camera] : db.ReadCameras()) {
    if (!used_cameras.count(id)) continue;
    double focal = 1.2 * std::max(camera.width, camera.height);  // COLMAP's default guess
    bool prior = false;
    if (options.use_exif_focal && focal_by_camera.count(id)) {
      focal = Median(focal_by_camera[id]);
      prior = true;
      ++with_prior;
    }
    camera.params[0] = focal;
    if (!single_focal) camera.params[1] = focal;
    camera.prior_focal_length = prior;
    db.UpdateCamera(camera);
  }
  RLOG_INFO("cameras: {} of {} start from an EXIF focal length prior", with_prior, used_cameras.size());
}

std::string ChooseMatcher(const SfmOptions& options, int num_photos) {
  if (options.matcher != "auto") return options.matcher;
  if (num_photos <= options.exhaustive_max_photos) return "exhaustive";
  if (!options.vocab_tree.empty()) return "vocab_tree";
  return "retrieval";
}

// sfm.mapper auto: the hierarchical mapper from this many photos. One incremental run costs about N^2.5
// (254 s of one core at 160 photos and 1,456 s at 320 on a 2-core VM, so about 7 h at 1,000), the hierarchical
// one about N (at 320 photos 12 clusters of 60-70, about 116 s of CPU each, two at a time); after the global
// bundle adjustment its cameras were as accurate (0.030 against 0.029 deg; docs/BENCHMARKS.md).
constexpr int kHierarchicalMinPhotos = 300;
// Hierarchical mapper: photos per leaf cluster before the overlap is added (COLMAP's default of 500 makes
// clusters whose incremental mapping is itself the cost above) and photos shared between neighbouring clusters
// (its default of 50 put 130 of 160 photos in every cluster).
constexpr int kLeafMaxPhotos = 40;
constexpr int kClusterOverlapPhotos = 10;

std::string ChooseMapper(const SfmOptions& options, int num_photos) {
  if (options.mapper != "auto") return options.mapper;
  return num_photos >= kHierarchicalMinPhotos ? "hierarchical" : "incremental";
}

// Reads every model below `models_dir` (mapper output 0/, 1/, ...), largest first.
std::vector<Reconstruction> ReadModels(const std::string& models_dir) {
  std::vector<Reconstruction> models;
  if (!fs::is_directory(models_dir)) return models;
  std::vector<fs::path> dirs;
  for (const auto& e : fs::directory_iterator(models_dir)) {
    if (e.is_directory() && fs::exists(e.path() / "images.bin")) dirs.push_back(e.path());
  }
  std::sort(dirs.begin(), dirs.end());
  for (const auto& d : dirs) models.push_back(Reconstruction::ReadBinary(d.string()));
  std::stable_sort(models.begin(), models.end(), [](const Reconstruction& a, const Reconstruction& b) {
    if (a.images.size() != b.images.size()) return a.images.size() > b.images.size();
    return a.points3d.size() > b.points3d.size();
  });
  return models;
}

// The model with images renamed from COLMAP names to photo names (or back).
void RenameImages(const std::map<std::string, std::string>& new_from_old, Reconstruction* model) {
  for (auto& [id, image] : model->images) {
    auto it = new_from_old.find(image.name);
    RELIGHT_CHECK(it != new_from_old.end()) << "image " << image.name << " has no name mapping";
    image.name = it->second;
  }
}

// Writes the model into sparse/ (binary) and sparse_txt/ (text).
void WriteModels(const Reconstruction& model, const std::string& output_dir) {
  for (const char* sub : {"sparse", "sparse_txt"}) {
    const std::string dir = JoinPath(output_dir, sub);
    std::error_code ec;
    fs::remove_all(dir, ec);
    EnsureDir(dir);
  }
  model.WriteBinary(JoinPath(output_dir, "sparse"));
  model.WriteText(JoinPath(output_dir, "sparse_txt"));
  // Verify what was written can be read back as the same model.
  const Reconstruction check = Reconstruction::ReadBinary(JoinPath(output_dir, "sparse"));
  RELIGHT_CHECK_EQ(check.images.size(), model.images.size());
  RELIGHT_CHECK_EQ(check.points3d.size(), model.points3d.size());
}

// Undistorts the registered photos into dense/ (COLMAP workspace for MVS).
// `model_colmap_names` is the world-frame model with COLMAP image names.
void Undistort(const SfmOptions& options, const Reconstruction& model_colmap_names, const std::string& work_dir,
               const std::string& image_dir, const std::string& output_dir, SfmSummary* summary) {
  const std::string input = JoinPath(work_dir, "world");
  std::error_code ec;
  fs::remove_all(input, ec);
  EnsureDir(input);
  model_colmap_names.WriteBinary(input);
  const std::string dense = JoinPath(output_dir, "dense");
  const std::string dense_tmp = dense + std::string(kTempMarker) + "undistort";
  fs::remove_all(dense_tmp, ec);
  EnsureDir(dense_tmp);
  ColmapCommand cmd{"image_undistorter", {}};
  cmd.Arg("--image_path", image_dir)
      .Arg("--input_path", input)
      .Arg("--output_path", dense_tmp)
      .Arg("--output_type", std::string("COLMAP"))
      .Arg("--max_image_size", options.undistort_max_image_size > 0 ? options.undistort_max_image_size : -1);
  RunStep("undistort", cmd, "Undistorting image", static_cast<int64_t>(model_colmap_names.images.size()),
          &summary->step_seconds);
  // Check the workspace: every registered image and the model must be there.
  for (const auto& [id, image] : model_colmap_names.images) {
    if (!fs::is_regular_file(fs::path(dense_tmp) / "images" / image.name)) {
      RELIGHT_USER_ERROR() << "COLMAP image_undistorter did not write '" << image.name << "' into " << dense_tmp
                           << "/images (see stage.log)";
    }
  }
  const Reconstruction undistorted = Reconstruction::Read(JoinPath(dense_tmp, "sparse"));
  if (undistorted.images.size() != model_colmap_names.images.size()) {
    RELIGHT_USER_ERROR() << "COLMAP image_undistorter wrote " << undistorted.images.size() << " of "
                         << model_colmap_names.images.size() << " images into " << dense_tmp
                         << "/sparse (see stage.log)";
  }
  ReplaceDir(dense_tmp, dense);
}

std::string JoinNames(const std::vector<std::string>& names, size_t max_names = 20) {
  std::string s;
  for (size_t i = 0; i < names.size() && i < max_names; ++i) s += (i ? ", " : "") + names[i];
  if (names.size() > max_names) s += ", ... (" + std::to_string(names.size() - max_names) + " more)";
  return s;
}

// Fills registration status and reasons from the final model.
void MarkRegistered(const Reconstruction& model, SfmSummary* summary) {
  summary->num_registered = 0;
  for (auto& p : summary->photos) {
    p.registered = model.FindImage(p.name) != nullptr;
    if (p.registered) {
      p.reason.clear();
      ++summary->num_registered;
    }
  }
  summary->num_points3d = model.points3d.size();
  summary->mean_reprojection_error_px = model.MeanReprojectionError();
}

void CheckRegistered(const SfmOptions& options, const SfmSummary& summary, const std::string& where) {
  const auto dropped = summary.UnregisteredNames();
  if (summary.num_registered < options.min_registered) {
    RELIGHT_USER_ERROR() << where << ": only " << summary.num_registered << " of " << summary.num_photos
                         << " photos registered (need sfm.min_registered = " << options.min_registered
                         << "); unregistered: " << JoinNames(dropped)
                         << ". Add photos that overlap more, or see stage.log for COLMAP's output";
  }
  std::string details;
  for (const auto& p : summary.photos) {
    if (!p.registered) details += "\n  " + p.name + ": " + p.reason;
  }
  // A partial or unreliable reconstruction stops the chain unless the user accepts it.
  std::vector<std::string> problems;
  int usable = 0;  // photos with features
  for (const auto& p : summary.photos) usable += p.num_keypoints != 0 ? 1 : 0;
  if (summary.mode == "colmap") {
    if (2 * summary.num_registered < usable) {
      problems.push_back("only " + std::to_string(summary.num_registered) + " of the " + std::to_string(usable) +
                         " photos with features registered");
    }
    if (summary.split_off_photos >= 3) {
      problems.push_back("the photos split into separate reconstructions: " +
                         std::to_string(summary.split_off_photos) + " photos form " +
                         std::to_string(summary.num_models - 1) + " smaller one(s) that COLMAP could not join to "
                         "the largest (" + std::to_string(summary.num_registered) + " photos)");
    }
    if (summary.consensus == "disagreed" || summary.consensus == "inconsistent") {
      const SfmMapperRun& kept = summary.mapper_runs[summary.chosen_run];
      problems.push_back(
          summary.consensus == "disagreed"
              ? std::to_string(summary.mapper_runs.size()) +
                    " mapper runs from different first pairs placed the cameras differently, so no reconstruction "
                    "can be trusted (a wrong model can have a normal reprojection error)"
              : "the reconstruction contradicts its own photo pairs: only " + std::to_string(kept.pairs_agreeing) +
                    " of " + std::to_string(kept.pairs_checked) +
                    " pairs' matches fit it (a wrong model can have a normal reprojection error)");
    }
  }
  if (!problems.empty()) {
    std::string message;
    for (const auto& p : problems) message += (message.empty() ? "" : "; ") + p;
    message += std::string(". ") + kWhatToChange;
    if (!options.allow_partial) {
      RELIGHT_USER_ERROR() << where << ": structure from motion is not reliable: " << message
                           << "; or set sfm.allow_partial: true to go on with the largest model (the "
                           << "reconstruction will miss photos or be wrong). Unregistered photos:" << details;
    }
    RLOG_WARN("structure from motion is not reliable (sfm.allow_partial is set, going on): {}", message);
  }
  if (!dropped.empty()) {
    RLOG_WARN("{} of {} photos are not in the model and are dropped:{}", dropped.size(), summary.num_photos, details);
  }
}

// Per-photo features and verified partners, for messages ("median 312 features per photo, ...; a.jpg: 120
// features, matched with 0 photos; ...").
std::string PhotoFeatureReport(const SfmSummary& summary, const std::vector<IngestedPhoto>& photos) {
  std::vector<double> features;
  for (const auto& p : summary.photos) features.push_back(std::max(0, p.num_keypoints));
  int longest = 0;
  for (const auto& p : photos) longest = std::max({longest, p.width, p.height});
  std::ostringstream s;
  s << "median " << Median(features) << " SIFT features per photo, the largest photo " << longest << " px";
  int listed = 0;
  for (const auto& p : summary.photos) {
    if (listed++ == 12) {
      s << "; ...";
      break;
    }
    s << "; " << p.name << ": " << std::max(0, p.num_keypoints) << " features, verified matches with "
      << std::max(0, p.num_matched_photos) << " photo(s)";
  }
  return s.str();
}

// Adds log-chromaticity SIFT features (chroma_features.h) to every image's grey SIFT features in the database.
void AddChromaFeatures(const std::string& database, const std::string& image_dir, const SfmOptions& options,
                       std::vector<std::pair<std::string, double>>* step_seconds) {
  Timer timer;
  ColmapDatabase db(database);
  const std::vector<DatabaseImage> images = db.ReadImages();
  Progress progress("colour features", static_cast<int64_t>(images.size()));
  std::vector<int> counts;
  for (const DatabaseImage& image : images) {
    const std::string path = JoinPath(image_dir, image.name);
    const cv::Mat bgr = cv::imread(path, cv::IMREAD_COLOR);
    if (bgr.empty()) {
      RLOG_WARN("colour features: cannot read '{}'; it keeps its grey features only", PathText(path));
      counts.push_back(0);
    } else {
      const FeatureSet features = ChromaFeatures(bgr, options.max_num_features, options.max_image_size);
      db.AppendFeatures(image.image_id, features.keypoints, features.descriptors);
      counts.push_back(features.size());
    }
    progress.Advance();
  }
  std::vector<double> sorted(counts.begin(), counts.end());
  RLOG_INFO("colour features: median {:.0f} per photo added to the grey SIFT features ({:.1f} s)",
            sorted.empty() ? 0.0 : Median(sorted), timer.Seconds());
  step_seconds->emplace_back("colour features", timer.Seconds());
}

// Two-view verification (two_view_verification.h) of each of `matches`: the geometry of every pair with at
// least kMinPairInliers inliers, in the order of `matches`. `keypoints` caches the database's keypoints.
std::vector<DatabaseTwoViewGeometry> VerifyPairs(const ColmapDatabase& db, const std::vector<DatabaseMatches>& matches,
                                                 int seed, tbb::task_arena& arena,
                                                 std::map<int, std::vector<Eigen::Vector2d>>* keypoints) {
  for (const auto& m : matches) {
    for (int id : {m.image_id1, m.image_id2}) {
      if (!keypoints->count(id)) (*keypoints)[id] = db.ReadKeypoints(id);
    }
  }
  TwoViewVerificationOptions verify;
  verify.min_num_inliers = kMinPairInliers;
  verify.seed = seed;
  std::vector<DatabaseTwoViewGeometry> geometries(matches.size());
  std::vector<char> verified(matches.size(), 0);
  Progress progress("verify matches", static_cast<int64_t>(matches.size()));
  arena.execute([&] {
    tbb::parallel_for(size_t(0), matches.size(), [&](size_t i) {
      const DatabaseMatches& m = matches[i];
      const auto& k1 = keypoints->at(m.image_id1);
      const auto& k2 = keypoints->at(m.image_id2);
      std::vector<Eigen::Vector2d> p1, p2;
      std::vector<std::array<uint32_t, 2>> valid;
      for (const auto& [a, b] : m.matches) {
        if (a < k1.size() && b < k2.size()) {
          p1.push_back(k1[a]);
          p2.push_back(k2[b]);
          valid.push_back({a, b});
        }
      }
      const TwoViewVerification v = VerifyTwoView(p1, p2, verify);
      if (v.verified) {
        DatabaseTwoViewGeometry& g = geometries[i];
        g.image_id1 = m.image_id1;
        g.image_id2 = m.image_id2;
        g.config = v.config;
        g.F = v.F;
        g.H = v.H;
        for (int k : v.inliers) g.inlier_matches.push_back(valid[k]);
        verified[i] = 1;
      }
      progress.Advance();
    });
  });
  progress.Finish();
  std::vector<DatabaseTwoViewGeometry> kept;
  for (size_t i = 0; i < matches.size(); ++i) {
    if (verified[i]) kept.push_back(std::move(geometries[i]));
  }
  return kept;
}

struct MatchCounts {
  int64_t compared = 0;  // photo pairs whose descriptors were compared
  int verified = 0;      // pairs with at least kMinPairInliers verified matches
};

// Matches and verifies photo pairs into the database's `matches` and `two_view_geometries` tables: every
// pair (exhaustive), each photo with its next `options.sequential_overlap` photos in name order
// (sequential), or each photo with its most similar photos (retrieval, image_retrieval.h), by our exact
// descriptor search (descriptor_matching.h) and two-view verification (VerifyPairs).
// Retrieval matches photos that verify poorly with more of their candidates (RetrievalExpansion).
MatchCounts MatchFeatures(const std::string& database, const std::string& matcher, const SfmOptions& options,
                          int threads, std::vector<std::pair<std::string, double>>* step_seconds) {
  constexpr int kRetrievalRankedFactor = 4;  // candidates ranked per photo, in multiples of retrieval_neighbors
  Timer timer;
  ColmapDatabase db(database);
  std::vector<DatabaseImage> images = db.ReadImages();
  std::sort(images.begin(), images.end(), [](const auto& a, const auto& b) { return a.name < b.name; });
  const int n = static_cast<int>(images.size());
  std::vector<CompactDescriptors> descriptors(n);
  for (int i = 0; i < n; ++i) {
    CompactDescriptors& d = descriptors[i];
    d.data = db.ReadDescriptors(images[i].image_id, &d.rows, &d.cols);
  }
  std::vector<std::pair<int, int>> pairs;  // indices into `images`, first < second
  std::optional<RetrievalExpansion> expansion;
  tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
  if (matcher == "retrieval") {
    ImageRetrievalOptions retrieval;
    retrieval.num_neighbors = options.retrieval_neighbors;
    retrieval.num_ranked = kRetrievalRankedFactor * options.retrieval_neighbors;
    retrieval.seed = static_cast<uint64_t>(options.seed);  // see image_retrieval.h on reproducibility
    RetrievalResult found;
    arena.execute([&] {
      found = RetrieveImagePairs(n, [&](int i) { return descriptors[i].Normalized(); }, retrieval);
    });
    pairs = std::move(found.pairs);
    expansion.emplace(std::move(found.ranked), options.retrieval_neighbors, pairs);
    step_seconds->emplace_back("retrieval: vocabulary", found.build_seconds);
    step_seconds->emplace_back("retrieval: ranking", found.query_seconds);
    RLOG_INFO("retrieval: {} visual words from the photos' own features ({:.1f} s), {} photo pairs of {} "
              "({} most similar photos each, {:.1f} s)",
              found.num_words, found.build_seconds, pairs.size(), int64_t(n) * (n - 1) / 2,
              options.retrieval_neighbors, found.query_seconds);
  } else {
    for (int i = 0; i < n; ++i) {
      const int last = matcher == "sequential" ? std::min(n - 1, i + options.sequential_overlap) : n - 1;
      for (int j = i + 1; j <= last; ++j) pairs.emplace_back(i, j);
    }
  }
  std::map<int, int> index_of_id;
  for (int i = 0; i < n; ++i) index_of_id[images[i].image_id] = i;
  int64_t num_compared = 0;
  std::vector<DatabaseMatches> putative;
  std::vector<DatabaseTwoViewGeometry> verified;
  std::map<int, std::vector<Eigen::Vector2d>> keypoints;
  double verify_seconds = 0;
  for (int round = 1; !pairs.empty(); ++round) {
    const std::string round_text = round > 1 ? ", round " + std::to_string(round) : "";
    std::vector<DatabaseMatches> results(pairs.size());
    Progress progress("match features (" + matcher + round_text + ")", static_cast<int64_t>(pairs.size()));
    // Each thread keeps the last photo it normalised: pairs come sorted by their first photo.
    tbb::enumerable_thread_specific<std::pair<int, DescriptorMatrix>> last(std::make_pair(-1, DescriptorMatrix()));
    arena.execute([&] {
      tbb::parallel_for(size_t(0), pairs.size(), [&](size_t k) {
        auto [i, j] = pairs[k];
        auto& [last_photo, last_descriptors] = last.local();
        if (last_photo != i) last_photo = i, last_descriptors = descriptors[i].Normalized();
        const DescriptorMatrix other = descriptors[j].Normalized();
        DatabaseMatches& m = results[k];
        const bool swap = images[i].image_id > images[j].image_id;  // COLMAP stores the smaller id first
        m.image_id1 = images[swap ? j : i].image_id;
        m.image_id2 = images[swap ? i : j].image_id;
        m.matches = swap ? MatchDescriptors(other, last_descriptors, DescriptorMatchingOptions{})
                         : MatchDescriptors(last_descriptors, other, DescriptorMatchingOptions{});
        progress.Advance();
      });
    });
    progress.Finish();
    num_compared += static_cast<int64_t>(pairs.size());
    std::vector<DatabaseMatches> kept;
    for (auto& m : results) {
      if (static_cast<int>(m.matches.size()) >= kMinPairInliers) kept.push_back(std::move(m));
    }
    Timer verify_timer;
    std::vector<DatabaseTwoViewGeometry> round_verified = VerifyPairs(db, kept, options.seed, arena, &keypoints);
    verify_seconds += verify_timer.Seconds();
    RLOG_INFO("matching ({}{}): {} photo pairs, {} with at least {} putative matches, {} verified", matcher,
              round_text, pairs.size(), kept.size(), kMinPairInliers, round_verified.size());
    std::vector<std::pair<int, int>> round_pairs;
    for (const auto& g : round_verified) {
      round_pairs.emplace_back(index_of_id.at(g.image_id1), index_of_id.at(g.image_id2));
    }
    std::move(kept.begin(), kept.end(), std::back_inserter(putative));
    std::move(round_verified.begin(), round_verified.end(), std::back_inserter(verified));
    pairs.clear();
    if (expansion) {
      pairs = expansion->Next(round_pairs);
      if (!pairs.empty()) {
        RLOG_INFO("retrieval: {} photo(s) with fewer verified partners than the median photo's {} matched with "
                  "more: {} photo pairs",
                  expansion->num_expanded_last(), expansion->median_partners(), pairs.size());
      }
    }
  }
  db.ReplaceMatches(putative);
  db.ReplaceTwoViewGeometries(verified);
  step_seconds->emplace_back("match features (" + matcher + ")", timer.Seconds() - verify_seconds);
  step_seconds->emplace_back("verify matches", verify_seconds);
  return {num_compared, static_cast<int>(verified.size())};
}

// Runs a COLMAP command that reads `model` from --input_path and writes a model to --output_path (fresh
// folders under `work`, removed afterwards) and returns that model; every image must come back.
Reconstruction RunModelCommand(ColmapCommand command, const Reconstruction& model, const std::string& work,
                               const std::string& label, std::vector<std::pair<std::string, double>>* step_seconds) {
  const std::string in_dir = JoinPath(work, "model_in"), out_dir = JoinPath(work, "model_out");
  std::error_code ec;
  for (const auto& d : {in_dir, out_dir}) {
    fs::remove_all(d, ec);
    EnsureDir(d);
  }
  model.WriteBinary(in_dir);
  command.Arg("--input_path", in_dir).Arg("--output_path", out_dir);
  RunStep(label, command, "", 0, step_seconds);
  Reconstruction out = Reconstruction::Read(out_dir);
  for (const auto& [id, image] : model.images) {
    if (!out.images.count(id)) {
      RELIGHT_USER_ERROR() << "COLMAP " << command.command << " returned " << out.images.size() << " images in "
                           << out_dir << " without '" << image.name << "' (see stage.log)";
    }
  }
  fs::remove_all(in_dir, ec);
  fs::remove_all(out_dir, ec);
  return out;
}

// Replaces the verified geometries of COLMAP's matchers by our deterministic ones; returns the pairs with at
// least kMinPairInliers inliers.
int VerifyDatabaseMatches(const std::string& database, int seed, int threads,
                          std::vector<std::pair<std::string, double>>* step_seconds) {
  Timer timer;
  ColmapDatabase db(database);
  tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
  std::map<int, std::vector<Eigen::Vector2d>> keypoints;
  const std::vector<DatabaseTwoViewGeometry> kept = VerifyPairs(db, db.ReadAllMatches(), seed, arena, &keypoints);
  db.ReplaceTwoViewGeometries(kept);
  step_seconds->emplace_back("verify matches", timer.Seconds());
  return static_cast<int>(kept.size());
}

// Photos and models of one mapper run's output folder.
MapperRun ReadMapperRun(const std::string& dir, const std::string& init_pair, double seconds) {
  MapperRun run;
  run.init_pair = init_pair;
  run.seconds = seconds;
  std::vector<Reconstruction> models = ReadModels(dir);
  run.num_models = static_cast<int>(models.size());
  if (models.empty()) return run;
  run.num_registered = static_cast<int>(models[0].images.size());
  run.split_off = SplitOffPhotos(models);
  run.mean_reprojection_error_px = models[0].MeanReprojectionError();
  run.model = std::move(models[0]);
  return run;
}

// Runs COLMAP's mapper until two runs from different first pairs agree (or
// sfm.max_mapper_runs is reached) and keeps the consensus run
// (model_consensus.h). Every run lets COLMAP choose its first pair, with the
// first pairs of the earlier runs withheld from its database copy: COLMAP's own
// choice weighs the pair's triangulation angle, which a pair forced on it does
// not, and a forced weak pair builds no model.
// `pair_observations` receives every verified pair's matches (for the two-view check).
std::vector<MapperRun> MapWithConsensus(const SfmOptions& options, const ColmapCommand& base,
                                        const std::string& database, const std::string& models_root, int n,
                                        SfmSummary* summary, std::vector<PairObservations>* pair_observations_out) {
  const bool hierarchical = base.command == "hierarchical_mapper";
  std::error_code ec;
  fs::remove_all(models_root, ec);
  EnsureDir(models_root);
  std::map<int, std::string> names;
  std::vector<PairObservations>& pair_observations = *pair_observations_out;
  pair_observations.clear();
  std::vector<DatabaseTwoViewGeometry> geometries;
  {
    ColmapDatabase db(database);
    for (const auto& im : db.ReadImages()) names[im.image_id] = im.name;
    geometries = db.ReadTwoViewGeometries();
    std::map<int, std::vector<Eigen::Vector2d>> keypoints;
    for (const auto& g : geometries) {
      PairObservations o;
      o.name1 = names[g.image_id1];
      o.name2 = names[g.image_id2];
      for (int id : {g.image_id1, g.image_id2}) {
        if (!keypoints.count(id)) keypoints[id] = db.ReadKeypoints(id);
      }
      const auto& k1 = keypoints[g.image_id1];
      const auto& k2 = keypoints[g.image_id2];
      for (const auto& [i, j] : g.inlier_matches) {
        if (i < k1.size() && j < k2.size()) {
          o.points1.push_back(k1[i]);
          o.points2.push_back(k2[j]);
        }
      }
      pair_observations.push_back(std::move(o));
    }
  }
  std::set<std::pair<int, int>> withheld;  // first pairs of earlier runs
  std::vector<MapperRun> runs;
  const double kToleranceDeg = 2.0;       // two runs agree on a photo
  const int min_photos = std::min(std::max(3, options.min_model_size), n);
  for (int attempt = 0; attempt < options.max_mapper_runs; ++attempt) {
    ColmapCommand map = base;
    std::string run_database = database;
    if (attempt > 0) {
      run_database = JoinPath(models_root, "database_" + std::to_string(attempt) + ".db");
      fs::copy_file(database, run_database, fs::copy_options::overwrite_existing);
      std::vector<DatabaseTwoViewGeometry> kept;
      for (const auto& g : geometries) {
        if (!withheld.count({g.image_id1, g.image_id2})) kept.push_back(g);
      }
      ColmapDatabase(run_database).ReplaceTwoViewGeometries(kept);
      for (auto& [key, value] : map.args) {
        if (key == "--database_path") value = run_database;
      }
    }
    const std::string dir = JoinPath(models_root, "run_" + std::to_string(attempt));
    EnsureDir(dir);  // mapper fails when its output folder is missing
    map.Arg("--output_path", dir);
    // The first pair of the first model: the last one COLMAP tried before it registered a third photo. The
    // hierarchical mapper maps its clusters in parallel, with interleaved logs: every pair it started from is
    // withheld from the next run, so that each cluster starts elsewhere.
    int last_a = -1, last_b = -1, first_a = -1, first_b = -1;
    std::set<std::pair<int, int>> started_from;
    RLOG_INFO("map, run {} of at most {} ({} first pair(s) withheld): {}", attempt + 1, options.max_mapper_runs,
              withheld.size(), map.ToString());
    Progress progress("map (run " + std::to_string(attempt + 1) + ")", n);
    std::set<int> registered_ids;
    const ProcessResult result = RunColmap(map, [&](const std::string& line) {
      int a = 0, b = 0, id = 0;
      if (std::sscanf(line.c_str(), "Initializing with image pair #%d and #%d", &a, &b) == 2) {
        last_a = a;
        last_b = b;
        if (hierarchical) started_from.insert({std::min(a, b), std::max(a, b)});
      }
      if (std::sscanf(line.c_str(), "Registering image #%d", &id) == 1) {
        if (first_a < 0) {
          first_a = last_a;
          first_b = last_b;
        }
        // Distinct photos registered (clusters overlap, and a photo can be registered again).
        if (registered_ids.insert(id).second && static_cast<int>(registered_ids.size()) <= n) progress.Advance(1);
      }
    });
    progress.Finish();
    if (run_database != database) fs::remove(run_database, ec);
    summary->step_seconds.emplace_back("map (run " + std::to_string(attempt + 1) + ")", result.seconds);
    if (first_a < 0) {
      RLOG_INFO("map, run {}: no model ({})", attempt + 1, result.Describe());
      break;  // no pair left that COLMAP can start from
    }
    started_from.insert({std::min(first_a, first_b), std::max(first_a, first_b)});
    withheld.insert(started_from.begin(), started_from.end());
    std::string init_pair = names[first_a] + " + " + names[first_b];
    if (started_from.size() > 1) init_pair += " and " + std::to_string(started_from.size() - 1) + " more";
    MapperRun run = ReadMapperRun(dir, init_pair, result.seconds);
    if (!result.ok() && run.num_models > 0) {
      RLOG_WARN("COLMAP mapper: {} but it wrote {} model(s); using them", result.Describe(), run.num_models);
    }
    if (run.num_registered < min_photos) {
      RLOG_INFO("map, run {}: no model of at least {} photos from first pair {}", attempt + 1, min_photos,
                run.init_pair);
      continue;
    }
    run.two_view = CheckTwoViewAgreement(run.model, pair_observations, kTwoViewMaxErrorPx);
    RLOG_INFO("map, run {} (first pair {}): {} model(s), the largest with {} of {} photos{} (reprojection error "
              "{:.2f} px; {} of {} photo pairs agree with it)",
              attempt + 1, run.init_pair, run.num_models, run.num_registered, n,
              run.split_off.empty() ? "" : ", " + std::to_string(run.split_off.size()) + " only in smaller ones",
              run.mean_reprojection_error_px, run.two_view.agreeing, run.two_view.pairs);
    runs.push_back(std::move(run));
    const int chosen = ChooseConsensusRun(&runs, kToleranceDeg);
    if (chosen >= 0 && !runs[chosen].agrees_with.empty() && Consistent(runs[chosen].two_view)) {
      break;  // two runs agree and their photo pairs agree with them
    }
  }
  const int with_model = static_cast<int>(runs.size());
  summary->chosen_run = ChooseConsensusRun(&runs, kToleranceDeg);
  for (const auto& run : runs) {
    SfmMapperRun s;
    s.init_pair = run.init_pair;
    s.num_models = run.num_models;
    s.num_registered = run.num_registered;
    s.split_off_photos = static_cast<int>(run.split_off.size());
    s.mean_reprojection_error_px = run.mean_reprojection_error_px;
    s.seconds = run.seconds;
    s.agrees_with = run.agrees_with;
    s.pairs_checked = run.two_view.pairs;
    s.pairs_agreeing = run.two_view.agreeing;
    summary->mapper_runs.push_back(s);
  }
  const int c = summary->chosen_run;
  if (c < 0) {
    summary->consensus = "none";
  } else if (!Consistent(runs[c].two_view)) {
    summary->consensus = "inconsistent";  // its own photo pairs contradict it
  } else if (!runs[c].agrees_with.empty()) {
    summary->consensus = "agreed";
  } else {
    // No other run agrees: that counts against the kept model only when the other run is itself consistent
    // with its photo pairs (a run that contradicts its own pairs is wrong, not a second opinion).
    bool contested = false;
    for (int j = 0; j < with_model; ++j) {
      if (j != c && runs[j].two_view.pairs >= 3 && Consistent(runs[j].two_view)) contested = true;
    }
    summary->consensus = contested                       ? "disagreed"
                         : runs[c].two_view.pairs >= 3   ? "consistent"
                                                         : "unchecked";
  }
  if (c >= 0) {
    // Photos that a run agreeing overall placed differently (colmap names; renamed with the model later).
    std::set<std::string> unstable;
    for (int j : runs[c].agrees_with) {
      for (const auto& name : CompareModels(runs[c].model, runs[j].model, kToleranceDeg).differing) {
        unstable.insert(name);
      }
    }
    // ... and photos most of whose checked pairs contradict the model.
    for (const auto& [name, counts] : runs[c].two_view.per_photo) {
      if (counts.second >= 2 && 2 * counts.first < counts.second) unstable.insert(name);
    }
    for (auto& p : summary->photos) {
      p.unstable = unstable.count(p.colmap_name) > 0;
      if (auto it = runs[c].two_view.per_photo.find(p.colmap_name); it != runs[c].two_view.per_photo.end()) {
        p.pairs_agreeing = it->second.first;
        p.pairs_checked = it->second.second;
      }
    }
    RLOG_INFO("mapper runs: {} ({} run(s); kept run {}, first pair {})", summary->consensus, runs.size(), c + 1,
              runs[c].init_pair);
  }
  return runs;
}

void RunColmapMode(const SfmOptions& options, const std::string& ingest_dir, const std::vector<IngestedPhoto>& photos,
                   const std::string& output_dir, int threads, SfmSummary& summary) {
  CheckColmapAvailable();
  const std::string work = JoinPath(output_dir, "colmap");
  std::error_code ec;
  fs::remove_all(work, ec);  // a killed earlier run leaves a half-filled database
  EnsureDir(work);
  const std::string image_dir = JoinPath(work, "images");
  const std::string database = JoinPath(work, "database.db");
  const int n = static_cast<int>(photos.size());
  const std::string thread_count = std::to_string(threads > 0 ? threads : -1);

  Timer step;
  PrepareColmapImages(ingest_dir, photos, image_dir, &summary.photos);
  summary.step_seconds.emplace_back("prepare images", step.Seconds());

  // Intrinsics: one shared camera needs one size and one camera.
  std::string difference;
  const bool all_same = AllSame(photos, &difference);
  if (options.shared_intrinsics == "single" && !all_same) {
    RELIGHT_USER_ERROR() << "sfm.shared_intrinsics is single but the photos differ (" << difference
                         << "); set sfm.shared_intrinsics: per_image (or auto)";
  }
  summary.shared_intrinsics =
      options.shared_intrinsics == "auto" ? (all_same ? "single" : "per_image") : options.shared_intrinsics;
  RLOG_INFO("intrinsics: {} {} camera{}{}", summary.shared_intrinsics == "single" ? "one shared" : "one per photo,",
            options.camera_model, summary.shared_intrinsics == "single" ? "" : "s",
            all_same ? "" : " (" + difference + ")");

  // Names file: exactly the manifest's photos, in manifest order.
  const std::string list_path = JoinPath(work, "image_list.txt");
  {
    std::string list;
    for (const auto& p : summary.photos) list += p.colmap_name + "\n";
    WriteFileAtomic(list_path, list);
  }

  ColmapCommand extract{"feature_extractor", {}};
  extract.Arg("--database_path", database)
      .Arg("--image_path", image_dir)
      .Arg("--image_list_path", list_path)
      .Arg("--ImageReader.camera_model", options.camera_model)
      .Arg("--ImageReader.single_camera", summary.shared_intrinsics == "single")
      .Arg("--SiftExtraction.use_gpu", false)
      .Arg("--SiftExtraction.num_threads", thread_count)
      .Arg("--SiftExtraction.max_image_size", options.max_image_size)
      .Arg("--SiftExtraction.max_num_features", options.max_num_features)
      .Arg("--random_seed", options.seed);
  RunStep("extract features", extract, "Processed file", n, &summary.step_seconds);
  if (!fs::is_regular_file(database)) {
    RELIGHT_USER_ERROR() << "COLMAP feature_extractor wrote no database at '" << database << "' (see stage.log)";
  }
  ColmapDatabase(database).CanonicalizeIds();
  AddChromaFeatures(database, image_dir, options, &summary.step_seconds);
  {
    ColmapDatabase db(database);
    std::map<std::string, int> keypoints;
    for (const auto& im : db.ReadImages()) keypoints[im.name] = im.num_keypoints;
    int with_features = 0;
    for (auto& p : summary.photos) {
      auto it = keypoints.find(p.colmap_name);
      p.num_keypoints = it == keypoints.end() ? 0 : it->second;
      if (it == keypoints.end()) {
        p.reason = "COLMAP could not read the image (see stage.log)";
      } else if (p.num_keypoints == 0) {
        p.reason = "no SIFT features (blank, blurred or unreadable photo)";
      } else {
        ++with_features;
      }
    }
    if (with_features < 2) {
      RELIGHT_USER_ERROR() << "COLMAP found SIFT features in only " << with_features << " of " << n << " photos of "
                           << ingest_dir << "; the photos need texture (see stage.log)";
    }
  }
  ApplyFocalPriors(options, database, photos, summary.photos);

  const bool all_priors = options.use_exif_focal && std::all_of(photos.begin(), photos.end(),
                                                                [](const auto& p) { return p.focal_px.has_value(); });
  summary.refine_intrinsics =
      options.refine_intrinsics == "auto" ? (all_priors ? "final" : "mapping") : options.refine_intrinsics;
  if (summary.refine_intrinsics != "mapping" && !all_priors) {
    RLOG_WARN(
        "sfm.refine_intrinsics is {} but not every photo has an EXIF focal length: those start from "
        "COLMAP's guess (1.2 x the longer side) and are only refined {}",
        summary.refine_intrinsics, summary.refine_intrinsics == "final" ? "at the end" : "never");
  }
  RLOG_INFO("intrinsics refinement: {}", summary.refine_intrinsics);

  summary.matcher = ChooseMatcher(options, n);
  int verified_pairs = 0;
  if (summary.matcher == "exhaustive" || summary.matcher == "sequential" || summary.matcher == "retrieval") {
    const MatchCounts counts = MatchFeatures(database, summary.matcher, options, threads, &summary.step_seconds);
    summary.num_pairs_matched = counts.compared;
    verified_pairs = counts.verified;
  } else {
    // COLMAP's spatial and vocabulary-tree matchers: their kd-tree search is not seeded, so matches (and
    // possibly the registration) vary slightly between runs.
    ColmapCommand match{summary.matcher + "_matcher", {}};
    match.Arg("--database_path", database)
        .Arg("--SiftMatching.use_gpu", false)
        .Arg("--SiftMatching.num_threads", thread_count)
        .Arg("--random_seed", options.seed);
    if (summary.matcher == "vocab_tree") match.Arg("--VocabTreeMatching.vocab_tree_path", options.vocab_tree);
    RunStep("match features (" + summary.matcher + ")", match, "Matching image", n, &summary.step_seconds);
    verified_pairs = VerifyDatabaseMatches(database, options.seed, threads, &summary.step_seconds);
  }
  {
    ColmapDatabase db(database);
    std::map<std::string, int> partners;
    for (const auto& im : db.ReadImages(kMinPairInliers)) partners[im.name] = im.num_verified_partners;
    for (auto& p : summary.photos) {
      p.num_matched_photos = partners.count(p.colmap_name) ? partners[p.colmap_name] : 0;
      if (p.reason.empty() && p.num_matched_photos == 0) {
        p.reason = "no verified matches with any other photo (different object, too little overlap, or the "
                   "light changed too much between it and its neighbours)";
      }
    }
    RLOG_INFO("matching: {} photo pairs with at least {} verified matches", verified_pairs, kMinPairInliers);
  }
  if (verified_pairs == 0) {
    RELIGHT_USER_ERROR() << "nothing registered: no two of the " << n << " photos of " << ingest_dir
                         << " share enough features to be matched (" << PhotoFeatureReport(summary, photos)
                         << "). " << kWhatToChange;
  }

  // One thread: COLMAP's multi-threaded bundle adjustment sums in a varying order, and the small differences
  // grew to 0.09 scene units between two runs on the same photos. The hierarchical mapper uses the threads to map
  // clusters in parallel instead.
  summary.mapper = ChooseMapper(options, n);
  const bool hierarchical = summary.mapper == "hierarchical";
  ColmapCommand map{hierarchical ? "hierarchical_mapper" : "mapper", {}};
  if (hierarchical) {
    map.Arg("--num_workers", thread_count)
        .Arg("--leaf_max_num_images", kLeafMaxPhotos)
        .Arg("--image_overlap", kClusterOverlapPhotos);
  }
  RLOG_INFO("mapper: {}{}", summary.mapper,
            hierarchical ? " (clusters of up to " + std::to_string(kLeafMaxPhotos) + " photos plus " +
                               std::to_string(kClusterOverlapPhotos) +
                               " shared with each neighbouring cluster, mapped in parallel and merged)"
                         : "");
  map.Arg("--database_path", database)
      .Arg("--image_path", image_dir)
      .Arg("--Mapper.num_threads", 1)
      .Arg("--Mapper.min_model_size", std::min(options.min_model_size, n))
      .Arg("--Mapper.abs_pose_min_num_inliers", options.abs_pose_min_num_inliers)
      .Arg("--Mapper.abs_pose_min_inlier_ratio", options.abs_pose_min_inlier_ratio)
      .Arg("--Mapper.ba_refine_principal_point", false)
      .Arg("--Mapper.ba_refine_focal_length", summary.refine_intrinsics == "mapping")
      .Arg("--Mapper.ba_refine_extra_params", summary.refine_intrinsics == "mapping")
      .Arg("--random_seed", options.seed);
  std::vector<PairObservations> pair_observations;
  std::vector<MapperRun> runs =
      MapWithConsensus(options, map, database, JoinPath(work, "sparse"), n, &summary, &pair_observations);
  const int chosen = summary.chosen_run;
  if (chosen < 0) {
    RELIGHT_USER_ERROR() << "nothing registered: COLMAP's mapper built no model of at least "
                         << std::min(std::max(3, options.min_model_size), n) << " photos from the " << n
                         << " photos of " << ingest_dir << ": only " << verified_pairs
                         << " photo pairs share verified matches, too few to chain (" << PhotoFeatureReport(summary, photos)
                         << "). " << kWhatToChange;
  }
  summary.num_models = runs[chosen].num_models;
  const std::set<std::string> split_off = runs[chosen].split_off;
  Reconstruction model = std::move(runs[chosen].model);
  runs.clear();
  // A photo most of whose own verified pairs contradict the kept model has a wrong camera: it leaves the model
  // (before the final bundle adjustment, which it would pull). A photo that another run placed differently but
  // whose pairs agree with the kept model stays: its own matches are the direct evidence.
  {
    std::set<std::string> contradicted;
    for (auto& p : summary.photos) {
      if (model.FindImage(p.colmap_name) == nullptr) continue;
      if (p.pairs_checked >= 2 && 2 * p.pairs_agreeing < p.pairs_checked) {
        contradicted.insert(p.colmap_name);
        p.reason = "its camera contradicts its own photo pairs (" + std::to_string(p.pairs_agreeing) + " of " +
                   std::to_string(p.pairs_checked) +
                   " pairs' matches fit it): a wrong registration; photos between it and its neighbours help";
      } else if (p.unstable) {
        RLOG_INFO("{}: another mapper run placed it differently, but {} of its {} photo pairs agree with the kept "
                  "model: kept",
                  p.colmap_name, p.pairs_agreeing, p.pairs_checked);
      }
    }
    // The hierarchical mapper merges clusters only where they share enough registered photos: a cluster it
    // could not merge stays a smaller model, and the photos no cluster registered stay out.
    int outside = 0;
    for (const auto& p : summary.photos) outside += p.num_keypoints > 0 && model.FindImage(p.colmap_name) == nullptr;
    const bool register_outside = hierarchical && outside > 0;
    if (!contradicted.empty() || register_outside) {
      if (!contradicted.empty()) {
        RLOG_WARN("{} photo(s) left out, their cameras contradicted by their own photo pairs: {}",
                  contradicted.size(), JoinNames(std::vector<std::string>(contradicted.begin(), contradicted.end())));
        RemoveImages(contradicted, &model);
      }
      if (register_outside) {
        RLOG_INFO("{} photo(s) with features outside the merged model ({} in clusters that were not merged): "
                  "registering them to it",
                  outside, split_off.size());
      }
      // Registered again against the model without them (COLMAP's image_registrator), they often find their
      // place (a wrong first pair misplaces its photos, not the model; a cluster left unmerged shares photos
      // with its neighbours); a photo whose pairs contradict the model stays out.
      ColmapCommand reg{"image_registrator", {}};
      reg.Arg("--database_path", database);
      for (const auto& [key, value] : map.args) {
        if (key.rfind("--Mapper.", 0) == 0) reg.Arg(key, value);
      }
      Reconstruction registered = RunModelCommand(reg, model, work, "register left-out photos", &summary.step_seconds);
      ColmapCommand adjust{"bundle_adjuster", {}};
      adjust.Arg("--BundleAdjustment.refine_focal_length", summary.refine_intrinsics == "mapping")
          .Arg("--BundleAdjustment.refine_extra_params", summary.refine_intrinsics == "mapping")
          .Arg("--BundleAdjustment.refine_principal_point", false);
      registered = RunModelCommand(adjust, registered, work, "adjust after registering", &summary.step_seconds);
      const TwoViewAgreement check = CheckTwoViewAgreement(registered, pair_observations, kTwoViewMaxErrorPx);
      // Every photo the registrator added (it tries all that are not in the model) must fit its pairs.
      std::set<std::string> still_wrong;
      for (auto& p : summary.photos) {
        if (model.FindImage(p.colmap_name) != nullptr || registered.FindImage(p.colmap_name) == nullptr) continue;
        const auto it = check.per_photo.find(p.colmap_name);
        const int agreeing = it == check.per_photo.end() ? 0 : it->second.first;
        const int checked = it == check.per_photo.end() ? 0 : it->second.second;
        if (checked >= 2 && 2 * agreeing >= checked) {
          RLOG_INFO("{}: registered again, now {} of its {} photo pairs agree", p.colmap_name, agreeing, checked);
          p.reason.clear();
          p.pairs_agreeing = agreeing;
          p.pairs_checked = checked;
        } else {
          still_wrong.insert(p.colmap_name);
        }
      }
      RemoveImages(still_wrong, &registered);
      model = std::move(registered);
    }
  }
  // Split off: the photos of the run's smaller models that are still not in the kept one.
  summary.split_off_photos = static_cast<int>(std::count_if(
      split_off.begin(), split_off.end(), [&](const std::string& name) { return model.FindImage(name) == nullptr; }));
  // The principal point: a camera shared by many photos constrains it (an off-centre principal point otherwise
  // turns every camera by atan(offset / focal): 0.9 deg on the Middlebury temple, 18 px off in 1520).
  bool refine_pp = options.refine_principal_point == "always";
  if (options.refine_principal_point == "auto") {
    std::map<uint32_t, int> photos_per_camera;
    for (const auto& [id, im] : model.images) ++photos_per_camera[im.camera_id];
    for (const auto& [camera, count] : photos_per_camera) refine_pp = refine_pp || count >= 10;
  }
  summary.principal_point_refined = refine_pp;
  if (summary.refine_intrinsics == "final" || refine_pp || hierarchical) {
    // One global bundle adjustment of the largest model with the intrinsics to refine free (the hierarchical
    // mapper adjusts each cluster alone, then only aligns them).
    ColmapCommand ba{"bundle_adjuster", {}};
    ba.Arg("--BundleAdjustment.refine_focal_length", summary.refine_intrinsics != "never")
        .Arg("--BundleAdjustment.refine_extra_params", summary.refine_intrinsics != "never")
        .Arg("--BundleAdjustment.refine_principal_point", refine_pp)
        .Arg("--random_seed", options.seed);
    Reconstruction refined = RunModelCommand(
        ba, model, work, hierarchical ? "global bundle adjustment" : "refine intrinsics", &summary.step_seconds);
    RLOG_INFO("final bundle adjustment: reprojection error {:.3f} -> {:.3f} px", model.MeanReprojectionError(),
              refined.MeanReprojectionError());
    model = std::move(refined);
  }

  // A weakly constrained photo can reach a degenerate camera (a telephoto from far away) with a normal
  // reprojection error; it is dropped with its reason.
  const std::map<std::string, std::string> implausible = RemoveImplausibleCameras(&model);
  for (auto& p : summary.photos) {
    if (auto it = implausible.find(p.colmap_name); it != implausible.end()) p.reason = it->second;
  }
  if (!implausible.empty()) {
    RLOG_WARN("{} photo(s) left out with implausible cameras: {}", implausible.size(),
              JoinNames([&] {
                std::vector<std::string> names;
                for (const auto& [name, why] : implausible) names.push_back(name);
                return names;
              }()));
  }

  // Name maps and reasons for photos left out of the largest model.
  std::map<std::string, std::string> name_from_colmap, colmap_from_name;
  for (const auto& p : summary.photos) {
    name_from_colmap[p.colmap_name] = p.name;
    colmap_from_name[p.name] = p.colmap_name;
  }
  for (auto& p : summary.photos) {
    if (model.FindImage(p.colmap_name) == nullptr && p.reason.empty()) {
      p.reason = "matched with " + std::to_string(p.num_matched_photos) +
                 " photo(s) but could not be registered to the largest model (too few inlier matches; "
                 "lowering sfm.abs_pose_min_num_inliers may help)";
    }
  }

  {
    Reconstruction renamed = model;
    RenameImages(name_from_colmap, &renamed);
    MarkRegistered(renamed, &summary);
  }
  CheckRegistered(options, summary, ingest_dir);

  // World frame: +Z up.
  summary.world_from_colmap = options.align_up ? UpAlignment(model) : Sim3();
  model.Transform(summary.world_from_colmap);
  Undistort(options, model, work, image_dir, output_dir, &summary);
  RenameImages(name_from_colmap, &model);
  WriteModels(model, output_dir);

  // The working folder: links to the ingest cache, raw models, the database.
  fs::remove_all(image_dir, ec);
  fs::remove_all(JoinPath(work, "world"), ec);
  if (!options.keep_database) fs::remove(database, ec);
}

// Sparse points for given cameras that come without any (ground truth, or a
// model of poses only): SIFT features matched exhaustively, kept where the
// known epipolar geometry allows them (a point-to-line test with the true
// poses rejects far more false matches than a RANSAC estimate could), then
// triangulated by COLMAP's point_triangulator with every camera held fixed.
// MVS takes its depth ranges and source views from these points.
void TriangulateGivenCameras(const SfmOptions& options, const std::string& work, const std::string& image_dir,
                             int threads, Reconstruction* model, SfmSummary* summary) {
  const std::string database = JoinPath(work, "database.db");
  const std::string thread_count = std::to_string(threads > 0 ? threads : -1);
  const int n = static_cast<int>(model->images.size());
  const std::string list_path = JoinPath(work, "image_list.txt");
  {
    std::string list;
    for (const auto& [id, im] : model->images) list += im.name + "\n";
    WriteFileAtomic(list_path, list);
  }
  ColmapCommand extract{"feature_extractor", {}};
  extract.Arg("--database_path", database)
      .Arg("--image_path", image_dir)
      .Arg("--image_list_path", list_path)
      .Arg("--ImageReader.single_camera_per_image", true)
      .Arg("--SiftExtraction.use_gpu", false)
      .Arg("--SiftExtraction.num_threads", thread_count)
      .Arg("--SiftExtraction.max_image_size", options.max_image_size)
      .Arg("--SiftExtraction.max_num_features", options.max_num_features);
  RunStep("extract features", extract, "Processed file", n, &summary->step_seconds);
  ColmapDatabase(database).CanonicalizeIds();

  // The database's images and cameras take the given cameras; every pair is matched along its known epipolar
  // lines (guided matching: a descriptor competes only with the keypoints near its line, so far more true
  // matches pass the ratio test than in an unguided search).
  Timer timer;
  Reconstruction input;  // the given model with the database's ids, no points
  size_t num_pairs = 0;  // pairs with enough matches
  {
    ColmapDatabase db(database);
    std::map<std::string, DatabaseImage> by_name;
    for (const auto& im : db.ReadImages()) by_name[im.name] = im;
    std::vector<int> ids;  // database image ids of the given images
    for (const auto& [id, im] : model->images) {
      auto it = by_name.find(im.name);
      if (it == by_name.end()) continue;  // COLMAP could not read it: no points from this photo
      const DatabaseImage& d = it->second;
      const Camera& c = model->cameras.at(im.camera_id);
      DatabaseCamera cam;
      cam.camera_id = d.camera_id;
      cam.model_id = Camera::ModelId(c.model);
      cam.width = c.width;
      cam.height = c.height;
      cam.params = c.params;
      cam.prior_focal_length = true;
      db.UpdateCamera(cam);
      Camera copy = c;
      copy.camera_id = d.camera_id;
      input.cameras[d.camera_id] = copy;
      ImageRecord record = im;
      record.image_id = d.image_id;
      record.camera_id = d.camera_id;
      record.points2d.clear();
      input.images[d.image_id] = record;
      ids.push_back(d.image_id);
    }
    std::sort(ids.begin(), ids.end());
    std::map<int, std::vector<Eigen::Vector3d>> rays;  // normalised keypoint rays per image
    std::map<int, DescriptorMatrix> descriptors;
    for (int id : ids) {
      const Camera& c = input.cameras.at(input.images.at(id).camera_id);
      for (const auto& k : db.ReadKeypoints(id)) rays[id].push_back(c.NormalizedFromImage(k).homogeneous());
      int rows = 0, cols = 0;
      const std::vector<uint8_t> data = db.ReadDescriptors(id, &rows, &cols);
      descriptors[id] = NormalizedDescriptors(data, rows, cols);
    }
    std::vector<std::pair<int, int>> pairs;
    for (size_t i = 0; i < ids.size(); ++i)
      for (size_t j = i + 1; j < ids.size(); ++j) pairs.emplace_back(ids[i], ids[j]);
    std::vector<DatabaseMatches> guided(pairs.size());
    Progress progress("match along the known epipolar lines", static_cast<int64_t>(pairs.size()));
    tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
    arena.execute([&] {
      tbb::parallel_for(size_t(0), pairs.size(), [&](size_t k) {
        const auto [ia, ib] = pairs[k];
        const ImageRecord& a = input.images.at(ia);
        const ImageRecord& b = input.images.at(ib);
        const Camera& ca = input.cameras.at(a.camera_id);
        const Camera& cb = input.cameras.at(b.camera_id);
        const Eigen::Matrix3d e = EssentialMatrix(a, b);  // the known relative pose
        const double max_sampson = 4.0 / std::sqrt(ca.FocalX() * cb.FocalX());  // 4 px in normalised units
        const auto& xa = rays.at(ia);
        const auto& xb = rays.at(ib);
        auto near_line = [&](int i, int j) { return SampsonDistance(e, xa[i], xb[j]) <= max_sampson; };
        DatabaseMatches& m = guided[k];
        m.image_id1 = ia;
        m.image_id2 = ib;
        if (!xa.empty() && !xb.empty()) {
          // The epipolar band already rejects most false candidates: a looser ratio keeps more true matches.
          DescriptorMatchingOptions guided_options;
          guided_options.max_ratio = 0.9;
          m.matches = MatchDescriptors(descriptors.at(ia), descriptors.at(ib), guided_options, near_line);
        }
        progress.Advance();
      });
    });
    progress.Finish();
    std::vector<DatabaseMatches> kept_matches;
    std::vector<DatabaseTwoViewGeometry> geometries;
    for (auto& m : guided) {
      if (static_cast<int>(m.matches.size()) < kMinPairInliers) continue;
      const ImageRecord& a = input.images.at(m.image_id1);
      const ImageRecord& b = input.images.at(m.image_id2);
      const Camera& ca = input.cameras.at(a.camera_id);
      const Camera& cb = input.cameras.at(b.camera_id);
      DatabaseTwoViewGeometry g;
      g.image_id1 = m.image_id1;
      g.image_id2 = m.image_id2;
      g.config = kTwoViewUncalibrated;
      g.F = cb.K().inverse().transpose() * EssentialMatrix(a, b) * ca.K().inverse();
      g.inlier_matches = m.matches;
      geometries.push_back(std::move(g));
      kept_matches.push_back(std::move(m));
    }
    db.ReplaceMatches(kept_matches);
    db.ReplaceTwoViewGeometries(geometries);
    num_pairs = geometries.size();
  }
  summary->step_seconds.emplace_back("match along the known epipolar lines", timer.Seconds());
  RLOG_INFO("given cameras: {} photo pairs with at least {} matches along the known epipolar lines", num_pairs,
            kMinPairInliers);
  if (num_pairs == 0) {
    RLOG_WARN("no two photos share features that fit the given cameras: no sparse points (MVS takes its depth "
              "ranges from the camera poses alone)");
    return;
  }
  ColmapCommand triangulate{"point_triangulator", {}};
  triangulate.Arg("--database_path", database)
      .Arg("--image_path", image_dir)
      .Arg("--Mapper.num_threads", thread_count)
      .Arg("--Mapper.ba_refine_focal_length", false)
      .Arg("--Mapper.ba_refine_principal_point", false)
      .Arg("--Mapper.ba_refine_extra_params", false)
      .Arg("--Mapper.tri_ignore_two_view_tracks", false);  // the poses are known: two views suffice
  Reconstruction triangulated = RunModelCommand(triangulate, input, work, "triangulate", &summary->step_seconds);
  // The given poses stay: COLMAP's bundle adjustment may only have moved the points.
  double moved = 0;
  for (const auto& [id, im] : triangulated.images) {
    moved = std::max(moved, (im.ProjectionCenter() - input.images.at(id).ProjectionCenter()).norm());
  }
  RLOG_INFO("given cameras: {} sparse points triangulated (largest camera shift {:.3g})",
            triangulated.points3d.size(), moved);
  *model = std::move(triangulated);
}

// Given cameras (the model mode's folder, or the one the stage's main resolved): a given model, conformed to the
// photos.
void RunGivenModelMode(const SfmOptions& options, const std::string& ingest_dir, const std::string& model_dir,
                       const std::vector<IngestedPhoto>& photos, const std::string& output_dir, int threads,
                       SfmSummary& summary) {
  Timer step;
  Reconstruction model = Reconstruction::Read(model_dir);
  const auto unknown = ConformToPhotos(photos, model_dir, &model);
  if (!unknown.empty()) {
    RLOG_WARN("{} image(s) of {} are not among the ingested photos and are ignored: {}", unknown.size(), model_dir,
              JoinNames(unknown));
  }
  for (auto& p : summary.photos) {
    if (model.FindImage(p.name) == nullptr) p.reason = "not in the given model " + model_dir;
  }
  summary.step_seconds.emplace_back("read model", step.Seconds());
  if (options.mode == "model" && options.align_up) {
    summary.world_from_colmap = UpAlignment(model);
    model.Transform(summary.world_from_colmap);
  }
  MarkRegistered(model, &summary);
  if (summary.num_registered == 0) {
    RELIGHT_USER_ERROR() << "nothing registered: none of the images of " << model_dir
                         << " is one of the ingested photos (names must match the photo file names)";
  }
  CheckRegistered(options, summary, model_dir);

  // dense/ workspace from the registered photos.
  CheckColmapAvailable();
  const std::string work = JoinPath(output_dir, "colmap");
  std::error_code ec;
  fs::remove_all(work, ec);
  EnsureDir(work);
  const std::string image_dir = JoinPath(work, "images");
  step.Restart();
  PrepareColmapImages(ingest_dir, photos, image_dir, &summary.photos);
  summary.step_seconds.emplace_back("prepare images", step.Seconds());
  std::map<std::string, std::string> colmap_from_name;
  for (const auto& p : summary.photos) colmap_from_name[p.name] = p.colmap_name;
  Reconstruction colmap_names = model;
  RenameImages(colmap_from_name, &colmap_names);
  if (model.points3d.empty()) {
    TriangulateGivenCameras(options, work, image_dir, threads, &colmap_names, &summary);
    std::map<std::string, std::string> name_from_colmap;
    for (const auto& p : summary.photos) name_from_colmap[p.colmap_name] = p.name;
    model = colmap_names;
    RenameImages(name_from_colmap, &model);
    MarkRegistered(model, &summary);
  }
  Undistort(options, colmap_names, work, image_dir, output_dir, &summary);
  WriteModels(model, output_dir);
  fs::remove_all(work, ec);
}

}  // namespace

std::vector<std::string> SfmSummary::UnregisteredNames() const {
  std::vector<std::string> names;
  for (const auto& p : photos) {
    if (!p.registered) names.push_back(p.name);
  }
  return names;
}

std::string SfmSummary::BriefReport() const {
  std::ostringstream s;
  s << "sfm (" << mode << "): " << num_registered << "/" << num_photos << " photos registered, " << num_points3d
    << " 3D points, mean reprojection error " << mean_reprojection_error_px << " px";
  if (mode == "colmap") {
    s << ", matcher " << matcher << ", mapper " << mapper << ", intrinsics " << shared_intrinsics
      << " (refined: " << refine_intrinsics << ")";
  }
  s << "; steps:";
  for (const auto& [name, seconds] : step_seconds) s << " " << name << " " << Progress::FormatSeconds(seconds) << ",";
  s << " total " << Progress::FormatSeconds(seconds);
  return s.str();
}

Sim3 UpAlignment(const Reconstruction& reconstruction) {
  Eigen::Vector3d up_sum = Eigen::Vector3d::Zero();
  for (const auto& [id, image] : reconstruction.images) {
    // Image -y in world coordinates: -(R^T e_y) = -(row 1 of R).
    up_sum -= image.CamFromWorldRotation().row(1).transpose();
  }
  Sim3 t;
  if (reconstruction.images.empty() || up_sum.norm() < 1e-3 * reconstruction.images.size()) {
    RLOG_WARN("the cameras' up directions cancel out; the model keeps COLMAP's orientation");
    return t;
  }
  t.rotation = Eigen::Quaterniond::FromTwoVectors(up_sum.normalized(), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return t;
}

void RemoveImages(const std::set<std::string>& names, Reconstruction* model) {
  std::set<uint32_t> kept;
  for (auto it = model->images.begin(); it != model->images.end();) {
    if (names.count(it->second.name)) {
      it = model->images.erase(it);
    } else {
      kept.insert(it->first);
      ++it;
    }
  }
  for (auto it = model->points3d.begin(); it != model->points3d.end();) {
    auto& track = it->second.track;
    track.erase(std::remove_if(track.begin(), track.end(), [&](const auto& e) { return !kept.count(e.first); }),
                track.end());
    it = track.size() < 2 ? model->points3d.erase(it) : std::next(it);
  }
  for (auto& [id, image] : model->images) {
    for (auto& p2 : image.points2d) {
      if (p2.point3d_id != Point2D::kInvalidPoint3D && !model->points3d.count(p2.point3d_id)) {
        p2.point3d_id = Point2D::kInvalidPoint3D;
      }
    }
  }
}

std::map<std::string, std::string> RemoveImplausibleCameras(Reconstruction* model) {
  std::map<std::string, std::string> removed;
  std::set<std::string> names;
  for (const auto& [id, image] : model->images) {
    const Camera& camera = model->cameras.at(image.camera_id);
    const double longer_side = std::max(camera.width, camera.height);
    const double focal_ratio = camera.FocalX() / longer_side;
    const size_t first_distortion = camera.model == "SIMPLE_RADIAL" || camera.model == "RADIAL" ? 3
                                    : camera.model == "OPENCV"                                   ? 4
                                                                                                 : camera.params.size();
    double largest_distortion = 0;
    for (size_t k = first_distortion; k < camera.params.size(); ++k) {
      largest_distortion = std::max(largest_distortion, std::abs(camera.params[k]));
    }
    if (!(focal_ratio >= kMinFocalRatio && focal_ratio <= kMaxFocalRatio && largest_distortion <= kMaxDistortion)) {
      removed[image.name] = fmt::format(
          "registered with an implausible camera (focal length {:.3g} px for a {} px photo, distortion {:.3g}): too "
          "few matches constrain it; photos between it and its neighbours help",
          camera.FocalX(), static_cast<int>(longer_side), largest_distortion);
      names.insert(image.name);
    }
  }
  RemoveImages(names, model);
  return removed;
}

std::vector<std::string> ConformToPhotos(const std::vector<IngestedPhoto>& photos, const std::string& where,
                                         Reconstruction* model) {
  std::map<std::string, const IngestedPhoto*> by_name, by_file;
  for (const auto& p : photos) {
    by_name[p.name] = &p;
    by_file[fs::path(p.file).filename().string()] = &p;
  }
  std::vector<std::string> unknown;
  std::map<std::pair<uint32_t, std::pair<int, int>>, uint32_t> rescaled_ids;
  uint32_t next_camera_id = model->cameras.empty() ? 1 : model->cameras.rbegin()->first + 1;
  std::map<uint32_t, Camera> new_cameras;
  for (auto it = model->images.begin(); it != model->images.end();) {
    ImageRecord& image = it->second;
    const IngestedPhoto* photo = by_name.count(image.name)   ? by_name[image.name]
                                 : by_file.count(image.name) ? by_file[image.name]
                                                             : nullptr;
    if (photo == nullptr) {
      unknown.push_back(image.name);
      it = model->images.erase(it);
      continue;
    }
    image.name = photo->name;
    auto cam = model->cameras.find(image.camera_id);
    if (cam == model->cameras.end()) {
      RELIGHT_USER_ERROR() << where << ": image '" << image.name << "' refers to camera " << image.camera_id
                           << ", which is not in cameras.txt/.bin";
    }
    const Camera& c = cam->second;
    if (c.width == photo->width && c.height == photo->height) {
      new_cameras[c.camera_id] = c;
    } else {
      const double sx = double(photo->width) / c.width, sy = double(photo->height) / c.height;
      if (std::abs(sx - sy) > 0.01 * sx) {
        RELIGHT_USER_ERROR() << where << ": camera " << c.camera_id << " is " << c.width << "x" << c.height
                             << " but photo '" << photo->name << "' is " << photo->width << "x" << photo->height
                             << " (different aspect ratio); the model does not belong to these photos";
      }
      const auto key = std::make_pair(c.camera_id, std::make_pair(photo->width, photo->height));
      auto r = rescaled_ids.find(key);
      if (r == rescaled_ids.end()) {
        Camera scaled = c;
        scaled.Rescale(sx);
        scaled.width = photo->width;
        scaled.height = photo->height;
        scaled.camera_id = next_camera_id++;
        new_cameras[scaled.camera_id] = scaled;
        r = rescaled_ids.emplace(key, scaled.camera_id).first;
      }
      image.camera_id = r->second;
    }
    // Observations are in the model's pixels; rescale them too.
    const Camera& final_camera = new_cameras[image.camera_id];
    const double s = double(final_camera.width) / c.width;
    if (s != 1.0) {
      for (auto& p2 : image.points2d) p2.xy *= s;
    }
    ++it;
  }
  model->cameras = std::move(new_cameras);
  // Tracks of removed images.
  std::set<uint32_t> kept;
  for (const auto& [id, im] : model->images) kept.insert(id);
  for (auto it = model->points3d.begin(); it != model->points3d.end();) {
    auto& track = it->second.track;
    track.erase(std::remove_if(track.begin(), track.end(), [&](const auto& e) { return !kept.count(e.first); }),
                track.end());
    it = track.empty() ? model->points3d.erase(it) : std::next(it);
  }
  return unknown;
}

Reconstruction ReadMiddleburyCameras(const std::string& path, int width, int height) {
  std::ifstream in(path);
  if (!in) RELIGHT_USER_ERROR() << "cannot open Middlebury camera file '" << path << "'";
  int count = 0;
  if (!(in >> count) || count <= 0) {
    RELIGHT_USER_ERROR() << "'" << path << "' does not start with a camera count (Middlebury *_par.txt format)";
  }
  Reconstruction model;
  for (int i = 0; i < count; ++i) {
    std::string name;
    double k[9], r[9], t[3];
    in >> name;
    for (double& v : k) in >> v;
    for (double& v : r) in >> v;
    for (double& v : t) in >> v;
    if (!in) {
      RELIGHT_USER_ERROR() << "'" << path << "': camera " << i + 1 << " of " << count
                           << " is incomplete (expected name, K (9), R (9), t (3))";
    }
    const uint32_t id = static_cast<uint32_t>(i + 1);
    model.cameras[id] = Camera::Pinhole(id, width, height, k[0], k[4], k[2], k[5]);
    ImageRecord image;
    image.image_id = id;
    image.camera_id = id;
    image.name = name;
    Eigen::Matrix3d rotation;
    rotation << r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8];
    image.cam_from_world_rotation = Eigen::Quaterniond(rotation).normalized();
    image.cam_from_world_translation = Eigen::Vector3d(t[0], t[1], t[2]);
    model.images[id] = image;
  }
  return model;
}

void WriteSfmSummary(const SfmSummary& summary, const std::string& path) {
  OrderedJson j;
  j["format"] = "relight-sfm-summary";
  j["version"] = 1;
  j["mode"] = summary.mode;
  j["num_photos"] = summary.num_photos;
  j["num_registered"] = summary.num_registered;
  j["unregistered"] = summary.UnregisteredNames();
  j["num_points3d"] = summary.num_points3d;
  j["mean_reprojection_error_px"] = summary.mean_reprojection_error_px;
  if (summary.mode == "colmap") {
    j["matcher"] = summary.matcher;
    if (summary.num_pairs_matched >= 0) j["num_pairs_matched"] = summary.num_pairs_matched;
    j["mapper"] = summary.mapper;
    j["shared_intrinsics"] = summary.shared_intrinsics;
    j["refine_intrinsics"] = summary.refine_intrinsics;
    j["principal_point_refined"] = summary.principal_point_refined;
    j["num_models"] = summary.num_models;
    j["split_off_photos"] = summary.split_off_photos;
    j["consensus"] = summary.consensus;
    OrderedJson runs = OrderedJson::array();
    for (size_t i = 0; i < summary.mapper_runs.size(); ++i) {
      const SfmMapperRun& r = summary.mapper_runs[i];
      OrderedJson e;
      e["first_pair"] = r.init_pair;
      e["num_models"] = r.num_models;
      e["num_registered"] = r.num_registered;
      e["split_off_photos"] = r.split_off_photos;
      e["mean_reprojection_error_px"] = r.mean_reprojection_error_px;
      e["agrees_with_runs"] = r.agrees_with;
      e["photo_pairs_checked"] = r.pairs_checked;
      e["photo_pairs_agreeing"] = r.pairs_agreeing;
      e["kept"] = static_cast<int>(i) == summary.chosen_run;
      e["seconds"] = r.seconds;
      runs.push_back(e);
    }
    j["mapper_runs"] = runs;
  }
  const Sim3& t = summary.world_from_colmap;
  OrderedJson transform;
  transform["description"] = "x_world = scale * rotation * x_colmap + translation (+Z up: mean camera up)";
  transform["scale"] = t.scale;
  transform["rotation"] = {{t.rotation(0, 0), t.rotation(0, 1), t.rotation(0, 2)},
                           {t.rotation(1, 0), t.rotation(1, 1), t.rotation(1, 2)},
                           {t.rotation(2, 0), t.rotation(2, 1), t.rotation(2, 2)}};
  transform["translation"] = {t.translation.x(), t.translation.y(), t.translation.z()};
  j["world_from_colmap"] = transform;
  OrderedJson photos = OrderedJson::array();
  for (const auto& p : summary.photos) {
    OrderedJson e;
    e["name"] = p.name;
    e["colmap_name"] = p.colmap_name;
    e["registered"] = p.registered;
    if (p.num_keypoints >= 0) e["num_keypoints"] = p.num_keypoints;
    if (p.num_matched_photos >= 0) e["num_matched_photos"] = p.num_matched_photos;
    if (!p.registered) e["reason"] = p.reason;
    if (p.unstable) e["unstable"] = true;
    if (p.pairs_checked > 0) {
      e["pairs_checked"] = p.pairs_checked;
      e["pairs_agreeing"] = p.pairs_agreeing;
    }
    photos.push_back(e);
  }
  j["photos"] = photos;
  OrderedJson steps;
  for (const auto& [name, seconds] : summary.step_seconds) steps[name] = seconds;
  j["step_seconds"] = steps;
  j["seconds"] = summary.seconds;
  if (!summary.failure.empty()) j["failure"] = summary.failure;
  WriteJsonAtomic(path, j);
}

SfmSummary RunSfm(const SfmOptions& options, const SfmInputs& inputs, const std::string& output_dir, int threads) {
  const std::string &ingest_dir = inputs.ingest_dir, &given_cameras_dir = inputs.given_cameras_dir;
  Timer timer;
  const IngestSummary ingest = ReadIngestManifest(ingest_dir);
  const int n = static_cast<int>(ingest.photos.size());
  if (options.mode == "colmap" && n < 3) {
    RELIGHT_USER_ERROR() << "structure from motion needs at least 3 photos, but " << ingest_dir
                         << "/manifest.json lists " << n << "; add photos of the object from more viewpoints";
  }
  if (n < 1) {  // given cameras: any number of photos will do
    RELIGHT_USER_ERROR() << ingest_dir << "/manifest.json lists no photos; add photos of the object";
  }
  SfmSummary summary;
  summary.mode = options.mode;
  summary.num_photos = n;
  for (const auto& p : ingest.photos) {
    SfmPhoto s;
    s.name = p.name;
    summary.photos.push_back(s);
  }
  RLOG_INFO("sfm ({} mode) on {} photos from {}", options.mode, n, ingest_dir);
  try {
    if (options.mode == "colmap") {
      RunColmapMode(options, ingest_dir, ingest.photos, output_dir, threads, summary);
    } else {
      const std::string& model_dir = options.mode == "model" ? options.model : given_cameras_dir;
      RELIGHT_CHECK(!model_dir.empty()) << "sfm.mode " << options.mode << " needs the given cameras' folder";
      RunGivenModelMode(options, ingest_dir, model_dir, ingest.photos, output_dir, threads, summary);
    }
  } catch (const UserError& e) {
    // The summary says what happened to each photo even when the stage stops.
    summary.failure = e.what();
    summary.seconds = timer.Seconds();
    WriteSfmSummary(summary, JoinPath(output_dir, "sfm_summary.json"));
    throw;
  }
  summary.seconds = timer.Seconds();
  WriteSfmSummary(summary, JoinPath(output_dir, "sfm_summary.json"));
  return summary;
}

}  // namespace relight
