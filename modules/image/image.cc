#include "image/image.h"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "core/error.h"
#include "core/fs.h"

namespace relight {
namespace fs = std::filesystem;
using namespace OIIO;

namespace {

std::optional<double> FindDouble(const ImageSpec& spec, const char* name) {
  const ParamValue* p = spec.find_attribute(name);
  if (p == nullptr) return std::nullopt;
  const double v = p->get_float();
  if (!std::isfinite(v) || v <= 0) return std::nullopt;
  return v;
}

ImageMetadata MetadataFromSpec(const ImageSpec& spec, const std::string& format) {
  ImageMetadata m;
  m.format = format;
  m.width = spec.width;
  m.height = spec.height;
  m.channels = spec.nchannels;
  m.is_float = spec.format.is_floating_point();
  m.bits_per_sample = static_cast<int>(spec.format.size() * 8);
  if (const ParamValue* bps = spec.find_attribute("oiio:BitsPerSample")) m.bits_per_sample = bps->get_int();
  m.orientation = std::clamp(spec.get_int_attribute("Orientation", 1), 1, 8);
  m.focal_length_mm = FindDouble(spec, "Exif:FocalLength");
  m.focal_length_35mm = FindDouble(spec, "Exif:FocalLengthIn35mmFilm");
  m.exposure_time_s = FindDouble(spec, "ExposureTime");
  m.f_number = FindDouble(spec, "FNumber");
  m.iso = FindDouble(spec, "Exif:PhotographicSensitivity");
  if (!m.iso) m.iso = FindDouble(spec, "Exif:ISOSpeedRatings");
  m.camera_make = spec.get_string_attribute("Make");
  m.camera_model = spec.get_string_attribute("Model");
  return m;
}

[[noreturn]] void NotAnImage(const std::string& path, const std::string& why) {
  RELIGHT_USER_ERROR() << "'" << path << "' is not a readable image (" << why
                       << "); replace it with a valid JPEG/PNG/TIFF/EXR/HDR file";
}

void CheckReadable(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) {
    RELIGHT_USER_ERROR() << "image '" << path << "' does not exist; check the path in the config";
  }
  if (fs::is_regular_file(path, ec) && fs::file_size(path, ec) == 0) NotAnImage(path, "the file is empty");
}

std::string CleanError(std::string e) {
  while (!e.empty() && (e.back() == '\n' || e.back() == ' ')) e.pop_back();
  std::replace(e.begin(), e.end(), '\n', ' ');
  return e.empty() ? "unknown error" : e;
}

}  // namespace

ImageMetadata ReadImageMetadata(const std::string& path) {
  CheckReadable(path);
  auto in = ImageInput::open(path);
  if (!in) NotAnImage(path, CleanError(OIIO::geterror()));
  ImageMetadata m = MetadataFromSpec(in->spec(), in->format_name());
  in->close();
  return m;
}

Image ReadImage(const std::string& path, ImageMetadata* metadata, bool apply_orientation) {
  CheckReadable(path);
  auto in = ImageInput::open(path);
  if (!in) NotAnImage(path, CleanError(OIIO::geterror()));
  const ImageSpec spec = in->spec();
  const ImageMetadata meta = MetadataFromSpec(spec, in->format_name());
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0) NotAnImage(path, "it has no pixels");
  Image image(spec.width, spec.height, spec.nchannels);
  const bool ok = in->read_image(0, 0, 0, spec.nchannels, TypeDesc::FLOAT, image.pixels.data());
  std::string error = in->geterror();
  in->close();
  if (!ok || !error.empty()) {
    // libjpeg reports truncated files as "Premature end of JPEG file"; the pixels
    // below the cut are grey fill, so such a photo must not be used.
    NotAnImage(path, ok ? "truncated or corrupt: " + CleanError(error) : CleanError(error));
  }
  if (apply_orientation && meta.orientation != 1) {
    ImageSpec float_spec(spec.width, spec.height, spec.nchannels, TypeDesc::FLOAT);
    float_spec.attribute("Orientation", meta.orientation);
    ImageBuf buf(float_spec, image.pixels.data());
    ImageBuf upright = ImageBufAlgo::reorient(buf);
    const ImageSpec& s = upright.spec();
    Image out(s.width, s.height, s.nchannels);
    upright.get_pixels(ROI::All(), TypeDesc::FLOAT, out.pixels.data());
    image = std::move(out);
  }
  if (metadata != nullptr) *metadata = meta;
  return image;
}

