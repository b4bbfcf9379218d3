// The `ingest` stage: from a folder of photos as downloaded to an upright,
// size-limited image set plus `manifest.json` (docs/FORMATS.md).
//
// Robust to what real folders contain: unreadable, truncated, empty and
// non-image files are skipped with a reason; black-and-white photos and
// duplicates are dropped (configurable); too few usable photos is an error.
#pragma once

#include <string>
#include <vector>

#include "image/image.h"
#include "ingest/ingest_options.h"

namespace relight {

// One photo as recorded in the manifest.
struct IngestedPhoto {
  std::string name;         // source file name (unique id of the photo)
  std::string source_path;  // absolute source path
  std::string sha256;       // digest of the source file
  std::string file;         // output path relative to the stage folder ("images/x.jpg")
  int width = 0;            // output size (upright, downscaled)
  int height = 0;
  int source_width = 0;     // upright size before downscaling
  int source_height = 0;
  double scale = 1.0;       // output / source size
  bool linear = false;      // float input (EXR/HDR): linear radiance, no transfer curve
  int bits_per_sample = 8;
  std::optional<double> focal_px;  // focal length prior in output pixels (EXIF), if known
  ImageMetadata exif;
};

// A file that was not used, and why.
struct SkippedFile {
  std::string name;
  std::string reason;
};

struct IngestSummary {
  std::vector<IngestedPhoto> photos;
  std::vector<SkippedFile> skipped;
  double seconds = 0;

  // One line for the log.
  std::string BriefReport() const;
};

// What the stage reads besides its options.
struct IngestInputs {
  std::string synthesize_dir;  // the synthesize stage's folder (images/, ground_truth/); empty: ingest.images
};

// Runs the stage: reads the photos of ingest.images (or of the synthesize stage; a DiLiGenT object folder,
// ingest.format diligent, is imported into output_dir/import first and keeps every photo), writes images/,
// manifest.json and summary.json into `output_dir`; ground truth (ingest.ground_truth, the synthesize stage's
// or the import's) is copied to output_dir/ground_truth.
IngestSummary RunIngest(const IngestOptions& options, const IngestInputs& inputs, const std::string& output_dir);

// Focal length in pixels of an image `max_side` pixels wide from EXIF, if the data allow.
std::optional<double> FocalPixelsFromExif(const ImageMetadata& exif, int source_width, int source_height,
                                          int max_side);

// Reads `manifest.json` of an ingest output folder.
IngestSummary ReadIngestManifest(const std::string& ingest_dir);

}  // namespace relight
