// Basis BRDFs (lobes), materials as non-negative RGB blends of lobes, and the
// reflectance model file (materials.json, docs/FORMATS.md).
//
// Directions are in the local frame of sphere/frame.h (z = surface normal),
// pointing away from the surface. `Eval` returns the BRDF value in 1/sr
// *without* the cosine factor. Templated on the scalar type so one
// implementation serves double, float and ceres::Jet (Mitsuba-style).
//
// Lobes (each scaled so that its coefficient is roughly its albedo):
//  - Lambertian: 1/pi.
//  - Cook-Torrance: Beckmann D, Cook-Torrance V-cavity G, Schlick F, D G F / (4 cos_i cos_o).
//  - GGX (Trowbridge-Reitz) with separable Smith G1 and Schlick F, D G F / (4 cos_i cos_o).
//  - Phong / Lafortune cosine lobe about the mirror direction,
//    (n+2)/(2 pi) max(0, wi . reflect(wo))^n, i.e. Lafortune with Cxy = -1, Cz = 1
//    and energy normalisation.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <string>
#include <vector>

#include "core/json.h"

namespace relight {

enum class BrdfModel { kLambertian, kCookTorrance, kGgx, kPhong };

// "lambertian", "cook_torrance", "ggx", "phong".
std::string BrdfModelName(BrdfModel model);
// Parses the names above; throws UserError listing the allowed names.
BrdfModel ParseBrdfModel(const std::string& name);

namespace brdf_internal {
template <typename T>
T Max0(const T& x) {
  return x > T(0) ? x : T(0);
}
template <typename T>
T Schlick(const T& f0, const T& cos_theta) {
  const T m = T(1) - Max0(cos_theta);
  const T m2 = m * m;
  return f0 + (T(1) - f0) * m2 * m2 * m;
}
}  // namespace brdf_internal

// One basis BRDF.
struct BrdfLobe {
  BrdfModel model = BrdfModel::kLambertian;
  double roughness = 0.3;  // microfacet alpha (Cook-Torrance/Beckmann, GGX); 0 < alpha <= 1
  double f0 = 0.04;        // Schlick Fresnel reflectance at normal incidence (microfacet lobes)
  double exponent = 50.0;  // Phong/Lafortune exponent n

  // BRDF value (1/sr, no cosine) for local directions; 0 below the horizon.
  template <typename T>
  T Eval(const Eigen::Matrix<T, 3, 1>& wi, const Eigen::Matrix<T, 3, 1>& wo) const;
  // The same value from the cosines it depends on, for callers that hold
  // directions in another frame than the lobe's normal n (any rotation leaves
  // them unchanged, so no change of frame is needed): cos_i = n·wi > 0,
  // cos_o = n·wo > 0; microfacet lobes: cos_h = n·h and o_dot_h = max(0, wo·h)
  // with h = normalize(wi + wo); Phong: cos_mirror = wi·(2 cos_o n − wo).
  // Arguments a lobe does not use are ignored. Eval computes these and calls it.
  template <typename T>
  T EvalCosines(const T& cos_i, const T& cos_o, const T& cos_h, const T& o_dot_h, const T& cos_mirror) const;
  // EvalCosines at one outgoing direction for n incident directions, vectorised (Eigen arrays): out[k] =
  // EvalCosines(cos_i[k], cos_o, cos_h[k], o_dot_h[k], cos_mirror[k]) within float rounding, for the inner loops
  // of quadratures over many directions. Arrays the lobe does not use may be null.
  void EvalCosinesBatch(float cos_o, int n, const float* cos_i, const float* cos_h, const float* o_dot_h,
                        const float* cos_mirror, float* out) const;
  // GGX factored for many incident directions at one outgoing one (the
  // transport rows hoist what depends on wo alone):
  //   f(wi, wo) cos_i = GgxViewFactor(cos_o) · Schlick(f0, o_dot_h) · GgxHalfFactor(cos_i, cos_h),
  // GgxViewFactor = G1(cos_o) / (4 cos_o) and GgxHalfFactor = D(cos_h) G1(cos_i),
  // in the division-light forms D = α²/(π (α² + (1−α²) sin²θ_h)²) and
  // G1(c) = 2c / (c + sqrt(α² + (1−α²) c²)). Cosines > 0; EvalCosines uses them.
  template <typename T>
  T GgxViewFactor(const T& cos_o) const;
  template <typename T>
  T GgxHalfFactor(const T& cos_i, const T& cos_h) const;

  // Importance-samples an incident direction for outgoing `wo` (local, z>0)
  // from uniform numbers u1, u2 in [0,1). Returns the direction (may lie below
  // the horizon, where Eval is 0) and its solid-angle density in `pdf`.
  Eigen::Vector3d Sample(const Eigen::Vector3d& wo, double u1, double u2, double* pdf) const;
  // Solid-angle density of Sample() producing `wi`.
  double Pdf(const Eigen::Vector3d& wo, const Eigen::Vector3d& wi) const;
  // Short description, e.g. "ggx(alpha=0.2, f0=0.04)".
  std::string Describe() const;
  // Throws UserError when a parameter is out of its valid range.
  void Check() const;
};

// A material: RGB coefficient of each basis lobe (non-negative).
struct Material {
  std::string name;
  std::vector<Eigen::Vector3d> coefficients;  // one RGB triple per basis lobe
};

// Basis lobes and materials of a scene; a vertex's BRDF is
// sum_m w_m sum_b coefficients[m][b] * basis[b] with per-vertex weights w_m >= 0.
struct ReflectanceModel {
  std::vector<BrdfLobe> basis;
  std::vector<Material> materials;

