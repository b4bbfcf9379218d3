// Float images and their file I/O (OpenImageIO).
//
// Pixel values are stored as read: 8/16-bit files map to [0, 1] *encoded*
// values (sRGB photos stay sRGB-encoded; linearization is its own stage),
// float files (EXR, HDR) keep their linear radiance. Row 0 is the top row;
// pixel (x, y) covers [x, x+1) × [y, y+1), its centre at (x+0.5, y+0.5).
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace relight {

// Interleaved float image.
struct Image {
  int width = 0;
  int height = 0;
  int channels = 0;
  std::vector<float> pixels;  // size width*height*channels

  Image() = default;
  Image(int w, int h, int c, float fill = 0.0f) : width(w), height(h), channels(c), pixels(size_t(w) * h * c, fill) {}
  bool empty() const { return pixels.empty(); }
  float& at(int x, int y, int c = 0) { return pixels[(size_t(y) * width + x) * channels + c]; }
  float at(int x, int y, int c = 0) const { return pixels[(size_t(y) * width + x) * channels + c]; }
  float* row(int y) { return pixels.data() + size_t(y) * width * channels; }
  const float* row(int y) const { return pixels.data() + size_t(y) * width * channels; }
};

// What a photo file says about itself (EXIF and format).
struct ImageMetadata {
  std::string format;         // OIIO format name: "jpeg", "png", "tiff", "openexr", "hdr"
  int width = 0;              // as stored, before orientation
  int height = 0;
  int channels = 0;
  int bits_per_sample = 8;    // 8, 16, 32
  bool is_float = false;      // EXR/HDR/float TIFF: linear radiance
  int orientation = 1;        // EXIF orientation 1..8
  std::optional<double> focal_length_mm;    // EXIF FocalLength
  std::optional<double> focal_length_35mm;  // EXIF FocalLengthIn35mmFilm
  std::optional<double> exposure_time_s;    // EXIF ExposureTime
  std::optional<double> f_number;           // EXIF FNumber
  std::optional<double> iso;                // EXIF ISOSpeedRatings
  std::string camera_make;
  std::string camera_model;
};

// Reads only the header. Throws UserError naming the file when it is not a readable image.
ImageMetadata ReadImageMetadata(const std::string& path);

// Reads a whole image as float. With `apply_orientation`, EXIF orientation is
// applied so the result is upright. Throws UserError naming the file and what
// to do when the file is missing, not an image, truncated or corrupt.
Image ReadImage(const std::string& path, ImageMetadata* metadata = nullptr, bool apply_orientation = true);

// Storage type when writing.
enum class PixelType { kUint8, kUint16, kHalf, kFloat };

struct WriteOptions {
  PixelType type = PixelType::kUint8;
  int jpeg_quality = 95;              // 1..100, JPEG only
  const ImageMetadata* exif = nullptr;  // EXIF fields to carry over (focal length, exposure, camera)
  // 0..9, PNG only (zlib's level): 2 writes about twice as fast as zlib's default 6 for files about 10 % larger,
  // what a pipeline writing hundreds of report images wants (Blender's own PNG default is a fast level too).
  int png_compression_level = 2;
  // Half and float EXR only: OpenEXR's codec ("zip", "piz", "none", ...).
  std::string exr_compression = "zip";
};

// Writes atomically (temporary name, then rename); the format follows the
// extension (.png .jpg .tif .exr .hdr). Integer types clamp to [0, 1].
void WriteImage(const std::string& path, const Image& image, const WriteOptions& options = {});

// Resizes with a good reconstruction filter (OIIO's default for the scale).
Image ResizeImage(const Image& image, int width, int height);

// Bilinear sample at continuous pixel coordinates (pixel centres at +0.5), clamped at the border.
void SampleBilinear(const Image& image, double x, double y, float* out);

}  // namespace relight
