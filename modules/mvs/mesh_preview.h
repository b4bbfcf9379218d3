// A quick look at a reconstructed mesh: ray-cast (Embree) from a view and
// shaded as grey clay lit from the camera, for summaries, reports and docs.
#pragma once

#include "geometry/mesh.h"
#include "image/image.h"
#include "mvs/stereo_view.h"

namespace relight {

// RGB image of `mesh` seen from `view` (its processing size and intrinsics), 2×2 supersampled:
// Lambertian shading by a light at the camera plus a fill light from above the image, white background.
Image RenderMeshPreview(const TriangleMesh& mesh, const StereoView& view);

}  // namespace relight
