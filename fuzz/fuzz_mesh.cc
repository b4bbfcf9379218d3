// PLY (ASCII and binary), OBJ and OFF meshes, one target per format
// (RELIGHT_FUZZ_MESH_EXT). ReadMesh also validates the result (TriangleMesh::Check).
// Only UserError may come out.
#include "core/error.h"
#include "fuzz_common.h"
#include "geometry/mesh_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace relight;
  const std::string path =
      fuzz::WriteScratch(std::string("mesh") + RELIGHT_FUZZ_MESH_EXT, std::string_view(reinterpret_cast<const char*>(data), size));
  try {
    ReadMesh(path);
  } catch (const UserError&) {
  }
  return 0;
}
