// The headers most of relight's files include, precompiled once per kind of target when
// RELIGHT_PRECOMPILED_HEADERS is on (cmake/RelightHelpers.cmake): parsing them is about 3 s of a file's
// 5-30 s compile at -O3. Files still include what they use; this list only saves the parsing.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>
#include <tbb/parallel_for.h>
