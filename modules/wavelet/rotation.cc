#include "wavelet/rotation.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>

#include "core/error.h"
#include "core/fs.h"
#include "core/log.h"
#include "core/timer.h"
#include "sphere/frame.h"
#include "sphere/octahedral.h"
#include "wavelet/haar.h"

namespace relight {
namespace {

constexpr char kMagic[8] = {'R', 'L', 'R', 'O', 'T', 0, 0, 0};
constexpr uint32_t kVersion = 1;

using SparseVec = std::vector<std::pair<uint32_t, double>>;

// Dense accumulators with a touched list, reused per thread.
struct Accumulator {
  std::vector<double> v[4];
  std::vector<uint8_t> mark;
  std::vector<uint32_t> touched;
  void Resize(size_t n) {
    if (mark.size() == n) return;
    for (auto& x : v) x.assign(n, 0.0);
    mark.assign(n, 0);
    touched.clear();
  }
  void Touch(uint32_t m) {
    if (!mark[m]) {
      mark[m] = 1;
      touched.push_back(m);
    }
  }
  // Sorted touched indices; caller reads v[*] and then calls Clear().
  void SortTouched() { std::sort(touched.begin(), touched.end()); }
  void Clear() {
    for (uint32_t m : touched) {
      mark[m] = 0;
      for (auto& x : v) x[m] = 0.0;
    }
    touched.clear();
  }
};
thread_local Accumulator tl_acc;

}  // namespace

void RotationOptions::Check() const {
  if (!IsPowerOfTwo(global_resolution) || global_resolution < 2 || global_resolution > 256)
    RELIGHT_USER_ERROR() << "rotation global_resolution " << global_resolution << " must be a power of two in [2, 256]";
  if (!IsPowerOfTwo(local_resolution) || local_resolution < 2 || local_resolution > 256)
    RELIGHT_USER_ERROR() << "rotation local_resolution " << local_resolution << " must be a power of two in [2, 256]";
  if (!(normal_grid >= 1 && normal_grid <= 256))
    RELIGHT_USER_ERROR() << "rotation normal_grid " << normal_grid << " must lie in [1, 256]";
  if (!(truncation >= 0 && truncation < 1))
    RELIGHT_USER_ERROR() << "rotation truncation " << truncation << " must lie in [0, 1)";
}

void SparseMatrixF::Multiply(const float* x, float* y) const {
  for (int r = 0; r < rows; ++r) {
    float sum = 0;
    for (uint32_t k = row_ptr[r]; k < row_ptr[r + 1]; ++k) sum += value[k] * x[col[k]];
    y[r] = sum;
  }
}

void SparseMatrixF::MultiplyAccumulate(const double* x, double scale, double* y) const {
  for (int r = 0; r < rows; ++r) {
    double sum = 0;
    for (uint32_t k = row_ptr[r]; k < row_ptr[r + 1]; ++k) sum += value[k] * x[col[k]];
    y[r] += scale * sum;
  }
}

void SparseMatrixF::MultiplyTransposeAccumulate(const double* x, double scale, double* y) const {
  for (int r = 0; r < rows; ++r) {
    const double xr = scale * x[r];
    if (xr == 0) continue;
    for (uint32_t k = row_ptr[r]; k < row_ptr[r + 1]; ++k) y[col[k]] += value[k] * xr;
  }
}

namespace {

// Texel pieces, centres and angular radii of a map, computed once per resolution.
struct TexelGeometry {
  std::vector<SpherePolygon> pieces;  // kMaxPieces per texel
  std::vector<uint8_t> count;
  std::vector<Eigen::Vector3d> centre;
  std::vector<double> cos_radius;  // cosine of the largest angle between centre and a vertex
  std::vector<double> solid_angle;
  static constexpr int kMaxPieces = 8;
};

TexelGeometry MakeGeometry(int n, bool hemi) {
  TexelGeometry g;
  const size_t texels = size_t(n) * n;
  g.pieces.resize(texels * TexelGeometry::kMaxPieces);
  g.count.resize(texels);
  g.centre.resize(texels);
  g.cos_radius.resize(texels);
  g.solid_angle.resize(texels);
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const size_t t = size_t(j) * n + i;
      SpherePolygon* p = &g.pieces[t * TexelGeometry::kMaxPieces];
      const int c = hemi ? HemiOctRectPolygons(-1.0 + 2.0 * i / n, -1.0 + 2.0 * j / n, -1.0 + 2.0 * (i + 1) / n,
                                               -1.0 + 2.0 * (j + 1) / n, p)
                         : OctRectPolygons(double(i) / n, double(j) / n, double(i + 1) / n, double(j + 1) / n, p);
      g.count[t] = uint8_t(c);
      g.centre[t] = hemi ? HemiOctTexelDirection(i, j, n) : OctTexelDirection(i, j, n);
      double cos_r = 1.0, area = 0;
      for (int k = 0; k < c; ++k) {
        area += SpherePolygonArea(p[k]);
        for (int v = 0; v < p[k].size; ++v) cos_r = std::min(cos_r, g.centre[t].dot(p[k].v[v].normalized()));
      }
      g.cos_radius[t] = cos_r;
      g.solid_angle[t] = area;
    }
  }
  return g;
}

