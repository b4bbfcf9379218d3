// The `relight` stage: renders the recovered model — the mesh with the
// per-vertex material weights and materials of the `inverse` stage, plus
// <mesh>/occluders.ply as shadow casters — from its precomputed transport
// (relight/transport_render.h, noise-free; the default) or with the project's
// Monte Carlo renderer (render/render_view.h, the conventions of the synthetic
// generator), under
//   (a) each input photo's recovered environment map, from that photo's camera
//       (re-renderings, scored by `evaluate`);
//   (b) given held-out views under given held-out environment maps, both in
//       the model's frame (HeldoutViews: the stage's main takes them from the
//       ground truth and brings them into the model's frame);
//   (c) HDR environment map files, a directional and a point light, from new
//       orbit cameras, plus flat albedo and dominant-material images;
//   (d) a turntable (frames on an orbit and an animated GIF).
//
// Output folder (docs/FORMATS.md):
//   renders/<kind>/<name>.exr   linear RGB radiance (float)
//   renders/<kind>/<name>.png   tone-mapped (relight/display.h), 8-bit sRGB
//   renders/<kind>/<name>_mask.png  object mask (255 where the pixel-centre ray first hits the object)
//   renders/turntable/frame_NNN.{exr,png}, renders/turntable/turntable.gif
//   export/model.glb, export/envmaps/<stem>.exr, export/scene.json
//                               the model as glTF 2.0 for Blender with each photo's recovered map and camera
//                               (relight/gltf_export.h); rewritten on every run
//   export/viewer/viewer.html, export/viewer/viewer_data.js
//                               the interactive WebGL viewer (relight/viewer_export.h); rewritten on every run
//   relight_summary.json        index of every image with its camera and light (RelightIndex below)
// Every image is written atomically; a rerun in the same folder renders only what is missing.
#pragma once

#include <Eigen/Core>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "brdf/brdf.h"
#include "core/json.h"
#include "geometry/mesh.h"
#include "geometry/reconstruction.h"
#include "relight/gltf_export.h"
#include "relight/relight_options.h"
#include "relight/transport_render.h"
#include "relight/views.h"
#include "render/scene.h"
#include "sphere/envmap.h"

namespace relight {

// The model the inverse stage recovered.
struct RecoveredModel {
  TriangleMesh mesh;             // <inverse>/reflectance.ply: positions, normals, w0…, albedo_r/g/b
  ReflectanceModel reflectance;  // <inverse>/materials.json
  TriangleMesh occluders;        // <mesh>/occluders.ply without properties; empty when absent
  Eigen::Vector3d center = Eigen::Vector3d::Zero();  // bounding sphere of the object
  double radius = 1;
  // <inverse>/lighting.json: side of the octahedral maps the light was solved on (the transport renderer
  // filters light to it), and the one bounce the model was fitted with (inverse.interreflection; 0: none).
  int env_resolution = 32;
  int bounce_rays_per_side = 0;
  // The occluders' albedo the inverse stage recovered with the bounce (lighting.json); negative: not recovered.
  Eigen::Vector3d occluder_albedo = Eigen::Vector3d::Constant(-1);

