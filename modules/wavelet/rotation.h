// Wavelet rotation: sparse matrices from the global octahedral Haar
// coefficients of a distant lighting L (world frame, N_g x N_g) to the local
// hemi-octahedral Haar coefficients (frame FrameFromNormal(n) of sphere/frame.h,
// N_l x N_l) of the lighting seen by a surface with normal n.
//
// Wang, Ng, Luebke, Humphreys, "Efficient Wavelet Rotation for Environment Map
// Rendering" (EGSR 2006); Haber et al. 2009 §4.2, eq. 6. For a grid normal,
//   R_n = W_l S_n W_g^T,
// W the orthonormal Haar transforms (wavelet/haar.h) and S_n the resampling
// operator whose row for local texel tau holds the fraction of tau's solid
// angle covered by each global texel, computed exactly (spherical polygon
// clipping, sphere/octahedral.h), so local texel values are exact texel
// *averages* of the piecewise-constant global map. R_n is built sparsely: each row of S_n W_g^T is the Haar transform
// of a handful of global pixels (their ancestor wavelets), and W_l mixes these rows along the local ancestor tree.
// Entries with |r| < truncation are dropped; the dropped Frobenius norm ||E||_F bounds the error of the local
// coefficients, ||dL_local||_2 <= ||E||_F ||L_global||_2 (reported per build).
// Grid: normals at the texel centres of a G x G octahedral map; an arbitrary
// normal blends the four nearest matrices bilinearly (fold-aware). Blending
// mixes four slightly different tangent frames: the frame twist between grid
// neighbours grows towards -Z (Frisvad's singular direction), so the
// blended rotation blurs most there (see the benchmark in docs/BENCHMARKS.md);
// BuildRotationMatrix() gives the exact matrix for any normal.
// Written by hand: no library implements Haar-domain rotations.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace relight {

// What a rotation grid is built from; every field enters the cache file name and header.
struct RotationOptions {
  int global_resolution = 32;  // N_g: side of the global octahedral lighting map (power of two)
  int local_resolution = 32;   // N_l: side of the local hemi-octahedral map (power of two)
  int normal_grid = 32;        // G: grid normals at the texel centres of a G x G octahedral map
  double truncation = 1e-4;    // drop entries with |r| < truncation (absolute; R has O(1) entries)

  // Throws UserError naming the violated constraint.
  void Check() const;
};

// Sparse matrix in compressed-row form with float values.
struct SparseMatrixF {
  int rows = 0;                   // N_l^2 (local coefficients)
  int cols = 0;                   // N_g^2 (global coefficients)
  std::vector<uint32_t> row_ptr;  // rows + 1 offsets into col / value
  std::vector<uint32_t> col;      // ascending within a row
  std::vector<float> value;

  // Number of stored entries.
  size_t nnz() const { return value.size(); }
  // y = A x (y has `rows` entries, overwritten).
  void Multiply(const float* x, float* y) const;
  // y += scale A x.
  void MultiplyAccumulate(const double* x, double scale, double* y) const;
  // y += scale A^T x (y has `cols` entries).
  void MultiplyTransposeAccumulate(const double* x, double scale, double* y) const;
};

// What a build did.
struct RotationSummary {
  size_t num_normals = 0;
  size_t nnz_total = 0;        // non-zeros over all grid matrices
  double nnz_per_matrix = 0;   // average
  double density = 0;          // nnz_per_matrix / (N_l^2 N_g^2)
  double max_dropped_rel = 0;  // max over normals of ||E||_F / ||R||_F (truncation error)
  double build_seconds = 0;    // 0 when loaded
  bool loaded_from_cache = false;
  std::string cache_path;  // file read or written ("" when not cached)
  size_t bytes = 0;        // memory held by the matrices
};

// The exact rotation matrix (truncated) for one normal. `dropped_frobenius`,
// `total_frobenius` (optional) receive ||E||_F and ||R||_F.
SparseMatrixF BuildRotationMatrix(const Eigen::Vector3d& normal_world, const RotationOptions& options,
                                  double* dropped_frobenius = nullptr, double* total_frobenius = nullptr);