const TexelGeometry& CachedGeometry(int n, bool hemi) {
  static std::mutex mutex;
  static std::map<std::pair<int, bool>, std::unique_ptr<TexelGeometry>> cache;
  std::lock_guard<std::mutex> lock(mutex);
  auto& entry = cache[{n, hemi}];
  if (!entry) entry = std::make_unique<TexelGeometry>(MakeGeometry(n, hemi));
  return *entry;
}

// cos(a + b) from cosines of angles in [0, pi].
double CosSum(double cos_a, double cos_b) {
  const double sin_a = std::sqrt(std::max(0.0, 1 - cos_a * cos_a)), sin_b = std::sqrt(std::max(0.0, 1 - cos_b * cos_b));
  return cos_a * cos_b - sin_a * sin_b;
}

// Row tau of S_n: the global pixels overlapping local texel tau and the fractions of tau's solid
// angle they cover (exact; sums to 1), pixels ascending.
std::vector<SparseVec> ExactFootprints(const Eigen::Vector3d& normal_world, const RotationOptions& options) {
  const int ng = options.global_resolution, nl = options.local_resolution;
  const LocalFrame<double> frame = FrameFromNormal<double>(normal_world.normalized());
  const TexelGeometry& global = CachedGeometry(ng, false);
  const TexelGeometry& local = CachedGeometry(nl, true);
  std::vector<SparseVec> rows(size_t(nl) * nl);
  std::vector<std::pair<uint32_t, double>> footprint;
  std::vector<uint32_t> candidates;
  const int probe = 2 * std::max(1, ng / nl);  // probe points per local texel side for finding candidates
  for (int j = 0; j < nl; ++j) {
    for (int i = 0; i < nl; ++i) {
      const size_t t = size_t(j) * nl + i;
      SpherePolygon pieces[TexelGeometry::kMaxPieces];
      const int count = local.count[t];
      for (int k = 0; k < count; ++k) {
        pieces[k] = local.pieces[t * TexelGeometry::kMaxPieces + k];
        for (int v = 0; v < pieces[k].size; ++v) pieces[k].v[v] = frame.ToWorld(pieces[k].v[v]);
      }
      const Eigen::Vector3d centre = frame.ToWorld(local.centre[t]);
      double covered = 0;
      for (int radius = 1; radius <= 3; ++radius) {
        // Candidates: global texels within `radius` texels of probe points.
        candidates.clear();
        for (int py = 0; py < probe; ++py)
          for (int px = 0; px < probe; ++px) {
            const Eigen::Vector2d ab(-1.0 + 2.0 * (i + (px + 0.5) / probe) / nl,
                                     -1.0 + 2.0 * (j + (py + 0.5) / probe) / nl);
            const Eigen::Vector2i g = OctTexelOf(frame.ToWorld(HemiOctDecode(ab)), ng);
            for (int dy = -radius; dy <= radius; ++dy)
              for (int dx = -radius; dx <= radius; ++dx) {
                const Eigen::Vector2i w =
                    OctWrapTexel(std::clamp(g.x() + dx, -ng, 2 * ng - 1), std::clamp(g.y() + dy, -ng, 2 * ng - 1), ng);
                candidates.push_back(uint32_t(std::clamp(w.y(), 0, ng - 1)) * ng + std::clamp(w.x(), 0, ng - 1));
              }
          }
        std::sort(candidates.begin(), candidates.end());
        candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
        footprint.clear();
        covered = 0;
        for (uint32_t c : candidates) {
          // Reject when the bounding caps do not meet.
          if (centre.dot(global.centre[c]) < CosSum(local.cos_radius[t], global.cos_radius[c]) - 1e-12) continue;
          double area = 0;
          for (int a = 0; a < count; ++a)
            for (int b = 0; b < global.count[c]; ++b)
              area +=
                  SpherePolygonArea(ClipToCone(pieces[a], global.pieces[size_t(c) * TexelGeometry::kMaxPieces + b]));
          if (area > 0) {
            footprint.emplace_back(c, area);
            covered += area;
          }
        }
        if (std::abs(covered - local.solid_angle[t]) <= 1e-9 * local.solid_angle[t] + 1e-15) break;
      }
      RELIGHT_CHECK(std::abs(covered - local.solid_angle[t]) <= 1e-6 * local.solid_angle[t])
          << "rotation footprint of local texel " << i << "," << j << " covers " << covered << " of "
          << local.solid_angle[t] << " sr";
      const double wsum = covered;
      SparseVec& row = rows[t];
      row.reserve(footprint.size());
      for (const auto& [pixel, w] : footprint) row.emplace_back(pixel, w / wsum);
      std::sort(row.begin(), row.end());
    }
  }
  return rows;
}

}  // namespace

