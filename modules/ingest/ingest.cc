#include "ingest/ingest.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <mutex>

#include "core/error.h"
#include "core/fs.h"
#include "core/hash.h"
#include "core/json.h"
#include "core/log.h"
#include "core/options.h"
#include "core/path_text.h"
#include "core/progress.h"
#include "core/timer.h"
#include "datasets/diligent.h"
#include "image/color.h"

namespace relight {
namespace fs = std::filesystem;

namespace {

// Why a file was not used, grouped in the error when too few photos are left.
enum class SkipKind { kUnreadable, kSize, kGrayscale, kDuplicate };

// Decoded photo before the duplicate and grayscale checks.
struct Candidate {
  IngestedPhoto photo;           // name and source_path as text (PathText)
  std::string source;            // the source path's bytes, for reading
  Image image;                   // upright, downscaled
  std::vector<float> thumbnail;  // 32x32 luminance, zero mean, unit norm
  double mean_chroma = 0;
  bool ok = false;
  std::string reason;
  SkipKind kind = SkipKind::kUnreadable;
};

// Reason to skip a photo of `width` x `height` pixels (from its header), or "".
std::string SizeProblem(const IngestOptions& options, int width, int height) {
  const double megapixels = double(width) * height / 1e6;
  if (width <= 0 || height <= 0) return "its header gives no size";
  if (megapixels > options.max_megapixels) {
    return "its header claims " + std::to_string(width) + "x" + std::to_string(height) + " pixels (" +
           std::to_string(static_cast<long>(std::lround(megapixels))) + " megapixels, more than ingest.max_megapixels = " +
           CanonicalDouble(options.max_megapixels) + "); not decoded";
  }
  const int longest = std::max(width, height), shortest = std::min(width, height);
  if (double(longest) > options.max_aspect_ratio * shortest) {
    return std::to_string(width) + "x" + std::to_string(height) + " pixels is a strip, not a photo (sides more than " +
           "ingest.max_aspect_ratio = " + CanonicalDouble(options.max_aspect_ratio) + " apart)";
  }
  const double scale = options.max_image_size > 0 && longest > options.max_image_size
                           ? double(options.max_image_size) / longest
                           : 1.0;
  const int shortest_out = std::max(1, static_cast<int>(std::lround(shortest * scale)));
  if (shortest_out < options.min_image_side) {
    return std::to_string(width) + "x" + std::to_string(height) + " pixels" +
           (scale < 1.0 ? " (shorter side " + std::to_string(shortest_out) + " after downscaling)" : std::string()) +
           " is too small for feature matching (ingest.min_image_side = " + std::to_string(options.min_image_side) +
           ")";
  }
  return "";
}

// The error when fewer than ingest.min_photos photos are usable: counts per
// kind, the first file of each with its reason, and what to change.
std::string TooFewPhotosMessage(const IngestOptions& options, const std::string& photo_dir,
                                const std::vector<Candidate>& candidates, size_t usable) {
  struct Group {
    const char* what;
    const char* fix;
    int count = 0;
    const Candidate* first = nullptr;
  };
  std::map<SkipKind, Group> groups{
      {SkipKind::kUnreadable, {"unreadable", "replace or remove them"}},
      {SkipKind::kSize, {"of unusable size", "see ingest.max_megapixels, min_image_side, max_aspect_ratio"}},
      {SkipKind::kGrayscale, {"black-and-white", "set ingest.drop_grayscale: false to keep them"}},
      {SkipKind::kDuplicate, {"duplicates", "set ingest.drop_duplicates: false to keep them"}}};
  for (const Candidate& c : candidates) {
    if (c.ok) continue;
    Group& g = groups.at(c.kind);
    if (g.count++ == 0) g.first = &c;
  }
  std::string text = "only " + std::to_string(usable) + " usable photo(s) in '" + photo_dir + "' (need at least " +
                     std::to_string(options.min_photos) + ")";
  for (const auto& [kind, g] : groups) {
    if (g.count == 0) continue;
    std::string example = g.first->reason;
    if (example.size() > 160) example = example.substr(0, 157) + "...";
    text += "; " + std::to_string(g.count) + " " + g.what + " (" + g.fix + "), e.g. " + g.first->photo.name + ": " +
            example;
  }
  return text + "; every skipped file and its reason is in the stage log; add more photos of the object or lower "
                "ingest.min_photos";
}

std::vector<float> Thumbnail(const Image& image) {
  const Image small = ResizeImage(image, 32, 32);
  std::vector<float> t(32 * 32);
  for (int i = 0; i < 32 * 32; ++i) {
    const float* p = &small.pixels[size_t(i) * small.channels];
    t[i] = small.channels >= 3 ? static_cast<float>(Luminance(p)) : p[0];
  }
  double mean = 0;
  for (float v : t) mean += v;
  mean /= t.size();
  double norm = 0;
  for (float& v : t) {
    v -= static_cast<float>(mean);
    norm += double(v) * v;
  }
  norm = std::sqrt(norm);
  if (norm > 1e-9)
    for (float& v : t) v /= static_cast<float>(norm);
  return t;
}

double MeanChroma(const Image& image) {
  if (image.channels < 3) return 0.0;
  const int step = std::max(1, static_cast<int>(std::sqrt(double(image.width) * image.height / 65536.0)));
  double sum = 0;
  long count = 0;
  for (int y = 0; y < image.height; y += step) {
    for (int x = 0; x < image.width; x += step) {
      const float r = image.at(x, y, 0), g = image.at(x, y, 1), b = image.at(x, y, 2);
      double hi = std::max({r, g, b}), lo = std::min({r, g, b});
      if (hi > 1.0) {  // float photos: judge chroma relative to brightness
        lo /= hi;
        hi = 1.0;
      }
      sum += hi - lo;
      ++count;
    }
  }
  return count ? sum / count : 0.0;
}

Json OptionalToJson(const std::optional<double>& v) { return v ? Json(*v) : Json(nullptr); }
std::optional<double> JsonToOptional(const Json& j, const char* key) {
  if (!j.contains(key) || j.at(key).is_null()) return std::nullopt;
  return j.at(key).get<double>();
}

void CopyTree(const std::string& from, const std::string& to) {
  std::error_code ec;
  fs::remove_all(to, ec);
  const std::string tmp = to + std::string(kTempMarker) + "copy";
  fs::remove_all(tmp, ec);
  // Hard links where possible: cache entries are never modified in place.
  fs::copy(from, tmp, fs::copy_options::recursive | fs::copy_options::create_hard_links, ec);
  if (ec) {
    ec.clear();
    fs::remove_all(tmp, ec);
    fs::copy(from, tmp, fs::copy_options::recursive, ec);
  }
  if (ec) RELIGHT_USER_ERROR() << "cannot copy ground truth '" << from << "' to '" << to << "': " << ec.message();
  fs::rename(tmp, to, ec);
  if (ec) RELIGHT_USER_ERROR() << "cannot move ground truth into place at '" << to << "': " << ec.message();
}

}  // namespace

std::optional<double> FocalPixelsFromExif(const ImageMetadata& exif, int source_width, int source_height,
                                          int max_side) {
  if (!exif.focal_length_35mm || source_width <= 0 || source_height <= 0) return std::nullopt;
  // 35 mm equivalent focal length is defined on the diagonal of a 36x24 mm frame.
  const double scale = double(max_side) / std::max(source_width, source_height);
  const double diag_px = std::hypot(double(source_width), double(source_height)) * scale;
  return *exif.focal_length_35mm * diag_px / std::hypot(36.0, 24.0);
}

namespace {

// The stage on a resolved folder of photos; `keep_all`: no photo is dropped as black-and-white or duplicate.
IngestSummary IngestFolder(const IngestOptions& options, const std::string& photo_dir,
                           const std::string& ground_truth_dir, bool keep_all, const std::string& output_dir) {
  Timer timer;
  IngestSummary summary;
  std::error_code ec;
  if (fs::is_regular_file(photo_dir, ec)) {
    RELIGHT_USER_ERROR() << "ingest.images: '" << photo_dir
                         << "' is a file, not a folder; set ingest.images to the folder that holds the photos";
  }
  if (!fs::is_directory(photo_dir, ec)) {
    RELIGHT_USER_ERROR() << "photo folder '" << photo_dir << "' does not exist; set ingest.images in the config";
  }
  const FileSelection selection = PhotoFileSelection(options.recursive);
  const std::vector<std::string> files = ListFiles(photo_dir, selection);
  if (files.empty()) {
    std::string extensions;
    for (const auto& e : selection.extensions) extensions += (extensions.empty() ? "" : " ") + e;
    RELIGHT_USER_ERROR() << "photo folder '" << photo_dir << "' contains no photos (files ending in " << extensions
                         << (options.recursive ? "" : "; sub-folders are read only with ingest.recursive: true")
                         << "); put the downloaded photos there";
  }
  RLOG_INFO("scanning {} photo files in {}", files.size(), photo_dir);

  const std::string image_dir = JoinPath(output_dir, "images");
  EnsureDir(image_dir);
  std::vector<Candidate> candidates(files.size());
  Progress progress("read photos", static_cast<int64_t>(files.size()));
  tbb::parallel_for(size_t(0), files.size(), [&](size_t i) {
    Candidate& c = candidates[i];
    const fs::path path = files[i];
    c.source = fs::absolute(path).string();
    // Names and paths as text (core/path_text.h): file names need not be UTF-8, the manifest must be.
    c.photo.name = PathText(options.recursive ? path.lexically_relative(photo_dir).generic_string()
                                              : path.filename().string());
    c.photo.source_path = PathText(c.source);
    try {
      // Decide on the size from the header, before decoding allocates the pixels.
      const ImageMetadata header = ReadImageMetadata(c.source);
      const std::string size_problem = SizeProblem(options, header.width, header.height);
      if (!size_problem.empty()) {
        c.kind = SkipKind::kSize;
        c.reason = size_problem;
        progress.Advance();
        return;
      }
      ImageMetadata meta;
      Image image = ReadImage(c.source, &meta, /*apply_orientation=*/true);
      c.photo.exif = meta;
      c.photo.linear = meta.is_float;
      c.photo.bits_per_sample = meta.bits_per_sample;
      c.photo.source_width = image.width;
      c.photo.source_height = image.height;
      const int longest = std::max(image.width, image.height);
      if (options.max_image_size > 0 && longest > options.max_image_size) {
        c.photo.scale = double(options.max_image_size) / longest;
        const int w = std::max(1, static_cast<int>(std::lround(image.width * c.photo.scale)));
        const int h = std::max(1, static_cast<int>(std::lround(image.height * c.photo.scale)));
        image = ResizeImage(image, w, h);
      }
      if (image.channels == 1 || image.channels == 2) {  // gray (+alpha): replicate to RGB
        Image rgb(image.width, image.height, 3);
        for (size_t p = 0; p < size_t(image.width) * image.height; ++p)
          for (int k = 0; k < 3; ++k) rgb.pixels[p * 3 + k] = image.pixels[p * image.channels];
        image = std::move(rgb);
      }
      if (image.channels == 4) {  // drop alpha
        Image rgb(image.width, image.height, 3);
        for (size_t p = 0; p < size_t(image.width) * image.height; ++p)
          for (int k = 0; k < 3; ++k) rgb.pixels[p * 3 + k] = image.pixels[p * 4 + k];
        image = std::move(rgb);
      }
      c.photo.width = image.width;
      c.photo.height = image.height;
      c.photo.focal_px = FocalPixelsFromExif(meta, c.photo.source_width, c.photo.source_height,
                                             std::max(image.width, image.height));
      c.photo.sha256 = FileSha256(c.source);
      c.thumbnail = Thumbnail(image);
      c.mean_chroma = MeanChroma(image);
      c.image = std::move(image);
      c.ok = true;
    } catch (const UserError& e) {
      c.reason = e.what();
    } catch (const std::bad_alloc&) {
      c.reason = "out of memory while decoding it; lower ingest.max_megapixels or decode fewer photos at once "
                 "(--threads)";
    }
    progress.Advance();
  });
  progress.Finish();

  // Drop black-and-white photos and duplicates, in name order (keep the first).
  std::vector<size_t> kept;
  for (size_t i = 0; i < candidates.size(); ++i) {
    Candidate& c = candidates[i];
    if (!c.ok) continue;
    if (options.drop_grayscale && !keep_all && c.mean_chroma < options.grayscale_chroma) {
      c.ok = false;
      c.kind = SkipKind::kGrayscale;
      c.reason = "black-and-white photo (mean chroma " + std::to_string(c.mean_chroma) +
                 " < ingest.grayscale_chroma); it carries no colour of the light";
      continue;
    }
    if (options.drop_duplicates && !keep_all) {
      for (size_t j : kept) {
        const Candidate& o = candidates[j];
        if (o.photo.sha256 == c.photo.sha256) {
          c.ok = false;
          c.kind = SkipKind::kDuplicate;
          c.reason = "exact duplicate of " + o.photo.name;
          break;
        }
        const double aspect_a = double(c.photo.width) / c.photo.height;
        const double aspect_b = double(o.photo.width) / o.photo.height;
        if (std::abs(aspect_a - aspect_b) > 0.02 * aspect_a) continue;
        double corr = 0;
        for (size_t k = 0; k < c.thumbnail.size(); ++k) corr += double(c.thumbnail[k]) * o.thumbnail[k];
        if (corr > options.duplicate_correlation) {
          c.ok = false;
          c.kind = SkipKind::kDuplicate;
          c.reason = "near-duplicate of " + o.photo.name + " (thumbnail correlation " + std::to_string(corr) + ")";
          break;
        }
      }
      if (!c.ok) continue;
    }
    kept.push_back(i);
  }

  // Write the kept photos (each atomically) under unique output names.
  std::map<std::string, int> used_names;
  for (size_t i : kept) {
    Candidate& c = candidates[i];
    // The output name is the text of the source name, without path separators or the backslashes of \xHH.
    std::string stem = fs::path(c.photo.name).stem().string();
    std::replace(stem.begin(), stem.end(), '/', '_');
    std::replace(stem.begin(), stem.end(), '\\', '_');
    const int n = used_names[stem]++;
    if (n > 0) stem += "_" + std::to_string(n);
    const bool is_float = c.photo.linear;
    // JPEGs stay JPEG; other 8/16-bit formats become lossless PNG; float stays EXR.
    const bool is_jpeg = c.photo.exif.format == "jpeg" && c.photo.bits_per_sample <= 8;
    const std::string ext = is_float ? ".exr" : is_jpeg ? ".jpg" : ".png";
    c.photo.file = "images/" + stem + ext;
  }
  Progress write_progress("write photos", static_cast<int64_t>(kept.size()));
  tbb::parallel_for(size_t(0), kept.size(), [&](size_t k) {
    Candidate& c = candidates[kept[k]];
    const std::string out = JoinPath(output_dir, c.photo.file);
    std::string source_ext = fs::path(c.source).extension().string();
    std::transform(source_ext.begin(), source_ext.end(), source_ext.begin(), ::tolower);
    if (source_ext == ".jpeg") source_ext = ".jpg";
    const bool untouched = c.photo.scale == 1.0 && c.photo.exif.orientation == 1 &&
                           source_ext == fs::path(out).extension().string() &&
                           c.image.channels == c.photo.exif.channels;
    if (untouched) {
      WriteFileAtomic(out, ReadFileToString(c.source));  // bit-exact copy keeps the JPEG as shot
    } else {
      WriteOptions w;
      w.type = c.photo.linear                   ? PixelType::kFloat
               : c.photo.bits_per_sample > 8 ? PixelType::kUint16
                                             : PixelType::kUint8;
      w.jpeg_quality = options.jpeg_quality;
      w.exif = &c.photo.exif;
      WriteImage(out, c.image, w);
    }
    c.image = Image();  // free memory early
    write_progress.Advance();
  });
  write_progress.Finish();

  for (const auto& c : candidates) {
    if (c.ok) {
      summary.photos.push_back(c.photo);
    } else {
      summary.skipped.push_back({c.photo.name, c.reason});
      RLOG_WARN("skipped '{}': {}", c.photo.source_path, c.reason);
    }
  }
  if (static_cast<int>(summary.photos.size()) < options.min_photos) {
    throw UserError(TooFewPhotosMessage(options, photo_dir, candidates, summary.photos.size()));
  }

  if (!ground_truth_dir.empty()) {
    if (!fs::is_directory(ground_truth_dir)) {
      RELIGHT_USER_ERROR() << "ground-truth folder '" << ground_truth_dir << "' does not exist; fix ingest.ground_truth";
    }
    CopyTree(ground_truth_dir, JoinPath(output_dir, "ground_truth"));
  }

  summary.seconds = timer.Seconds();
  OrderedJson manifest;
  manifest["format"] = "relight-ingest-manifest";
  manifest["version"] = 1;
  manifest["source_folder"] = PathText(fs::absolute(photo_dir).string());
  manifest["ground_truth"] = ground_truth_dir.empty() ? Json(nullptr) : Json("ground_truth");
  OrderedJson photos = OrderedJson::array();
  for (const auto& p : summary.photos) {
    OrderedJson j;
    j["name"] = p.name;
    j["file"] = p.file;
    j["source_path"] = p.source_path;
    j["sha256"] = p.sha256;
    j["width"] = p.width;
    j["height"] = p.height;
    j["source_width"] = p.source_width;
    j["source_height"] = p.source_height;
    j["scale"] = p.scale;
    j["linear"] = p.linear;
    j["bits_per_sample"] = p.bits_per_sample;
    j["focal_px"] = OptionalToJson(p.focal_px);
    j["exif"] = {{"format", p.exif.format},
                 {"orientation", p.exif.orientation},
                 {"focal_length_mm", OptionalToJson(p.exif.focal_length_mm)},
                 {"focal_length_35mm", OptionalToJson(p.exif.focal_length_35mm)},
                 {"exposure_time_s", OptionalToJson(p.exif.exposure_time_s)},
                 {"f_number", OptionalToJson(p.exif.f_number)},
                 {"iso", OptionalToJson(p.exif.iso)},
                 {"camera_make", p.exif.camera_make},
                 {"camera_model", p.exif.camera_model}};
    photos.push_back(j);
  }
  manifest["photos"] = photos;
  OrderedJson skipped = OrderedJson::array();
  for (const auto& s : summary.skipped) skipped.push_back({{"name", s.name}, {"reason", s.reason}});
  manifest["skipped"] = skipped;
  WriteJsonAtomic(JoinPath(output_dir, "manifest.json"), manifest);

  OrderedJson stage_summary;
  stage_summary["photos"] = summary.photos.size();
  stage_summary["skipped"] = summary.skipped.size();
  stage_summary["seconds"] = summary.seconds;
  WriteJsonAtomic(JoinPath(output_dir, "summary.json"), stage_summary);
  return summary;
}

}  // namespace

IngestSummary RunIngest(const IngestOptions& options, const IngestInputs& inputs, const std::string& output_dir) {
  std::string photos = options.images;
  std::string ground_truth = options.ground_truth;
  if (!inputs.synthesize_dir.empty()) {
    if (!photos.empty()) {
      RELIGHT_USER_ERROR() << "ingest.images is set and the synthesize stage runs too; remove one of them";
    }
    photos = JoinPath(inputs.synthesize_dir, "images");
    if (ground_truth.empty()) ground_truth = JoinPath(inputs.synthesize_dir, "ground_truth");
  }
  const bool diligent = options.format == "diligent";
  if (diligent) {
    // A DiLiGenT object folder becomes a scene (photos + ground truth) first.
    if (photos.empty()) RELIGHT_USER_ERROR() << "ingest.format = diligent needs ingest.images (the object folder)";
    const std::string scene = JoinPath(output_dir, "import");
    ImportDiligent(photos, scene, {options.diligent_sphere_subdivisions, 100.0});
    photos = JoinPath(scene, "images");
    if (ground_truth.empty()) ground_truth = JoinPath(scene, "ground_truth");
  }
  if (photos.empty()) {
    RELIGHT_USER_ERROR() << "no photos: set ingest.images to the folder of downloaded photos "
                         << "(or add a synthesize: section to render a synthetic collection)";
  }
  // Calibrated photometric data (DiLiGenT): one view under different known lights. The photos are nearly
  // achromatic on a dark background and may look alike; every one of them is used.
  return IngestFolder(options, photos, ground_truth, diligent, output_dir);
}

std::string IngestSummary::BriefReport() const {
  return fmt::format("ingest: {} photos, {} skipped{}; {}", photos.size(), skipped.size(),
                     skipped.empty() ? "" : " (reasons in manifest.json)", Progress::FormatSeconds(seconds));
}

IngestSummary ReadIngestManifest(const std::string& ingest_dir) {
  const Json j = ReadJsonFile(JoinPath(ingest_dir, "manifest.json"));
  IngestSummary s;
  for (const auto& p : j.at("photos")) {
    IngestedPhoto photo;
    photo.name = p.at("name");
    photo.file = p.at("file");
    photo.source_path = p.value("source_path", "");
    photo.sha256 = p.value("sha256", "");
    photo.width = p.at("width");
    photo.height = p.at("height");
    photo.source_width = p.value("source_width", photo.width);
    photo.source_height = p.value("source_height", photo.height);
    photo.scale = p.value("scale", 1.0);
    photo.linear = p.value("linear", false);
    photo.bits_per_sample = p.value("bits_per_sample", 8);
    photo.focal_px = JsonToOptional(p, "focal_px");
    if (p.contains("exif")) {
      const Json& e = p.at("exif");
      photo.exif.format = e.value("format", "");
      photo.exif.orientation = e.value("orientation", 1);
      photo.exif.focal_length_mm = JsonToOptional(e, "focal_length_mm");
      photo.exif.focal_length_35mm = JsonToOptional(e, "focal_length_35mm");
      photo.exif.exposure_time_s = JsonToOptional(e, "exposure_time_s");
      photo.exif.f_number = JsonToOptional(e, "f_number");
      photo.exif.iso = JsonToOptional(e, "iso");
      photo.exif.camera_make = e.value("camera_make", "");
      photo.exif.camera_model = e.value("camera_model", "");
    }
    s.photos.push_back(photo);
  }
  for (const auto& k : j.value("skipped", Json::array())) s.skipped.push_back({k.at("name"), k.at("reason")});
  return s;
}

}  // namespace relight
