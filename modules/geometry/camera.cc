#include "geometry/camera.h"

#include <Eigen/LU>
#include <cmath>

#include "core/error.h"

namespace relight {
namespace {

struct ModelInfo {
  const char* name;
  int id;
  int num_params;
};
constexpr ModelInfo kModels[] = {{"SIMPLE_PINHOLE", 0, 3}, {"PINHOLE", 1, 4},  {"SIMPLE_RADIAL", 2, 4},
                                 {"RADIAL", 3, 5},         {"OPENCV", 4, 8},   {"FULL_OPENCV", 6, 12}};

const ModelInfo& Info(const std::string& model) {
  for (const auto& m : kModels)
    if (model == m.name) return m;
  RELIGHT_USER_ERROR() << "camera model '" << model
                       << "' is not supported; use SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV or "
                          "FULL_OPENCV (e.g. sfm.camera_model)";
}

bool SingleFocal(const std::string& model) {
  return model == "SIMPLE_PINHOLE" || model == "SIMPLE_RADIAL" || model == "RADIAL";
}

}  // namespace

Camera Camera::Pinhole(uint32_t id, int width, int height, double fx, double fy, double cx, double cy) {
  Camera c;
  c.camera_id = id;
  c.model = "PINHOLE";
  c.width = width;
  c.height = height;
  c.params = {fx, fy, cx, cy};
  return c;
}

int Camera::ModelId(const std::string& model) { return Info(model).id; }

std::string Camera::ModelName(int model_id) {
  for (const auto& m : kModels)
    if (m.id == model_id) return m.name;
  RELIGHT_USER_ERROR() << "camera model id " << model_id
                       << " is not supported (supported: SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV, "
                          "FULL_OPENCV); rerun SfM with one of them";
}

int Camera::NumParams(const std::string& model) { return Info(model).num_params; }

double Camera::FocalX() const { return params[0]; }
double Camera::FocalY() const { return SingleFocal(model) || model == "SIMPLE_PINHOLE" ? params[0] : params[1]; }
double Camera::PrincipalX() const { return SingleFocal(model) ? params[1] : params[2]; }
double Camera::PrincipalY() const { return SingleFocal(model) ? params[2] : params[3]; }

Eigen::Matrix3d Camera::K() const {
  Eigen::Matrix3d k = Eigen::Matrix3d::Identity();
  k(0, 0) = FocalX();
  k(1, 1) = FocalY();
  k(0, 2) = PrincipalX();
  k(1, 2) = PrincipalY();
  return k;
}

bool Camera::HasDistortion() const {
  if (model == "SIMPLE_PINHOLE" || model == "PINHOLE") return false;
  const int first = SingleFocal(model) ? 3 : 4;
  for (size_t i = first; i < params.size(); ++i)
    if (params[i] != 0.0) return true;
  return false;
}

void Camera::Check(const std::string& where) const {
  const ModelInfo& info = Info(model);
  if (static_cast<int>(params.size()) != info.num_params) {
    RELIGHT_USER_ERROR() << where << ": camera " << camera_id << " (" << model << ") has " << params.size()
                         << " parameters, expected " << info.num_params;
  }
  if (width <= 0 || height <= 0) {
    RELIGHT_USER_ERROR() << where << ": camera " << camera_id << " has invalid size " << width << "x" << height;
  }
  for (double p : params) {
    if (!std::isfinite(p)) {
      RELIGHT_USER_ERROR() << where << ": camera " << camera_id << " has a parameter that is not a finite number";
    }
  }
  if (!(FocalX() > 0) || !(FocalY() > 0)) {
    RELIGHT_USER_ERROR() << where << ": camera " << camera_id << " has a non-positive focal length";
  }
}

Eigen::Vector2d Camera::Distort(const Eigen::Vector2d& n) const {
  const double u = n.x(), v = n.y();
  const double u2 = u * u, v2 = v * v, uv = u * v, r2 = u2 + v2;
  if (model == "SIMPLE_RADIAL") {
    const double radial = params[3] * r2;
    return {u + u * radial, v + v * radial};
  }
  if (model == "RADIAL") {
    const double radial = params[3] * r2 + params[4] * r2 * r2;
    return {u + u * radial, v + v * radial};
  }
  if (model == "OPENCV") {
    const double k1 = params[4], k2 = params[5], p1 = params[6], p2 = params[7];
    const double radial = k1 * r2 + k2 * r2 * r2;
    return {u + u * radial + 2 * p1 * uv + p2 * (r2 + 2 * u2), v + v * radial + 2 * p2 * uv + p1 * (r2 + 2 * v2)};
  }
  if (model == "FULL_OPENCV") {
    const double k1 = params[4], k2 = params[5], p1 = params[6], p2 = params[7], k3 = params[8], k4 = params[9],
                 k5 = params[10], k6 = params[11];
    const double r4 = r2 * r2, r6 = r4 * r2;
    const double radial = (1 + k1 * r2 + k2 * r4 + k3 * r6) / (1 + k4 * r2 + k5 * r4 + k6 * r6);
    return {u * radial + 2 * p1 * uv + p2 * (r2 + 2 * u2), v * radial + 2 * p2 * uv + p1 * (r2 + 2 * v2)};
  }
  return n;
}

Eigen::Vector2d Camera::ImageFromNormalized(const Eigen::Vector2d& normalized) const {
  const Eigen::Vector2d d = Distort(normalized);
  return {FocalX() * d.x() + PrincipalX(), FocalY() * d.y() + PrincipalY()};
}

Eigen::Vector2d Camera::ImageFromCamera(const Eigen::Vector3d& p) const {
  return ImageFromNormalized(Eigen::Vector2d(p.x() / p.z(), p.y() / p.z()));
}

Eigen::Vector2d Camera::NormalizedFromImage(const Eigen::Vector2d& pixel) const {
  const Eigen::Vector2d distorted((pixel.x() - PrincipalX()) / FocalX(), (pixel.y() - PrincipalY()) / FocalY());
  if (!HasDistortion()) return distorted;
  if (model == "SIMPLE_RADIAL" || model == "RADIAL") {
    // Radial: distorted = n (1 + k1 r² + k2 r⁴) with r = |n|, so n is distorted scaled by r / |distorted|, r the
    // root of r (1 + k1 r² + k2 r⁴) = |distorted| that Newton's method reaches from r = |distorted| (the one
    // inside the distortion's fold, where the derivative stays positive).
    const double k1 = params[3], k2 = model == "RADIAL" ? params[4] : 0.0, rd = distorted.norm();
    if (!(rd > 0)) return distorted;
    double r = rd;
    for (int iter = 0; iter < 100; ++iter) {
      const double r2 = r * r;
      const double slope = 1 + 3 * k1 * r2 + 5 * k2 * r2 * r2;
      if (!(slope > 0)) break;  // beyond the fold: no unique inverse
      const double step = (r * (1 + k1 * r2 + k2 * r2 * r2) - rd) / slope;
      r -= step;
      if (std::abs(step) <= 1e-15 * r) break;
    }
    return distorted * (r / rd);
  }
  // Newton iterations on Distort(n) = distorted, with a numeric Jacobian (as COLMAP does), solved in closed form.
  Eigen::Vector2d n = distorted;
  for (int iter = 0; iter < 100; ++iter) {
    const Eigen::Vector2d at_n = Distort(n);
    const Eigen::Vector2d f = at_n - distorted;
    if (f.squaredNorm() < 1e-24) break;
    Eigen::Matrix2d jac;
    const double h = 1e-7 * std::max(1.0, n.norm());
    for (int k = 0; k < 2; ++k) {
      Eigen::Vector2d dn = n;
      dn[k] += h;
      jac.col(k) = (Distort(dn) - at_n) / h;
    }
    const double det = jac.determinant();
    if (!(std::abs(det) > 1e-300)) break;  // singular: the distortion folds here
    const Eigen::Vector2d step =
        Eigen::Vector2d(jac(1, 1) * f.x() - jac(0, 1) * f.y(), jac(0, 0) * f.y() - jac(1, 0) * f.x()) / det;
    n -= step;
    if (step.squaredNorm() < 1e-24) break;
  }
  return n;
}

Eigen::Vector3d Camera::RayFromImage(const Eigen::Vector2d& pixel) const {
  const Eigen::Vector2d n = NormalizedFromImage(pixel);
  return Eigen::Vector3d(n.x(), n.y(), 1.0).normalized();
}

void Camera::Rescale(double scale) {
  width = std::max(1, static_cast<int>(std::lround(width * scale)));
  height = std::max(1, static_cast<int>(std::lround(height * scale)));
  const int pixel_params = SingleFocal(model) ? 3 : 4;
  for (int i = 0; i < pixel_params; ++i) params[i] *= scale;
}

}  // namespace relight
