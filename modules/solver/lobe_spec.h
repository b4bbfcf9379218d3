// Basis BRDFs written as short strings in configs: "lambertian", "ggx:0.2",
// "ggx:0.2:0.04", "cook_torrance:0.3", "phong:50".
#pragma once

#include <string>
#include <vector>

#include "brdf/brdf.h"

namespace relight {

// Parses one spec; throws UserError naming the spec and the accepted forms.
BrdfLobe ParseLobeSpec(const std::string& spec);
std::vector<BrdfLobe> ParseLobeSpecs(const std::vector<std::string>& specs);
// The spec string of a lobe (inverse of ParseLobeSpec).
std::string LobeSpec(const BrdfLobe& lobe);

}  // namespace relight
