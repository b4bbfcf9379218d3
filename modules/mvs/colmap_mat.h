// COLMAP's dense-map file format (`stereo/depth_maps/*.bin`,
// `stereo/normal_maps/*.bin`), as written by `colmap::mvs::Mat<float>::Write`
// (COLMAP src/mvs/mat.h, mat.cc) and read by `stereo_fusion`:
//
//   ASCII header "<width>&<height>&<channels>&", then width·height·channels
//   little-endian float32 values, channel-planar, each plane row-major:
//   value(row, col, channel) = data[channel·width·height + row·width + col].
//
// (COLMAP's Python reader calls this column-major order of a
// (width, height, channels) array.) Written by hand: the format has no library
// outside COLMAP, which Debian ships only as an executable.
#pragma once

#include <string>
#include <vector>

namespace relight {

// A width × height × channels float array in COLMAP's planar layout.
struct ColmapMat {
  int width = 0;
  int height = 0;
  int channels = 0;
  std::vector<float> data;  // planar: data[c·width·height + row·width + col]

  ColmapMat() = default;
  ColmapMat(int w, int h, int c, float fill = 0.0f)
      : width(w), height(h), channels(c), data(size_t(w) * h * c, fill) {}
  float& at(int row, int col, int channel = 0) { return data[(size_t(channel) * height + row) * width + col]; }
  float at(int row, int col, int channel = 0) const { return data[(size_t(channel) * height + row) * width + col]; }
};

// Serialises to COLMAP's byte layout (header + float32 data).
std::string EncodeColmapMat(const ColmapMat& mat);
// Parses COLMAP's byte layout; throws UserError naming `where` when malformed or truncated.
ColmapMat DecodeColmapMat(const std::string& bytes, const std::string& where);
// Writes atomically (temporary name, then rename).
void WriteColmapMat(const std::string& path, const ColmapMat& mat);
// Reads a .bin file; throws UserError naming the file when missing or malformed.
ColmapMat ReadColmapMat(const std::string& path);

}  // namespace relight
