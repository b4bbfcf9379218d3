// mvs_preview: renders a mesh as grey clay from one camera of a COLMAP model (mvs/mesh_preview.h), e.g. the
// mesh stage's cleaned temple for docs/RESULTS.md.
//
//   mvs_preview MESH SPARSE_MODEL_DIR IMAGE_NAME OUT_PNG [MAX_IMAGE_SIZE]
//
// MAX_IMAGE_SIZE: longest side of the picture (default 1000; 0 keeps the camera's size).
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "core/error.h"
#include "core/log.h"
#include "geometry/mesh_io.h"
#include "geometry/reconstruction.h"
#include "image/image.h"
#include "mvs/mesh_preview.h"
#include "mvs/stereo_view.h"

int main(int argc, char** argv) {
  using namespace relight;
  if (argc < 5 || argc > 6) {
    std::fprintf(stderr, "usage: %s MESH SPARSE_MODEL_DIR IMAGE_NAME OUT_PNG [MAX_IMAGE_SIZE]\n", argv[0]);
    return 2;
  }
  InitLogging("mvs_preview", "", LogLevel::kWarning);
  try {
    const TriangleMesh mesh = ReadMesh(argv[1]);
    const Reconstruction model = Reconstruction::Read(argv[2]);
    const std::string name = argv[3];
    const ImageRecord* image = nullptr;
    for (const auto& [id, record] : model.images) {
      if (record.name == name) image = &record;
    }
    if (image == nullptr) {
      RELIGHT_USER_ERROR() << "the model in '" << argv[2] << "' has no image named '" << name << "'";
    }
    const int max_size = argc == 6 ? std::atoi(argv[5]) : 1000;
    WriteImage(argv[4], RenderMeshPreview(mesh, MakeStereoView(model, *image, max_size)));
    return 0;
  } catch (const UserError& e) {
    std::fprintf(stderr, "mvs_preview: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mvs_preview: internal error: %s\n", e.what());
    return 3;
  }
}