// S_n alone: local hemi-octahedral texel averages from global octahedral *pixels* (rows N_l^2,
// cols N_g^2, each row the exact covered fractions, summing to 1). R_n = W_l S_n W_g^T.
SparseMatrixF BuildResamplingMatrix(const Eigen::Vector3d& normal_world, const RotationOptions& options);
// The four grid normals (texel centres of a grid x grid octahedral map) around a normal and their
// bilinear weights (fold-aware, sum 1).
void OctGridBlendWeights(const Eigen::Vector3d& normal_world, int grid, int index[4], double weight[4]);

// Rotation matrices for a grid of normals, with bilinear blending.
class RotationGrid {
 public:
  // Builds every grid matrix (TBB parallel).
  static RotationGrid Build(const RotationOptions& options, RotationSummary* summary = nullptr);
  // Loads `cache_dir/<name from options>` when present and valid, otherwise builds and saves it there.
  static RotationGrid LoadOrBuild(const RotationOptions& options, const std::string& cache_dir,
                                  RotationSummary* summary = nullptr);
  // File name of the cache for these options (encodes every field and the format version).
  static std::string CacheFileName(const RotationOptions& options);
  // Writes the grid atomically (magic "RLROT\0\0\0", version, options, matrices).
  void Save(const std::string& path) const;
  // Reads a grid; throws UserError naming the file when it is not a valid cache of this version.
  static RotationGrid Load(const std::string& path);

  // Options the grid was built with.
  const RotationOptions& options() const { return options_; }
  // G^2.
  int num_normals() const { return int(matrices_.size()); }
  // Grid normal g (texel centre (g % G, g / G) of the G x G octahedral map).
  Eigen::Vector3d grid_normal(int g) const;
  // Matrix of grid normal g.
  const SparseMatrixF& matrix(int g) const { return matrices_[g]; }
  // The four grid normals around `normal_world` and their bilinear weights (sum 1).
  void BlendWeights(const Eigen::Vector3d& normal_world, int index[4], double weight[4]) const;
  // local = R(n) global, blended: global has N_g^2 entries, local N_l^2.
  void Rotate(const Eigen::Vector3d& normal_world, const float* global, float* local) const;
  // global += scale R(n)^T local, blended (transport rows: a = R^T t).
  void AccumulateTransposed(const Eigen::Vector3d& normal_world, const double* local, double scale,
                            double* global) const;
  // Total non-zeros.
  size_t nnz() const;

 private:
  RotationOptions options_;
  std::vector<SparseMatrixF> matrices_;
  std::vector<float> dropped_rel_;  // per matrix ||E||_F / ||R||_F
};

// The same blended rotation with S_n stored instead of R_n, applied as
// R_n x = W_l (S_n (W_g^T x)): exact (no truncation), 4-5x less memory than
// RotationGrid at N = 32 and faster transposed products, at the price of two
// Haar transforms per call (docs/BENCHMARKS.md). Results equal RotationGrid's
// up to its truncation.
class ResamplingGrid {
 public:
  // Builds S_n for every grid normal (TBB parallel); truncation is ignored.
  static ResamplingGrid Build(const RotationOptions& options, RotationSummary* summary = nullptr);
  // Options the grid was built with.
  const RotationOptions& options() const { return options_; }
  // G^2.
  int num_normals() const { return int(matrices_.size()); }
  // Grid normal g (texel centre (g % G, g / G) of the G x G octahedral map).
  Eigen::Vector3d grid_normal(int g) const;
  // S of grid normal g.
  const SparseMatrixF& matrix(int g) const { return matrices_[g]; }
  // The four grid normals around `normal_world` and their bilinear weights (sum 1).
  void BlendWeights(const Eigen::Vector3d& normal_world, int index[4], double weight[4]) const;
  // local = R(n) global in Haar coefficients (as RotationGrid::Rotate).
  void Rotate(const Eigen::Vector3d& normal_world, const float* global, float* local) const;
  // global += scale R(n)^T local in Haar coefficients (as RotationGrid::AccumulateTransposed).
  void AccumulateTransposed(const Eigen::Vector3d& normal_world, const double* local, double scale,
                            double* global) const;
  // Total non-zeros.
  size_t nnz() const;

 private:
  RotationOptions options_;
  std::vector<SparseMatrixF> matrices_;
};

}  // namespace relight
