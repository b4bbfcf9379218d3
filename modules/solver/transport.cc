#include "solver/transport.h"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <memory>

#include "core/error.h"
#include "core/progress.h"
#include "core/scratch_file.h"
#include "observe/observe.h"
#include "solver/reflectance.h"
#include "sphere/frame.h"
#include "sphere/octahedral.h"
#include "sphere/sh.h"
#include "wavelet/brdf_slice.h"
#include "wavelet/haar.h"
#include "wavelet/rotation.h"
#include "wavelet/triple_product.h"

namespace relight {

double LobeHalfVectorCutoff(const BrdfLobe& lobe) {
  if (lobe.model != BrdfModel::kGgx && lobe.model != BrdfModel::kCookTorrance) return -1.0;
  const double a2 = lobe.roughness * lobe.roughness;
  auto d = [&](double cos_h) {
    const double c2 = cos_h * cos_h, t2 = (1 - c2) / c2;
    if (lobe.model == BrdfModel::kCookTorrance) return std::exp(-t2 / a2) / (a2 * c2 * c2);
    return a2 / (c2 * c2 * (a2 + t2) * (a2 + t2));
  };
  const double peak = d(1.0);
  for (int k = 1; k <= 900; ++k) {
    const double theta = k * (M_PI / 2) / 900.0;
    if (d(std::cos(theta)) < 1e-5 * peak) return std::cos(theta);
  }
  return -1.0;
}

double PhongMirrorCutoff(const BrdfLobe& lobe) {
  if (lobe.model != BrdfModel::kPhong || lobe.exponent <= 0) return -1.0;
  return std::exp(std::log(1e-5) / lobe.exponent);
}

double LobeFootprintSpread(const BrdfLobe& lobe) {
  // Angular standard deviation of the lobe around the mirror direction [rad]:
  // Phong cos^n θ ≈ exp(−n θ²/2); GGX α in the half vector ≈ α/√2, twice that
  // in the reflected direction.
  double sigma = M_PI / 2;
  if (lobe.model == BrdfModel::kPhong && lobe.exponent > 0) sigma = 1.0 / std::sqrt(lobe.exponent);
  if (lobe.model == BrdfModel::kGgx || lobe.model == BrdfModel::kCookTorrance) sigma = std::sqrt(2.0) * lobe.roughness;
  // Averaging a Gaussian lobe over mirror directions spread by 2δ changes its
  // peak by about (2δ)²/(4σ²); below 2 % the vertex normal alone is kept.
  return std::sqrt(0.02) * sigma;
}

int TransportSupersampling(int visibility_resolution, int env_resolution, int requested) {
  if (requested > 0) return requested;
  // A hemi-octahedral texel of side N covers 2π/N² sr, a global octahedral one
  // of side M covers 4π/M²: equal density at M = √2 N. One sample per global
  // texel side or better.
  return std::max(1, static_cast<int>(std::ceil(env_resolution / (std::sqrt(2.0) * visibility_resolution) - 1e-9)));
}

struct TransportStore::Pool {
  std::vector<char> memory;           // in memory
  std::unique_ptr<ScratchFile> file;  // or on disk
};

namespace {

// Bytes of a record of n coefficients: n floats, n uint16 indices, padded to 4 bytes.
size_t RecordBytes(uint32_t n) { return (size_t(n) * 6 + 3) & ~size_t(3); }

}  // namespace

TransportStore::TransportStore() : pool_(std::make_shared<Pool>()) {}

TransportStore::Row TransportStore::Get(size_t observation, uint32_t vertex, int lobe) const {
  const size_t r = view_dependent_[lobe] ? vertex_rows_ + observation * num_dependent_ + slot_[lobe]
                                         : size_t(vertex) * num_independent_ + slot_[lobe];
  const char* record = data_ + offsets_[r];
  const uint32_t n = sizes_[r];
  return {reinterpret_cast<const uint16_t*>(record + size_t(n) * 4), reinterpret_cast<const float*>(record), n};
}

float TransportStore::Dot(size_t observation, uint32_t vertex, int lobe, const float* dense) const {
  const Row row = Get(observation, vertex, lobe);
  float s = 0.0f;
  for (uint32_t k = 0; k < row.size; ++k) s += row.value[k] * dense[row.index[k]];
  return s;
}

size_t TransportStore::bytes() const {
  const size_t pool = pool_->file ? pool_->file->size() : pool_->memory.size();
  return pool + offsets_.size() * sizeof(uint64_t) + sizes_.size() * sizeof(uint32_t);
}

bool TransportStore::on_disk() const { return pool_->file != nullptr; }

void TransportStore::Evict(size_t observation_begin, size_t observation_end) const {
  if (!pool_->file || num_dependent_ == 0 || observation_begin >= observation_end) return;
  // The observations' rows are contiguous within each wave: per wave, the span from the first to the end of the last.
  const size_t num_waves = wave_begin_.size();
  std::vector<uint64_t> lo(num_waves, UINT64_MAX), hi(num_waves, 0);
  const size_t r0 = vertex_rows_ + observation_begin * num_dependent_;
  const size_t r1 = std::min(offsets_.size(), vertex_rows_ + observation_end * num_dependent_);
  for (size_t r = r0; r < r1; ++r) {
    if (sizes_[r] == 0) continue;
    const size_t w =
        size_t(std::upper_bound(wave_begin_.begin(), wave_begin_.end(), offsets_[r]) - wave_begin_.begin()) - 1;
    lo[w] = std::min<uint64_t>(lo[w], offsets_[r]);
    hi[w] = std::max<uint64_t>(hi[w], offsets_[r] + RecordBytes(sizes_[r]));
  }
  for (size_t w = 0; w < num_waves; ++w)
    if (lo[w] < hi[w]) pool_->file->DropPages(lo[w], hi[w]);
}

void TransportStore::EvictAll() const {
  if (pool_->file) pool_->file->DropPages(0, pool_->file->size());
}

namespace {

// A footprint normal that faces the camera, prepared for one observation (vertex-local frame).
struct FootprintSample {
  Eigen::Vector3f normal;
  float weight;
  float cos_o;             // cosine between the sample's normal and the view direction
  Eigen::Vector3f mirror;  // view direction mirrored about the sample's normal
};

// Writes records into the pool in the order given: straight into memory, or through a buffer into the
// scratch file (TransportStore, "Rows on disk").
class PoolWriter {
 public:
  explicit PoolWriter(const std::string& spill_dir) : pool_(std::make_shared<TransportStore::Pool>()) {
    if (!spill_dir.empty()) pool_->file = std::make_unique<ScratchFile>(spill_dir, "transport rows");
  }
  // Bytes written so far: the offset of the next record.
  uint64_t size() const { return pool_->file ? pool_->file->size() + pending_.size() : pool_->memory.size(); }
  void Write(const char* record, size_t bytes) {
    std::vector<char>& out = pool_->file ? pending_ : pool_->memory;
    out.insert(out.end(), record, record + bytes);
    if (pool_->file && pending_.size() >= kFlushBytes) Flush();
  }
  // The finished pool and its first byte.
  std::shared_ptr<TransportStore::Pool> Finish(const char** data) {
    if (pool_->file) {
      Flush();
      std::vector<char>().swap(pending_);
      *data = pool_->file->Map();
    } else {
      *data = pool_->memory.data();
    }
    return std::move(pool_);
  }