  // RGB BRDF value of a weight vector (one weight per material).
  Eigen::Vector3d Eval(const std::vector<double>& material_weights, const Eigen::Vector3d& wi,
                       const Eigen::Vector3d& wo) const;
  // Diffuse (Lambertian-lobe) RGB albedo of a weight vector.
  Eigen::Vector3d DiffuseAlbedo(const std::vector<double>& material_weights) const;
};

Json BrdfLobeToJson(const BrdfLobe& lobe);
BrdfLobe BrdfLobeFromJson(const Json& j);
Json ReflectanceModelToJson(const ReflectanceModel& model);
// Throws UserError naming `source` on missing fields or bad values.
ReflectanceModel ReflectanceModelFromJson(const Json& j, const std::string& source);
ReflectanceModel ReadReflectanceModel(const std::string& path);
void WriteReflectanceModel(const std::string& path, const ReflectanceModel& model);

// ---------------------------------------------------------------------------

template <typename T>
T BrdfLobe::Eval(const Eigen::Matrix<T, 3, 1>& wi, const Eigen::Matrix<T, 3, 1>& wo) const {
  using std::sqrt;
  using brdf_internal::Max0;
  const T cos_i = wi.z();
  const T cos_o = wo.z();
  if (!(cos_i > T(0)) || !(cos_o > T(0))) return T(0);
  switch (model) {
    case BrdfModel::kLambertian:
      return T(1.0 / M_PI);
    case BrdfModel::kPhong: {
      const Eigen::Matrix<T, 3, 1> mirror(-wo.x(), -wo.y(), wo.z());
      return EvalCosines(cos_i, cos_o, T(0), T(0), T(wi.dot(mirror)));
    }
    case BrdfModel::kCookTorrance:
    case BrdfModel::kGgx: {
      Eigen::Matrix<T, 3, 1> h = wi + wo;
      const T h_norm = sqrt(h.squaredNorm());
      if (!(h_norm > T(1e-12))) return T(0);
      h /= h_norm;
      return EvalCosines(cos_i, cos_o, T(h.z()), T(Max0(wo.dot(h))), T(0));
    }
  }
  return T(0);
}

template <typename T>
T BrdfLobe::EvalCosines(const T& cos_i, const T& cos_o, const T& cos_h, const T& o_dot_h, const T& cos_mirror) const {
  using std::exp;
  using std::pow;
  using brdf_internal::Max0;
  if (!(cos_i > T(0)) || !(cos_o > T(0))) return T(0);
  switch (model) {
    case BrdfModel::kLambertian:
      return T(1.0 / M_PI);
    case BrdfModel::kPhong: {
      const T c = Max0(cos_mirror);
      if (!(c > T(0))) return T(0);
      return T((exponent + 2.0) / (2.0 * M_PI)) * pow(c, T(exponent));
    }
    case BrdfModel::kCookTorrance:
    case BrdfModel::kGgx: {
      const T f = brdf_internal::Schlick(T(f0), o_dot_h);
      if (model == BrdfModel::kGgx) return GgxViewFactor(cos_o) * f * GgxHalfFactor(cos_i, cos_h) / cos_i;
      const T cos_h2 = cos_h * cos_h;
      const T tan_h2 = (T(1) - cos_h2) / cos_h2;
      const T a2 = T(roughness * roughness);
      const T d = exp(-tan_h2 / a2) / (T(M_PI) * a2 * cos_h2 * cos_h2);
      // Cook-Torrance V-cavity masking-shadowing.
      const T gi = T(2) * cos_h * cos_i / o_dot_h;
      const T go = T(2) * cos_h * cos_o / o_dot_h;
      T g = T(1);
      if (gi < g) g = gi;
      if (go < g) g = go;
      return d * g * f / (T(4) * cos_i * cos_o);
    }
  }
  return T(0);
}

template <typename T>
T BrdfLobe::GgxViewFactor(const T& cos_o) const {
  using std::sqrt;
  const T a2 = T(roughness * roughness);
  return T(1) / (T(2) * (cos_o + sqrt(a2 + (T(1) - a2) * cos_o * cos_o)));
}

template <typename T>
T BrdfLobe::GgxHalfFactor(const T& cos_i, const T& cos_h) const {
  using std::sqrt;
  const T a2 = T(roughness * roughness);
  // (α²−1) cos_h² + 1 = α² + (1−α²) sin²θ_h, with sin² = (1−cos)(1+cos) free of
  // cancellation near the peak (1 − cos is exact there).
  const T t = a2 + (T(1) - a2) * ((T(1) - cos_h) * (T(1) + cos_h));
  return T(2 * roughness * roughness / M_PI) * cos_i / (t * t * (cos_i + sqrt(a2 + (T(1) - a2) * cos_i * cos_i)));
}

}  // namespace relight
