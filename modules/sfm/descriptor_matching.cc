#include "sfm/descriptor_matching.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"

namespace relight {
namespace {

// The two largest similarities (dot products) of each row and their columns.
struct Best2 {
  float s1 = -2, s2 = -2;
  int j1 = -1;
  void Add(float s, int j) {
    if (s > s1) {
      s2 = s1;
      s1 = s;
      j1 = j;
    } else if (s > s2) {
      s2 = s;
    }
  }
};

double Angle(float similarity) { return std::acos(std::clamp(double(similarity), -1.0, 1.0)); }

bool Passes(const Best2& b, const DescriptorMatchingOptions& o) {
  if (b.j1 < 0) return false;
  const double a1 = Angle(b.s1), a2 = Angle(b.s2);
  return a1 <= o.max_angle_rad && a1 < o.max_ratio * a2;
}

}  // namespace

DescriptorMatrix NormalizedDescriptors(const std::vector<uint8_t>& data, int rows, int cols) {
  RELIGHT_CHECK_EQ(data.size(), size_t(rows) * cols);
  DescriptorMatrix m(rows, cols);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) m(r, c) = data[size_t(r) * cols + c];
    const float norm = m.row(r).norm();
    if (norm > 0) m.row(r) /= norm;
  }
  return m;
}

std::vector<std::array<uint32_t, 2>> MatchDescriptors(const DescriptorMatrix& a, const DescriptorMatrix& b,
                                                      const DescriptorMatchingOptions& options,
                                                      const std::function<bool(int, int)>& allowed) {
  std::vector<std::array<uint32_t, 2>> matches;
  if (a.rows() < 2 || b.rows() < 2 || a.cols() != b.cols()) return matches;
  std::vector<Best2> best_a(a.rows()), best_b(b.rows());
  // Blocks of rows of `a` keep the similarity matrix small (1024 x |b| floats).
  const int kBlock = 1024;
  Eigen::MatrixXf s;
  for (int r0 = 0; r0 < a.rows(); r0 += kBlock) {
    const int rows = std::min<int>(kBlock, static_cast<int>(a.rows()) - r0);
    s.noalias() = a.middleRows(r0, rows) * b.transpose();
    for (int j = 0; j < s.cols(); ++j) {
      for (int i = 0; i < rows; ++i) {
        if (allowed && !allowed(r0 + i, j)) continue;
        const float v = s(i, j);
        best_a[r0 + i].Add(v, j);
        best_b[j].Add(v, r0 + i);
      }
    }
  }
  for (int i = 0; i < a.rows(); ++i) {
    if (!Passes(best_a[i], options)) continue;
    const int j = best_a[i].j1;
    if (options.cross_check && (best_b[j].j1 != i || !Passes(best_b[j], options))) continue;
    matches.push_back({uint32_t(i), uint32_t(j)});
  }
  return matches;
}

}  // namespace relight
