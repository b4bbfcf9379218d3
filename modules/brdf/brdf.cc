#include "brdf/brdf.h"

#include <Eigen/Core>
#include <algorithm>
#include <limits>
#include <sstream>

#include "core/error.h"
#include "core/fs.h"

namespace relight {
namespace {

// Orthonormal basis around unit vector `n` (any continuous choice will do here).
void Basis(const Eigen::Vector3d& n, Eigen::Vector3d* t, Eigen::Vector3d* b) {
  const double sign = std::copysign(1.0, n.z());
  const double a = -1.0 / (sign + n.z());
  const double c = n.x() * n.y() * a;
  *t = Eigen::Vector3d(1.0 + sign * n.x() * n.x() * a, sign * c, -sign * n.x());
  *b = Eigen::Vector3d(c, sign + n.y() * n.y() * a, -n.y());
}

double MicrofacetD(const BrdfLobe& lobe, double cos_h) {
  if (cos_h <= 0) return 0;
  const double cos_h2 = cos_h * cos_h;
  const double tan_h2 = (1 - cos_h2) / cos_h2;
  const double a2 = lobe.roughness * lobe.roughness;
  if (lobe.model == BrdfModel::kCookTorrance) return std::exp(-tan_h2 / a2) / (M_PI * a2 * cos_h2 * cos_h2);
  const double denom = a2 + tan_h2;
  return a2 / (M_PI * cos_h2 * cos_h2 * denom * denom);
}

}  // namespace

std::string BrdfModelName(BrdfModel model) {
  switch (model) {
    case BrdfModel::kLambertian: return "lambertian";
    case BrdfModel::kCookTorrance: return "cook_torrance";
    case BrdfModel::kGgx: return "ggx";
    case BrdfModel::kPhong: return "phong";
  }
  return "?";
}

BrdfModel ParseBrdfModel(const std::string& name) {
  if (name == "lambertian") return BrdfModel::kLambertian;
  if (name == "cook_torrance" || name == "beckmann") return BrdfModel::kCookTorrance;
  if (name == "ggx") return BrdfModel::kGgx;
  if (name == "phong" || name == "lafortune") return BrdfModel::kPhong;
  RELIGHT_USER_ERROR() << "unknown BRDF model '" << name << "'; allowed: lambertian, cook_torrance, ggx, phong";
}

void BrdfLobe::Check() const {
  if ((model == BrdfModel::kCookTorrance || model == BrdfModel::kGgx) && !(roughness > 0 && roughness <= 1)) {
    RELIGHT_USER_ERROR() << Describe() << ": roughness must be in (0, 1]";
  }
  if ((model == BrdfModel::kCookTorrance || model == BrdfModel::kGgx) && !(f0 >= 0 && f0 <= 1)) {
    RELIGHT_USER_ERROR() << Describe() << ": f0 must be in [0, 1]";
  }
  if (model == BrdfModel::kPhong && !(exponent >= 0)) {
    RELIGHT_USER_ERROR() << Describe() << ": exponent must be >= 0";
  }
}

std::string BrdfLobe::Describe() const {
  std::ostringstream s;
  s << BrdfModelName(model);
  if (model == BrdfModel::kCookTorrance || model == BrdfModel::kGgx) {
    s << "(alpha=" << roughness << ", f0=" << f0 << ")";
  } else if (model == BrdfModel::kPhong) {
    s << "(n=" << exponent << ")";
  }
  return s.str();
}

Eigen::Vector3d BrdfLobe::Sample(const Eigen::Vector3d& wo, double u1, double u2, double* pdf) const {
  switch (model) {
    case BrdfModel::kLambertian: {
      const double r = std::sqrt(u1), phi = 2 * M_PI * u2;
      const Eigen::Vector3d wi(r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.0, 1 - u1)));
      *pdf = wi.z() / M_PI;
      return wi;
    }
    case BrdfModel::kPhong: {
      const Eigen::Vector3d mirror(-wo.x(), -wo.y(), wo.z());
      const double cos_a = std::pow(std::max(u1, 1e-300), 1.0 / (exponent + 1.0));
      const double sin_a = std::sqrt(std::max(0.0, 1 - cos_a * cos_a));
      const double phi = 2 * M_PI * u2;
      Eigen::Vector3d t, b;
      Basis(mirror, &t, &b);
      const Eigen::Vector3d wi = (t * (sin_a * std::cos(phi)) + b * (sin_a * std::sin(phi)) + mirror * cos_a).normalized();
      *pdf = Pdf(wo, wi);
      return wi;
    }
    case BrdfModel::kCookTorrance:
    case BrdfModel::kGgx: {
      const double a2 = roughness * roughness;
      const double tan2 = model == BrdfModel::kCookTorrance ? -a2 * std::log(std::max(1e-300, 1 - u1))
                                                            : a2 * u1 / std::max(1e-300, 1 - u1);
      const double cos_m = 1 / std::sqrt(1 + tan2);
      const double sin_m = std::sqrt(std::max(0.0, 1 - cos_m * cos_m));
      const double phi = 2 * M_PI * u2;
      const Eigen::Vector3d m(sin_m * std::cos(phi), sin_m * std::sin(phi), cos_m);
      const Eigen::Vector3d wi = 2 * wo.dot(m) * m - wo;
      *pdf = Pdf(wo, wi);
      return wi;
    }
  }
  *pdf = 0;
  return Eigen::Vector3d::UnitZ();
}