  // The occluders' albedo to render with: the recovered one, else `configured` (relight.occluder_albedo) grey.
  Eigen::Vector3d OccluderAlbedo(double configured) const {
    return occluder_albedo.minCoeff() >= 0 ? occluder_albedo : Eigen::Vector3d::Constant(configured);
  }
};

// Reads the model; throws UserError naming the missing or broken file and what to rerun.
RecoveredModel LoadRecoveredModel(const std::string& inverse_dir, const std::string& mesh_dir);

// Renders `model` with the bounce it was solved with (RecoveredModel::bounce_rays_per_side; nothing when 0):
// enabled in `transport` and/or `monte_carlo` (the path tracer's one bounce), either may be null.
void EnableModelInterreflection(const RecoveredModel& model, TransportRenderer* transport, RenderOptions* monte_carlo);

// Renderer surfaces: the object (role kObject) with `reflectance` (weights w0… of `object_mesh`), then the
// occluders (kOccluder) as Lambertian of `occluder_albedo` (RGB).
std::vector<Scene::Surface> ModelSurfaces(const TriangleMesh& object_mesh, const ReflectanceModel& reflectance,
                                          const TriangleMesh& occluders, const Eigen::Vector3d& occluder_albedo);
inline std::vector<Scene::Surface> ModelSurfaces(const TriangleMesh& object_mesh, const ReflectanceModel& reflectance,
                                                 const TriangleMesh& occluders, double occluder_albedo) {
  return ModelSurfaces(object_mesh, reflectance, occluders, Eigen::Vector3d::Constant(occluder_albedo));
}

// Texels of an n x n octahedral environment map from which the scene's object surfaces receive no light:
// from all but a handful of the sampled object vertices (at most `max_vertices`, evenly strided; fewer than
// max(2, 0.2%) may see it, for contact points whose offset rays start behind the ground), the rays towards
// the texel's centre and four inner points (±0.35 texel) are blocked by the scene; then dilated by one texel
// so bilinear lookups in every direction that is seen never touch them. 1 = unseen.
std::vector<char> UnseenOctTexels(const Scene& scene, int n, int max_vertices = 2000);

// A copy of an octahedral RGB map with the `unseen` texels set to 0. The inverse stage has no data on them
// (no observation's transport reaches them), and zeroing them leaves the expected radiance of every object
// pixel unchanged while it stops the renderer's light sampling from wasting samples on them (the extrapolated
// lower hemisphere under a ground plane is often the brightest part of a recovered map).
Image ZeroTexels(const Image& oct, const std::vector<char>& unseen);

// The sun a photo's lighting.json entry says the inverse stage solved as its own light ("sun" with
// "irradiance_rgb", docs/FORMATS.md), with `sky` set to the photo's octahedral map `oct` without it (the sun's
// irradiance over the solid angle of the texel that holds it, taken from that texel); empty without one.
std::optional<DirectionalLight> SolvedSun(const Json& entry, const Image& oct, Image* sky);

// Per-vertex colour of the dominant material (largest weight), from a fixed qualitative palette.
std::vector<Eigen::Vector3f> DominantMaterialColors(const TriangleMesh& mesh, int num_materials);
// The palette colour (linear RGB) of material m.
Eigen::Vector3f MaterialColor(int m);

// One image the stage wrote.
struct RenderRecord {
  std::string kind;   // rerender, heldout, novel, albedo, material, turntable
  std::string name;   // unique within the kind: photo stem, "<view>__<envmap>", "<view>__<light>", ...
  std::string view;   // photo name (rerender), held-out view name, orbit camera name
  std::string light;  // "recovered:<stem>", "heldout:<envmap>", "envmap:<file stem>", "directional", "point", "none"
  std::string exr;    // relative to the stage folder; empty for flat images
  std::string png;
  std::string mask;
  RenderCamera camera;  // intrinsics and pose in the model's frame
  double exposure = 1;  // of the PNG (relight/display.h)
  double seconds = 0;   // 0 when reused from an earlier, killed run
};

struct RelightSummary {
  std::vector<RenderRecord> renders;
  int rendered = 0;                // images rendered by this run
  int reused = 0;                  // images already present (an earlier run was killed)
  std::string frame_method;        // HeldoutViews::frame_method
  std::string turntable_gif;       // relative path; empty when none
  ExportRecord exported;           // the export folder (relight/gltf_export.h)
  std::string viewer;              // the interactive viewer page, relative; empty when none
  std::vector<std::string> notes;  // what was skipped and why
  double seconds = 0;

  // One paragraph for the log.
  std::string BriefReport() const;
  // relight_summary.json: {"format": "relight-renders", "version": 1, "renders": [...], "export": {...}, ...}.
  OrderedJson ToJson() const;
};

// Reads <relight>/relight_summary.json (throws UserError naming it when missing or malformed); the export
// record is empty (model == "") for a summary written before relight version 4.
std::vector<RenderRecord> ReadRenderIndex(const std::string& relight_dir, std::string* turntable_gif = nullptr,
                                          ExportRecord* exported = nullptr);

// Views rendered as kind "heldout" (`<view>__<envmap>`, in this order) with their cameras and maps in the
// model's frame; what the relation to their frame was and why there are none are recorded in the summary.
struct HeldoutViews {
  std::string frame_method = "none";                         // relight_summary.json "frame"
  std::vector<std::string> notes;                            // e.g. why there are none
  Reconstruction cameras;                                    // image names = view names
  std::map<std::string, EnvMap> envmaps;                     // by name
  std::vector<std::pair<std::string, std::string>> renders;  // (view, envmap): names in `cameras`, `envmaps`
};

// Upstream folders of the stage.
struct RelightInputs {
  HeldoutViews heldout;     // optional: held-out views (the stage's main fills them)
  std::string sfm_dir;      // cameras of the photos (sparse/)
  std::string mesh_dir;     // occluders.ply
  std::string inverse_dir;  // reflectance.ply, materials.json, lighting.json, envmaps/
  std::string visibility_dir;  // visibility.bin (relight.renderer: transport)
};

// Runs the stage into `output_dir` (which exists).
// With an active `shard` (one pass: step 0): only the radiance and masks of the shard's views, nothing else.
RelightSummary RunRelight(const RelightOptions& options, const RelightInputs& inputs, const std::string& output_dir,
                          const ShardSpec& shard = {});

// Reads the maps of relight.envmaps (before anything is rendered). Throws
// UserError naming the entry when it is missing, a folder, unreadable, not
// 2:1 or holds NaN/negative radiance (EnvMap::Load).
std::vector<EnvMap> LoadRelightEnvmaps(const std::vector<std::string>& paths);

}  // namespace relight
