#include "synth/shapes.h"

#include <Eigen/Geometry>
#include <cmath>
#include <map>
#include <utility>

#include "core/error.h"
#include "geometry/primitives.h"
#include "meshing/mesh_cleanup.h"
#include "synth/noise.h"

namespace relight {
namespace {

int IcosphereLevels(int min_vertices) {
  int levels = 0;
  while (10 * (int64_t(1) << (2 * levels)) + 2 < min_vertices && levels < 9) ++levels;
  return levels;
}

}  // namespace

TriangleMesh MakeSphere(int min_vertices) { return MakeIcosphere(IcosphereLevels(min_vertices)); }

TriangleMesh MakeTorusKnot(int min_vertices) {
  // Curve of the (p, q) = (2, 3) torus knot on a torus of radii 2 and 1; tube radius 0.5.
  const int p = 2, q = 3;
  const double tube = 0.5;
  const int around = std::max(8, int(std::lround(std::sqrt(min_vertices / 10.0))));
  const int along = std::max(24, (min_vertices + around - 1) / around);
  auto curve = [&](double t) {
    const double r = 2.0 + std::cos(q * t);
    return Eigen::Vector3d(r * std::cos(p * t), r * std::sin(p * t), std::sin(q * t));
  };
  TriangleMesh mesh;
  for (int i = 0; i < along; ++i) {
    const double t = 2 * M_PI * i / along;
    const Eigen::Vector3d c = curve(t);
    const Eigen::Vector3d tangent = (curve(t + 1e-4) - curve(t - 1e-4)).normalized();
    const Eigen::Vector3d radial(std::cos(p * t), std::sin(p * t), 0.0);
    const Eigen::Vector3d normal = (radial - radial.dot(tangent) * tangent).normalized();
    const Eigen::Vector3d binormal = tangent.cross(normal);
    for (int j = 0; j < around; ++j) {
      const double a = 2 * M_PI * j / around;
      const Eigen::Vector3d n = std::cos(a) * normal + std::sin(a) * binormal;
      mesh.vertices.push_back((c + tube * n).cast<float>());
      mesh.normals.push_back(n.cast<float>());
    }
  }
  for (int i = 0; i < along; ++i)
    for (int j = 0; j < around; ++j) {
      const int i1 = (i + 1) % along, j1 = (j + 1) % around;
      const int a = i * around + j, b = i1 * around + j, c = i1 * around + j1, d = i * around + j1;
      // (tangent, normal, binormal) is right-handed: d(around) x d(along) points outwards.
      mesh.faces.emplace_back(a, d, c);
      mesh.faces.emplace_back(a, c, b);
    }
  return mesh;
}

TriangleMesh MakeBlob(int min_vertices, uint64_t seed) {
  TriangleMesh mesh = MakeIcosphere(IcosphereLevels(min_vertices));
  const GradientNoise noise(seed);
  for (auto& v : mesh.vertices) {
    const Eigen::Vector3d d = v.cast<double>();
    // Low-frequency lumps plus a squash along z: non-convex, with cavities that shadow themselves.
    const double r = 1.0 + 0.9 * noise.Fractal(1.3 * d + Eigen::Vector3d(3.1, 7.7, 1.9), 3, 0.45);
    v = (r * Eigen::Vector3d(d.x(), d.y(), 0.8 * d.z())).cast<float>();
  }
  mesh.normals.clear();
  mesh.ComputeVertexNormals();
  return mesh;
}

TriangleMesh MakeShape(const std::string& shape, int min_vertices, uint64_t seed) {
  if (shape == "sphere") return MakeSphere(min_vertices);
  if (shape == "torus_knot") return MakeTorusKnot(min_vertices);
  if (shape == "blob") return MakeBlob(min_vertices, seed);
  RELIGHT_USER_ERROR() << "unknown built-in shape '" << shape << "'; allowed: sphere, torus_knot, blob "
                       << "(or set a mesh file)";
}

void RotateUp(TriangleMesh* mesh, const std::string& up, double yaw_deg) {
  Eigen::Matrix3d r;
  if (up == "+z") {
    r.setIdentity();
  } else if (up == "-z") {
    r = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  } else if (up == "+y") {
    r = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  } else if (up == "-y") {
    r = Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  } else if (up == "+x") {
    r = Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitY()).toRotationMatrix();
  } else if (up == "-x") {
    r = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY()).toRotationMatrix();
  } else {
    RELIGHT_USER_ERROR() << "unknown up axis '" << up << "'; allowed: +x, -x, +y, -y, +z, -z";
  }
  r = Eigen::AngleAxisd(yaw_deg * M_PI / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix() * r;
  const Eigen::Matrix3f rf = r.cast<float>();
  for (auto& v : mesh->vertices) v = rf * v;
  for (auto& n : mesh->normals) n = rf * n;
}

