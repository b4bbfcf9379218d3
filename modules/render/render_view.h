// Rendering a view of a scene (a COLMAP camera and pose) and the exitant
// radiance of a mesh vertex: the Monte Carlo reference renderer of the project
// (synthesis, relighting references, and the tests of other stages).
//
// Pixel convention (docs/FORMATS.md): pixel (x, y) covers [x, x+1) x [y, y+1),
// its centre at (x + 0.5, y + 0.5), and camera rays come from
// Camera::RayFromImage (lens distortion included). Each pixel averages a
// jittered k x k grid of camera rays (box filter). Work is split into tiles run
// by TBB; every pixel draws from its own random stream (seed, view, pixel), so
// the image does not depend on the thread count.
#pragma once

#include <Eigen/Core>

#include "core/progress.h"
#include "geometry/camera.h"
#include "geometry/reconstruction.h"
#include "image/image.h"
#include "render/lighting.h"
#include "render/render_options.h"
#include "render/scene.h"

namespace relight {

// The images of one rendered view.
struct RenderedView {
  Image radiance;  // linear RGB radiance (scene units), W x H x 3
  Image mask;      // 1 channel: 1 where the pixel-centre ray first hits an object surface, else 0
  Image coverage;  // 1 channel: fraction of the pixel's camera rays that first hit an object surface
  Image depth;     // 1 channel: camera-space z of the pixel-centre ray's first hit; 0 when it hits nothing
  Image surface;   // 1 channel: index of the surface the pixel-centre ray hits first; -1 for none
  double seconds = 0;
};

// Renders `pose` seen through `camera`. `view_index` selects the random
// streams (different views of one seed get independent noise). `progress`, if
// given, advances by one per tile (see NumTiles).
RenderedView RenderView(const Scene& scene, const Lighting& lighting, const Camera& camera, const ImageRecord& pose,
                        const RenderOptions& options, uint64_t view_index = 0, Progress* progress = nullptr);

// Number of tiles RenderView splits a camera's image into.
int64_t NumTiles(const Camera& camera, const RenderOptions& options);

// A Monte Carlo estimate and its standard error.
struct RadianceEstimate {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();       // RGB radiance
  Eigen::Vector3d std_error = Eigen::Vector3d::Zero();  // standard error of the mean, per channel
  int num_estimates = 0;                                // independent estimates averaged
};

// Exitant radiance of vertex `vertex` of surface `surface` towards
// `dir_out_world` (unit, away from the surface), the average of `num_estimates`
// independent estimates with the sample counts of `options` (seeded by
// options.seed, the surface and the vertex). The point is the vertex with its
// vertex normal and its own material weights, exactly what RenderView sees at
// the vertex. A direction below the vertex's tangent plane gets the radiance of
// the surface's back side. A pixel averages the surface over its footprint, so
// where shading curves it differs from this point value by up to a few percent
// on coarse meshes (docs/SYNTHETIC.md, "Known limitations"); compare
// statistically, with `std_error`.
RadianceEstimate VertexRadiance(const Scene& scene, const Lighting& lighting, int surface, int vertex,
                                const Eigen::Vector3d& dir_out_world, const RenderOptions& options,
                                int num_estimates = 64);

// The same for an arbitrary shading record (e.g. a hit point).
RadianceEstimate PointRadiance(const Scene& scene, const Lighting& lighting, const SurfacePoint& point,
                               const Eigen::Vector3d& dir_out_world, const RenderOptions& options, int num_estimates,
                               uint64_t stream);

}  // namespace relight
