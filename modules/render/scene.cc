#include "render/scene.h"

#include <algorithm>

#include "core/error.h"

namespace relight {

std::vector<std::vector<double>> VertexMaterialWeights(const TriangleMesh& mesh, int num_materials,
                                                       const std::string& where) {
  std::vector<std::vector<double>> weights(mesh.num_vertices(), std::vector<double>(num_materials, 0.0));
  if (num_materials == 1 && mesh.FindProperty("w0") == nullptr) {
    for (auto& w : weights) w[0] = 1.0;
    return weights;
  }
  for (int m = 0; m < num_materials; ++m) {
    const std::string name = "w" + std::to_string(m);
    const std::vector<float>* values = mesh.FindProperty(name);
    if (values == nullptr) {
      RELIGHT_USER_ERROR() << where << ": the mesh has no vertex property '" << name
                           << "' but the reflectance model has " << num_materials << " materials; add w0 … w"
                           << num_materials - 1 << " (material weights) to the mesh";
    }
    for (size_t v = 0; v < mesh.num_vertices(); ++v) {
      const double w = (*values)[v];
      if (!(w >= 0) || !std::isfinite(w)) {
        RELIGHT_USER_ERROR() << where << ": vertex " << v << " has material weight " << name << " = " << w
                             << "; weights must be finite and non-negative";
      }
      weights[v][m] = w;
    }
  }
  return weights;
}

ReflectanceModel LambertianModel(const Eigen::Vector3d& albedo_rgb, const std::string& name) {
  ReflectanceModel model;
  model.basis.push_back(BrdfLobe{});
  model.materials.push_back(Material{name, {albedo_rgb}});
  return model;
}

Scene::Scene(std::vector<Surface> surfaces, const std::string& where) : surfaces_(std::move(surfaces)) {
  lobe_rgb_.resize(surfaces_.size());
  for (size_t s = 0; s < surfaces_.size(); ++s) {
    Surface& surface = surfaces_[s];
    const std::string name = where + " surface " + std::to_string(s);
    surface.mesh.Check(name);
    if (surface.mesh.empty()) RELIGHT_USER_ERROR() << name << ": the mesh is empty";
    if (surface.mesh.normals.size() != surface.mesh.num_vertices()) surface.mesh.ComputeVertexNormals();
    const ReflectanceModel& model = surface.reflectance;
    const int num_lobes = static_cast<int>(model.basis.size());
    if (num_lobes < 1 || num_lobes > kMaxLobes) {
      RELIGHT_USER_ERROR() << name << ": " << num_lobes << " basis BRDFs; the renderer supports 1 to " << kMaxLobes;
    }
    if (model.materials.empty()) RELIGHT_USER_ERROR() << name << ": the reflectance model has no materials";
    for (const BrdfLobe& lobe : model.basis) lobe.Check();
    for (const Material& m : model.materials) {
      if (static_cast<int>(m.coefficients.size()) != num_lobes) {
        RELIGHT_USER_ERROR() << name << ": material '" << m.name << "' has " << m.coefficients.size()
                             << " coefficients for " << num_lobes << " basis BRDFs";
      }
      for (const auto& c : m.coefficients) {
        if (!(c.minCoeff() >= 0)) {
          RELIGHT_USER_ERROR() << name << ": material '" << m.name << "' has a negative coefficient";
        }
      }
    }
    const auto weights = VertexMaterialWeights(surface.mesh, static_cast<int>(model.materials.size()), name);
    std::vector<float>& rgb = lobe_rgb_[s];
    rgb.assign(surface.mesh.num_vertices() * num_lobes * 3, 0.0f);
    for (size_t v = 0; v < surface.mesh.num_vertices(); ++v) {
      for (int b = 0; b < num_lobes; ++b) {
        Eigen::Vector3d k = Eigen::Vector3d::Zero();
        for (size_t m = 0; m < model.materials.size(); ++m) k += weights[v][m] * model.materials[m].coefficients[b];
        for (int c = 0; c < 3; ++c) rgb[(v * num_lobes + b) * 3 + c] = static_cast<float>(k[c]);
      }
    }
  }
  std::vector<const TriangleMesh*> meshes;
  for (const Surface& s : surfaces_) meshes.push_back(&s.mesh);
  caster_ = std::make_unique<RayCaster>(meshes);
}

Scene::~Scene() = default;

SurfacePoint Scene::PointFromHit(const RayHit& hit) const {
  RELIGHT_CHECK(hit.hit);
  SurfacePoint p;
  p.surface = static_cast<int>(hit.geom_id);
  const Surface& s = surfaces_[p.surface];
  p.position_world = hit.point.cast<double>();
  p.normal_geometric_world = hit.normal.cast<double>();
  p.normal_shading_world = caster_->ShadingNormal(hit).cast<double>().normalized();
  if (!(p.normal_geometric_world.squaredNorm() > 0.5)) p.normal_geometric_world = p.normal_shading_world;
  const int num_lobes = static_cast<int>(s.reflectance.basis.size());
  p.num_lobes = num_lobes;
  const Eigen::Vector3i& f = s.mesh.faces[hit.prim_id];
  const double b0 = 1.0 - hit.u - hit.v, b1 = hit.u, b2 = hit.v;
  const float* rgb = lobe_rgb_[p.surface].data();
  for (int b = 0; b < num_lobes; ++b) {
    for (int c = 0; c < 3; ++c) {
      p.lobe_rgb[b][c] = b0 * rgb[(size_t(f[0]) * num_lobes + b) * 3 + c] +
                         b1 * rgb[(size_t(f[1]) * num_lobes + b) * 3 + c] +
                         b2 * rgb[(size_t(f[2]) * num_lobes + b) * 3 + c];
    }
  }
  return p;
}

SurfacePoint Scene::PointAtVertex(int surface, int vertex) const {
  RELIGHT_CHECK(surface >= 0 && surface < num_surfaces()) << surface;
  const Surface& s = surfaces_[surface];
  RELIGHT_CHECK(vertex >= 0 && vertex < static_cast<int>(s.mesh.num_vertices())) << vertex;
  SurfacePoint p;
  p.surface = surface;
  p.position_world = s.mesh.vertices[vertex].cast<double>();
  const Eigen::Vector3d n = s.mesh.normals[vertex].cast<double>();
  p.normal_shading_world = n.norm() > 1e-12 ? n.normalized() : Eigen::Vector3d::UnitZ();
  p.normal_geometric_world = p.normal_shading_world;
  const int num_lobes = static_cast<int>(s.reflectance.basis.size());
  p.num_lobes = num_lobes;
  const float* rgb = lobe_rgb_[surface].data();
  for (int b = 0; b < num_lobes; ++b)
    for (int c = 0; c < 3; ++c) p.lobe_rgb[b][c] = rgb[(size_t(vertex) * num_lobes + b) * 3 + c];
  return p;
}

}  // namespace relight
