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

namespace {

// Rows are built per block of this many vertices (BlockRows), in waves of blocks.
constexpr size_t kBlock = 256;

// The store's row numbering (TransportStore::Get), apart from the store: only BuildTransport may write the store.
struct RowLayout {
  int dim = 0;
  std::vector<bool> view_dependent;  // per lobe
  std::vector<int> slot;             // lobe -> slot among view-(in)dependent lobes
  int num_independent = 0, num_dependent = 0;
  size_t vertex_rows = 0;  // vertex rows first, then observation rows

  // Row of view-independent lobe b at vertex v.
  size_t VertexRow(size_t v, int b) const { return v * num_independent + slot[b]; }
  // Row of view-dependent lobe b for observation `obs`.
  size_t ObservationRow(size_t obs, int b) const { return vertex_rows + obs * num_dependent + slot[b]; }
};

// The row numbering for the options' basis and `nv` vertices.
RowLayout MakeRowLayout(const TransportOptions& o, size_t nv) {
  RowLayout layout;
  const bool haar = o.lighting_basis == "haar";
  layout.dim = haar ? o.env_resolution * o.env_resolution : ShNumCoefficients(o.sh_order);
  RELIGHT_CHECK(layout.dim <= 65536) << "env_resolution too large for 16-bit row indices";
  const int num_lobes = static_cast<int>(o.basis.size());
  layout.view_dependent.resize(num_lobes);
  layout.slot.resize(num_lobes);
  for (int b = 0; b < num_lobes; ++b) {
    const bool dep = o.basis[b].model != BrdfModel::kLambertian;
    layout.view_dependent[b] = dep;
    layout.slot[b] = dep ? layout.num_dependent++ : layout.num_independent++;
  }
  layout.vertex_rows = nv * layout.num_independent;
  return layout;
}

// One thread's buffers while it builds a block's rows, reused from vertex to vertex.
struct BlockScratch {
  BlockScratch(const RowLayout& layout, bool haar, int n_local, size_t num_samples, BlockRows* rows)
      : rows(rows),
        pixel(haar ? layout.dim : 0),
        coeffs(haar ? layout.dim : 0),
        texel_integrals(size_t(n_local) * n_local),
        sh_coeffs(haar ? 0 : layout.dim),
        acc(num_samples, 0.0f) {}
  BlockRows* rows;                  // where the block's rows go
  std::vector<uint16_t> row_index;  // the row being built
  std::vector<float> row_value;
  std::vector<float> pixel, coeffs;    // haar: the global map and its coefficients
  std::vector<float> texel_integrals;  // sh: per local texel
  std::vector<double> sh_coeffs;
  VertexTexels t;             // the vertex's texels
  std::vector<int> visible;   // the vertex's visible texels
  std::vector<float> acc;     // texel sums over a footprint's normals
  std::vector<float> values;  // a row before the splat or projection: texel values ...
  std::vector<int> support;   // ... and their texels
  std::vector<FootprintSample> samples;
  std::vector<float> sample_view;  // GGX: a sample's weight times its GgxViewFactor
  EnergyTruncator truncator;
};

// A view-dependent lobe's constants for the texel loops.
struct LobeTerms {
  const BrdfLobe& lobe;
  float half_cutoff, mirror_cutoff;  // cosines (LobeHalfVectorCutoff, PhongMirrorCutoff; -1: none)
  bool microfacet, ggx;
  float f0;
};

// Builds the rows of BuildTransport. Holds the per-build tables (directions, solid angles, parent texels,
// cutoffs, footprint, slices, rotation grid); const once made, so the threads share it.
class RowBuilder {
 public:
  RowBuilder(const TriangleMesh& mesh, const VisibilityData& visibility, const ObservationSet& observations,
             const TransportOptions& o, const RowLayout& layout);
  // Rows of the vertices of block `blk` (kBlock vertices), into `rows`.
  void BuildBlock(size_t blk, BlockRows* rows, Progress* progress) const;

