#include "geometry/point_grid.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <random>

#include "core/error.h"

namespace relight {
namespace {

using Cell = std::array<int64_t, 3>;

Cell CellOf(const Eigen::Vector3d& p, double cell_size) {
  return {static_cast<int64_t>(std::floor(p.x() / cell_size)), static_cast<int64_t>(std::floor(p.y() / cell_size)),
          static_cast<int64_t>(std::floor(p.z() / cell_size))};
}

bool Neighbours(const Cell& a, const Cell& b) {
  for (int k = 0; k < 3; ++k) {
    if (std::abs(a[k] - b[k]) > 1) return false;
  }
  return true;
}

// The documented Nearest by brute force: all points in the 27 cells around
// p's, within `radius`, the nearest; ties to the largest (cell, index).
std::optional<size_t> BruteNearestInCells(const std::vector<Eigen::Vector3d>& points, double cell_size,
                                          const Eigen::Vector3d& p, double radius) {
  const Cell cp = CellOf(p, cell_size);
  std::optional<size_t> best;
  double best_d2 = 0;
  Cell best_cell{};
  for (size_t i = 0; i < points.size(); ++i) {
    const Cell ci = CellOf(points[i], cell_size);
    const double d2 = (points[i] - p).squaredNorm();
    if (!Neighbours(ci, cp) || d2 > radius * radius) continue;
    if (!best || d2 < best_d2 || (d2 == best_d2 && std::make_pair(ci, i) > std::make_pair(best_cell, *best))) {
      best = i;
      best_d2 = d2;
      best_cell = ci;
    }
  }
  return best;
}

// The smallest squared distance from p to a point within `radius`, cells ignored.
std::optional<double> BruteNearestSquaredDistance(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& p,
                                                  double radius) {
  std::optional<double> best;
  for (const auto& x : points) {
    const double d2 = (x - p).squaredNorm();
    if (d2 <= radius * radius && (!best || d2 < *best)) best = d2;
  }
  return best;
}

bool BruteAnyInNeighbourCells(const std::vector<Eigen::Vector3d>& points, double cell_size, const Eigen::Vector3d& p) {
  const Cell cp = CellOf(p, cell_size);
  for (const auto& x : points) {
    if (Neighbours(CellOf(x, cell_size), cp)) return true;
  }
  return false;
}

// Compares every query with brute force at `queries`, for several radii.
void ExpectMatchesBruteForce(const std::vector<Eigen::Vector3d>& points, double cell_size,
                             const std::vector<Eigen::Vector3d>& queries, int* found, int* occupied) {
  const PointGrid grid(points, cell_size);
  for (const Eigen::Vector3d& q : queries) {
    for (const double radius : {0.0, 0.3 * cell_size, cell_size}) {
      const std::optional<size_t> got = grid.Nearest(q, radius);
      ASSERT_EQ(got, BruteNearestInCells(points, cell_size, q, radius))
          << "query " << q.transpose() << " radius " << radius;
      // Within one cell the 27 cells hold every point in range: the true nearest distance.
      const std::optional<double> d2 = BruteNearestSquaredDistance(points, q, radius);
      ASSERT_EQ(got.has_value(), d2.has_value()) << "query " << q.transpose() << " radius " << radius;
      if (got) {
        EXPECT_EQ((points[*got] - q).squaredNorm(), *d2);
        ++*found;
      }
    }
    const bool any = grid.AnyPointInNeighbourCells(q);
    ASSERT_EQ(any, BruteAnyInNeighbourCells(points, cell_size, q)) << "query " << q.transpose();
    if (BruteNearestSquaredDistance(points, q, cell_size)) {
      EXPECT_TRUE(any) << "query " << q.transpose();
    }
    *occupied += any;
  }
}

TEST(PointGridTest, RandomPointsMatchBruteForce) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-3, 3), v(-3.5, 3.5);
  std::vector<Eigen::Vector3d> points(1500), queries(1500);
  for (auto& p : points) p = {u(rng), u(rng), u(rng)};
  for (auto& q : queries) q = {v(rng), v(rng), v(rng)};
  int found = 0, occupied = 0;
  ExpectMatchesBruteForce(points, 0.37, queries, &found, &occupied);
  // Both outcomes occur, so the comparison is not vacuous.
  EXPECT_GT(found, 500);
  EXPECT_LT(found, 3 * 1500 - 500);
  EXPECT_GT(occupied, 100);
  EXPECT_LT(occupied, 1500 - 100);
}

