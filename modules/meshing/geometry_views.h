// Pictures of the reconstructed geometry from the photos' own cameras: the
// cleaned mesh as grey clay and the fused MVS points as shaded dots, written
// by the mesh stage and shown by the report beside the photos, so that a bad
// surface (a missing dome, a relief instead of a statue) is obvious before the
// inverse rendering runs.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "geometry/mesh.h"
#include "geometry/reconstruction.h"
#include "image/image.h"

namespace relight {

// Clay render of `mesh` seen by `image`'s camera (with its distortion), scaled so the longer side is at most
// `max_size` pixels, 2x2 supersampled: Lambertian light from the camera and from above; white background.
Image RenderMeshView(const TriangleMesh& mesh, const Camera& camera, const ImageRecord& image, int max_size);

// The vertices of `points` (with normals when it has them) as z-buffered dots of about 1.5 output pixels,
// shaded like the clay when normals exist, else dark grey; white background.
Image RenderPointsView(const TriangleMesh& points, const Camera& camera, const ImageRecord& image, int max_size);

// Up to `count` registered images spread evenly over `model`'s images in name order.
std::vector<const ImageRecord*> SpreadViews(const Reconstruction& model, int count);

}  // namespace relight