SparseMatrixF BuildResamplingMatrix(const Eigen::Vector3d& normal_world, const RotationOptions& options) {
  const std::vector<SparseVec> rows = ExactFootprints(normal_world, options);
  SparseMatrixF out;
  out.rows = int(rows.size());
  out.cols = options.global_resolution * options.global_resolution;
  out.row_ptr.assign(out.rows + 1, 0);
  for (int r = 0; r < out.rows; ++r) {
    for (const auto& [pixel, w] : rows[r]) {
      out.col.push_back(pixel);
      out.value.push_back(float(w));
    }
    out.row_ptr[r + 1] = uint32_t(out.value.size());
  }
  return out;
}

void OctGridBlendWeights(const Eigen::Vector3d& normal_world, int grid, int index[4], double weight[4]) {
  const Eigen::Vector2d st = OctEncode(normal_world);
  const double x = st.x() * grid - 0.5, y = st.y() * grid - 0.5;
  const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
  const double fx = x - x0, fy = y - y0;
  for (int c = 0; c < 4; ++c) {
    const int dx = c & 1, dy = c >> 1;
    const Eigen::Vector2i ij = OctWrapTexel(x0 + dx, y0 + dy, grid);
    index[c] = ij.y() * grid + ij.x();
    weight[c] = (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy);
  }
}

