// Options of the `ingest` stage: scan a photo folder into a clean, upright,
// size-limited image set with a manifest.
#pragma once

#include <string>

#include "core/error.h"
#include "core/fs.h"
#include "core/options.h"
#include "core/stage.h"

namespace relight {

inline const StageInfo kIngestStage{
    "ingest", "Scan the photo folder: read EXIF, fix orientation, downscale, drop unusable photos", 2};

// The files ingest reads from ingest.images: photos by extension (any case),
// not hidden, in sub-folders only when `recursive`. The cache key digests the
// same files, so a stray notes.txt or Thumbs.db reruns nothing.
inline FileSelection PhotoFileSelection(bool recursive) {
  return {recursive, {".jpg", ".jpeg", ".png", ".tif", ".tiff", ".exr", ".hdr", ".bmp", ".ppm", ".pgm", ".webp"}};
}

struct IngestOptions {
  std::string images;                // Photo folder; empty when the synthesize stage provides the photos.
  std::string format = "photos";     // photos, or diligent (a DiLiGenT photometric-stereo object folder)
  int diligent_sphere_subdivisions = 5;  // subdivision levels of the sphere fitted to a DiLiGenT mask
  std::string ground_truth;          // Optional ground-truth folder carried along for evaluation.
  bool recursive = false;            // Also scan sub-folders.
  int max_image_size = 1600;         // Longest side in pixels after downscaling; 0 keeps the original size.
  int min_photos = 3;                // Fewer usable photos than this is an error.
  int jpeg_quality = 95;             // Quality of re-encoded 8-bit photos.
  bool drop_grayscale = true;        // Drop black-and-white photos (they carry no colour of the light).
  double grayscale_chroma = 0.01;    // Mean chroma (max-min of RGB, encoded) below which a photo is grayscale.
  bool drop_duplicates = true;       // Drop exact and near-duplicate photos (keeps the first by name).
  double duplicate_correlation = 0.995;  // Thumbnail correlation above which two photos are near-duplicates.
  double max_megapixels = 250;       // Photos whose header claims more pixels are skipped before decoding.
  int min_image_side = 64;           // Photos whose shorter side (after downscaling) is smaller are skipped.
  double max_aspect_ratio = 10;      // Photos longer than this many times their width are skipped.

  void Declare(OptionTable* t) {
    t->Add("images", &images,
           "Photo folder (JPEG/PNG/TIFF/EXR/HDR/BMP/PPM/PGM/WebP, by file extension; other files are not read). "
           "Empty when the synthesize stage runs.")
        .InputDir()
        .Reads([this] { return PhotoFileSelection(recursive); });
    t->Add("format", &format,
           "What ingest.images holds: photos (any folder of photos), or diligent (a DiLiGenT object "
           "folder: the photos, known lights and mask become a scene with ground truth).")
        .Choices({"photos", "diligent"});
    t->Add("diligent_sphere_subdivisions", &diligent_sphere_subdivisions,
           "Subdivision levels of the octahedral sphere fitted to the ball (5: 4098 vertices).")
        .Range(2, 8)
        .Advanced()
        .OnlyWhen("format", {"diligent"});
    t->Add("ground_truth", &ground_truth,
           "Optional ground-truth folder (docs/FORMATS.md) copied along for the evaluate stage.")
        .InputDir();
    t->Add("recursive", &recursive, "Also scan sub-folders of the photo folder.");
    t->Add("max_image_size", &max_image_size,
           "Longest image side in pixels after downscaling; 0 keeps the original size.")
        .Min(0);
    t->Add("min_photos", &min_photos, "Fewer usable photos than this is an error.").Min(1);
    t->Add("jpeg_quality", &jpeg_quality, "JPEG quality of re-encoded 8-bit photos.").Range(50, 100).Advanced();
    t->Add("drop_grayscale", &drop_grayscale, "Drop black-and-white photos (they carry no colour of the light).");
    t->Add("grayscale_chroma", &grayscale_chroma,
           "Mean chroma (max-min of encoded RGB) below which a photo counts as black-and-white.")
        .Range(0, 1)
        .Advanced();
    t->Add("drop_duplicates", &drop_duplicates, "Drop exact and near-duplicate photos (keeps the first by name).");
    t->Add("duplicate_correlation", &duplicate_correlation,
           "Thumbnail correlation above which two photos count as near-duplicates.")
        .Range(0, 1)
        .Advanced();
    t->Add("max_megapixels", &max_megapixels,
           "Photos whose header claims more pixels than this (in millions) are skipped before decoding, with a "
           "reason: a damaged or hostile header cannot exhaust memory. Decoding takes about 12 bytes per pixel; "
           "raise it for gigapixel panoramas on a machine with the memory.")
        .Min(1)
        .Advanced();
    t->Add("min_image_side", &min_image_side,
           "Photos whose shorter side, after downscaling to max_image_size, is below this many pixels are skipped "
           "(SIFT finds next to no features in them). Lower it only for tiny test images.")
        .Min(1)
        .Advanced();
    t->Add("max_aspect_ratio", &max_aspect_ratio,
           "Photos whose longer side exceeds this multiple of the shorter one (strips, banners, broken headers) "
           "are skipped; raise it to keep wide panoramas, which COLMAP's pinhole cameras model poorly anyway.")
        .Min(1)
        .Advanced();
  }
  void Check() const {}
};

}  // namespace relight