 private:
  static constexpr size_t kFlushBytes = size_t(4) << 20;
  void Flush() {
    pool_->file->Append(pending_.data(), pending_.size());
    pending_.clear();
  }
  std::shared_ptr<TransportStore::Pool> pool_;
  std::vector<char> pending_;
};

// Rows of one block of vertices as records (TransportStore's layout), in the order they were built.
struct BlockRows {
  struct Entry {
    size_t row;
    size_t offset;  // into bytes
    uint32_t size;
  };
  std::vector<Entry> entries;
  std::vector<char> bytes;

  void Add(size_t row, const std::vector<uint16_t>& index, const std::vector<float>& value) {
    const uint32_t n = static_cast<uint32_t>(index.size());
    entries.push_back({row, bytes.size(), n});
    bytes.resize(bytes.size() + RecordBytes(n));
    char* p = bytes.data() + entries.back().offset;
    std::memcpy(p, value.data(), size_t(n) * 4);
    std::memcpy(p + size_t(n) * 4, index.data(), size_t(n) * 2);
  }
};

// Per-vertex precomputation: the visible local texels with their weights
// V·Ω, local directions, and their global footprint.
struct VertexTexels {
  std::vector<Eigen::Vector3f> dir_local;
  std::vector<float> weight;             // V_j Ω_j (the cosine belongs to each footprint normal)
  std::vector<std::array<uint16_t, 4>> splat_index;  // haar: bilinear global texels
  std::vector<std::array<float, 4>> splat_weight;
};

// The fewest largest-magnitude coefficients holding `fraction` of the energy,
// at most `cap`, as ascending indices. Ranked by (energy descending, index
// ascending), a strict order, so the kept set is unique. The count is found
// in two steps, O(n) in all: a histogram of the energies by their float
// exponent (one octave per bucket) names the octave where the running sum
// from the top reaches the target; everything above it is kept, everything
// below dropped, and only that octave's coefficients go through the
// selection on partial sums (each round an nth_element over the still
// undecided part, which halves it). The kept ones are emitted by a scan in
// index order. Sorting the candidates (an earlier version) dominated the
// build, and so did the selection over all of them (the version before this).
struct Truncator {
  // Per non-zero coefficient one key that sorts like the ranking: the energy's
  // bits (a non-negative float orders like its bit pattern) above the
  // complemented index, so one integer comparison ranks.
  std::vector<uint64_t> nz, scratch;
  std::vector<uint8_t> kept;  // per coefficient: 1 when kept
  std::array<double, 256> octave_energy{};
  std::array<uint32_t, 256> octave_count{};