SparseMatrixF BuildRotationMatrix(const Eigen::Vector3d& normal_world, const RotationOptions& options,
                                  double* dropped_frobenius, double* total_frobenius) {
  const int ng = options.global_resolution, nl = options.local_resolution;
  const int lg = Log2(ng), ll = Log2(nl);
  const std::vector<SparseVec> footprints = ExactFootprints(normal_world, options);
  Accumulator& acc = tl_acc;
  acc.Resize(size_t(ng) * ng);

  // Rows of S W_g^T: for each local texel, the global Haar coefficients of its exact footprint.
  std::vector<SparseVec> block(size_t(nl) * nl);
  for (size_t t = 0; t < block.size(); ++t) {
    {
      const SparseVec& footprint = footprints[t];
      // Sparse forward Haar transform of the footprint.
      for (const auto& [pixel, w] : footprint) {
        const int pi = int(pixel % ng), pj = int(pixel / ng);
        acc.Touch(0);
        acc.v[0][0] += w / ng;
        for (int l = 0; l < lg; ++l) {
          const int shift = lg - l;
          const int a = pi >> shift, b = pj >> shift;
          const double sxg = ((pi >> (shift - 1)) & 1) ? -1.0 : 1.0;
          const double syg = ((pj >> (shift - 1)) & 1) ? -1.0 : 1.0;
          const double v = w * double(1 << l) / ng;
          const uint32_t ix = HaarIndex(HaarType::kDx, l, a, b, ng), iy = HaarIndex(HaarType::kDy, l, a, b, ng),
                         ixy = HaarIndex(HaarType::kDxy, l, a, b, ng);
          acc.Touch(ix);
          acc.Touch(iy);
          acc.Touch(ixy);
          acc.v[0][ix] += sxg * v;
          acc.v[0][iy] += syg * v;
          acc.v[0][ixy] += sxg * syg * v;
        }
      }
      acc.SortTouched();
      SparseVec& row = block[t];
      row.reserve(acc.touched.size());
      for (uint32_t m : acc.touched) row.emplace_back(m, acc.v[0][m]);
      acc.Clear();
    }
  }

  // W_l along the local tree, bottom up: block sums B_q, and wavelet rows from the children's B.
  std::vector<SparseVec> rows(size_t(nl) * nl);
  double dropped2 = 0, total2 = 0;
  auto emit = [&](uint32_t row_index, const SparseVec& entries) {
    SparseVec& out = rows[row_index];
    for (const auto& [m, v] : entries) {
      total2 += v * v;
      if (std::abs(v) < options.truncation || v == 0) {
        dropped2 += v * v;
      } else {
        out.emplace_back(m, v);
      }
    }
  };
  SparseVec rx, ry, rxy;
  for (int l = ll - 1; l >= 0; --l) {
    const int s = 1 << l;
    const double scale = double(s) / nl;
    std::vector<SparseVec> parent(size_t(s) * s);
    for (int b = 0; b < s; ++b) {
      for (int a = 0; a < s; ++a) {
        for (int c = 0; c < 4; ++c) {
          const int dx = c & 1, dy = c >> 1;
          const double sx = dx ? -1.0 : 1.0, sy = dy ? -1.0 : 1.0;
          const SparseVec& child = block[size_t(2 * b + dy) * (2 * s) + 2 * a + dx];
          for (const auto& [m, v] : child) {
            acc.Touch(m);
            acc.v[0][m] += v;
            acc.v[1][m] += sx * v;
            acc.v[2][m] += sy * v;
            acc.v[3][m] += sx * sy * v;
          }
        }
        acc.SortTouched();
        SparseVec& sum = parent[size_t(b) * s + a];
        sum.reserve(acc.touched.size());
        rx.clear();
        ry.clear();
        rxy.clear();
        for (uint32_t m : acc.touched) {
          sum.emplace_back(m, acc.v[0][m]);
          rx.emplace_back(m, scale * acc.v[1][m]);
          ry.emplace_back(m, scale * acc.v[2][m]);
          rxy.emplace_back(m, scale * acc.v[3][m]);
        }
        acc.Clear();
        emit(HaarIndex(HaarType::kDx, l, a, b, nl), rx);
        emit(HaarIndex(HaarType::kDy, l, a, b, nl), ry);
        emit(HaarIndex(HaarType::kDxy, l, a, b, nl), rxy);
      }
    }
    block.swap(parent);
  }
  SparseVec root;
  for (const auto& [m, v] : block[0]) root.emplace_back(m, v / nl);
  emit(0, root);

  SparseMatrixF out;
  out.rows = nl * nl;
  out.cols = ng * ng;
  out.row_ptr.assign(out.rows + 1, 0);
  size_t nnz = 0;
  for (const auto& r : rows) nnz += r.size();
  out.col.reserve(nnz);
  out.value.reserve(nnz);
  for (int r = 0; r < out.rows; ++r) {
    for (const auto& [m, v] : rows[r]) {
      out.col.push_back(m);
      out.value.push_back(float(v));
    }
    out.row_ptr[r + 1] = uint32_t(out.value.size());
  }
  if (dropped_frobenius) *dropped_frobenius = std::sqrt(dropped2);
  if (total_frobenius) *total_frobenius = std::sqrt(total2);
  return out;
}

Eigen::Vector3d RotationGrid::grid_normal(int g) const {
  const int n = options_.normal_grid;
  return OctTexelDirection(g % n, g / n, n);
}

