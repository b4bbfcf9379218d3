// A hash grid of 3D points in cubic cells, for queries that reach at most
// one cell from the query point (fixed-radius nearest point, occupancy of
// the 27 cells around a point).
//
// Hand-written on purpose: the kd-trees at hand (CGAL's spatial searching;
// nanoflann, which Debian ships but the project does not use) find the nearest
// point within r, but have no cell-occupancy test like the one the mesh crop
// documents (a centroid's cell and its 26 neighbours) and break ties their own
// way; CGAL's headers would also slow every file that includes this one.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <unordered_map>
#include <vector>

namespace relight {

// Points bucketed into cells of side `cell_size`: point p lies in cell
// floor(p / cell_size) (per axis, so -0.1 is in cell -1 for a unit cell).
// Points whose cell index does not fit (non-finite, or |p / cell_size| >= 2^62)
// lie in no cell and are never found. Queries are const and thread-safe.
class PointGrid {
 public:
  // Buckets `points` (kept by the grid; indices refer to this order). cell_size > 0;
  // an infinite one makes a single cell of all finite points.
  PointGrid(std::vector<Eigen::Vector3d> points, double cell_size);

  // Index of the point nearest to `p` with distance <= `radius`, or none. Only
  // p's cell and its 26 neighbours are searched; with 0 <= radius <= cell_size
  // (checked) they hold every such point, up to rounding on cell borders.
  // Ties go to the last point in (cell x, cell y, cell z, index) order.
  std::optional<std::size_t> Nearest(const Eigen::Vector3d& p, double radius) const;

  // True when p's cell or one of its 26 neighbours holds a point: so when a
  // point is within cell_size of p (up to rounding on cell borders), and never
  // when none is within 2 * sqrt(3) * cell_size.
  bool AnyPointInNeighbourCells(const Eigen::Vector3d& p) const;

  const std::vector<Eigen::Vector3d>& points() const { return points_; }  // as given
  double cell_size() const { return cell_size_; }                         // world units

 private:
  struct Cell {
    int64_t x, y, z;
    bool operator==(const Cell& o) const { return x == o.x && y == o.y && z == o.z; }
  };
  struct CellHash {
    std::size_t operator()(const Cell& c) const;
  };
  // False when p's cell index does not fit in an int64_t with room for a neighbour.
  bool CellOf(const Eigen::Vector3d& p, Cell* cell) const;

  std::vector<Eigen::Vector3d> points_;
  double cell_size_;
  std::unordered_map<Cell, std::size_t, CellHash> cell_ids_;  // occupied cell -> id
  std::vector<std::size_t> cell_starts_;                      // id -> first slot in order_ (size: cells + 1)
  std::vector<std::size_t> order_;                            // point indices by cell id, ascending within a cell
};

}  // namespace relight