 private:
  void GroupObservations();
  void TabulateSamples();
  void TabulateWavelet();
  void TabulateFootprint();
  void WaveletRows(size_t v, BlockScratch* s) const;
  void PixelRows(size_t v, BlockScratch* s) const;
  void VisibleTexels(size_t v, const LocalFrame<float>& frame, BlockScratch* s) const;
  void EmitHaar(size_t row, BlockScratch* s) const;
  void FinishRow(size_t row, const LocalFrame<double>& frame_d, BlockScratch* s) const;
  void LambertianRows(size_t v, const LocalFrame<double>& frame_d, BlockScratch* s) const;
  void ObservationRows(size_t v, uint32_t obs, const LocalFrame<double>& frame_d, BlockScratch* s) const;
  float FacingSamples(size_t v, const Observation& ob, const Eigen::Vector3f& wo, BlockScratch* s) const;
  LobeTerms Terms(int b) const;
  void LobeAtVertexNormal(int b, const Eigen::Vector3f& wo, BlockScratch* s) const;
  void LobeOverFootprint(int b, const Eigen::Vector3f& wo, float spread, BlockScratch* s) const;

  const TriangleMesh& mesh_;
  const VisibilityData& visibility_;
  const ObservationSet& observations_;
  const TransportOptions& o_;
  const RowLayout layout_;
  const bool haar_, wavelet_;
  const int n_global_, n_local_, num_lobes_;
  // Observations grouped by vertex: vertex v's are by_vertex_[first_[v] .. first_[v + 1]).
  std::vector<uint32_t> first_, by_vertex_;
  // Local sample directions and solid angles [sr] (sub-texels of the visibility map), and each one's visibility texel.
  std::vector<Eigen::Vector3d> local_dirs_;
  std::vector<double> local_solid_angles_;
  std::vector<int> parent_texel_;
  std::vector<double> half_cutoff_, mirror_cutoff_;  // per lobe (LobeHalfVectorCutoff, PhongMirrorCutoff)
  std::unique_ptr<ShHemiOctProjector> sh_;
  std::unique_ptr<ResamplingGrid> rotation_;  // wavelet route
  std::vector<std::vector<double>> slices_;   // [lobe * view_grid² + view] local Haar coefficients
  FootprintNormals footprint_;
  std::vector<float> footprint_spread_;  // per vertex [rad]
  std::vector<float> lobe_min_spread_;   // per lobe [rad] (LobeFootprintSpread)
};

RowBuilder::RowBuilder(const TriangleMesh& mesh, const VisibilityData& visibility, const ObservationSet& observations,
                       const TransportOptions& o, const RowLayout& layout)
    : mesh_(mesh),
      visibility_(visibility),
      observations_(observations),
      o_(o),
      layout_(layout),
      haar_(o.lighting_basis == "haar"),
      wavelet_(haar_ && o.route == "wavelet"),
      n_global_(o.env_resolution),
      n_local_(visibility.resolution),
      num_lobes_(static_cast<int>(o.basis.size())) {
  GroupObservations();
  TabulateSamples();
  if (!haar_) sh_ = std::make_unique<ShHemiOctProjector>(n_local_, o.sh_order);
  if (wavelet_) TabulateWavelet();
  TabulateFootprint();
}

// first_ and by_vertex_ (a counting sort of the observations by vertex).
void RowBuilder::GroupObservations() {
  const size_t nv = mesh_.num_vertices(), no = observations_.records.size();
  first_.assign(nv + 1, 0);
  for (const auto& ob : observations_.records) ++first_[ob.vertex + 1];
  for (size_t v = 0; v < nv; ++v) first_[v + 1] += first_[v];
  by_vertex_.resize(no);
  std::vector<uint32_t> cursor(first_.begin(), first_.end() - 1);
  for (size_t k = 0; k < no; ++k) by_vertex_[cursor[observations_.records[k].vertex]++] = static_cast<uint32_t>(k);
}

// The local samples, their visibility texels and the lobes' cutoffs.
void RowBuilder::TabulateSamples() {
  // Haar pixel route: each visibility texel is integrated over `sub`² sub-texels
  // (TransportSupersampling), so the splats resolve the global map's texels.
  const int sub = haar_ && o_.route == "pixel" ? TransportSupersampling(n_local_, n_global_, o_.supersampling) : 1;
  const int n_sample = sub * n_local_;
  local_dirs_ = HemiOctTexelDirections(n_sample);
  local_solid_angles_ = HemiOctTexelSolidAngles(n_sample);
  parent_texel_.resize(local_dirs_.size());
  for (int y = 0; y < n_sample; ++y)
    for (int x = 0; x < n_sample; ++x) parent_texel_[size_t(y) * n_sample + x] = (y / sub) * n_local_ + x / sub;
  half_cutoff_.resize(num_lobes_);
  mirror_cutoff_.resize(num_lobes_);
  for (int b = 0; b < num_lobes_; ++b) {
    half_cutoff_[b] = LobeHalfVectorCutoff(o_.basis[b]);
    mirror_cutoff_[b] = PhongMirrorCutoff(o_.basis[b]);
  }
}

// Wavelet route: rotation (resampling) grid and BRDF slices tabulated over view directions.
void RowBuilder::TabulateWavelet() {
  RotationOptions ro;
  ro.global_resolution = n_global_;
  ro.local_resolution = n_local_;
  ro.normal_grid = o_.normal_grid;
  rotation_ = std::make_unique<ResamplingGrid>(ResamplingGrid::Build(ro));
  BrdfSliceOptions so;
  so.resolution = n_local_;
  const int vg = o_.view_grid;
  slices_.resize(size_t(num_lobes_) * vg * vg);
  tbb::parallel_for(size_t(0), slices_.size(), [&](size_t k) {
    const int b = static_cast<int>(k / (vg * vg)), view = static_cast<int>(k % (vg * vg));
    // Lambertian slices do not depend on the view: only view 0 is used.
    if (o_.basis[b].model == BrdfModel::kLambertian && view != 0) return;
    slices_[k].resize(size_t(n_local_) * n_local_);
    BrdfSliceHaar(o_.basis[b], HemiOctTexelDirection(view % vg, view / vg, vg), so, slices_[k].data());
  });
}

// The footprint's normals and spreads.
void RowBuilder::TabulateFootprint() {
  footprint_ = SampleFootprintNormals(mesh_, wavelet_ ? 0.0 : o_.footprint_scale);
  // Each vertex's spread: the largest angle between its normal and a footprint normal [rad].
  const size_t nv = mesh_.num_vertices();
  footprint_spread_.assign(nv, 0.0f);
  for (size_t v = 0; v < nv; ++v)
    for (uint32_t s = footprint_.first[v]; s < footprint_.first[v + 1]; ++s)
      footprint_spread_[v] =
          std::max(footprint_spread_[v], std::acos(std::clamp(footprint_.normal_local[s].z(), -1.0f, 1.0f)));
  lobe_min_spread_.resize(num_lobes_);
  for (int b = 0; b < num_lobes_; ++b) lobe_min_spread_[b] = static_cast<float>(LobeFootprintSpread(o_.basis[b]));
}

void RowBuilder::BuildBlock(size_t blk, BlockRows* rows, Progress* progress) const {
  const size_t v_begin = blk * kBlock, v_end = std::min(mesh_.num_vertices(), v_begin + kBlock);
  BlockScratch s(layout_, haar_, n_local_, local_dirs_.size(), rows);
  for (size_t v = v_begin; v < v_end; ++v) {
    if (wavelet_) {
      WaveletRows(v, &s);
    } else {
      PixelRows(v, &s);
    }
    progress->Advance();
  }
}

// Wavelet route, all rows of vertex v: local Haar visibility, product with the slice, transposed rotation to the
// global basis.
void RowBuilder::WaveletRows(size_t v, BlockScratch* s) const {
  const size_t n2 = size_t(n_local_) * n_local_;
  std::vector<double> vis_haar(n2, 0.0), product(n2), global(layout_.dim);
  visibility_.per_vertex[v].ToDense(vis_haar.data());
  const Eigen::Vector3d normal = mesh_.normals[v].cast<double>();
  auto wavelet_row = [&](size_t row, const std::vector<double>& slice) {
    ProductProjection(vis_haar.data(), slice.data(), n_local_, product.data());
    std::fill(global.begin(), global.end(), 0.0);
    rotation_->AccumulateTransposed(normal, product.data(), 1.0, global.data());
    for (int k = 0; k < layout_.dim; ++k) s->coeffs[k] = static_cast<float>(global[k]);
    s->truncator.Run(s->coeffs.data(), layout_.dim, o_.keep_energy, o_.max_coefficients, &s->row_index, &s->row_value);
    s->rows->Add(row, s->row_index, s->row_value);
  };
  const int vg = o_.view_grid;
  for (int b = 0; b < num_lobes_; ++b) {
    if (layout_.view_dependent[b]) continue;
    wavelet_row(layout_.VertexRow(v, b), slices_[size_t(b) * vg * vg]);
  }
  for (uint32_t q = first_[v]; q < first_[v + 1]; ++q) {
    const uint32_t obs = by_vertex_[q];
    const Observation& ob = observations_.records[obs];
    const Eigen::Vector3d wo(ob.view_local[0], ob.view_local[1], std::max(0.0f, ob.view_local[2]));
    const Eigen::Vector2i cell = HemiOctTexelOf(wo, vg);
    const int view = cell.y() * vg + cell.x();
    for (int b = 0; b < num_lobes_; ++b) {
      if (!layout_.view_dependent[b]) continue;
      wavelet_row(layout_.ObservationRow(obs, b), slices_[size_t(b) * vg * vg + view]);
    }
  }
}

// Pixel route (haar or sh), all rows of vertex v.
void RowBuilder::PixelRows(size_t v, BlockScratch* s) const {
  const Eigen::Vector3f nrm = mesh_.normals[v];
  const LocalFrame<float> frame = FrameFromNormal<float>(nrm);
  const LocalFrame<double> frame_d = FrameFromNormal<double>(nrm.cast<double>());
  VisibleTexels(v, frame, s);
  LambertianRows(v, frame_d, s);
  for (uint32_t q = first_[v]; q < first_[v + 1]; ++q) ObservationRows(v, by_vertex_[q], frame_d, s);
}

// The visible texels of vertex v (s->visible) with their weights, directions and splats (s->t).
void RowBuilder::VisibleTexels(size_t v, const LocalFrame<float>& frame, BlockScratch* s) const {
  const std::vector<float> vis = visibility_.DenseMap(v);
  VertexTexels& t = s->t;
  s->visible.clear();
  t.dir_local.assign(local_dirs_.size(), Eigen::Vector3f::Zero());
  t.weight.assign(local_dirs_.size(), 0.0f);
  if (haar_) {
    t.splat_index.resize(local_dirs_.size());
    t.splat_weight.resize(local_dirs_.size());
  }
  for (size_t j = 0; j < local_dirs_.size(); ++j) {
    const float vj = std::clamp(vis[parent_texel_[j]], 0.0f, 1.0f);
    if (vj <= 1e-4f) continue;
    const Eigen::Vector3f d = local_dirs_[j].cast<float>();
    t.dir_local[j] = d;
    t.weight[j] = static_cast<float>(vj * local_solid_angles_[j]);
    if (t.weight[j] <= 0 || local_dirs_[j].z() <= 0) continue;
    if (haar_) Splat(frame.ToWorld(d), n_global_, &t.splat_index[j], &t.splat_weight[j]);
    s->visible.push_back(static_cast<int>(j));
  }
}

// Haar row from texel values (s->values at s->support): splat onto the global map, transform, truncate.
void RowBuilder::EmitHaar(size_t row, BlockScratch* s) const {
  std::fill(s->pixel.begin(), s->pixel.end(), 0.0f);
  for (size_t q = 0; q < s->support.size(); ++q) {
    const int j = s->support[q];
    for (int k = 0; k < 4; ++k) s->pixel[s->t.splat_index[j][k]] += s->values[q] * s->t.splat_weight[j][k];
  }
  HaarForward(s->pixel.data(), n_global_, s->coeffs.data());
  s->truncator.Run(s->coeffs.data(), layout_.dim, o_.keep_energy, o_.max_coefficients, &s->row_index, &s->row_value);
  s->rows->Add(row, s->row_index, s->row_value);
}

// Row `row` from the texel values in s->values and s->support: Haar, or projected onto world-frame SH (dense).
void RowBuilder::FinishRow(size_t row, const LocalFrame<double>& frame_d, BlockScratch* s) const {
  if (haar_) {
    EmitHaar(row, s);
    return;
  }
  std::fill(s->texel_integrals.begin(), s->texel_integrals.end(), 0.0f);
  for (size_t q = 0; q < s->support.size(); ++q) s->texel_integrals[s->support[q]] = s->values[q];
  sh_->ProjectIntegrals(s->texel_integrals.data(), frame_d, s->sh_coeffs.data());
  s->row_index.resize(layout_.dim);
  s->row_value.resize(layout_.dim);
  for (int k = 0; k < layout_.dim; ++k) {
    s->row_index[k] = static_cast<uint16_t>(k);
    s->row_value[k] = static_cast<float>(s->sh_coeffs[k]);
  }
  s->rows->Add(row, s->row_index, s->row_value);
}

// View-independent (Lambertian) lobes: once per vertex, summed over the footprint's normals (vertex-local).
void RowBuilder::LambertianRows(size_t v, const LocalFrame<double>& frame_d, BlockScratch* s) const {
  const VertexTexels& t = s->t;
  std::vector<float>& acc = s->acc;
  for (int b = 0; b < num_lobes_; ++b) {
    if (layout_.view_dependent[b]) continue;
    for (uint32_t k = footprint_.first[v]; k < footprint_.first[v + 1]; ++k) {
      const Eigen::Vector3f& m = footprint_.normal_local[k];
      const float w = footprint_.weight[k] * static_cast<float>(1.0 / M_PI);
      for (int j : s->visible) acc[j] += w * t.weight[j] * std::max(0.0f, m.dot(t.dir_local[j]));
    }
    // The non-zero sums as the row's values; `acc` cleared for the next lobe.
    s->values.clear();
    s->support.clear();
    for (int j : s->visible) {
      if (acc[j] > 0) {
        s->values.push_back(acc[j]);
        s->support.push_back(j);
      }
      acc[j] = 0.0f;
    }
    FinishRow(layout_.VertexRow(v, b), frame_d, s);
  }
}

// View-dependent lobes of observation `obs` of vertex v: averaged over the footprint's
// normals that face the camera. A lobe much wider than the footprint's
// spread of mirror directions is evaluated at the vertex normal alone
// (LobeFootprintSpread), and for the others texels outside the union of
// the samples' lobes are skipped with one test against the vertex's own.
void RowBuilder::ObservationRows(size_t v, uint32_t obs, const LocalFrame<double>& frame_d, BlockScratch* s) const {
  const Observation& ob = observations_.records[obs];
  const Eigen::Vector3f wo(ob.view_local[0], ob.view_local[1], ob.view_local[2]);
  const float spread = FacingSamples(v, ob, wo, s);
  for (int b = 0; b < num_lobes_; ++b) {
    if (!layout_.view_dependent[b]) continue;
    s->values.clear();
    s->support.clear();
    if (s->samples.size() <= 1 || spread < lobe_min_spread_[b]) {
      LobeAtVertexNormal(b, wo, s);
    } else {
      LobeOverFootprint(b, wo, spread, s);
    }
    FinishRow(layout_.ObservationRow(obs, b), frame_d, s);
  }
}

// The footprint's samples facing the camera (s->samples: normal, weight, cosine to the view, mirror direction),
// and the spread of their normals [rad]. Each observation's normals are spread over its own kernel (kernel_scale
// times the nominal disc).
float RowBuilder::FacingSamples(size_t v, const Observation& ob, const Eigen::Vector3f& wo, BlockScratch* s) const {
  const float g = ob.kernel_scale;
  float spread = footprint_spread_[v];
  s->samples.clear();
  float facing = 0.0f;
  for (uint32_t k = footprint_.first[v]; k < footprint_.first[v + 1]; ++k) {
    const Eigen::Vector3f m = g == 1.0f ? footprint_.normal_local[k] : footprint_.ScaledNormal(k, g);
    if (g != 1.0f) spread = std::max(spread, std::acos(std::clamp(m.z(), -1.0f, 1.0f)));
    const float cos_o = m.dot(wo);
    if (cos_o <= 0) continue;
    s->samples.push_back({m, footprint_.weight[k], cos_o, 2.0f * cos_o * m - wo});
    facing += footprint_.weight[k];
  }
  for (auto& sm : s->samples) sm.weight /= facing;
  return spread;
}

// Lobe b's constants (LobeTerms).
LobeTerms RowBuilder::Terms(int b) const {
  const BrdfLobe& lobe = o_.basis[b];
  return {lobe,
          static_cast<float>(half_cutoff_[b]),
          static_cast<float>(mirror_cutoff_[b]),
          lobe.model == BrdfModel::kGgx || lobe.model == BrdfModel::kCookTorrance,
          lobe.model == BrdfModel::kGgx,
          static_cast<float>(lobe.f0)};
}

// Lobe b's texel values (s->values, s->support) at the vertex normal alone; none when the view is below the horizon.
// GGX is evaluated factored (BrdfLobe::GgxViewFactor): what depends on the view alone once, the Fresnel term once
// per texel. Flattened: the BRDF evaluation is inlined into the texel loop, as the compiler chose when this loop sat
// in BuildTransport's vertex-observation-lobe loop nest (in a function of its own, it stays a call: 2 % slower rows).
[[gnu::flatten]] void RowBuilder::LobeAtVertexNormal(int b, const Eigen::Vector3f& wo, BlockScratch* s) const {
  if (!(wo.z() > 0)) return;
  const LobeTerms l = Terms(b);
  const BrdfLobe& lobe = l.lobe;
  const float hc = l.half_cutoff, mc = l.mirror_cutoff, f0 = l.f0;
  const bool microfacet = l.microfacet, ggx = l.ggx;
  const VertexTexels& t = s->t;
  const Eigen::Vector3f mirror0(-wo.x(), -wo.y(), wo.z());
  const float view_factor = ggx ? lobe.GgxViewFactor<float>(wo.z()) : 0.0f;
  for (int j : s->visible) {
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
    s->values.push_back(f_cos * t.weight[j]);
    s->support.push_back(j);
  }
}

// Lobe b's texel values (s->values, s->support) averaged over the facing samples (s->samples), whose normals spread
// by `spread` [rad]. The lobe at each sample's normal from rotation-invariant cosines (BrdfLobe::EvalCosines): no
// change of frame per sample and texel, and the half vector (and wo·h) is the same for every sample. GGX factored as
// in LobeAtVertexNormal, and flattened like it.
[[gnu::flatten]] void RowBuilder::LobeOverFootprint(int b, const Eigen::Vector3f& wo, float spread,
                                                    BlockScratch* s) const {
  const LobeTerms l = Terms(b);
  const BrdfLobe& lobe = l.lobe;
  const float hc = l.half_cutoff, mc = l.mirror_cutoff, f0 = l.f0;
  const bool microfacet = l.microfacet, ggx = l.ggx;
  const VertexTexels& t = s->t;
  const std::vector<FootprintSample>& samples = s->samples;
  const Eigen::Vector3f mirror0(-wo.x(), -wo.y(), wo.z());
  // Cutoffs widened by the spread: the mirror direction turns by up to twice the normal's angle.
  const float mc_union = mc > -1 ? std::cos(std::min<float>(M_PI, std::acos(mc) + 2 * spread)) : -2.0f;
  const float hc_union = hc > -1 ? std::cos(std::min<float>(M_PI, std::acos(hc) + spread)) : -2.0f;
  if (ggx) {
    s->sample_view.resize(samples.size());
    for (size_t k = 0; k < samples.size(); ++k)
      s->sample_view[k] = samples[k].weight * lobe.GgxViewFactor<float>(samples[k].cos_o);
  }
  const std::vector<float>& sample_view = s->sample_view;
  for (int j : s->visible) {
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
      for (size_t k = 0; k < samples.size(); ++k) {
        const FootprintSample& sm = samples[k];
        const float cos_i = sm.normal.dot(wi);
        if (cos_i <= 0) continue;
        const float cos_h = h.dot(sm.normal);
        if (hc > -1 && cos_h < hc) continue;
        sum += sample_view[k] * lobe.GgxHalfFactor<float>(cos_i, cos_h);
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
    s->values.push_back(sum * t.weight[j]);
    s->support.push_back(j);
  }
}

// Where each row's record lies in the pool (TransportStore's offsets_, sizes_, wave_begin_), filled wave by wave.
struct PoolIndex {
  explicit PoolIndex(size_t total_rows) : offsets(total_rows, 0), sizes(total_rows, 0) {}
  std::vector<uint64_t> offsets;
  std::vector<uint32_t> sizes;
  size_t num_coefficients = 0;
  std::vector<uint64_t> wave_begin;
  std::vector<std::pair<size_t, const BlockRows::Entry*>> order;  // (block, entry)

  // Appends the rows of blocks [begin, end) to the pool in row order and empties the blocks; returns their bytes.
  size_t AppendWave(std::vector<BlockRows>* blocks, size_t begin, size_t end, PoolWriter* writer) {
    order.clear();
    size_t record_bytes = 0;
    for (size_t b = begin; b < end; ++b) {
      for (const BlockRows::Entry& e : (*blocks)[b].entries) order.emplace_back(b, &e);
      record_bytes += (*blocks)[b].bytes.size();
    }
    std::sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.second->row < b.second->row; });
    wave_begin.push_back(writer->size());
    for (const auto& [b, e] : order) {
      offsets[e->row] = writer->size();
      sizes[e->row] = e->size;
      num_coefficients += e->size;
      writer->Write((*blocks)[b].bytes.data() + e->offset, RecordBytes(e->size));
    }
    for (size_t b = begin; b < end; ++b) (*blocks)[b] = BlockRows();
    return record_bytes;
  }
};

}  // namespace