RotationGrid RotationGrid::Build(const RotationOptions& options, RotationSummary* summary) {
  options.Check();
  Timer timer;
  RotationGrid grid;
  grid.options_ = options;
  const int count = options.normal_grid * options.normal_grid;
  grid.matrices_.resize(count);
  grid.dropped_rel_.resize(count);
  tbb::parallel_for(0, count, [&](int g) {
    double dropped = 0, total = 0;
    grid.matrices_[g] = BuildRotationMatrix(grid.grid_normal(g), options, &dropped, &total);
    grid.dropped_rel_[g] = float(total > 0 ? dropped / total : 0.0);
  });
  if (summary) {
    *summary = RotationSummary();
    summary->build_seconds = timer.Seconds();
  }
  if (summary) {
    summary->num_normals = count;
    summary->nnz_total = grid.nnz();
    summary->nnz_per_matrix = double(summary->nnz_total) / count;
    summary->density = summary->nnz_per_matrix / (double(options.local_resolution) * options.local_resolution *
                                                  options.global_resolution * options.global_resolution);
    summary->max_dropped_rel = *std::max_element(grid.dropped_rel_.begin(), grid.dropped_rel_.end());
    summary->bytes =
        summary->nnz_total * 8 + size_t(count) * (options.local_resolution * options.local_resolution + 1) * 4;
  }
  return grid;
}

size_t RotationGrid::nnz() const {
  size_t n = 0;
  for (const auto& m : matrices_) n += m.nnz();
  return n;
}

std::string RotationGrid::CacheFileName(const RotationOptions& o) {
  char buf[160];
  std::snprintf(buf, sizeof(buf), "rotation_v%u_g%d_l%d_n%d_t%.3e.bin", kVersion, o.global_resolution,
                o.local_resolution, o.normal_grid, o.truncation);
  return buf;
}

namespace {
template <typename T>
void Put(std::string* out, const T& v) {
  out->append(reinterpret_cast<const char*>(&v), sizeof(T));
}
template <typename T>
void PutArray(std::string* out, const std::vector<T>& v) {
  out->append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
}
// Streams straight into the destination vectors (the cache can be hundreds of MB).
struct Reader {
  std::ifstream& in;
  const std::string& path;
  template <typename T>
  T Get() {
    T v;
    Read(&v, sizeof(T));
    return v;
  }
  template <typename T>
  void GetArray(std::vector<T>* v, size_t count) {
    v->resize(count);
    Read(v->data(), count * sizeof(T));
  }
  void Read(void* dst, size_t bytes) {
    if (!in.read(static_cast<char*>(dst), std::streamsize(bytes)))
      RELIGHT_USER_ERROR() << "rotation cache " << path << " is truncated: delete it to rebuild";
  }
};
}  // namespace

void RotationGrid::Save(const std::string& path) const {
  std::string out;
  out.reserve(64 + nnz() * 8 +
              matrices_.size() * (size_t(options_.local_resolution) * options_.local_resolution + 2) * 4);
  out.append(kMagic, 8);
  Put(&out, kVersion);
  Put(&out, uint32_t(options_.global_resolution));
  Put(&out, uint32_t(options_.local_resolution));
  Put(&out, uint32_t(options_.normal_grid));
  Put(&out, options_.truncation);
  Put(&out, uint32_t(matrices_.size()));
  for (size_t g = 0; g < matrices_.size(); ++g) {
    const SparseMatrixF& m = matrices_[g];
    Put(&out, uint32_t(m.nnz()));
    Put(&out, dropped_rel_[g]);
    PutArray(&out, m.row_ptr);
    PutArray(&out, m.col);
    PutArray(&out, m.value);
  }
  WriteFileAtomic(path, out);
}

