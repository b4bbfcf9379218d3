// The `observe` stage: the measurements y of the method (Haber et al. 2009,
// §4.3, eq. 9) with their confidences alpha_y. For each photo a depth map is
// ray cast with Embree; a vertex is observed when it lies in the frustum, faces
// the camera and agrees with the depth map. Its colour is the confidence-
// weighted mean of the linear photo over a footprint matching the vertex's
// projected share of the surface (an image pyramid keeps that O(1) per vertex).
// A footprint holding more than a share of distrusted pixels (linearize:
// clipped) does not give that mean, which would be biased low on highlights
// (high in crushed shadows): by default it gives a lower bound instead, the
// mean over all its pixels with clipped ones at their clipped value
// (kObservationLowerBound; the solver enforces it one-sided), or it is
// dropped. The confidence multiplies: the trusted fraction of the footprint
// (not for lower bounds), a ramp on the view angle (low at grazing angles)
// and a ramp on the distance to silhouettes and depth discontinuities.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include "geometry/camera.h"
#include "geometry/mesh.h"
#include "geometry/raycaster.h"
#include "geometry/reconstruction.h"
#include "image/image.h"
#include "observe/observations.h"
#include "observe/observe_options.h"

namespace relight {

// Camera-space depth (z) per pixel by ray casting; 0 where no surface is hit.
Image RenderDepthMap(const RayCaster& caster, const Camera& camera, const ImageRecord& pose);

// Distance (pixels) from each pixel to the nearest silhouette or depth discontinuity
// (relative jump above `relative_jump` between 4-neighbours).
Image DepthEdgeDistance(const Image& depth, double relative_jump);

// Per-vertex radius (world units) of a disc with the vertex's share (1/3 of
// its incident faces) of the surface area.
std::vector<float> VertexFootprintRadius(const TriangleMesh& mesh);

// Where the footprint of a disc of `radius_px` (level-0 pixels) is sampled in a
// pyramid of `levels` levels: the level, the disc's radius in that level's
// pixels, and the taps per half axis. The taps are the points of a
// (2 taps + 1)² grid of step radius / taps inside the disc.
struct FootprintTaps {
  int level = 0;
  double radius = 0;  // in pixels of `level`
  int taps = 1;
};
FootprintTaps FootprintTapLayout(double radius_px, int levels);

// Radius (level-0 pixels) of the disc with the same second moment as what an
// observation of a disc of `radius_px` averages: the taps' own spread, plus the
// width of the pixels they read (at level L, the bilinear tent between pixels
// 2^L apart and each pixel's box of 2^L photo pixels: together a variance of
// 4^L / 4 per axis). It exceeds `radius_px` by 7 to 23 % at the coarser levels
// (1.5 to 3 pixels per radius), more at level 0 (footprints of 3 pixels or less);
// the transport rows average their normals over a disc this much wider
// (Observation::kernel_scale).
double FootprintKernelRadiusPx(double radius_px, int levels);

// One photo ready for observation.
struct PhotoView {
  Camera camera;        // at the radiance image's resolution
  ImageRecord pose;
  const Image* radiance = nullptr;    // linear RGB
  const Image* confidence = nullptr;  // 1 channel
  // Linear value at and above which a channel of `radiance` was over-exposed
  // (linearize stats); infinity when unknown: then every channel of a clipped
  // footprint is a bound.
  double overexposed_linear = std::numeric_limits<double>::infinity();
};

// Observations of the mesh's vertices (normals required) in one photo;
// `clipped_footprints`, when given, receives how many otherwise valid
// footprints held too many distrusted pixels (options.max_distrusted_share),
// whether kept as lower bounds or dropped (options.clipped_footprints).
std::vector<Observation> ObservePhoto(const TriangleMesh& mesh, const std::vector<float>& footprint_radius,
                                      const RayCaster& caster, const PhotoView& photo, uint32_t photo_index,
                                      const ObserveOptions& options, size_t* clipped_footprints = nullptr);

struct ObserveSummary {
  int photos = 0;
  size_t vertices = 0;             // of the mesh
  int reused_photos = 0;           // finished by an earlier, killed run
  size_t observations = 0;
  size_t unobserved_vertices = 0;  // vertices with no exact observation (lower bounds do not count)
  size_t clipped_footprints = 0;   // footprints over max_distrusted_share
  size_t lower_bounds = 0;         // of those, kept as lower bounds (all photos)
  size_t lower_bound_channels = 0; // their channels that are bounds (the others measure)
  double seconds = 0;

  // One paragraph for the log.
  std::string BriefReport() const;
};

// Runs the stage: reads <sfm>/sparse, <mesh>/mesh.ply (+ occluders.ply),
// <linearize>/linear and confidence; writes observations.bin, photos.json,
// coverage.json into `output_dir`. With an active `shard` (one pass: step 0) only that shard's photos go
// into per_photo/, and nothing else is written.
struct ObserveInputs {
  std::string sfm_dir;        // the sfm stage's folder
  std::string mesh_dir;       // the mesh stage's folder
  std::string linearize_dir;  // the linearize stage's folder
};
ObserveSummary RunObserve(const ObserveOptions& options, const ObserveInputs& inputs, const std::string& output_dir,
                          const ShardSpec& shard = {});

}  // namespace relight