double BrdfLobe::Pdf(const Eigen::Vector3d& wo, const Eigen::Vector3d& wi) const {
  switch (model) {
    case BrdfModel::kLambertian: return std::max(0.0, wi.z()) / M_PI;
    case BrdfModel::kPhong: {
      const Eigen::Vector3d mirror(-wo.x(), -wo.y(), wo.z());
      const double c = wi.dot(mirror);
      return c > 0 ? (exponent + 1) / (2 * M_PI) * std::pow(c, exponent) : 0.0;
    }
    case BrdfModel::kCookTorrance:
    case BrdfModel::kGgx: {
      Eigen::Vector3d h = wi + wo;
      if (h.norm() < 1e-12) return 0;
      h.normalize();
      // Sample() also reflects about microfacets facing away from wo; their half
      // vector points down, so orient h upwards to count them.
      if (h.z() < 0) h = -h;
      const double o_dot_h = std::abs(wo.dot(h));
      if (o_dot_h < 1e-12) return 0;
      return MicrofacetD(*this, h.z()) * h.z() / (4 * o_dot_h);
    }
  }
  return 0;
}

Eigen::Vector3d ReflectanceModel::Eval(const std::vector<double>& w, const Eigen::Vector3d& wi,
                                       const Eigen::Vector3d& wo) const {
  RELIGHT_CHECK_EQ(w.size(), materials.size());
  Eigen::Vector3d lobe_weight = Eigen::Vector3d::Zero();
  Eigen::Vector3d out = Eigen::Vector3d::Zero();
  for (size_t b = 0; b < basis.size(); ++b) {
    lobe_weight.setZero();
    for (size_t m = 0; m < materials.size(); ++m) lobe_weight += w[m] * materials[m].coefficients[b];
    if (lobe_weight.isZero()) continue;
    out += lobe_weight * basis[b].Eval<double>(wi, wo);
  }
  return out;
}

Eigen::Vector3d ReflectanceModel::DiffuseAlbedo(const std::vector<double>& w) const {
  Eigen::Vector3d out = Eigen::Vector3d::Zero();
  for (size_t b = 0; b < basis.size(); ++b) {
    if (basis[b].model != BrdfModel::kLambertian) continue;
    for (size_t m = 0; m < materials.size() && m < w.size(); ++m) out += w[m] * materials[m].coefficients[b];
  }
  return out;
}

Json BrdfLobeToJson(const BrdfLobe& lobe) {
  Json j;
  j["model"] = BrdfModelName(lobe.model);
  if (lobe.model == BrdfModel::kCookTorrance || lobe.model == BrdfModel::kGgx) {
    j["roughness"] = lobe.roughness;
    j["f0"] = lobe.f0;
  } else if (lobe.model == BrdfModel::kPhong) {
    j["exponent"] = lobe.exponent;
  }
  return j;
}

BrdfLobe BrdfLobeFromJson(const Json& j) {
  BrdfLobe lobe;
  lobe.model = ParseBrdfModel(j.at("model").get<std::string>());
  lobe.roughness = j.value("roughness", lobe.roughness);
  lobe.f0 = j.value("f0", lobe.f0);
  lobe.exponent = j.value("exponent", lobe.exponent);
  lobe.Check();
  return lobe;
}

Json ReflectanceModelToJson(const ReflectanceModel& model) {
  Json j;
  j["format"] = "relight-materials";
  j["version"] = 1;
  j["basis"] = Json::array();
  for (const auto& b : model.basis) j["basis"].push_back(BrdfLobeToJson(b));
  j["materials"] = Json::array();
  for (const auto& m : model.materials) {
    Json coeffs = Json::array();
    for (const auto& c : m.coefficients) coeffs.push_back({c.x(), c.y(), c.z()});
    j["materials"].push_back({{"name", m.name}, {"coefficients", coeffs}});
  }
  return j;
}