RotationGrid RotationGrid::Load(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) RELIGHT_USER_ERROR() << "cannot read rotation cache '" << path << "': it does not exist or is not readable";
  Reader r{in, path};
  char magic[8];
  r.Read(magic, 8);
  if (std::memcmp(magic, kMagic, 8) != 0)
    RELIGHT_USER_ERROR() << path << " is not a rotation cache (bad magic): delete it to rebuild";
  const uint32_t version = r.Get<uint32_t>();
  if (version != kVersion)
    RELIGHT_USER_ERROR() << "rotation cache " << path << " has version " << version << ", expected " << kVersion
                         << ": delete it to rebuild";
  RotationGrid grid;
  grid.options_.global_resolution = int(r.Get<uint32_t>());
  grid.options_.local_resolution = int(r.Get<uint32_t>());
  grid.options_.normal_grid = int(r.Get<uint32_t>());
  grid.options_.truncation = r.Get<double>();
  grid.options_.Check();
  const uint32_t count = r.Get<uint32_t>();
  if (count != uint32_t(grid.options_.normal_grid * grid.options_.normal_grid))
    RELIGHT_USER_ERROR() << "rotation cache " << path << " holds " << count << " matrices for a grid of "
                         << grid.options_.normal_grid << "^2: delete it to rebuild";
  const int rows = grid.options_.local_resolution * grid.options_.local_resolution;
  const int cols = grid.options_.global_resolution * grid.options_.global_resolution;
  grid.matrices_.resize(count);
  grid.dropped_rel_.resize(count);
  for (uint32_t g = 0; g < count; ++g) {
    SparseMatrixF& m = grid.matrices_[g];
    const uint32_t nnz = r.Get<uint32_t>();
    grid.dropped_rel_[g] = r.Get<float>();
    m.rows = rows;
    m.cols = cols;
    r.GetArray(&m.row_ptr, rows + 1);
    r.GetArray(&m.col, nnz);
    r.GetArray(&m.value, nnz);
    if (m.row_ptr.back() != nnz)
      RELIGHT_USER_ERROR() << "rotation cache " << path << " is corrupt (matrix " << g << "): delete it to rebuild";
    for (uint32_t c : m.col)
      if (c >= uint32_t(cols)) RELIGHT_USER_ERROR() << "rotation cache " << path << " is corrupt: delete it to rebuild";
  }
  if (in.peek() != std::char_traits<char>::eof())
    RELIGHT_USER_ERROR() << "rotation cache " << path << " has trailing bytes: delete it to rebuild";
  return grid;
}

RotationGrid RotationGrid::LoadOrBuild(const RotationOptions& options, const std::string& cache_dir,
                                       RotationSummary* summary) {
  options.Check();
  const std::string path = JoinPath(cache_dir, CacheFileName(options));
  if (std::filesystem::exists(path)) {
    try {
      RotationGrid grid = Load(path);
      const RotationOptions& o = grid.options_;
      if (o.global_resolution == options.global_resolution && o.local_resolution == options.local_resolution &&
          o.normal_grid == options.normal_grid && o.truncation == options.truncation) {
        if (summary) {
          *summary = RotationSummary();
          summary->num_normals = grid.matrices_.size();
          summary->nnz_total = grid.nnz();
          summary->nnz_per_matrix = double(summary->nnz_total) / grid.matrices_.size();
          summary->density = summary->nnz_per_matrix / (double(o.local_resolution) * o.local_resolution *
                                                        o.global_resolution * o.global_resolution);
          summary->max_dropped_rel = *std::max_element(grid.dropped_rel_.begin(), grid.dropped_rel_.end());
          summary->loaded_from_cache = true;
          summary->cache_path = path;
          summary->bytes =
              summary->nnz_total * 8 + grid.matrices_.size() * (o.local_resolution * o.local_resolution + 1) * 4;
        }
        RLOG_INFO("rotation matrices loaded from {}", path);
        return grid;
      }
      RLOG_WARN("rotation cache {} was built with other options; rebuilding", path);
    } catch (const UserError& e) {
      RLOG_WARN("{}; rebuilding", e.what());
    }
  }
  RotationGrid grid = Build(options, summary);
  EnsureDir(cache_dir);
  grid.Save(path);
  if (summary) summary->cache_path = path;
  RLOG_INFO("rotation matrices built ({} normals, {} non-zeros) and cached in {}", grid.matrices_.size(), grid.nnz(),
            path);
  return grid;
}

void RotationGrid::BlendWeights(const Eigen::Vector3d& normal_world, int index[4], double weight[4]) const {
  OctGridBlendWeights(normal_world, options_.normal_grid, index, weight);
}

void RotationGrid::Rotate(const Eigen::Vector3d& normal_world, const float* global, float* local) const {
  int index[4];
  double weight[4];
  BlendWeights(normal_world, index, weight);
  const int rows = options_.local_resolution * options_.local_resolution;
  std::fill(local, local + rows, 0.0f);
  for (int c = 0; c < 4; ++c) {
    if (weight[c] == 0) continue;
    const SparseMatrixF& m = matrices_[index[c]];
    const float w = float(weight[c]);
    for (int r = 0; r < rows; ++r) {
      float sum = 0;
      for (uint32_t k = m.row_ptr[r]; k < m.row_ptr[r + 1]; ++k) sum += m.value[k] * global[m.col[k]];
      local[r] += w * sum;
    }
  }
}

