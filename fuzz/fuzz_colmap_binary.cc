// COLMAP binary models: cameras.bin, images.bin, points3D.bin from one input:
// two little-endian uint32 sizes (cameras.bin, images.bin), then the three
// files back to back. Only UserError may come out.
#include <cstring>

#include "core/error.h"
#include "fuzz_common.h"
#include "geometry/reconstruction.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace relight;
  if (size < 8) return 0;
  uint32_t sizes[2];
  std::memcpy(sizes, data, 8);
  std::string_view rest(reinterpret_cast<const char*>(data) + 8, size - 8);
  std::string_view files[3];
  for (int i = 0; i < 2; ++i) {
    files[i] = rest.substr(0, std::min<size_t>(sizes[i], rest.size()));
    rest.remove_prefix(files[i].size());
  }
  files[2] = rest;
  const char* names[] = {"cameras.bin", "images.bin", "points3D.bin"};
  for (int i = 0; i < 3; ++i) fuzz::WriteScratch(names[i], files[i]);
  try {
    Reconstruction::ReadBinary(fuzz::ScratchDir());
  } catch (const UserError&) {
  }
  return 0;
}
