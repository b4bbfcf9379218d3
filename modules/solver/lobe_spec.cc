#include "solver/lobe_spec.h"

#include <sstream>

#include "core/error.h"

namespace relight {

BrdfLobe ParseLobeSpec(const std::string& spec) {
  std::vector<std::string> parts;
  std::stringstream ss(spec);
  std::string part;
  while (std::getline(ss, part, ':')) parts.push_back(part);
  auto bad = [&]() {
    RELIGHT_USER_ERROR() << "BRDF '" << spec
                         << "' is not understood; use lambertian, ggx:ALPHA[:F0], cook_torrance:ALPHA[:F0] or "
                            "phong:EXPONENT (e.g. ggx:0.2, phong:50)";
  };
  if (parts.empty()) bad();
  BrdfLobe lobe;
  try {
    lobe.model = ParseBrdfModel(parts[0]);
  } catch (const UserError&) {
    bad();
  }
  try {
    if (lobe.model == BrdfModel::kLambertian) {
      if (parts.size() != 1) bad();
    } else if (lobe.model == BrdfModel::kPhong) {
      if (parts.size() != 2) bad();
      lobe.exponent = std::stod(parts[1]);
    } else {
      if (parts.size() < 2 || parts.size() > 3) bad();
      lobe.roughness = std::stod(parts[1]);
      lobe.f0 = parts.size() == 3 ? std::stod(parts[2]) : 1.0;  // the material coefficient carries the scale
    }
  } catch (const std::invalid_argument&) {
    bad();
  }
  lobe.Check();
  return lobe;
}

std::vector<BrdfLobe> ParseLobeSpecs(const std::vector<std::string>& specs) {
  std::vector<BrdfLobe> lobes;
  for (const auto& s : specs) lobes.push_back(ParseLobeSpec(s));
  return lobes;
}

std::string LobeSpec(const BrdfLobe& lobe) {
  std::ostringstream s;
  s << BrdfModelName(lobe.model);
  if (lobe.model == BrdfModel::kPhong) s << ":" << lobe.exponent;
  if (lobe.model == BrdfModel::kGgx || lobe.model == BrdfModel::kCookTorrance) {
    s << ":" << lobe.roughness;
    if (lobe.f0 != 1.0) s << ":" << lobe.f0;
  }
  return s.str();
}

}  // namespace relight