void NormalizeOntoGround(TriangleMesh* mesh, double size) {
  RELIGHT_CHECK(!mesh->vertices.empty());
  const Eigen::AlignedBox3f box = mesh->BoundingBox();
  const double largest = box.sizes().maxCoeff();
  RELIGHT_CHECK_GT(largest, 0.0);
  const double scale = size / largest;
  const Eigen::Vector3d shift(-box.center().x(), -box.center().y(), -box.min().z());
  for (auto& v : mesh->vertices) v = ((v.cast<double>() + shift) * scale).cast<float>();
}

void SubdivideToVertices(TriangleMesh* mesh, int min_vertices) {
  if (mesh->normals.size() != mesh->num_vertices()) mesh->ComputeVertexNormals();
  while (static_cast<int>(mesh->num_vertices()) < min_vertices && !mesh->faces.empty()) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      const auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      mesh->vertices.push_back(0.5f * (mesh->vertices[a] + mesh->vertices[b]));
      Eigen::Vector3f n = mesh->normals[a] + mesh->normals[b];
      mesh->normals.push_back(n.norm() > 1e-12f ? n.normalized() : mesh->normals[a]);
      for (auto& [name, values] : mesh->properties) values.push_back(0.5f * (values[a] + values[b]));
      if (!mesh->colors.empty()) mesh->colors.push_back(mesh->colors[a]);
      return mid[key] = int(mesh->vertices.size()) - 1;
    };
    std::vector<Eigen::Vector3i> faces;
    faces.reserve(mesh->faces.size() * 4);
    for (const auto& tri : mesh->faces) {
      const int a = midpoint(tri[0], tri[1]), b = midpoint(tri[1], tri[2]), c = midpoint(tri[2], tri[0]);
      faces.emplace_back(tri[0], a, c);
      faces.emplace_back(tri[1], b, a);
      faces.emplace_back(tri[2], c, b);
      faces.emplace_back(a, b, c);
    }
    mesh->faces = std::move(faces);
  }
}

TriangleMesh MakeGroundPlane(double size, int cells) {
  RELIGHT_CHECK_GT(cells, 0);
  TriangleMesh mesh;
  const double half = size / 2;
  for (int j = 0; j <= cells; ++j)
    for (int i = 0; i <= cells; ++i) {
      mesh.vertices.emplace_back(float(-half + size * i / cells), float(-half + size * j / cells), 0.0f);
      mesh.normals.emplace_back(0.0f, 0.0f, 1.0f);
    }
  for (int j = 0; j < cells; ++j)
    for (int i = 0; i < cells; ++i) {
      const int a = j * (cells + 1) + i, b = a + 1, c = a + cells + 2, d = a + cells + 1;
      mesh.faces.emplace_back(a, b, c);
      mesh.faces.emplace_back(a, c, d);
    }
  return mesh;
}