TEST(PointGridTest, PointsOnCellBordersAndExactTiesMatchBruteForce) {
  // A lattice of step cell/4 (exact in binary): points and queries lie on cell
  // borders, distances equal the radius exactly, and equidistant points (and
  // duplicates) test the tie rule.
  const double cell = 0.5;
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> k(-9, 9);
  auto lattice = [&] {
    Eigen::Vector3d p;
    for (int a = 0; a < 3; ++a) p[a] = k(rng) * (cell / 4);
    return p;
  };
  std::vector<Eigen::Vector3d> points(300), queries(1500);
  for (auto& p : points) p = lattice();
  for (int i = 0; i < 50; ++i) points.push_back(points[i]);  // duplicates with higher indices
  for (auto& q : queries) q = lattice();
  int found = 0, occupied = 0;
  ExpectMatchesBruteForce(points, cell, queries, &found, &occupied);
  EXPECT_GT(found, 500);
  EXPECT_GT(occupied, 100);

  const PointGrid grid({{0, 0, 0}, {0.5, 0, 0}, {0, 0, 0}}, cell);
  EXPECT_EQ(grid.Nearest({0.25, 0, 0}, cell), 1u);  // tie across cells: the larger cell x
  EXPECT_EQ(grid.Nearest({0.1, 0, 0}, cell), 2u);   // duplicates: the larger index
  EXPECT_EQ(grid.Nearest({1.0, 0, 0}, cell), 1u);   // exactly at the radius, on a border
  EXPECT_EQ(grid.Nearest({1.0, 0, 0}, 0.49), std::nullopt);
}

TEST(PointGridTest, NegativeCoordinatesFloorToTheCellBelow) {
  const PointGrid grid({{-0.1, 0, 0}}, 1.0);                  // cell -1 (truncation would say 0)
  EXPECT_TRUE(grid.AnyPointInNeighbourCells({-1.5, 0, 0}));   // cell -2
  EXPECT_FALSE(grid.AnyPointInNeighbourCells({1.5, 0, 0}));   // cell 1
  EXPECT_FALSE(grid.AnyPointInNeighbourCells({-2.5, 0, 0}));  // cell -3
  EXPECT_EQ(grid.Nearest({-1.05, 0, 0}, 1.0), 0u);
  EXPECT_EQ(grid.Nearest({0.95, 0, 0}, 1.0), std::nullopt);
}

TEST(PointGridTest, EmptyGridFindsNothing) {
  const PointGrid grid({}, 0.5);
  EXPECT_TRUE(grid.points().empty());
  EXPECT_EQ(grid.Nearest({0, 0, 0}, 0.5), std::nullopt);
  EXPECT_FALSE(grid.AnyPointInNeighbourCells({0, 0, 0}));
}

TEST(PointGridTest, FarCellsDoNotAliasAndUnrepresentablePointsLieInNoCell) {
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  const PointGrid grid({{0, 0, 0}, {nan, 0, 0}, {inf, 0, 0}, {0, 1e300, 0}}, 1.0);
  // 2^21 cells away: a key packed into 21 bits per axis would alias cell 0.
  EXPECT_FALSE(grid.AnyPointInNeighbourCells({2097152.5, 0, 0}));
  EXPECT_FALSE(grid.AnyPointInNeighbourCells({0, 1e300, 0}));
  EXPECT_FALSE(grid.AnyPointInNeighbourCells({nan, 0, 0}));
  EXPECT_EQ(grid.Nearest({nan, 0, 0}, 1.0), std::nullopt);
  EXPECT_EQ(grid.Nearest({0, 1e300, 0}, 1.0), std::nullopt);
  EXPECT_EQ(grid.Nearest({0.5, 0, 0}, 1.0), 0u);

  const PointGrid one_cell({{-1e9, 0, 0}, {nan, 0, 0}, {2e9, 0, 0}}, inf);  // every finite point in cell 0
  EXPECT_TRUE(one_cell.AnyPointInNeighbourCells({5e9, -3, 0}));
  EXPECT_EQ(one_cell.Nearest({5e9, -3, 0}, inf), 2u);
  EXPECT_FALSE(one_cell.AnyPointInNeighbourCells({inf, 0, 0}));
}

TEST(PointGridTest, RejectsABadCellSizeOrRadius) {
  EXPECT_THROW(PointGrid({}, 0.0), InternalError);
  EXPECT_THROW(PointGrid({}, -1.0), InternalError);
  EXPECT_THROW(PointGrid({}, std::numeric_limits<double>::quiet_NaN()), InternalError);
  const PointGrid grid({{0, 0, 0}}, 1.0);
  EXPECT_THROW(grid.Nearest({0, 0, 0}, 1.5), InternalError);  // beyond the neighbour cells
  EXPECT_THROW(grid.Nearest({0, 0, 0}, -1.0), InternalError);
}

}  // namespace
}  // namespace relight
