// Export of the recovered model for Blender and other tools (issue 36): the
// `relight` stage writes <relight>/export/ (docs/FORMATS.md, "Export"):
//   model.glb             glTF 2.0 binary (tinygltf) of the object mesh; occluders (ground, blockers) are left out
//   envmaps/<stem>.exr    each photo's recovered environment map, float RGB lat-long (project convention,
//                         docs/FORMATS.md: row 0 is the zenith +Z, azimuth from +X towards +Y; Blender's is its
//                         mirror image, see scene.json "envmap_blender"), as re-rendered, times the export gauge
//   scene.json            {"format": "relight-export", "version": 1}: which map and camera belong to which photo
// Conventions of model.glb:
//  - Frame: glTF is +Y up, the project's world +Z up; a world point (x, y, z) is written as (x, z, -y), a rotation
//    of -90 deg about X (GltfFromWorld). Blender's importer turns it back into (x, y, z).
//  - COLOR_0 (float RGB, linear, as glTF defines it): the linear diffuse albedo divided by the export gauge
//    (ExportAlbedoScale; the maps are multiplied by it, so albedo x light is unchanged), clamped to [0, 1].
//  - Materials: one pbrMetallicRoughness material per material of materials.json, baseColorFactor 1 (COLOR_0
//    carries the colour), metallicFactor 0, roughnessFactor from the material's lobes (GltfRoughness); each
//    triangle belongs to the primitive of its dominant material (DominantFaceMaterials), so there is one
//    primitive per material that dominates a triangle; all primitives share one vertex array.
//  - _ROUGHNESS (application-specific attribute, float): the same roughness rule applied to each vertex's
//    blended BRDF, an approximation of the basis-BRDF blend a glTF material cannot express.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "brdf/brdf.h"
#include "core/json.h"
#include "geometry/mesh.h"
#include "relight/views.h"
#include "render/lighting.h"
#include "sphere/envmap.h"

namespace relight {

// glTF (+Y up) coordinates of a world-frame (+Z up) point or direction: (x, z, -y).
inline Eigen::Vector3f GltfFromWorld(const Eigen::Vector3f& v) { return {v.x(), v.z(), -v.y()}; }
// The same rotation as a matrix (x_gltf = R x_world).
Eigen::Matrix3d GltfFromWorldRotation();

// GGX alpha equivalent to a lobe: microfacet lobes (GGX, Beckmann) their alpha, Phong exponent n
// sqrt(2 / (n + 2)) (Walter et al. 2007), Lambertian 1; clamped to [0, 1].
double LobeAlpha(const BrdfLobe& lobe);
// glTF roughnessFactor of a BRDF blend given each basis lobe's RGB coefficient: the mean of sqrt(LobeAlpha)
// (glTF's alpha is roughness squared) over the glossy (non-Lambertian) lobes, weighted by the luminance of
// their coefficients; 1 when no glossy lobe has weight (purely Lambertian).
double GltfRoughness(const std::vector<BrdfLobe>& basis, const std::vector<Eigen::Vector3d>& lobe_rgb);
// GltfRoughness of material m alone.
double MaterialGltfRoughness(const ReflectanceModel& model, int m);
// GltfRoughness of every vertex's blend sum_m w_m material_m (weights w0 ... of the mesh; missing ones are 0).
std::vector<float> VertexGltfRoughness(const TriangleMesh& mesh, const ReflectanceModel& model);
// Each face's dominant material: the largest mean of w_m over its three vertices (the lowest m on ties,
// 0 without weights).
std::vector<int> DominantFaceMaterials(const TriangleMesh& mesh, int num_materials);
// Linear diffuse albedo per vertex: albedo_r/g/b when the mesh has them, else the Lambertian coefficients
// blended by the weights (ReflectanceModel::DiffuseAlbedo).
std::vector<Eigen::Vector3f> VertexAlbedo(const TriangleMesh& mesh, const ReflectanceModel& model);
// The export gauge s >= 1: the 99.5th percentile over vertices of the largest albedo channel when above 1,
// else 1. The recovered albedo is unique only up to a scale (inverse.gauge); COLOR_0 holds albedo / s and
// the exported maps radiance * s, so their product, the rendered radiance, is unchanged.
double ExportAlbedoScale(const std::vector<Eigen::Vector3f>& albedo);

// What WriteModelGlb wrote.
struct GltfModelSummary {
  int vertices = 0;
  int triangles = 0;
  int primitives = 0;                       // materials that dominate at least one triangle
  std::vector<int> triangles_per_material;  // one entry per material of the model
  std::vector<double> roughness;            // roughnessFactor per material
  int cameras = 0;                          // camera nodes
};

// Writes the mesh (positions, normals, faces, weights w0 ..., optional albedo_r/g/b) as glTF 2.0 binary to
// `path`, atomically, with the conventions above; COLOR_0 = clamp(albedo / albedo_scale, 0, 1). Each of
// `cameras` becomes a node named after it with a perspective camera: the pose GltfWorldFromCamera (a matrix),
// yfov from the focal length in y, aspectRatio width / height, znear 1 % of the mesh's bounding radius.
// glTF has no principal point offset, unequal focal lengths or lens distortion: those of a COLMAP camera
// are left out (scene.json keeps the full camera).
GltfModelSummary WriteModelGlb(const std::string& path, const TriangleMesh& mesh, const ReflectanceModel& model,
                               double albedo_scale = 1, const std::vector<RenderCamera>& cameras = {});

// A photo's recovered light and camera, as the relight stage uses them.
struct RecoveredPhoto {
  std::string name;                    // photo file name
  EnvMap envmap;                       // recovered map (world frame), unseen texels zeroed when relight asks
  // The sun the inverse stage solved as its own light (lighting.json "sun", "irradiance_rgb"), which `envmap`
  // holds in the one texel around its direction; `sky` is `envmap` without it. Re-renderings trace the sun as
  // a delta light (one shadow ray per shading point) under the sky.
  std::optional<DirectionalLight> sun;
  EnvMap sky;
  std::optional<RenderCamera> camera;  // from <sfm>/sparse; empty when the photo has none there
};

// glTF world (+Y up) from glTF camera (x right, y up, looking along -z): 4 x 4, for a COLMAP pose.
Eigen::Matrix4d GltfWorldFromCamera(const ImageRecord& cam_from_world);

// The export folder as relight_summary.json lists it (paths relative to the relight folder).
struct ExportRecord {
  std::string model;                 // export/model.glb
  std::string scene;                 // export/scene.json
  std::vector<std::string> envmaps;  // export/envmaps/<stem>.exr, in photo order
  int vertices = 0;
  int triangles = 0;
  int primitives = 0;
  double albedo_scale = 1;  // export gauge (ExportAlbedoScale)
  double seconds = 0;

  OrderedJson ToJson() const;
  // Reads ToJson's output; an absent or empty entry gives an empty record (model == "").
  static ExportRecord FromJson(const Json& j);
};

// Writes export/ (model.glb, envmaps/<stem>.exr, scene.json) into `output_dir`, every file atomically,
// scene.json last.
ExportRecord WriteExport(const std::string& output_dir, const TriangleMesh& mesh, const ReflectanceModel& model,
                         const std::vector<RecoveredPhoto>& photos);

}  // namespace relight
