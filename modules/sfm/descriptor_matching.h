// Putative matches between the SIFT descriptors of two photos: mutual nearest
// neighbours that pass Lowe's ratio test and a distance bound, as COLMAP's
// matcher defines them (descriptors compared by the angle between them).
//
// Written here rather than left to COLMAP: COLMAP 3.8's CPU matcher searches
// randomised kd-trees whose seeds are not ours to set, so the same photos gave
// different matches on every run (112 of 276 pairs of one collection), and a
// photo could register once and fail the next time. This is an exhaustive
// search (one matrix product per block of descriptors), so it is exact and
// always gives the same matches.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <functional>
#include <vector>

namespace relight {

// Descriptors as rows, each of unit length.
using DescriptorMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct DescriptorMatchingOptions {
  double max_ratio = 0.8;     // best / second-best angle must be below this (Lowe's ratio test)
  double max_angle_rad = 0.7;  // angle between matched descriptors at most this (COLMAP's max_distance)
  bool cross_check = true;    // keep a match only when each descriptor is the other's nearest neighbour
};

// Rows normalised to unit length (COLMAP stores SIFT descriptors as uint8).
DescriptorMatrix NormalizedDescriptors(const std::vector<uint8_t>& data, int rows, int cols);

// One photo's SIFT descriptors as COLMAP stores them: a quarter of the memory of its DescriptorMatrix, so a
// collection is held as these and each photo's are normalised when they are compared.
struct CompactDescriptors {
  std::vector<uint8_t> data;  // rows x cols, row-major
  int rows = 0, cols = 0;
  DescriptorMatrix Normalized() const { return NormalizedDescriptors(data, rows, cols); }
};

// Index pairs (row in `a`, row in `b`) of the putative matches, sorted by the row in `a`. With `allowed`
// (guided matching, e.g. by a known epipolar geometry) only pairs (i, j) it accepts are compared: nearest
// neighbours and the ratio test are taken among them.
std::vector<std::array<uint32_t, 2>> MatchDescriptors(const DescriptorMatrix& a, const DescriptorMatrix& b,
                                                      const DescriptorMatchingOptions& options,
                                                      const std::function<bool(int, int)>& allowed = {});

}  // namespace relight
