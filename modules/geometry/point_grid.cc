#include "geometry/point_grid.h"

#include <cmath>
#include <utility>

#include "core/error.h"

namespace relight {

std::size_t PointGrid::CellHash::operator()(const Cell& c) const {
  uint64_t h = static_cast<uint64_t>(c.x);
  h = h * 0x9E3779B97F4A7C15ull ^ static_cast<uint64_t>(c.y);
  h = h * 0x9E3779B97F4A7C15ull ^ static_cast<uint64_t>(c.z);
  return static_cast<std::size_t>(h ^ (h >> 29));
}

bool PointGrid::CellOf(const Eigen::Vector3d& p, Cell* cell) const {
  constexpr double kLimit = 4611686018427387904.0;  // 2^62: the index and its neighbours fit in int64_t
  int64_t index[3];
  for (int k = 0; k < 3; ++k) {
    // Divided, not multiplied by the inverse: the cell of a point on a border
    // must not depend on rounding that differs from floor(x / cell_size).
    const double q = std::floor(p[k] / cell_size_);
    if (!(std::abs(q) < kLimit)) return false;  // also NaN and infinities
    index[k] = static_cast<int64_t>(q);
  }
  *cell = {index[0], index[1], index[2]};
  return true;
}

PointGrid::PointGrid(std::vector<Eigen::Vector3d> points, double cell_size)
    : points_(std::move(points)), cell_size_(cell_size) {
  RELIGHT_CHECK(cell_size > 0) << "cell_size=" << cell_size;  // false for NaN
  constexpr std::size_t kNoCell = static_cast<std::size_t>(-1);
  // Counting sort of the points by cell: a flat index array instead of one vector per cell.
  std::vector<std::size_t> point_cell(points_.size(), kNoCell);
  std::vector<std::size_t> counts;
  for (std::size_t i = 0; i < points_.size(); ++i) {
    Cell c;
    if (!CellOf(points_[i], &c)) continue;
    const auto [it, inserted] = cell_ids_.try_emplace(c, counts.size());
    if (inserted) counts.push_back(0);
    ++counts[it->second];
    point_cell[i] = it->second;
  }
  cell_starts_.assign(counts.size() + 1, 0);
  for (std::size_t id = 0; id < counts.size(); ++id) cell_starts_[id + 1] = cell_starts_[id] + counts[id];
  order_.resize(cell_starts_.back());
  std::vector<std::size_t> next(cell_starts_.begin(), cell_starts_.end() - 1);
  for (std::size_t i = 0; i < points_.size(); ++i) {
    if (point_cell[i] != kNoCell) order_[next[point_cell[i]]++] = i;
  }
}

std::optional<std::size_t> PointGrid::Nearest(const Eigen::Vector3d& p, double radius) const {
  RELIGHT_CHECK(radius >= 0 && radius <= cell_size_) << "radius=" << radius << " cell_size=" << cell_size_;
  Cell c;
  if (cell_ids_.empty() || !CellOf(p, &c)) return std::nullopt;
  double best = radius * radius;
  std::optional<std::size_t> nearest;
  // Cells in increasing (x, y, z) and points in increasing index with `<=`:
  // the last of equally near points wins (the documented tie rule).
  for (int64_t dx = -1; dx <= 1; ++dx) {
    for (int64_t dy = -1; dy <= 1; ++dy) {
      for (int64_t dz = -1; dz <= 1; ++dz) {
        const auto it = cell_ids_.find({c.x + dx, c.y + dy, c.z + dz});
        if (it == cell_ids_.end()) continue;
        for (std::size_t s = cell_starts_[it->second]; s < cell_starts_[it->second + 1]; ++s) {
          const double d2 = (points_[order_[s]] - p).squaredNorm();
          if (d2 <= best) {
            best = d2;
            nearest = order_[s];
          }
        }
      }
    }
  }
  return nearest;
}

bool PointGrid::AnyPointInNeighbourCells(const Eigen::Vector3d& p) const {
  Cell c;
  if (cell_ids_.empty() || !CellOf(p, &c)) return false;
  for (int64_t dx = -1; dx <= 1; ++dx) {
    for (int64_t dy = -1; dy <= 1; ++dy) {
      for (int64_t dz = -1; dz <= 1; ++dz) {
        if (cell_ids_.count({c.x + dx, c.y + dy, c.z + dz}) > 0) return true;
      }
    }
  }
  return false;
}

}  // namespace relight
