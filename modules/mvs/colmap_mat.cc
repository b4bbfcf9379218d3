#include "mvs/colmap_mat.h"

#include <cstring>

#include "core/error.h"
#include "core/fs.h"

namespace relight {

static_assert(sizeof(float) == 4, "COLMAP maps are float32");

std::string EncodeColmapMat(const ColmapMat& mat) {
  RELIGHT_CHECK_EQ(mat.data.size(), size_t(mat.width) * mat.height * mat.channels);
  std::string out = std::to_string(mat.width) + "&" + std::to_string(mat.height) + "&" +
                    std::to_string(mat.channels) + "&";
  const size_t header = out.size();
  out.resize(header + mat.data.size() * sizeof(float));
  // x86-64 and aarch64 are little-endian, as the format requires.
  std::memcpy(out.data() + header, mat.data.data(), mat.data.size() * sizeof(float));
  return out;
}

ColmapMat DecodeColmapMat(const std::string& bytes, const std::string& where) {
  size_t pos = 0;
  long dims[3];
  for (long& d : dims) {
    const size_t amp = bytes.find('&', pos);
    if (amp == std::string::npos || amp == pos || amp - pos > 10) {
      RELIGHT_USER_ERROR() << "'" << where << "' is not a COLMAP depth/normal map (header 'W&H&C&' expected); "
                           << "delete it and rerun the mvs stage";
    }
    try {
      d = std::stol(bytes.substr(pos, amp - pos));
    } catch (const std::exception&) {
      d = -1;
    }
    if (d <= 0) RELIGHT_USER_ERROR() << "'" << where << "' has a bad size in its header; delete it and rerun";
    pos = amp + 1;
  }
  // Sizes are checked against the data before anything is allocated (a damaged header may claim terabytes).
  const size_t values = (bytes.size() - pos) / sizeof(float);
  const bool fits = size_t(dims[0]) <= values && size_t(dims[1]) <= values / size_t(dims[0]) &&
                    size_t(dims[2]) <= values / (size_t(dims[0]) * size_t(dims[1]));
  const size_t expected = fits ? size_t(dims[0]) * size_t(dims[1]) * size_t(dims[2]) * sizeof(float) : 0;
  if (!fits || bytes.size() - pos != expected) {
    RELIGHT_USER_ERROR() << "'" << where << "' holds " << bytes.size() - pos << " data bytes, not the "
                         << "4 bytes per value of " << dims[0] << "x" << dims[1] << "x" << dims[2]
                         << " (truncated?); delete it and rerun the mvs stage";
  }
  ColmapMat mat(static_cast<int>(dims[0]), static_cast<int>(dims[1]), static_cast<int>(dims[2]));
  std::memcpy(mat.data.data(), bytes.data() + pos, expected);
  return mat;
}

void WriteColmapMat(const std::string& path, const ColmapMat& mat) { WriteFileAtomic(path, EncodeColmapMat(mat)); }

ColmapMat ReadColmapMat(const std::string& path) { return DecodeColmapMat(ReadFileToString(path), path); }

}  // namespace relight