ReflectanceModel ReflectanceModelFromJson(const Json& j, const std::string& source) {
  ReflectanceModel model;
  try {
    for (const auto& b : j.at("basis")) model.basis.push_back(BrdfLobeFromJson(b));
    for (const auto& m : j.at("materials")) {
      Material mat;
      mat.name = m.value("name", "");
      for (const auto& c : m.at("coefficients")) {
        const Eigen::Vector3d rgb(c.at(0).get<double>(), c.at(1).get<double>(), c.at(2).get<double>());
        if ((rgb.array() < 0).any()) RELIGHT_USER_ERROR() << source << ": material coefficients must be >= 0";
        mat.coefficients.push_back(rgb);
      }
      if (mat.coefficients.size() != model.basis.size()) {
        RELIGHT_USER_ERROR() << source << ": material '" << mat.name << "' has " << mat.coefficients.size()
                             << " coefficients for " << model.basis.size() << " basis BRDFs";
      }
      model.materials.push_back(mat);
    }
  } catch (const Json::exception& e) {
    RELIGHT_USER_ERROR() << source << ": malformed materials file (" << e.what() << ")";
  }
  return model;
}

ReflectanceModel ReadReflectanceModel(const std::string& path) {
  return ReflectanceModelFromJson(ReadJsonFile(path), path);
}

void WriteReflectanceModel(const std::string& path, const ReflectanceModel& model) {
  WriteJsonAtomic(path, ReflectanceModelToJson(model));
}

void BrdfLobe::EvalCosinesBatch(float cos_o, int n, const float* cos_i_ptr, const float* cos_h_ptr,
                                const float* o_dot_h_ptr, const float* cos_mirror_ptr, float* out_ptr) const {
  // Chunks of at most 256 directions on the stack (no allocation per call). Eigen evaluates a select()
  // coefficient by coefficient, so what is costly (exp, log, sqrt, divisions) is computed before the masks.
  constexpr int kChunk = 256;
  using Chunk = Eigen::Array<float, Eigen::Dynamic, 1, Eigen::ColMajor, kChunk, 1>;
  using ConstMap = Eigen::Map<const Eigen::ArrayXf>;
  if (!(cos_o > 0) || model == BrdfModel::kLambertian) {
    const float lambert = cos_o > 0 ? static_cast<float>(1.0 / M_PI) : 0.0f;
    for (int k = 0; k < n; ++k) out_ptr[k] = cos_i_ptr[k] > 0 ? lambert : 0.0f;
    return;
  }
  const float a2 = static_cast<float>(roughness * roughness), f0f = static_cast<float>(f0);
  for (int first = 0; first < n; first += kChunk) {
    const int len = std::min(kChunk, n - first);
    const ConstMap cos_i(cos_i_ptr + first, len);
    Eigen::Map<Eigen::ArrayXf> out(out_ptr + first, len);
    Chunk value(len);
    if (model == BrdfModel::kPhong) {
      // c^n as exp(n log c), which Eigen vectorises; used where c > 0.
      const ConstMap cos_mirror(cos_mirror_ptr + first, len);
      value = cos_mirror.max(std::numeric_limits<float>::min()).log();
      value = (static_cast<float>(exponent) * value).exp() * static_cast<float>((exponent + 2.0) / (2.0 * M_PI));
      out = ((cos_i > 0.0f) && (cos_mirror > 0.0f)).select(value, 0.0f);
      continue;
    }
    const ConstMap cos_h(cos_h_ptr + first, len), o_dot_h(o_dot_h_ptr + first, len);
    Chunk m = 1.0f - o_dot_h.max(0.0f);
    const Chunk fresnel = f0f + (1.0f - f0f) * m.square().square() * m;  // brdf_internal::Schlick
    if (model == BrdfModel::kGgx) {
      // GgxViewFactor(cos_o) · Schlick · GgxHalfFactor(cos_i, cos_h) / cos_i, the last divided out.
      const Chunk t = a2 + (1.0f - a2) * ((1.0f - cos_h) * (1.0f + cos_h));
      value = (a2 + (1.0f - a2) * cos_i.square()).sqrt();
      value = (GgxViewFactor(cos_o) * static_cast<float>(2 * roughness * roughness / M_PI)) * fresnel /
              (t.square() * (cos_i + value));
    } else {
      // Cook-Torrance: Beckmann D, V-cavity G (EvalCosines).
      const Chunk cos_h2 = cos_h.square();
      value = (-((1.0f - cos_h2) / cos_h2) / a2).exp() / (static_cast<float>(M_PI) * a2 * cos_h2.square());
      m = (2.0f * cos_h * cos_i / o_dot_h).min(2.0f * cos_h * cos_o / o_dot_h).min(1.0f);
      value = value * m * fresnel / (4.0f * cos_i * cos_o);
    }
    out = (cos_i > 0.0f).select(value, 0.0f);
  }
}

}  // namespace relight