  static float Energy(uint64_t key) {
    const uint32_t bits = static_cast<uint32_t>(key >> 16);
    float e;
    std::memcpy(&e, &bits, sizeof e);
    return e;
  }
  static uint16_t Index(uint64_t key) { return static_cast<uint16_t>(0xFFFFu - (key & 0xFFFFu)); }
  // The float exponent field of the energy: keys of a higher octave rank higher.
  static int Octave(uint64_t key) { return static_cast<int>(key >> (16 + 23)) & 0xFF; }

  void Run(const float* coeffs, int size, double fraction, int cap, std::vector<uint16_t>* index,
           std::vector<float>* value) {
    nz.clear();
    double total = 0;
    for (int k = 0; k < size; ++k) {
      if (coeffs[k] == 0.0f) continue;
      const float e = coeffs[k] * coeffs[k];
      uint32_t bits;
      std::memcpy(&bits, &e, sizeof bits);
      nz.push_back((uint64_t(bits) << 16) | (0xFFFFu - static_cast<uint32_t>(k)));
      total += e;
    }
    index->clear();
    value->clear();
    if (nz.empty()) return;
    const size_t limit = static_cast<size_t>(std::max(0, cap));
    if (fraction >= 1.0 && nz.size() <= limit) {  // everything
      index->reserve(nz.size());
      value->reserve(nz.size());
      for (uint64_t key : nz) {
        index->push_back(Index(key));
        value->push_back(coeffs[Index(key)]);
      }
      return;
    }
    const std::greater<uint64_t> larger;
    const double target = fraction * total;
    // Invariant: [0, lo) are the lo highest ranked, with sum `acc` < target;
    // [lo, hi) the next ones; acc + their sum >= target (or hi = n).
    size_t keep = 0;
    if (target > 0) {
      // Energy and count per octave, then the octave where the sum from the top reaches the target.
      int top = 0, bottom = 255;  // octaves in use
      for (uint64_t key : nz) {
        const int oct = Octave(key);
        top = std::max(top, oct);
        bottom = std::min(bottom, oct);
        octave_energy[oct] += Energy(key);
        ++octave_count[oct];
      }
      int boundary = top;
      double above = 0;  // energy of the octaves above `boundary`
      size_t count_above = 0;
      while (boundary > bottom && above + octave_energy[boundary] < target) {
        above += octave_energy[boundary];
        count_above += octave_count[boundary];
        --boundary;
      }
      // Keys above the boundary octave first, then the boundary's, then the rest.
      scratch.resize(nz.size());
      size_t hi_pos = 0, mid_pos = count_above, lo_pos = count_above + octave_count[boundary];
      for (uint64_t key : nz) {
        const int oct = Octave(key);
        scratch[oct > boundary ? hi_pos++ : oct == boundary ? mid_pos++ : lo_pos++] = key;
      }
      nz.swap(scratch);
      size_t lo = count_above, hi = count_above + octave_count[boundary];
      for (int q = bottom; q <= top; ++q) {  // cleared for the next row
        octave_energy[q] = 0;
        octave_count[q] = 0;
      }
      double acc = above;
      while (hi - lo > 1) {
        const size_t mid = lo + (hi - lo) / 2;
        std::nth_element(nz.begin() + lo, nz.begin() + mid, nz.begin() + hi, larger);
        double part = 0;
        for (size_t q = lo; q < mid; ++q) part += Energy(nz[q]);
        if (acc + part >= target) {
          hi = mid;
        } else {
          acc += part;
          lo = mid;
        }
      }
      keep = hi;
    }
    if (keep > limit) {
      std::nth_element(nz.begin(), nz.begin() + limit, nz.begin() + keep, larger);
      keep = limit;
    }
    kept.assign(size, 0);
    for (size_t q = 0; q < keep; ++q) kept[Index(nz[q])] = 1;
    index->reserve(keep);
    value->reserve(keep);
    for (int k = 0; k < size; ++k) {
      if (!kept[k]) continue;
      index->push_back(static_cast<uint16_t>(k));
      value->push_back(coeffs[k]);
    }
  }
};

void Splat(const Eigen::Vector3f& dir_world, int n, std::array<uint16_t, 4>* idx, std::array<float, 4>* w) {
  const Eigen::Vector2d st = OctEncode(dir_world.cast<double>());
  const double x = st.x() * n - 0.5, y = st.y() * n - 0.5;
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
  const int dx[4] = {0, 1, 0, 1}, dy[4] = {0, 0, 1, 1};
  const float wt[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2i t = OctWrapTexel(x0 + dx[k], y0 + dy[k], n);
    (*idx)[k] = static_cast<uint16_t>(t.y() * n + t.x());
    (*w)[k] = wt[k];
  }
}

}  // namespace

Eigen::Vector3f FootprintNormals::ScaledNormal(uint32_t s, float g) const {
  // The renderer's linear interpolation along the edge, in the vertex's frame (where its normal is +Z).
  const float t = std::min(1.0f, g * reach[s]);
  const Eigen::Vector3f z(0.0f, 0.0f, 1.0f);
  const Eigen::Vector3f m = z + t * (toward_local[s] - z);
  return m.squaredNorm() > 1e-12f ? Eigen::Vector3f(m.normalized()) : z;
}

FootprintNormals SampleFootprintNormals(const TriangleMesh& mesh, double footprint_scale) {
  const size_t nv = mesh.num_vertices();
  RELIGHT_CHECK(mesh.normals.size() == nv);
  // The radius `observe` samples the photo over, and the mesh neighbours.
  const std::vector<float> area_radius = VertexFootprintRadius(mesh);
  const std::vector<std::vector<uint32_t>> ring = VertexNeighbours(mesh);
  FootprintNormals out;
  out.first.assign(nv + 1, 0);
  for (size_t v = 0; v < nv; ++v) {
    const std::vector<uint32_t>& nb = ring[v];
    const Eigen::Vector3f n = mesh.normals[v];
    const LocalFrame<float> frame = FrameFromNormal<float>(n);
    out.normal_local.emplace_back(0.0f, 0.0f, 1.0f);
    out.weight.push_back(1.0f);
    out.toward_local.emplace_back(0.0f, 0.0f, 1.0f);
    out.reach.push_back(0.0f);
    const double radius = footprint_scale * area_radius[v];
    if (radius > 0 && !nb.empty()) {
      out.weight.back() = 1.0f / 3.0f;
      const float w = static_cast<float>(2.0 / (3.0 * nb.size()));
      for (uint32_t j : nb) {
        const double edge = (mesh.vertices[j] - mesh.vertices[v]).cast<double>().norm();
        out.toward_local.push_back(frame.ToLocal(mesh.normals[j]));
        out.reach.push_back(edge > 0 ? static_cast<float>(0.5 * std::sqrt(3.0) * radius / edge) : 0.0f);
        out.weight.push_back(w);
        out.normal_local.push_back(out.ScaledNormal(static_cast<uint32_t>(out.reach.size() - 1), 1.0f));
      }
    }
    out.first[v + 1] = static_cast<uint32_t>(out.normal_local.size());
  }
  return out;
}

TransportStore BuildTransport(const TriangleMesh& mesh, const VisibilityData& visibility,
                              const ObservationSet& observations, const TransportOptions& o) {
  RELIGHT_CHECK(mesh.normals.size() == mesh.num_vertices());
  RELIGHT_CHECK_EQ(visibility.per_vertex.size(), mesh.num_vertices());
  RELIGHT_CHECK_EQ(observations.num_vertices, mesh.num_vertices());
  const bool haar = o.lighting_basis == "haar";
  const int n_global = o.env_resolution;
  TransportStore store;
  store.dim_ = haar ? n_global * n_global : ShNumCoefficients(o.sh_order);
  RELIGHT_CHECK(store.dim_ <= 65536) << "env_resolution too large for 16-bit row indices";
  const int num_lobes = static_cast<int>(o.basis.size());
  store.view_dependent_.resize(num_lobes);
  store.slot_.resize(num_lobes);
  for (int b = 0; b < num_lobes; ++b) {
    const bool dep = o.basis[b].model != BrdfModel::kLambertian;
    store.view_dependent_[b] = dep;
    store.slot_[b] = dep ? store.num_dependent_++ : store.num_independent_++;
  }
  const size_t nv = mesh.num_vertices(), no = observations.records.size();
  store.vertex_rows_ = nv * store.num_independent_;
  const size_t total_rows = store.vertex_rows_ + no * store.num_dependent_;

  // Observations grouped by vertex.
  std::vector<uint32_t> first(nv + 1, 0);
  for (const auto& ob : observations.records) ++first[ob.vertex + 1];
  for (size_t v = 0; v < nv; ++v) first[v + 1] += first[v];
  std::vector<uint32_t> by_vertex(no);
  {
    std::vector<uint32_t> cursor(first.begin(), first.end() - 1);
    for (size_t k = 0; k < no; ++k) by_vertex[cursor[observations.records[k].vertex]++] = static_cast<uint32_t>(k);
  }

  const int n_local = visibility.resolution;
  // Haar pixel route: each visibility texel is integrated over `sub`² sub-texels
  // (TransportSupersampling), so the splats resolve the global map's texels.
  const int sub = haar && o.route == "pixel" ? TransportSupersampling(n_local, n_global, o.supersampling) : 1;
  const int n_sample = sub * n_local;
  const std::vector<Eigen::Vector3d> local_dirs = HemiOctTexelDirections(n_sample);
  const std::vector<double> local_solid_angles = HemiOctTexelSolidAngles(n_sample);
  // Sample j's visibility texel.
  std::vector<int> parent_texel(local_dirs.size());
  for (int y = 0; y < n_sample; ++y)
    for (int x = 0; x < n_sample; ++x) parent_texel[size_t(y) * n_sample + x] = (y / sub) * n_local + x / sub;
  std::vector<double> half_cutoff(num_lobes), mirror_cutoff(num_lobes);
  for (int b = 0; b < num_lobes; ++b) {
    half_cutoff[b] = LobeHalfVectorCutoff(o.basis[b]);
    mirror_cutoff[b] = PhongMirrorCutoff(o.basis[b]);
  }
  std::unique_ptr<ShHemiOctProjector> sh;
  if (!haar) sh = std::make_unique<ShHemiOctProjector>(n_local, o.sh_order);
  // Wavelet route: rotation (resampling) grid and BRDF slices tabulated over view directions.
  const bool wavelet = haar && o.route == "wavelet";
  std::unique_ptr<ResamplingGrid> rotation;
  std::vector<std::vector<double>> slices;  // [lobe * view_grid² + view] local Haar coefficients
  if (wavelet) {
    RotationOptions ro;
    ro.global_resolution = n_global;
    ro.local_resolution = n_local;
    ro.normal_grid = o.normal_grid;
    rotation = std::make_unique<ResamplingGrid>(ResamplingGrid::Build(ro));
    BrdfSliceOptions so;
    so.resolution = n_local;
    const int vg = o.view_grid;
    slices.resize(size_t(num_lobes) * vg * vg);
    tbb::parallel_for(size_t(0), slices.size(), [&](size_t k) {
      const int b = static_cast<int>(k / (vg * vg)), view = static_cast<int>(k % (vg * vg));
      // Lambertian slices do not depend on the view: only view 0 is used.
      if (o.basis[b].model == BrdfModel::kLambertian && view != 0) return;
      slices[k].resize(size_t(n_local) * n_local);
      BrdfSliceHaar(o.basis[b], HemiOctTexelDirection(view % vg, view / vg, vg), so, slices[k].data());
    });
  }

  const FootprintNormals footprint = SampleFootprintNormals(mesh, wavelet ? 0.0 : o.footprint_scale);
  // Each vertex's spread: the largest angle between its normal and a footprint normal [rad].
  std::vector<float> footprint_spread(nv, 0.0f);
  for (size_t v = 0; v < nv; ++v)
    for (uint32_t s = footprint.first[v]; s < footprint.first[v + 1]; ++s)
      footprint_spread[v] = std::max(footprint_spread[v], std::acos(std::clamp(footprint.normal_local[s].z(), -1.0f, 1.0f)));
  std::vector<float> lobe_min_spread(num_lobes);
  for (int b = 0; b < num_lobes; ++b) lobe_min_spread[b] = static_cast<float>(LobeFootprintSpread(o.basis[b]));

  // Rows are built per block of vertices, in waves of blocks (about o.wave_bytes of rows each); each
  // wave's rows are appended to the pool in row order (TransportStore).
  constexpr size_t kBlock = 256;
  const size_t num_blocks = (nv + kBlock - 1) / kBlock;
  std::vector<BlockRows> blocks(num_blocks);
  Progress progress("transport rows", static_cast<int64_t>(nv));
  auto build_block = [&](size_t blk) {
    const size_t v_begin = blk * kBlock, v_end = std::min(nv, v_begin + kBlock);
    BlockRows& out = blocks[blk];
    std::vector<uint16_t> row_index;  // the row being built
    std::vector<float> row_value;
    std::vector<float> pixel(haar ? store.dim_ : 0), coeffs(haar ? store.dim_ : 0);
    std::vector<float> texel_integrals(size_t(n_local) * n_local);
    std::vector<double> sh_coeffs(haar ? 0 : store.dim_);
    VertexTexels t;
    std::vector<float> acc(local_dirs.size(), 0.0f);  // texel sums over a footprint's normals
    std::vector<FootprintSample> samples;
    std::vector<float> sample_view;  // GGX: a sample's weight times its GgxViewFactor
    Truncator truncator;
    // Haar row from texel values: splat onto the global map, transform, truncate.
    auto emit_haar = [&](size_t row, const std::vector<float>& values, const std::vector<int>& texels) {
      std::fill(pixel.begin(), pixel.end(), 0.0f);
      for (size_t q = 0; q < texels.size(); ++q) {
        const int j = texels[q];
        for (int k = 0; k < 4; ++k) pixel[t.splat_index[j][k]] += values[q] * t.splat_weight[j][k];
      }
      HaarForward(pixel.data(), n_global, coeffs.data());
      truncator.Run(coeffs.data(), store.dim_, o.keep_energy, o.max_coefficients, &row_index, &row_value);
      out.Add(row, row_index, row_value);
    };
    for (size_t v = v_begin; v < v_end; ++v) {
      const std::vector<float> vis = visibility.DenseMap(v);
      const Eigen::Vector3f nrm = mesh.normals[v];
      const LocalFrame<float> frame = FrameFromNormal<float>(nrm);
      const LocalFrame<double> frame_d = FrameFromNormal<double>(nrm.cast<double>());
      if (wavelet) {
        // Local Haar visibility, product with the slice, transposed rotation to the global basis.
        const size_t n2 = size_t(n_local) * n_local;
        std::vector<double> vis_haar(n2, 0.0), product(n2), global(store.dim_);
        visibility.per_vertex[v].ToDense(vis_haar.data());
        const Eigen::Vector3d normal = nrm.cast<double>();
        auto wavelet_row = [&](size_t row, const std::vector<double>& slice) {
          ProductProjection(vis_haar.data(), slice.data(), n_local, product.data());
          std::fill(global.begin(), global.end(), 0.0);
          rotation->AccumulateTransposed(normal, product.data(), 1.0, global.data());
          for (int k = 0; k < store.dim_; ++k) coeffs[k] = static_cast<float>(global[k]);
          truncator.Run(coeffs.data(), store.dim_, o.keep_energy, o.max_coefficients, &row_index, &row_value);
          out.Add(row, row_index, row_value);
        };
        const int vg = o.view_grid;
        for (int b = 0; b < num_lobes; ++b) {
          if (store.view_dependent_[b]) continue;
          wavelet_row(size_t(v) * store.num_independent_ + store.slot_[b], slices[size_t(b) * vg * vg]);
        }
        for (uint32_t q = first[v]; q < first[v + 1]; ++q) {
          const uint32_t obs = by_vertex[q];
          const Observation& ob = observations.records[obs];
          const Eigen::Vector3d wo(ob.view_local[0], ob.view_local[1], std::max(0.0f, ob.view_local[2]));
          const Eigen::Vector2i cell = HemiOctTexelOf(wo, vg);
          const int view = cell.y() * vg + cell.x();
          for (int b = 0; b < num_lobes; ++b) {
            if (!store.view_dependent_[b]) continue;
            wavelet_row(store.vertex_rows_ + size_t(obs) * store.num_dependent_ + store.slot_[b],
                        slices[size_t(b) * vg * vg + view]);
          }
        }
        progress.Advance();
        continue;
      }
      // Visible texels of this vertex.
      std::vector<int> visible;
      t.dir_local.assign(local_dirs.size(), Eigen::Vector3f::Zero());
      t.weight.assign(local_dirs.size(), 0.0f);
      if (haar) {
        t.splat_index.resize(local_dirs.size());
        t.splat_weight.resize(local_dirs.size());
      }
      for (size_t j = 0; j < local_dirs.size(); ++j) {
        const float vj = std::clamp(vis[parent_texel[j]], 0.0f, 1.0f);
        if (vj <= 1e-4f) continue;
        const Eigen::Vector3f d = local_dirs[j].cast<float>();
        t.dir_local[j] = d;
        t.weight[j] = static_cast<float>(vj * local_solid_angles[j]);
        if (t.weight[j] <= 0 || local_dirs[j].z() <= 0) continue;
        if (haar) Splat(frame.ToWorld(d), n_global, &t.splat_index[j], &t.splat_weight[j]);
        visible.push_back(static_cast<int>(j));
      }
      std::vector<float> values;
      std::vector<int> support;
      auto finish = [&](size_t row) {
        if (haar) {
          emit_haar(row, values, support);
        } else {
          std::fill(texel_integrals.begin(), texel_integrals.end(), 0.0f);
          for (size_t q = 0; q < support.size(); ++q) texel_integrals[support[q]] = values[q];
          sh->ProjectIntegrals(texel_integrals.data(), frame_d, sh_coeffs.data());
          row_index.resize(store.dim_);
          row_value.resize(store.dim_);
          for (int k = 0; k < store.dim_; ++k) {
            row_index[k] = static_cast<uint16_t>(k);
            row_value[k] = static_cast<float>(sh_coeffs[k]);
          }
          out.Add(row, row_index, row_value);
        }
      };
      // The footprint's normals (vertex-local).
      const uint32_t s_begin = footprint.first[v], s_end = footprint.first[v + 1];
      // Sums texel values over the footprint's normals into `acc`, then lists the non-zero ones.
      auto gather = [&]() {
        values.clear();
        support.clear();
        for (int j : visible) {
          if (acc[j] > 0) {
            values.push_back(acc[j]);
            support.push_back(j);
          }
          acc[j] = 0.0f;
        }
      };
      // View-independent (Lambertian) lobes: once per vertex.
      for (int b = 0; b < num_lobes; ++b) {
        if (store.view_dependent_[b]) continue;
        for (uint32_t s = s_begin; s < s_end; ++s) {
          const Eigen::Vector3f& m = footprint.normal_local[s];
          const float w = footprint.weight[s] * static_cast<float>(1.0 / M_PI);
          for (int j : visible) acc[j] += w * t.weight[j] * std::max(0.0f, m.dot(t.dir_local[j]));
        }
        gather();
        finish(size_t(v) * store.num_independent_ + store.slot_[b]);
      }
      // View-dependent lobes: per observation, averaged over the footprint's
      // normals that face the camera. A lobe much wider than the footprint's
      // spread of mirror directions is evaluated at the vertex normal alone
      // (LobeFootprintSpread), and for the others texels outside the union of
      // the samples' lobes are skipped with one test against the vertex's own.
      // Each observation's normals are spread over its own kernel (kernel_scale times the nominal disc).
      for (uint32_t q = first[v]; q < first[v + 1]; ++q) {
        const uint32_t obs = by_vertex[q];
        const Observation& ob = observations.records[obs];
        const Eigen::Vector3f wo(ob.view_local[0], ob.view_local[1], ob.view_local[2]);
        const float g = ob.kernel_scale;
        float spread = footprint_spread[v];
        // Samples facing the camera: normal, weight, cosine to the view, mirror direction.
        samples.clear();
        float facing = 0.0f;
        for (uint32_t s = s_begin; s < s_end; ++s) {
          const Eigen::Vector3f m = g == 1.0f ? footprint.normal_local[s] : footprint.ScaledNormal(s, g);
          if (g != 1.0f) spread = std::max(spread, std::acos(std::clamp(m.z(), -1.0f, 1.0f)));
          const float cos_o = m.dot(wo);
          if (cos_o <= 0) continue;
          samples.push_back({m, footprint.weight[s], cos_o, 2.0f * cos_o * m - wo});
          facing += footprint.weight[s];
        }
        for (auto& sm : samples) sm.weight /= facing;
        const Eigen::Vector3f mirror0(-wo.x(), -wo.y(), wo.z());
        for (int b = 0; b < num_lobes; ++b) {
          if (!store.view_dependent_[b]) continue;
          const BrdfLobe& lobe = o.basis[b];
          const float hc = static_cast<float>(half_cutoff[b]), mc = static_cast<float>(mirror_cutoff[b]);
          values.clear();
          support.clear();
          // GGX is evaluated factored (BrdfLobe::GgxViewFactor): what depends on the
          // view alone once per sample, the Fresnel term once per texel.
          const bool microfacet = lobe.model == BrdfModel::kGgx || lobe.model == BrdfModel::kCookTorrance;
          const bool ggx = lobe.model == BrdfModel::kGgx;
          const float f0 = static_cast<float>(lobe.f0);
          if (samples.size() <= 1 || spread < lobe_min_spread[b]) {
            // The vertex normal alone.
            if (!(wo.z() > 0)) {
              finish(store.vertex_rows_ + size_t(obs) * store.num_dependent_ + store.slot_[b]);
              continue;
            }
            const float view_factor = ggx ? lobe.GgxViewFactor<float>(wo.z()) : 0.0f;
            for (int j : visible) {
              const Eigen::Vector3f& wi = t.dir_local[j];
              const float cos_mirror = wi.dot(mirror0);
              if (mc > -1 && cos_mirror < mc) continue;
              float f_cos;  // f(wi, wo) cos_i
              if (microfacet) {
                Eigen::Vector3f h = wi + wo;
                const float h_norm = h.norm();
                if (!(h_norm > 1e-12f)) continue;
                h /= h_norm;
                if (hc > -1 && h.z() < hc) continue;
                const float o_dot_h = std::max(0.0f, wo.dot(h));
                f_cos = ggx ? view_factor * brdf_internal::Schlick(f0, o_dot_h) * lobe.GgxHalfFactor<float>(wi.z(), h.z())
                            : lobe.EvalCosines<float>(wi.z(), wo.z(), h.z(), o_dot_h, 0.0f) * wi.z();
              } else {
                f_cos = lobe.EvalCosines<float>(wi.z(), wo.z(), 0.0f, 0.0f, cos_mirror) * wi.z();
              }
              if (!(f_cos > 0)) continue;
              values.push_back(f_cos * t.weight[j]);
              support.push_back(j);
            }
          } else {
            // Cutoffs widened by the spread: the mirror direction turns by up to twice the normal's angle.
            const float mc_union = mc > -1 ? std::cos(std::min<float>(M_PI, std::acos(mc) + 2 * spread)) : -2.0f;
            const float hc_union = hc > -1 ? std::cos(std::min<float>(M_PI, std::acos(hc) + spread)) : -2.0f;
            // The lobe at each sample's normal from rotation-invariant cosines
            // (BrdfLobe::EvalCosines): no change of frame per sample and texel,
            // and the half vector (and wo·h) is the same for every sample.
            if (ggx) {
              sample_view.resize(samples.size());
              for (size_t s = 0; s < samples.size(); ++s)
                sample_view[s] = samples[s].weight * lobe.GgxViewFactor<float>(samples[s].cos_o);
            }
            for (int j : visible) {
              const Eigen::Vector3f& wi = t.dir_local[j];
              if (wi.dot(mirror0) < mc_union) continue;
              Eigen::Vector3f h = Eigen::Vector3f::Zero();
              float o_dot_h = 0.0f;
              if (microfacet) {
                h = wi + wo;
                const float h_norm = h.norm();
                if (!(h_norm > 1e-12f)) continue;
                h /= h_norm;
                if (hc > -1 && h.z() < hc_union) continue;
                o_dot_h = std::max(0.0f, wo.dot(h));
              }
              float sum = 0.0f;
              if (ggx) {
                for (size_t s = 0; s < samples.size(); ++s) {
                  const FootprintSample& sm = samples[s];
                  const float cos_i = sm.normal.dot(wi);
                  if (cos_i <= 0) continue;
                  const float cos_h = h.dot(sm.normal);
                  if (hc > -1 && cos_h < hc) continue;
                  sum += sample_view[s] * lobe.GgxHalfFactor<float>(cos_i, cos_h);
                }
                sum *= brdf_internal::Schlick(f0, o_dot_h);
              } else {
                for (const FootprintSample& sm : samples) {
                  const float cos_mirror = wi.dot(sm.mirror);
                  if (mc > -1 && cos_mirror < mc) continue;
                  const float cos_i = sm.normal.dot(wi);
                  if (cos_i <= 0) continue;
                  const float cos_h = microfacet ? h.dot(sm.normal) : 0.0f;
                  if (hc > -1 && cos_h < hc) continue;
                  const float f = lobe.EvalCosines<float>(cos_i, sm.cos_o, cos_h, o_dot_h, cos_mirror);
                  if (f > 0) sum += sm.weight * f * cos_i;
                }
              }
              if (!(sum > 0)) continue;
              values.push_back(sum * t.weight[j]);
              support.push_back(j);
            }
          }
          finish(store.vertex_rows_ + size_t(obs) * store.num_dependent_ + store.slot_[b]);
        }
      }
      progress.Advance();
    }
  };

  store.offsets_.assign(total_rows, 0);
  store.sizes_.assign(total_rows, 0);
  PoolWriter writer(o.spill_dir);
  std::vector<std::pair<size_t, const BlockRows::Entry*>> order;                // (block, entry)
  const size_t min_wave = 2 * size_t(tbb::this_task_arena::max_concurrency());  // blocks: every thread busy
  size_t wave_size = min_wave;
  for (size_t begin = 0; begin < num_blocks;) {
    const size_t end = std::min(num_blocks, begin + wave_size);
    tbb::parallel_for(begin, end, build_block);
    order.clear();
    size_t record_bytes = 0;
    for (size_t b = begin; b < end; ++b) {
      for (const BlockRows::Entry& e : blocks[b].entries) order.emplace_back(b, &e);
      record_bytes += blocks[b].bytes.size();
    }
    std::sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.second->row < b.second->row; });
    store.wave_begin_.push_back(writer.size());
    for (const auto& [b, e] : order) {
      store.offsets_[e->row] = writer.size();
      store.sizes_[e->row] = e->size;
      store.num_coefficients_ += e->size;
      writer.Write(blocks[b].bytes.data() + e->offset, RecordBytes(e->size));
    }
    for (size_t b = begin; b < end; ++b) blocks[b] = BlockRows();
    // The next wave holds about o.wave_bytes of rows, at the rate of this one.
    const double per_block = double(record_bytes) / double(end - begin);
    wave_size = std::max(min_wave, static_cast<size_t>(double(o.wave_bytes) / std::max(1.0, per_block)));
    begin = end;
  }
  progress.Finish();
  // Offsets of empty rows point at the start of the pool (their records are never read).
  store.pool_ = writer.Finish(&store.data_);
  return store;
}

}  // namespace relight
