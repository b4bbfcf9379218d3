#include "radiometry/linearize.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>

#include "core/error.h"
#include "core/fs.h"
#include "core/json.h"
#include "core/log.h"
#include "core/progress.h"
#include "core/timer.h"
#include "image/color.h"
#include "ingest/ingest.h"

namespace relight {
namespace fs = std::filesystem;



std::optional<double> ExifExposure(std::optional<double> t, std::optional<double> n, std::optional<double> iso) {
  if (!t || !n || *t <= 0 || *n <= 0) return std::nullopt;
  return *t * iso.value_or(100.0) / (*n * *n);
}

LinearImage Linearize(const Image& encoded, bool is_float, const LinearizeOptions& o) {
  RELIGHT_CHECK(encoded.channels == 3) << "linearize expects RGB images (ingest converts gray to RGB)";
  LinearImage out;
  out.radiance = Image(encoded.width, encoded.height, 3);
  Image bad(encoded.width, encoded.height, 1, 0.0f);
  long clipped = 0, black = 0;
  std::vector<std::pair<int, int>> black_pixels;  // kept with black_confidence
  for (int y = 0; y < encoded.height; ++y) {
    for (int x = 0; x < encoded.width; ++x) {
      bool is_clipped = false, is_black = false;
      for (int c = 0; c < 3; ++c) {
        const float v = encoded.at(x, y, c);
        double l;
        if (is_float) {
          l = std::isfinite(v) ? std::max(0.0f, v) : 0.0;
          if (!std::isfinite(v) || v < 0) is_clipped = true;
        } else {
          if (v >= o.saturation_level) is_clipped = true;
          if (v <= o.black_level) is_black = true;
          l = o.transfer == "srgb" ? SrgbDecode(v) : o.transfer == "gamma" ? std::pow(std::max(0.0f, v), o.gamma) : v;
        }
        out.radiance.at(x, y, c) = static_cast<float>(l);
      }
      clipped += is_clipped;
      black += is_black;
      if (is_clipped || (is_black && o.black_confidence <= 0)) bad.at(x, y) = 1.0f;
      if (!is_clipped && is_black && o.black_confidence > 0) black_pixels.push_back({x, y});
    }
  }
  const double n = double(encoded.width) * encoded.height;
  out.clipped_fraction = clipped / n;
  if (!is_float) {
    const double v = o.saturation_level;
    out.overexposed_linear = o.transfer == "srgb" ? SrgbDecode(v) : o.transfer == "gamma" ? std::pow(v, o.gamma) : v;
  }
  out.black_fraction = black / n;
  // Confidence: 0 on and near clipped pixels (a square dilation of radius clip_dilation_px).
  out.confidence = Image(encoded.width, encoded.height, 1, 1.0f);
  const int r = o.clip_dilation_px;
  for (int y = 0; y < encoded.height; ++y) {
    for (int x = 0; x < encoded.width; ++x) {
      if (bad.at(x, y) == 0.0f) continue;
      for (int dy = -r; dy <= r; ++dy) {
        const int yy = y + dy;
        if (yy < 0 || yy >= encoded.height) continue;
        for (int dx = -r; dx <= r; ++dx) {
          const int xx = x + dx;
          if (xx >= 0 && xx < encoded.width) out.confidence.at(xx, yy) = 0.0f;
        }
      }
    }
  }
  // Kept black pixels (black_confidence > 0) away from clipped ones get their own confidence.
  for (const auto& [x, y] : black_pixels) {
    float& c = out.confidence.at(x, y);
    c = std::min(c, static_cast<float>(o.black_confidence));
  }
  return out;
}

std::string LinearizeSummary::BriefReport() const {
  return fmt::format("linearize: {} photos ({} from an earlier run); exposure {}; {}", photos, reused,
                     exposure_normalized ? "normalised" : "as recorded", Progress::FormatSeconds(seconds));
}

LinearizeSummary RunLinearize(const LinearizeOptions& options, const LinearizeInputs& inputs,
                              const std::string& output_dir, const ShardSpec& shard) {
  const std::string& ingest_dir = inputs.ingest_dir;
  Timer timer;
  const IngestSummary manifest = ReadIngestManifest(ingest_dir);
  if (manifest.photos.empty()) RELIGHT_USER_ERROR() << "'" << ingest_dir << "/manifest.json' lists no photos";
  for (const char* sub : {"linear", "confidence", "stats"}) EnsureDir(JoinPath(output_dir, sub));

  LinearizeSummary summary;
  summary.photos = static_cast<int>(manifest.photos.size());
  // Exposure normalisation needs EXIF on every 8/16-bit photo.
  std::vector<double> scale(manifest.photos.size(), 1.0);
  std::vector<std::optional<double>> exposure(manifest.photos.size());
  int with_exif = 0;
  for (size_t i = 0; i < manifest.photos.size(); ++i) {
    const auto& e = manifest.photos[i].exif;
    exposure[i] = ExifExposure(e.exposure_time_s, e.f_number, e.iso);
    with_exif += exposure[i].has_value();
  }
  if (!options.normalize_exposure) {
    summary.exposure_note = "disabled (linearize.normalize_exposure = false)";
  } else if (with_exif < summary.photos) {
    summary.exposure_note = std::to_string(summary.photos - with_exif) + " of " + std::to_string(summary.photos) +
                            " photos lack EXIF exposure time or f-number; each photo keeps its own scale";
  } else {
    std::vector<double> sorted;
    for (const auto& e : exposure) sorted.push_back(*e);
    std::sort(sorted.begin(), sorted.end());
    const double reference = sorted[sorted.size() / 2];
    for (size_t i = 0; i < scale.size(); ++i) scale[i] = reference / *exposure[i];
    summary.exposure_normalized = true;
    summary.exposure_note = "scaled to the median EXIF exposure (t·ISO/N² = " + std::to_string(reference) + ")";
  }
  RLOG_INFO("exposure: {}", summary.exposure_note);

  std::atomic<int> reused{0};
  int64_t owned = 0;
  for (size_t i = 0; i < manifest.photos.size(); ++i) owned += shard.Owns(i);
  Progress progress("linearize photos", owned);
  tbb::parallel_for(size_t(0), manifest.photos.size(), [&](size_t i) {
    if (!shard.Owns(i)) return;
    const IngestedPhoto& photo = manifest.photos[i];
    const std::string stem = fs::path(photo.file).stem().string();
    const std::string linear_path = JoinPath(output_dir, "linear/" + stem + ".exr");
    const std::string confidence_path = JoinPath(output_dir, "confidence/" + stem + ".exr");
    const std::string stats_path = JoinPath(output_dir, "stats/" + stem + ".json");
    // Every file is written atomically and the stats last: their presence means the photo is done.
    if (fs::exists(stats_path) && fs::exists(linear_path) && fs::exists(confidence_path)) {
      ++reused;
      progress.Advance();
      return;
    }
    ImageMetadata meta;
    const Image encoded = ReadImage(JoinPath(ingest_dir, photo.file), &meta);
    LinearImage lin = Linearize(encoded, photo.linear || meta.is_float, options);
    if (scale[i] != 1.0) {
      for (float& v : lin.radiance.pixels) v = static_cast<float>(v * scale[i]);
    }
    WriteImage(linear_path, lin.radiance, {PixelType::kFloat});
    WriteImage(confidence_path, lin.confidence, {PixelType::kHalf});
    OrderedJson stats;
    stats["name"] = photo.name;
    stats["file"] = photo.file;
    stats["linear"] = "linear/" + stem + ".exr";
    stats["confidence"] = "confidence/" + stem + ".exr";
    stats["transfer"] = (photo.linear || meta.is_float) ? "none (float input)" : options.transfer;
    stats["exposure_scale"] = scale[i];
    stats["clipped_fraction"] = lin.clipped_fraction;
    stats["black_fraction"] = lin.black_fraction;
    if (std::isfinite(lin.overexposed_linear)) {
      stats["overexposed_linear"] = lin.overexposed_linear * scale[i];
    } else {
      stats["overexposed_linear"] = nullptr;
    }
    WriteJsonAtomic(stats_path, stats);
    if (lin.clipped_fraction > 0.2) {
      RLOG_WARN("photo '{}' is {:.0f}% over-exposed; its clipped pixels are ignored", photo.name,
                100 * lin.clipped_fraction);
    }
    progress.Advance();
  });
  progress.Finish();
  summary.reused = reused.load();
  if (shard.active()) return summary;  // the unsharded run that follows writes the summary

  Json j;
  j["photos"] = Json::array();
  for (const auto& photo : manifest.photos) {
    const std::string stem = fs::path(photo.file).stem().string();
    j["photos"].push_back(ReadJsonFile(JoinPath(output_dir, "stats/" + stem + ".json")));
  }
  j["exposure_normalized"] = summary.exposure_normalized;
  j["exposure_note"] = summary.exposure_note;
  j["reused_from_earlier_run"] = summary.reused;
  summary.seconds = timer.Seconds();
  j["seconds"] = summary.seconds;
  WriteJsonAtomic(JoinPath(output_dir, "linearize_summary.json"), j);
  return summary;
}

}  // namespace relight
