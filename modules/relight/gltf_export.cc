#include "relight/gltf_export.h"

#include <tiny_gltf.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>

#include "core/error.h"
#include "core/fs.h"
#include "core/timer.h"
#include "image/image.h"

namespace relight {
namespace fs = std::filesystem;

namespace {

double Lum(const Eigen::Vector3d& rgb) { return Luminance(rgb); }

// Appends `bytes` to buffer 0 (4-byte aligned) as a new buffer view; returns its index.
int AddView(tinygltf::Model* g, const void* data, size_t bytes, int target) {
  std::vector<unsigned char>& buffer = g->buffers[0].data;
  buffer.resize((buffer.size() + 3) / 4 * 4, 0);
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = buffer.size();
  view.byteLength = bytes;
  view.target = target;
  const auto* p = static_cast<const unsigned char*>(data);
  buffer.insert(buffer.end(), p, p + bytes);
  g->bufferViews.push_back(view);
  return int(g->bufferViews.size()) - 1;
}

// A float accessor of `count` elements of `type` (TINYGLTF_TYPE_*) over `values`; returns its index.
int AddFloatAccessor(tinygltf::Model* g, const std::vector<float>& values, int type, size_t count,
                     bool with_bounds = false) {
  tinygltf::Accessor a;
  a.bufferView = AddView(g, values.data(), values.size() * sizeof(float), TINYGLTF_TARGET_ARRAY_BUFFER);
  a.componentType = TINYGLTF_COMPONENT_TYPE_FLOAT;
  a.type = type;
  a.count = count;
  if (with_bounds) {  // required for POSITION
    const int n = tinygltf::GetNumComponentsInType(type);
    a.minValues.assign(n, INFINITY);
    a.maxValues.assign(n, -INFINITY);
    for (size_t k = 0; k < values.size(); ++k) {
      a.minValues[k % n] = std::min<double>(a.minValues[k % n], values[k]);
      a.maxValues[k % n] = std::max<double>(a.maxValues[k % n], values[k]);
    }
  }
  g->accessors.push_back(a);
  return int(g->accessors.size()) - 1;
}

int AddIndexAccessor(tinygltf::Model* g, const std::vector<uint32_t>& indices) {
  tinygltf::Accessor a;
  a.bufferView = AddView(g, indices.data(), indices.size() * sizeof(uint32_t), TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
  a.componentType = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT;
  a.type = TINYGLTF_TYPE_SCALAR;
  a.count = indices.size();
  g->accessors.push_back(a);
  return int(g->accessors.size()) - 1;
}

// The shared vertex attributes (glTF frame): POSITION, NORMAL, COLOR_0, _ROUGHNESS.
std::map<std::string, int> AddVertexAttributes(tinygltf::Model* g, const TriangleMesh& mesh,
                                               const ReflectanceModel& model, double albedo_scale) {
  const size_t n = mesh.num_vertices();
  std::vector<float> positions, normals, colors;
  positions.reserve(3 * n);
  normals.reserve(3 * n);
  colors.reserve(3 * n);
  const std::vector<Eigen::Vector3f> albedo = VertexAlbedo(mesh, model);
  for (size_t v = 0; v < n; ++v) {
    const Eigen::Vector3f p = GltfFromWorld(mesh.vertices[v]);
    Eigen::Vector3f nrm = v < mesh.normals.size() ? mesh.normals[v] : Eigen::Vector3f::Zero();
    nrm = nrm.norm() > 1e-12f ? GltfFromWorld(nrm.normalized()) : Eigen::Vector3f::UnitY();  // glTF wants unit
    for (int c = 0; c < 3; ++c) {
      positions.push_back(p[c]);
      normals.push_back(nrm[c]);
      colors.push_back(std::clamp(float(albedo[v][c] / albedo_scale), 0.0f, 1.0f));
    }
  }
  return {{"POSITION", AddFloatAccessor(g, positions, TINYGLTF_TYPE_VEC3, n, true)},
          {"NORMAL", AddFloatAccessor(g, normals, TINYGLTF_TYPE_VEC3, n)},
          {"COLOR_0", AddFloatAccessor(g, colors, TINYGLTF_TYPE_VEC3, n)},
          {"_ROUGHNESS", AddFloatAccessor(g, VertexGltfRoughness(mesh, model), TINYGLTF_TYPE_SCALAR, n)}};
}

// Lat-long height of an exported map: the stored height of a lat-long map; for an N x N octahedral map
// max(32, 2N), as the inverse stage writes its *_latlong.exr.
int ExportHeight(const EnvMap& map) {
  if (map.layout() == EnvMap::Layout::kLatLong) return map.image().height;
  return std::max(32, 2 * map.image().width);
}

// scene.json's entry of one photo.
OrderedJson PhotoJson(const RecoveredPhoto& photo, const std::string& envmap) {
  OrderedJson e;
  e["photo"] = photo.name;
  e["envmap"] = envmap;
  if (!photo.camera) {
    e["camera"] = nullptr;
    return e;
  }
  const Camera& c = photo.camera->camera;
  OrderedJson cam = OrderedJson(CameraToJson(c, photo.camera->pose));
  cam["yfov_rad"] = 2 * std::atan(0.5 * c.height / c.FocalY());
  const Eigen::Matrix4d m = GltfWorldFromCamera(photo.camera->pose);
  OrderedJson rows = OrderedJson::array();
  for (int r = 0; r < 4; ++r) rows.push_back({m(r, 0), m(r, 1), m(r, 2), m(r, 3)});
  cam["gltf_world_from_camera"] = rows;
  e["camera"] = cam;
  return e;
}

}  // namespace

Eigen::Matrix3d GltfFromWorldRotation() {
  Eigen::Matrix3d r;
  r << 1, 0, 0, 0, 0, 1, 0, -1, 0;
  return r;
}

double LobeAlpha(const BrdfLobe& lobe) {
  double alpha = 1;
  switch (lobe.model) {
    case BrdfModel::kLambertian:
      alpha = 1;
      break;
    case BrdfModel::kPhong:
      alpha = std::sqrt(2 / (std::max(0.0, lobe.exponent) + 2));
      break;
    case BrdfModel::kCookTorrance:
    case BrdfModel::kGgx:
      alpha = lobe.roughness;
      break;
  }
  return std::clamp(alpha, 0.0, 1.0);
}

double GltfRoughness(const std::vector<BrdfLobe>& basis, const std::vector<Eigen::Vector3d>& lobe_rgb) {
  RELIGHT_CHECK_EQ(basis.size(), lobe_rgb.size());
  double sum = 0, weight = 0;
  for (size_t b = 0; b < basis.size(); ++b) {
    if (basis[b].model == BrdfModel::kLambertian) continue;
    const double w = std::max(0.0, Lum(lobe_rgb[b]));
    sum += w * std::sqrt(LobeAlpha(basis[b]));
    weight += w;
  }
  return weight > 1e-12 ? sum / weight : 1.0;
}

double MaterialGltfRoughness(const ReflectanceModel& model, int m) {
  return GltfRoughness(model.basis, model.materials.at(m).coefficients);
}

std::vector<float> VertexGltfRoughness(const TriangleMesh& mesh, const ReflectanceModel& model) {
  const size_t num_m = model.materials.size(), num_b = model.basis.size();
  std::vector<const std::vector<float>*> w(num_m);
  for (size_t m = 0; m < num_m; ++m) w[m] = mesh.FindProperty("w" + std::to_string(m));
  std::vector<float> out(mesh.num_vertices());
  std::vector<Eigen::Vector3d> blend(num_b);
  for (size_t v = 0; v < mesh.num_vertices(); ++v) {
    std::fill(blend.begin(), blend.end(), Eigen::Vector3d::Zero());
    for (size_t m = 0; m < num_m; ++m) {
      const double wm = w[m] ? std::max(0.0f, (*w[m])[v]) : 0.0;
      for (size_t b = 0; b < num_b; ++b) blend[b] += wm * model.materials[m].coefficients.at(b);
    }
    out[v] = static_cast<float>(GltfRoughness(model.basis, blend));
  }
  return out;
}

std::vector<int> DominantFaceMaterials(const TriangleMesh& mesh, int num_materials) {
  std::vector<const std::vector<float>*> w(num_materials);
  for (int m = 0; m < num_materials; ++m) w[m] = mesh.FindProperty("w" + std::to_string(m));
  std::vector<int> out(mesh.num_faces(), 0);
  for (size_t f = 0; f < mesh.num_faces(); ++f) {
    double best = -INFINITY;
    for (int m = 0; m < num_materials; ++m) {
      if (!w[m]) continue;
      const Eigen::Vector3i& t = mesh.faces[f];
      const double mean = (double((*w[m])[t[0]]) + (*w[m])[t[1]] + (*w[m])[t[2]]) / 3;
      if (mean > best) {
        best = mean;
        out[f] = m;
      }
    }
  }
  return out;
}

std::vector<Eigen::Vector3f> VertexAlbedo(const TriangleMesh& mesh, const ReflectanceModel& model) {
  const std::vector<float>* ar = mesh.FindProperty("albedo_r");
  const std::vector<float>* ag = mesh.FindProperty("albedo_g");
  const std::vector<float>* ab = mesh.FindProperty("albedo_b");
  std::vector<Eigen::Vector3f> out(mesh.num_vertices());
  if (ar && ag && ab) {
    for (size_t v = 0; v < out.size(); ++v) out[v] = Eigen::Vector3f((*ar)[v], (*ag)[v], (*ab)[v]);
    return out;
  }
  std::vector<const std::vector<float>*> w(model.materials.size());
  for (size_t m = 0; m < w.size(); ++m) w[m] = mesh.FindProperty("w" + std::to_string(m));
  std::vector<double> weights(w.size());
  for (size_t v = 0; v < out.size(); ++v) {
    for (size_t m = 0; m < w.size(); ++m) weights[m] = w[m] ? (*w[m])[v] : 0.0;
    out[v] = model.DiffuseAlbedo(weights).cast<float>();
  }
  return out;
}

double ExportAlbedoScale(const std::vector<Eigen::Vector3f>& albedo) {
  if (albedo.empty()) return 1;
  std::vector<float> peak;
  peak.reserve(albedo.size());
  for (const auto& a : albedo) peak.push_back(a.maxCoeff());
  const size_t k = std::min(peak.size() - 1, size_t(std::floor(0.995 * (peak.size() - 1) + 0.5)));
  std::nth_element(peak.begin(), peak.begin() + k, peak.end());
  return std::isfinite(peak[k]) ? std::max(1.0, double(peak[k])) : 1.0;
}

GltfModelSummary WriteModelGlb(const std::string& path, const TriangleMesh& mesh, const ReflectanceModel& model,
                               double albedo_scale, const std::vector<RenderCamera>& cameras) {
  RELIGHT_CHECK(!mesh.empty() && !model.materials.empty() && albedo_scale > 0);
  mesh.Check(path);
  tinygltf::Model g;
  g.asset.version = "2.0";
  g.asset.generator = "relight (tinygltf)";
  g.buffers.resize(1);
  const std::map<std::string, int> attributes = AddVertexAttributes(&g, mesh, model, albedo_scale);

  GltfModelSummary summary;
  const int num_m = int(model.materials.size());
  summary.vertices = int(mesh.num_vertices());
  summary.triangles = int(mesh.num_faces());
  summary.triangles_per_material.assign(num_m, 0);
  std::vector<std::vector<uint32_t>> indices(num_m);
  const std::vector<int> dominant = DominantFaceMaterials(mesh, num_m);
  for (size_t f = 0; f < mesh.num_faces(); ++f) {
    for (int c = 0; c < 3; ++c) indices[dominant[f]].push_back(uint32_t(mesh.faces[f][c]));
    ++summary.triangles_per_material[dominant[f]];
  }
  tinygltf::Mesh gm;
  gm.name = "object";
  for (int m = 0; m < num_m; ++m) {
    tinygltf::Material mat;
    mat.name = model.materials[m].name.empty() ? "material_" + std::to_string(m) : model.materials[m].name;
    mat.doubleSided = true;  // cropped meshes are open: their inside shows
    mat.pbrMetallicRoughness.baseColorFactor = {1, 1, 1, 1};
    mat.pbrMetallicRoughness.metallicFactor = 0;
    mat.pbrMetallicRoughness.roughnessFactor = MaterialGltfRoughness(model, m);
    summary.roughness.push_back(mat.pbrMetallicRoughness.roughnessFactor);
    g.materials.push_back(mat);
    if (indices[m].empty()) continue;
    tinygltf::Primitive p;
    p.attributes = attributes;
    p.indices = AddIndexAccessor(&g, indices[m]);
    p.material = m;
    p.mode = TINYGLTF_MODE_TRIANGLES;
    gm.primitives.push_back(p);
  }
  summary.primitives = int(gm.primitives.size());
  g.meshes.push_back(gm);
  tinygltf::Node node;
  node.name = "object";
  node.mesh = 0;
  g.nodes.push_back(node);
  tinygltf::Scene scene;
  scene.name = "relight";
  scene.nodes = {0};
  Eigen::Vector3d center;
  double radius = 1;
  MeshBoundingSphere(mesh, &center, &radius);
  for (const RenderCamera& view : cameras) {
    tinygltf::Camera cam;
    cam.name = view.name;
    cam.type = "perspective";
    cam.perspective.yfov = 2 * std::atan(0.5 * view.camera.height / view.camera.FocalY());
    cam.perspective.aspectRatio = double(view.camera.width) / view.camera.height;
    cam.perspective.znear = 0.01 * radius;
    g.cameras.push_back(cam);
    tinygltf::Node n;
    n.name = view.name;
    n.camera = int(g.cameras.size()) - 1;
    const Eigen::Matrix4d m = GltfWorldFromCamera(view.pose);
    for (int col = 0; col < 4; ++col)
      for (int row = 0; row < 4; ++row) n.matrix.push_back(m(row, col));  // glTF matrices are column-major
    scene.nodes.push_back(int(g.nodes.size()));
    g.nodes.push_back(n);
  }
  summary.cameras = int(cameras.size());
  g.scenes.push_back(scene);
  g.defaultScene = 0;
  g.buffers[0].data.resize((g.buffers[0].data.size() + 3) / 4 * 4, 0);

  std::ostringstream bytes;
  tinygltf::TinyGLTF writer;
  if (!writer.WriteGltfSceneToStream(&g, bytes, false, true)) {
    RELIGHT_USER_ERROR() << "cannot encode '" << path << "' as glTF binary";
  }
  WriteFileAtomic(path, bytes.str());
  return summary;
}

Eigen::Matrix4d GltfWorldFromCamera(const ImageRecord& cam_from_world) {
  // COLMAP camera: x right, y down, z forward; glTF camera: x right, y up, looking along -z.
  const Eigen::Matrix3d flip = Eigen::Vector3d(1, -1, -1).asDiagonal();
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = GltfFromWorldRotation() * cam_from_world.CamFromWorldRotation().transpose() * flip;
  m.topRightCorner<3, 1>() = GltfFromWorldRotation() * cam_from_world.ProjectionCenter();
  return m;
}

OrderedJson ExportRecord::ToJson() const {
  OrderedJson j;
  j["model"] = model;
  j["scene"] = scene;
  j["envmaps"] = envmaps;
  j["vertices"] = vertices;
  j["triangles"] = triangles;
  j["primitives"] = primitives;
  j["albedo_scale"] = albedo_scale;
  j["seconds"] = seconds;
  return j;
}

ExportRecord ExportRecord::FromJson(const Json& j) {
  ExportRecord r;
  if (!j.is_object()) return r;
  r.model = j.value("model", "");
  r.scene = j.value("scene", "");
  r.envmaps = j.value("envmaps", std::vector<std::string>{});
  r.vertices = j.value("vertices", 0);
  r.triangles = j.value("triangles", 0);
  r.primitives = j.value("primitives", 0);
  r.albedo_scale = j.value("albedo_scale", 1.0);
  r.seconds = j.value("seconds", 0.0);
  return r;
}

ExportRecord WriteExport(const std::string& output_dir, const TriangleMesh& mesh, const ReflectanceModel& model,
                         const std::vector<RecoveredPhoto>& photos) {
  Timer timer;
  EnsureDir(JoinPath(output_dir, "export/envmaps"));
  ExportRecord record;
  record.model = "export/model.glb";
  record.scene = "export/scene.json";
  record.albedo_scale = ExportAlbedoScale(VertexAlbedo(mesh, model));
  std::vector<RenderCamera> cameras;
  for (const RecoveredPhoto& photo : photos)
    if (photo.camera) cameras.push_back(*photo.camera);
  const GltfModelSummary s =
      WriteModelGlb(JoinPath(output_dir, record.model), mesh, model, record.albedo_scale, cameras);
  record.vertices = s.vertices;
  record.triangles = s.triangles;
  record.primitives = s.primitives;

  OrderedJson list = OrderedJson::array();
  std::set<std::string> used;
  for (const RecoveredPhoto& photo : photos) {
    const std::string stem = fs::path(photo.name).stem().string();
    std::string name = stem;
    for (int k = 2; used.count(name); ++k) name = stem + "_" + std::to_string(k);
    used.insert(name);
    const std::string rel = "envmaps/" + name + ".exr";
    const EnvMap scaled = photo.envmap.Transformed(Eigen::Matrix3d::Identity(), record.albedo_scale);
    const int height = ExportHeight(photo.envmap);
    WriteImage(JoinPath(output_dir, "export/" + rel),
               scaled.ToLatLong(height, scaled.CoveringSupersampling(M_PI / height)), {PixelType::kFloat});
    record.envmaps.push_back("export/" + rel);
    list.push_back(PhotoJson(photo, rel));
  }
  OrderedJson scene;
  scene["format"] = "relight-export";
  scene["version"] = 1;
  scene["model"] = "model.glb";
  scene["frame"] =
      "model.glb is glTF +Y up: a world point (x, y, z) (+Z up, docs/FORMATS.md) is (x, z, -y) in glTF; cameras "
      "(qvec, tvec: COLMAP cam_from_world) are in the world frame, gltf_world_from_camera in glTF's (camera looking "
      "along -z, y up)";
  scene["envmap_layout"] =
      "lat-long float RGB, width = 2 height, world frame: pixel (col, row) of W x H has centre u = (col + 0.5) / W, "
      "v = (row + 0.5) / H; direction theta = pi v from +Z (row 0 is the zenith, glTF +Y), phi = 2 pi u from +X "
      "towards +Y (glTF -Z)";
  scene["envmap_blender"] =
      "World nodes: Texture Coordinate (Generated) -> Mapping (type Vector, scale -1, 1, 1) -> Environment "
      "Texture -> Background; Blender's lat-long is the mirror image of this one (X flipped)";
  scene["albedo_scale"] = record.albedo_scale;
  scene["albedo_scale_note"] =
      "COLOR_0 = albedo / albedo_scale and envmaps = recovered radiance * albedo_scale (the product is unchanged)";
  scene["vertices"] = record.vertices;
  scene["triangles"] = record.triangles;
  OrderedJson materials = OrderedJson::array();
  for (size_t m = 0; m < model.materials.size(); ++m)
    materials.push_back(
        {{"name", model.materials[m].name}, {"roughness", s.roughness[m]}, {"triangles", s.triangles_per_material[m]}});
  scene["materials"] = materials;
  scene["photos"] = list;
  WriteJsonAtomic(JoinPath(output_dir, record.scene), scene);
  record.seconds = timer.Seconds();
  return record;
}

}  // namespace relight
