// The `synthesize` stage: a scene (object, ground, blockers, spatially varying
// reflectance), a photo collection of it under varied distant lighting, and the
// complete ground truth beside it (docs/FORMATS.md "Ground truth folder",
// docs/SYNTHETIC.md). Rendering: render/render_view.h.
//
// Output folder:
//   images/photo_000.jpg …             the collection (sRGB JPEG, EXIF focal length)
//   ground_truth/…                      cameras, meshes, materials, lighting, env maps,
//                                       depth, masks, linear renders, relighting references
//   summary.json                        what was made and how long it took
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "brdf/brdf.h"
#include "core/json.h"
#include "geometry/mesh.h"
#include "render/rng.h"
#include "render/scene.h"
#include "synth/cameras.h"
#include "synth/synthesize_options.h"

namespace relight {

// The static scene of a collection (what the ground truth describes).
struct SyntheticScene {
  TriangleMesh object;                               // world frame, normals, w0 … w{M-1}, albedo_r/g/b
  ReflectanceModel object_reflectance;               // the materials the weights blend
  TriangleMesh occluders;                            // ground plane and blockers (one mesh); empty when none
  ReflectanceModel occluder_reflectance;             // Lambertian materials of the occluders
  Eigen::Vector3d center = Eigen::Vector3d::Zero();  // centre of the object's bounding box
  double radius = 0;                                 // largest distance of an object vertex from `center`
  std::vector<double> blocker_azimuths_deg;          // directions of the blockers from the object's axis
};

// Builds the object, its reflectance and the occluders. Throws UserError naming
// the file when the mesh or materials file is missing or broken.
SyntheticScene BuildSyntheticScene(const SynthesizeOptions& options);

// Renderer surfaces of the scene: the object (role kObject), then the occluders (kOccluder) if any.
std::vector<Scene::Surface> SceneSurfaces(const SyntheticScene& scene);

// A box standing on the ground between `view`'s camera and the object, hiding
// part of it (a passer-by): Lambertian, of a colour drawn from `rng`.
Scene::Surface MakeTransientOccluder(const SyntheticScene& scene, const SyntheticView& view, double object_size,
                                     Pcg32* rng);

// What the stage made.
struct SynthesizeSummary {
  int num_photos = 0;
  int num_lightings = 0;
  int num_transient = 0;  // photos with a transient occluder
  int num_relight_renders = 0;
  size_t object_vertices = 0;
  size_t object_faces = 0;
  size_t occluder_vertices = 0;
  double seconds_scene = 0;     // building geometry and reflectance
  double seconds_lighting = 0;  // env maps (loading, resampling, sky model)
  double seconds_render = 0;    // rendering the photos
  double seconds_relight = 0;   // rendering the relighting references
  double seconds_total = 0;
  OrderedJson photos = OrderedJson::array();  // per photo: name, size, focal, lighting, exposure, clipping, seconds

  // One paragraph for the log.
  std::string BriefReport() const;
  OrderedJson ToJson() const;
};

// Runs the stage into `output_dir` (which exists).
SynthesizeSummary RunSynthesize(const SynthesizeOptions& options, const std::string& output_dir);

}  // namespace relight