void WriteImage(const std::string& path, const Image& image, const WriteOptions& options) {
  RELIGHT_CHECK(!image.empty() && image.pixels.size() == size_t(image.width) * image.height * image.channels);
  TypeDesc type = TypeDesc::UINT8;
  switch (options.type) {
    case PixelType::kUint8: type = TypeDesc::UINT8; break;
    case PixelType::kUint16: type = TypeDesc::UINT16; break;
    case PixelType::kHalf: type = TypeDesc::HALF; break;
    case PixelType::kFloat: type = TypeDesc::FLOAT; break;
  }
  AtomicFile file(path);
  auto out = ImageOutput::create(path);
  if (!out) RELIGHT_USER_ERROR() << "cannot write '" << path << "': unsupported file extension";
  ImageSpec spec(image.width, image.height, image.channels, type);
  spec.attribute("CompressionQuality", options.jpeg_quality);
  spec.attribute("png:compressionLevel", std::clamp(options.png_compression_level, 0, 9));
  if (options.type == PixelType::kHalf || options.type == PixelType::kFloat)
    spec.attribute("compression", options.exr_compression);
  if (options.exif != nullptr) {
    const ImageMetadata& m = *options.exif;
    if (m.focal_length_mm) spec.attribute("Exif:FocalLength", static_cast<float>(*m.focal_length_mm));
    if (m.focal_length_35mm) spec.attribute("Exif:FocalLengthIn35mmFilm", static_cast<int>(*m.focal_length_35mm));
    if (m.exposure_time_s) spec.attribute("ExposureTime", static_cast<float>(*m.exposure_time_s));
    if (m.f_number) spec.attribute("FNumber", static_cast<float>(*m.f_number));
    if (m.iso) spec.attribute("Exif:PhotographicSensitivity", static_cast<int>(*m.iso));
    if (!m.camera_make.empty()) spec.attribute("Make", m.camera_make);
    if (!m.camera_model.empty()) spec.attribute("Model", m.camera_model);
  }
  std::vector<float> clamped;
  const float* data = image.pixels.data();
  if (options.type == PixelType::kUint8 || options.type == PixelType::kUint16) {
    clamped.resize(image.pixels.size());
    for (size_t i = 0; i < clamped.size(); ++i) {
      const float v = image.pixels[i];
      clamped[i] = std::isfinite(v) ? std::clamp(v, 0.0f, 1.0f) : 0.0f;
    }
    data = clamped.data();
  }
  if (!out->open(file.temp_path(), spec) || !out->write_image(TypeDesc::FLOAT, data) || !out->close()) {
    RELIGHT_USER_ERROR() << "cannot write '" << path << "': " << CleanError(out->geterror())
                         << " (disk full or folder not writable?)";
  }
  file.Commit();
}

Image ResizeImage(const Image& image, int width, int height) {
  RELIGHT_CHECK(width > 0 && height > 0);
  ImageSpec spec(image.width, image.height, image.channels, TypeDesc::FLOAT);
  ImageBuf src(spec, const_cast<float*>(image.pixels.data()));
  ImageBuf dst = ImageBufAlgo::resize(src, "", 0.0f, ROI(0, width, 0, height, 0, 1, 0, image.channels));
  RELIGHT_CHECK(!dst.has_error()) << dst.geterror();
  Image out(width, height, image.channels);
  dst.get_pixels(ROI::All(), TypeDesc::FLOAT, out.pixels.data());
  return out;
}

void SampleBilinear(const Image& image, double x, double y, float* out) {
  const double fx = std::clamp(x - 0.5, 0.0, double(image.width - 1));
  const double fy = std::clamp(y - 0.5, 0.0, double(image.height - 1));
  const int x0 = static_cast<int>(fx), y0 = static_cast<int>(fy);
  const int x1 = std::min(x0 + 1, image.width - 1), y1 = std::min(y0 + 1, image.height - 1);
  const float tx = static_cast<float>(fx - x0), ty = static_cast<float>(fy - y0);
  for (int c = 0; c < image.channels; ++c) {
    const float a = image.at(x0, y0, c) * (1 - tx) + image.at(x1, y0, c) * tx;
    const float b = image.at(x0, y1, c) * (1 - tx) + image.at(x1, y1, c) * tx;
    out[c] = a * (1 - ty) + b * ty;
  }
}

}  // namespace relight
