// envmap_compression: relative L2 error of environment maps vs the number of
// kept Haar coefficients (non-linear approximation, wavelet/haar.h), and vs
// the spherical-harmonic order for comparison (sphere/sh.h). Writes a CSV for
// tools/envmap_compression.gp and prints a Markdown summary table.
//
//   envmap_compression [MAP.hdr|MAP.exr ...] [--resolutions 64,128] [--csv OUT.csv]
//
// Without maps: ../shared/data/envmaps/*.hdr (beside the checkout) and the
// Blender studio lights city, courtyard, interior, studio, sunset, forest.
// Error metric (both bases): solid-angle-weighted relative L2 over the
// sphere, sqrt(sum_tau w_tau |L - L_hat|^2 / sum_tau w_tau |L|^2) over the
// octahedral texels tau (weights = exact texel solid angles, RGB summed). The
// Haar coefficients kept are the k largest by RGB magnitude (one index set
// for the three channels, as a solver would store them).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numeric>
#include <sstream>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/fs.h"
#include "sphere/envmap.h"
#include "sphere/octahedral.h"
#include "sphere/sh.h"
#include "wavelet/haar.h"

namespace {

using namespace relight;

std::vector<std::string> DefaultMaps() {
  std::vector<std::string> maps;
  for (const char* dir : {"../shared/data/envmaps"}) {
    if (!std::filesystem::is_directory(dir)) continue;
    std::vector<std::string> found;
    for (const auto& e : std::filesystem::directory_iterator(dir))
      if (e.path().extension() == ".hdr" || e.path().extension() == ".exr") found.push_back(e.path().string());
    std::sort(found.begin(), found.end());
    maps.insert(maps.end(), found.begin(), found.end());
    break;
  }
  for (const char* name : {"city", "courtyard", "interior", "studio", "sunset", "forest"}) {
    const std::string path = std::string("/usr/share/blender/datafiles/studiolights/world/") + name + ".exr";
    if (std::filesystem::exists(path)) maps.push_back(path);
  }
  return maps;
}

std::vector<size_t> CoefficientCounts(size_t total) {
  std::vector<size_t> counts;
  for (size_t k = 1; k <= total; k *= 2) {
    counts.push_back(k);
    if (k * 3 / 2 < total && k >= 2) counts.push_back(k * 3 / 2);
  }
  if (counts.back() != total) counts.push_back(total);
  std::sort(counts.begin(), counts.end());
  counts.erase(std::unique(counts.begin(), counts.end()), counts.end());
  return counts;
}

struct Row {
  std::string map, basis;
  int resolution;
  size_t coefficients;
  double error;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("Relative L2 error of environment maps vs kept Haar coefficients and SH order", "envmap_compression");
  std::vector<std::string> maps;
  std::vector<int> resolutions = {64, 128};
  std::string csv_path;
  app.add_option("MAPS", maps, "Lat-long .hdr/.exr environment maps (default: shared data and Blender maps)");
  app.add_option("--resolutions", resolutions, "Octahedral map sides (powers of two)")->delimiter(',');
  app.add_option("--csv", csv_path, "Write the curves to this CSV file");
  CLI11_PARSE(app, argc, argv);
  try {
    if (maps.empty()) maps = DefaultMaps();
    if (maps.empty()) RELIGHT_USER_ERROR() << "no environment maps given and none found in the default places";
    std::vector<Row> rows;
    for (const std::string& path : maps) {
      const std::string name = std::filesystem::path(path).stem().string();
      const EnvMap env = EnvMap::Load(path);
      for (int n : resolutions) {
        if (!IsPowerOfTwo(n)) RELIGHT_USER_ERROR() << "resolution " << n << " is not a power of two";
        const Image oct = env.ToOctahedral(n);
        const std::vector<double> omega = OctTexelSolidAngles(n);
        const size_t total = size_t(n) * n;
        std::vector<std::vector<double>> pixels(3, std::vector<double>(total)), coeffs(3);
        double norm2 = 0;
        for (int c = 0; c < 3; ++c) {
          for (size_t t = 0; t < total; ++t) {
            pixels[c][t] = oct.pixels[3 * t + c];
            norm2 += omega[t] * pixels[c][t] * pixels[c][t];
          }
          coeffs[c] = pixels[c];
          HaarForward(coeffs[c].data(), n, coeffs[c].data());
        }
        auto weighted_error = [&](const std::vector<std::vector<double>>& approx) {
          double e2 = 0;
          for (int c = 0; c < 3; ++c)
            for (size_t t = 0; t < total; ++t) e2 += omega[t] * std::pow(approx[c][t] - pixels[c][t], 2);
          return std::sqrt(e2 / norm2);
        };
        // Haar: k largest by RGB magnitude.
        std::vector<double> magnitude(total);
        for (size_t k = 0; k < total; ++k)
          magnitude[k] = coeffs[0][k] * coeffs[0][k] + coeffs[1][k] * coeffs[1][k] + coeffs[2][k] * coeffs[2][k];
        const std::vector<uint32_t> order = IndicesByMagnitude(magnitude.data(), n);
        std::vector<std::vector<double>> approx(3, std::vector<double>(total));
        for (size_t k : CoefficientCounts(total)) {
          for (int c = 0; c < 3; ++c) {
            std::fill(approx[c].begin(), approx[c].end(), 0.0);
            for (size_t r = 0; r < k; ++r) approx[c][order[r]] = coeffs[c][order[r]];
            HaarInverse(approx[c].data(), n, approx[c].data());
          }
          rows.push_back({name, "haar", n, k, weighted_error(approx)});
        }
        // Spherical harmonics of orders 2..8, projected with exact texel solid angles.
        for (int order = 2; order <= kMaxShOrder; ++order) {
          for (int c = 0; c < 3; ++c) {
            std::vector<float> values(pixels[c].begin(), pixels[c].end());
            const Eigen::VectorXd sh = ShProjectOct(values.data(), n, order);
            const std::vector<float> back = ShToOct(sh, n);
            approx[c].assign(back.begin(), back.end());
          }
          rows.push_back({name, "sh", n, size_t(ShNumCoefficients(order)), weighted_error(approx)});
        }
        std::fprintf(stderr, "%s at %d^2 done\n", name.c_str(), n);
      }
    }
    if (!csv_path.empty()) {
      std::ostringstream csv;
      csv << "envmap,basis,resolution,coefficients,rel_l2_error\n";
      for (const Row& r : rows) {
        char line[256];
        std::snprintf(line, sizeof(line), "%s,%s,%d,%zu,%.6e\n", r.map.c_str(), r.basis.c_str(), r.resolution,
                      r.coefficients, r.error);
        csv << line;
      }
      WriteFileAtomic(csv_path, csv.str());
    }
    // Markdown summary: error at a few coefficient budgets.
    auto find = [&](const std::string& map, const std::string& basis, int n, size_t k) {
      for (const Row& r : rows)
        if (r.map == map && r.basis == basis && r.resolution == n && r.coefficients == k) return r.error;
      return std::nan("");
    };
    for (int n : resolutions) {
      std::printf("\nOctahedral %d x %d (%d coefficients), relative L2 error over the sphere:\n\n", n, n, n * n);
      std::printf("| map | SH order 2 (9) | Haar 9 | SH order 8 (81) | Haar 81 | Haar 256 | Haar 1024 |\n");
      std::printf("|---|---|---|---|---|---|---|\n");
      std::vector<std::string> names;
      for (const Row& r : rows)
        if (std::find(names.begin(), names.end(), r.map) == names.end()) names.push_back(r.map);
      auto haar_at = [&](const std::string& m, size_t k) {
        // Interpolate log-linearly between the stored counts when k itself is not stored.
        double e = find(m, "haar", n, k);
        if (!std::isnan(e)) return e;
        size_t lo = 0, hi = 0;
        for (const Row& r : rows)
          if (r.map == m && r.basis == "haar" && r.resolution == n) {
            if (r.coefficients <= k) lo = std::max(lo, r.coefficients);
            if (r.coefficients >= k && (hi == 0 || r.coefficients < hi)) hi = r.coefficients;
          }
        const double el = find(m, "haar", n, lo), eh = find(m, "haar", n, hi);
        const double t = std::log(double(k) / lo) / std::log(double(hi) / lo);
        return std::exp(std::log(el) + t * (std::log(eh) - std::log(el)));
      };
      for (const std::string& m : names) {
        std::printf("| %s | %.3f | %.3f | %.3f | %.3f | %.3f | %.4f |\n", m.c_str(), find(m, "sh", n, 9), haar_at(m, 9),
                    find(m, "sh", n, 81), haar_at(m, 81), haar_at(m, 256), haar_at(m, 1024));
      }
    }
  } catch (const UserError& e) {
    std::fprintf(stderr, "envmap_compression: error: %s\n", e.what());
    return 2;
  }
  return 0;
}