void RotationGrid::AccumulateTransposed(const Eigen::Vector3d& normal_world, const double* local, double scale,
                                        double* global) const {
  int index[4];
  double weight[4];
  BlendWeights(normal_world, index, weight);
  for (int c = 0; c < 4; ++c) {
    if (weight[c] == 0) continue;
    matrices_[index[c]].MultiplyTransposeAccumulate(local, scale * weight[c], global);
  }
}

ResamplingGrid ResamplingGrid::Build(const RotationOptions& options, RotationSummary* summary) {
  options.Check();
  Timer timer;
  ResamplingGrid grid;
  grid.options_ = options;
  const int count = options.normal_grid * options.normal_grid;
  grid.matrices_.resize(count);
  tbb::parallel_for(0, count, [&](int g) { grid.matrices_[g] = BuildResamplingMatrix(grid.grid_normal(g), options); });
  if (summary) {
    *summary = RotationSummary();
    summary->build_seconds = timer.Seconds();
    summary->num_normals = count;
    summary->nnz_total = grid.nnz();
    summary->nnz_per_matrix = double(summary->nnz_total) / count;
    summary->density = summary->nnz_per_matrix / (double(options.local_resolution) * options.local_resolution *
                                                  options.global_resolution * options.global_resolution);
    summary->bytes =
        summary->nnz_total * 8 + size_t(count) * (options.local_resolution * options.local_resolution + 1) * 4;
  }
  return grid;
}

Eigen::Vector3d ResamplingGrid::grid_normal(int g) const {
  const int n = options_.normal_grid;
  return OctTexelDirection(g % n, g / n, n);
}

void ResamplingGrid::BlendWeights(const Eigen::Vector3d& normal_world, int index[4], double weight[4]) const {
  OctGridBlendWeights(normal_world, options_.normal_grid, index, weight);
}

size_t ResamplingGrid::nnz() const {
  size_t n = 0;
  for (const auto& m : matrices_) n += m.nnz();
  return n;
}

void ResamplingGrid::Rotate(const Eigen::Vector3d& normal_world, const float* global, float* local) const {
  int index[4];
  double weight[4];
  BlendWeights(normal_world, index, weight);
  const int ng = options_.global_resolution, nl = options_.local_resolution;
  thread_local std::vector<float> pixels;
  pixels.resize(size_t(ng) * ng);
  HaarInverse(global, ng, pixels.data());
  std::fill(local, local + size_t(nl) * nl, 0.0f);
  for (int c = 0; c < 4; ++c) {
    if (weight[c] == 0) continue;
    const SparseMatrixF& m = matrices_[index[c]];
    const float w = float(weight[c]);
    for (int r = 0; r < m.rows; ++r) {
      float sum = 0;
      for (uint32_t k = m.row_ptr[r]; k < m.row_ptr[r + 1]; ++k) sum += m.value[k] * pixels[m.col[k]];
      local[r] += w * sum;
    }
  }
  HaarForward(local, nl, local);
}

void ResamplingGrid::AccumulateTransposed(const Eigen::Vector3d& normal_world, const double* local, double scale,
                                          double* global) const {
  int index[4];
  double weight[4];
  BlendWeights(normal_world, index, weight);
  const int ng = options_.global_resolution, nl = options_.local_resolution;
  thread_local std::vector<double> local_pixels, global_pixels;
  local_pixels.resize(size_t(nl) * nl);
  global_pixels.assign(size_t(ng) * ng, 0.0);
  HaarInverse(local, nl, local_pixels.data());
  for (int c = 0; c < 4; ++c) {
    if (weight[c] == 0) continue;
    matrices_[index[c]].MultiplyTransposeAccumulate(local_pixels.data(), weight[c], global_pixels.data());
  }
  HaarForward(global_pixels.data(), ng, global_pixels.data());
  for (size_t k = 0; k < global_pixels.size(); ++k) global[k] += scale * global_pixels[k];
}

}  // namespace relight