TriangleMesh MakeGroundDisk(double size, int rings) {
  RELIGHT_CHECK_GT(rings, 0);
  TriangleMesh mesh;
  const double radius = size / 2;
  // Ring k: 6k vertices, the j-th at angle 2π j / 6k (so that each of the six sectors holds k edges).
  auto first = [](int k) { return k == 0 ? 0 : 1 + 3 * k * (k - 1); };  // index of ring k's first vertex
  mesh.vertices.emplace_back(0.0f, 0.0f, 0.0f);
  for (int k = 1; k <= rings; ++k) {
    const double r = radius * k / rings;
    for (int j = 0; j < 6 * k; ++j) {
      const double a = 2 * M_PI * j / (6.0 * k);
      mesh.vertices.emplace_back(float(r * std::cos(a)), float(r * std::sin(a)), 0.0f);
    }
  }
  mesh.normals.assign(mesh.vertices.size(), Eigen::Vector3f(0, 0, 1));
  // Between ring k-1 (inner, 6(k-1) vertices) and ring k (outer, 6k): in each sector s the outer ring
  // has k edges and the inner ring k-1; walk both, always advancing the side whose next vertex lies at
  // the smaller angle (counter-clockwise faces, normal +Z).
  for (int k = 1; k <= rings; ++k) {
    const int n_in = 6 * (k - 1), n_out = 6 * k;
    int i = 0, o = 0;  // steps taken on the inner and outer ring
    while (i < n_in || o < n_out) {
      const int a_in = k == 1 ? 0 : first(k - 1) + i % n_in;
      const int a_out = first(k) + o % n_out;
      // Angles of the next vertices (fractions of the full turn).
      const double next_in = n_in == 0 ? 2.0 : double(i + 1) / n_in;
      const double next_out = double(o + 1) / n_out;
      if (o < n_out && (i >= n_in || next_out <= next_in)) {
        mesh.faces.emplace_back(a_in, a_out, first(k) + (o + 1) % n_out);
        ++o;
      } else {
        mesh.faces.emplace_back(a_in, a_out, first(k - 1) + (i + 1) % n_in);
        ++i;
      }
    }
  }
  return mesh;
}

TriangleMesh MakeBox(const Eigen::Vector3d& min, const Eigen::Vector3d& max, int cells) {
  RELIGHT_CHECK_GT(cells, 0);
  TriangleMesh mesh;
  // Each face: an origin corner and two edge vectors whose cross product points outwards.
  const Eigen::Vector3d e = max - min;
  const Eigen::Vector3d ex(e.x(), 0, 0), ey(0, e.y(), 0), ez(0, 0, e.z());
  const std::array<std::array<Eigen::Vector3d, 3>, 6> faces = {{
      {min, ey, ex},                        // bottom (-z)
      {Eigen::Vector3d(min + ez), ex, ey},  // top (+z)
      {min, ex, ez},                        // front (-y)
      {Eigen::Vector3d(min + ey), ez, ex},  // back (+y)
      {min, ez, ey},                        // left (-x)
      {Eigen::Vector3d(min + ex), ey, ez},  // right (+x)
  }};
  for (const auto& [origin, du, dv] : faces) {
    const Eigen::Vector3f n = du.cross(dv).normalized().cast<float>();
    const int base = static_cast<int>(mesh.vertices.size());
    for (int j = 0; j <= cells; ++j)
      for (int i = 0; i <= cells; ++i) {
        mesh.vertices.push_back((origin + du * (double(i) / cells) + dv * (double(j) / cells)).cast<float>());
        mesh.normals.push_back(n);
      }
    for (int j = 0; j < cells; ++j)
      for (int i = 0; i < cells; ++i) {
        const int a = base + j * (cells + 1) + i, b = a + 1, c = a + cells + 2, d = a + cells + 1;
        mesh.faces.emplace_back(a, b, c);
        mesh.faces.emplace_back(a, c, d);
      }
  }
  return mesh;
}

void BoundingSphere(const TriangleMesh& mesh, Eigen::Vector3d* center, double* radius) {
  *center = mesh.BoundingBox().center().cast<double>();
  double r2 = 0;
  for (const auto& v : mesh.vertices) r2 = std::max(r2, (v.cast<double>() - *center).squaredNorm());
  *radius = std::sqrt(r2);
}

bool SimplifyToVertices(TriangleMesh* mesh, int max_vertices, const std::string& where) {
  if (max_vertices <= 0 || mesh->num_vertices() <= size_t(max_vertices)) return false;
  MeshCleanupOptions simplify;
  simplify.target_vertices = max_vertices;
  simplify.max_components = 1 << 30;  // keep every part of the object
  simplify.min_component_fraction = 0.0;
  simplify.max_hole_edges = 0;        // leave the file's holes as they are
  MeshCleanupSummary summary;
  *mesh = CleanMesh(*mesh, simplify, where, &summary);
  return true;
}

}  // namespace relight