TransportStore BuildTransport(const TriangleMesh& mesh, const VisibilityData& visibility,
                              const ObservationSet& observations, const TransportOptions& o) {
  RELIGHT_CHECK(mesh.normals.size() == mesh.num_vertices());
  RELIGHT_CHECK_EQ(visibility.per_vertex.size(), mesh.num_vertices());
  RELIGHT_CHECK_EQ(observations.num_vertices, mesh.num_vertices());
  const size_t nv = mesh.num_vertices(), no = observations.records.size();
  const RowLayout layout = MakeRowLayout(o, nv);
  TransportStore store;
  store.dim_ = layout.dim;
  store.view_dependent_ = layout.view_dependent;
  store.slot_ = layout.slot;
  store.num_independent_ = layout.num_independent;
  store.num_dependent_ = layout.num_dependent;
  store.vertex_rows_ = layout.vertex_rows;
  const size_t total_rows = store.vertex_rows_ + no * store.num_dependent_;
  const RowBuilder builder(mesh, visibility, observations, o, layout);

  // Rows are built per block of vertices, in waves of blocks (about o.wave_bytes of rows each); each
  // wave's rows are appended to the pool in row order (TransportStore).
  const size_t num_blocks = (nv + kBlock - 1) / kBlock;
  std::vector<BlockRows> blocks(num_blocks);
  Progress progress("transport rows", static_cast<int64_t>(nv));
  PoolIndex index(total_rows);
  PoolWriter writer(o.spill_dir);
  const size_t min_wave = 2 * size_t(tbb::this_task_arena::max_concurrency());  // blocks: every thread busy
  size_t wave_size = min_wave;
  for (size_t begin = 0; begin < num_blocks;) {
    const size_t end = std::min(num_blocks, begin + wave_size);
    tbb::parallel_for(begin, end, [&](size_t blk) { builder.BuildBlock(blk, &blocks[blk], &progress); });
    const size_t record_bytes = index.AppendWave(&blocks, begin, end, &writer);
    // The next wave holds about o.wave_bytes of rows, at the rate of this one.
    const double per_block = double(record_bytes) / double(end - begin);
    wave_size = std::max(min_wave, static_cast<size_t>(double(o.wave_bytes) / std::max(1.0, per_block)));
    begin = end;
  }
  progress.Finish();
  store.offsets_ = std::move(index.offsets);
  store.sizes_ = std::move(index.sizes);
  store.num_coefficients_ = index.num_coefficients;
  store.wave_begin_ = std::move(index.wave_begin);
  // Offsets of empty rows point at the start of the pool (their records are never read).
  store.pool_ = writer.Finish(&store.data_);
  return store;
}

}  // namespace relight
