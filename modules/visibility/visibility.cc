#include "visibility/visibility.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <cstring>
#include <filesystem>

#include "core/error.h"
#include "core/fs.h"
#include "core/json.h"
#include "core/log.h"
#include "core/progress.h"
#include "core/timer.h"
#include "geometry/mesh_io.h"
#include "sphere/frame.h"
#include "sphere/octahedral.h"

namespace relight {
namespace fs = std::filesystem;

std::vector<float> VisibilityData::DenseMap(size_t vertex) const {
  std::vector<float> coeffs(size_t(resolution) * resolution, 0.0f);
  per_vertex[vertex].ToDense(coeffs.data());
  std::vector<float> map(coeffs.size());
  HaarInverse(coeffs.data(), resolution, map.data());
  return map;
}

namespace {
template <typename T>
void Put(std::string* out, const T& v) {
  out->append(reinterpret_cast<const char*>(&v), sizeof(T));
}

std::string EncodeVertices(const std::vector<SparseCoefficients>& maps, size_t begin, size_t end) {
  std::string out;
  for (size_t v = begin; v < end; ++v) {
    const auto& s = maps[v];
    Put(&out, static_cast<uint32_t>(s.size()));
    for (size_t k = 0; k < s.size(); ++k) {
      Put(&out, s.index[k]);
      Put(&out, s.value[k]);
    }
  }
  return out;
}

// Decodes `count` vertices' records starting at `pos`.
void DecodeVertices(const std::string& data, size_t* pos, size_t count, int resolution, const std::string& path,
                    std::vector<SparseCoefficients>* out) {
  auto damaged = [&](const std::string& why) {
    RELIGHT_USER_ERROR() << "'" << path << "' is not a valid visibility file (" << why
                         << "); rerun the visibility stage (pipeline run CONFIG --from visibility)";
  };
  const uint32_t max_index = static_cast<uint32_t>(resolution * resolution);
  for (size_t v = 0; v < count; ++v) {
    if (*pos + 4 > data.size()) damaged("truncated");
    uint32_t n;
    std::memcpy(&n, data.data() + *pos, 4);
    *pos += 4;
    if (n > max_index || *pos + size_t(n) * 8 > data.size()) damaged("truncated or bad coefficient count");
    SparseCoefficients s;
    s.n = resolution;
    s.index.resize(n);
    s.value.resize(n);
    for (uint32_t k = 0; k < n; ++k) {
      std::memcpy(&s.index[k], data.data() + *pos, 4);
      std::memcpy(&s.value[k], data.data() + *pos + 4, 4);
      *pos += 8;
      if (s.index[k] >= max_index) damaged("coefficient index out of range");
    }
    out->push_back(std::move(s));
  }
}
}  // namespace

void WriteVisibility(const std::string& path, const VisibilityData& data) {
  std::string out(kVisibilityMagic, 8);
  Put(&out, kVisibilityVersion);
  Put(&out, static_cast<uint32_t>(data.per_vertex.size()));
  Put(&out, static_cast<uint32_t>(data.resolution));
  Put(&out, static_cast<uint32_t>(data.supersampling));
  Put(&out, data.keep_energy);
  out += EncodeVertices(data.per_vertex, 0, data.per_vertex.size());
  WriteFileAtomic(path, out);
}

VisibilityData ReadVisibility(const std::string& path) {
  const std::string data = ReadFileToString(path);
  if (data.size() < 28 || std::memcmp(data.data(), kVisibilityMagic, 8) != 0) {
    RELIGHT_USER_ERROR() << "'" << path << "' is not a visibility file (bad magic); rerun the visibility stage";
  }
  uint32_t version, count, resolution, ss;
  std::memcpy(&version, data.data() + 8, 4);
  if (version != kVisibilityVersion) {
    RELIGHT_USER_ERROR() << "'" << path << "' has visibility format version " << version << ", this build reads "
                         << kVisibilityVersion << "; rerun the visibility stage";
  }
  std::memcpy(&count, data.data() + 12, 4);
  std::memcpy(&resolution, data.data() + 16, 4);
  std::memcpy(&ss, data.data() + 20, 4);
  VisibilityData out;
  out.resolution = static_cast<int>(resolution);
  out.supersampling = static_cast<int>(ss);
  std::memcpy(&out.keep_energy, data.data() + 24, 4);
  if (!IsPowerOfTwo(out.resolution)) RELIGHT_USER_ERROR() << "'" << path << "': bad resolution " << resolution;
  size_t pos = 28;
  out.per_vertex.reserve(count);
  DecodeVertices(data, &pos, count, out.resolution, path, &out.per_vertex);
  if (pos != data.size()) RELIGHT_USER_ERROR() << "'" << path << "' has trailing bytes; rerun the visibility stage";
  return out;
}

std::vector<Eigen::Vector3f> HemiOctSampleDirections(int n, int ss) {
  std::vector<Eigen::Vector3f> dirs(size_t(n) * n * ss * ss);
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      for (int sj = 0; sj < ss; ++sj) {
        for (int si = 0; si < ss; ++si) {
          const double a = -1.0 + 2.0 * (i + (si + 0.5) / ss) / n;
          const double b = -1.0 + 2.0 * (j + (sj + 0.5) / ss) / n;
          dirs[(size_t(j) * n + i) * ss * ss + sj * ss + si] = HemiOctDecode({a, b}).cast<float>();
        }
      }
    }
  }
  return dirs;
}

std::vector<SparseCoefficients> CompressVisibilityMaps(const std::vector<float>& maps, size_t count,
                                                       const VisibilityOptions& options) {
  const int n = options.resolution;
  const size_t per_map = size_t(n) * n;
  RELIGHT_CHECK_EQ(maps.size(), count * per_map);
  std::vector<SparseCoefficients> sparse(count);
  tbb::parallel_for(size_t(0), count, [&](size_t q) {
    std::vector<float> coeffs(per_map);
    HaarForward(maps.data() + q * per_map, n, coeffs.data());
    sparse[q] = options.keep_energy >= 1.0 ? SparseFromDense(coeffs.data(), n)
                                           : KeepEnergy(coeffs.data(), n, options.keep_energy);
  });
  return sparse;
}

VisibilityData ComputeVisibility(const TriangleMesh& mesh, const RayCaster& caster, const VisibilityOptions& options) {
  std::vector<uint32_t> all(mesh.num_vertices());
  for (size_t v = 0; v < all.size(); ++v) all[v] = static_cast<uint32_t>(v);
  std::vector<float> maps;
  BakeVisibilityMaps(mesh, caster, all, options, &maps);
  VisibilityData data;
  data.resolution = options.resolution;
  data.supersampling = options.supersampling;
  data.keep_energy = static_cast<float>(options.keep_energy);
  data.per_vertex = CompressVisibilityMaps(maps, all.size(), options);
  return data;
}

void BakeVisibilityMaps(const TriangleMesh& mesh, const RayCaster& caster, const std::vector<uint32_t>& vertices,
                        const VisibilityOptions& o, std::vector<float>* maps) {
  const int n = o.resolution, ss = o.supersampling;
  const size_t per_map = size_t(n) * n, rays_per_vertex = per_map * ss * ss;
  const std::vector<Eigen::Vector3f> local = HemiOctSampleDirections(n, ss);
  // Ray origins move off the surface by a fraction of the vertex's own edge
  // length (coarse and fine regions alike), plus the scene's float epsilon.
  std::vector<float> local_edge(mesh.num_vertices(), 0.0f);
  std::vector<int> degree(mesh.num_vertices(), 0);
  for (const auto& f : mesh.faces) {
    for (int k = 0; k < 3; ++k) {
      const float len = (mesh.vertices[f[(k + 1) % 3]] - mesh.vertices[f[k]]).norm();
      local_edge[f[k]] += len;
      local_edge[f[(k + 1) % 3]] += len;
      degree[f[k]] += 1;
      degree[f[(k + 1) % 3]] += 1;
    }
  }
  maps->assign(vertices.size() * per_map, 0.0f);
  struct Scratch {
    std::vector<Ray> rays;
    std::vector<uint8_t> occluded;
  };
  tbb::enumerable_thread_specific<Scratch> scratch;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, vertices.size(), 16), [&](const tbb::blocked_range<size_t>& r) {
    Scratch& s = scratch.local();
    s.rays.resize(rays_per_vertex);
    s.occluded.resize(rays_per_vertex);
    for (size_t q = r.begin(); q < r.end(); ++q) {
      const uint32_t v = vertices[q];
      const Eigen::Vector3f nrm = mesh.normals[v];
      const LocalFrame<float> frame = FrameFromNormal<float>(nrm);
      const float edge = degree[v] ? local_edge[v] / degree[v] : 0.0f;
      const float offset = static_cast<float>(o.origin_offset) * edge + caster.Epsilon();
      const Eigen::Vector3f origin = mesh.vertices[v] + offset * nrm;
      for (size_t k = 0; k < rays_per_vertex; ++k) {
        s.rays[k].origin = origin;
        s.rays[k].dir = frame.ToWorld(local[k]);
        s.rays[k].t_near = 0.0f;
        s.rays[k].t_far = std::numeric_limits<float>::infinity();
      }
      caster.OccludedStream(s.rays.data(), rays_per_vertex, false, s.occluded.data());
      float* map = maps->data() + q * per_map;
      const float inv = 1.0f / (ss * ss);
      for (size_t t = 0; t < per_map; ++t) {
        int open = 0;
        for (int k = 0; k < ss * ss; ++k) open += !s.occluded[t * ss * ss + k];
        map[t] = open * inv;
      }
    }
  });
}

std::string VisibilitySummary::BriefReport() const {
  return fmt::format(
      "visibility: {} vertices, {:.1f} coefficients per vertex, {:.0f} % of the hemisphere open, "
      "{:.1f} Mrays/s ({} chunks from an earlier run); {}",
      vertices, mean_coefficients, 100 * mean_open_fraction, rays_per_second / 1e6, reused_chunks,
      Progress::FormatSeconds(seconds));
}

VisibilitySummary RunVisibility(const VisibilityOptions& options, const VisibilityInputs& inputs,
                                const std::string& output_dir) {
  const std::string& mesh_dir = inputs.mesh_dir;
  Timer timer;
  VisibilitySummary summary;
  TriangleMesh mesh = ReadMesh(JoinPath(mesh_dir, "mesh.ply"));
  if (mesh.empty()) RELIGHT_USER_ERROR() << "'" << mesh_dir << "/mesh.ply' has no faces; check the mesh stage";
  if (mesh.normals.size() != mesh.num_vertices()) mesh.ComputeVertexNormals();
  TriangleMesh occluders;
  if (fs::exists(JoinPath(mesh_dir, "occluders.ply"))) occluders = ReadMesh(JoinPath(mesh_dir, "occluders.ply"));
  std::vector<const TriangleMesh*> scene{&mesh};
  if (!occluders.empty()) scene.push_back(&occluders);
  const RayCaster caster(scene);

  const int n = options.resolution;
  const size_t per_map = size_t(n) * n;
  summary.vertices = mesh.num_vertices();
  const size_t chunk = static_cast<size_t>(options.chunk_vertices);
  const size_t num_chunks = (mesh.num_vertices() + chunk - 1) / chunk;
  EnsureDir(JoinPath(output_dir, "chunks"));
  RLOG_INFO("baking {}x{} visibility maps ({} rays each) for {} vertices", n, n,
            per_map * options.supersampling * options.supersampling, mesh.num_vertices());

  VisibilityData data;
  data.resolution = n;
  data.supersampling = options.supersampling;
  data.keep_energy = static_cast<float>(options.keep_energy);
  data.per_vertex.resize(mesh.num_vertices());
  double open_sum = 0, ray_seconds = 0;
  Progress progress("bake visibility", static_cast<int64_t>(mesh.num_vertices()));
  for (size_t c = 0; c < num_chunks; ++c) {
    const size_t begin = c * chunk, end = std::min(mesh.num_vertices(), begin + chunk);
    const std::string chunk_path = JoinPath(output_dir, "chunks/" + std::to_string(c) + ".bin");
    std::vector<SparseCoefficients> sparse;
    if (fs::exists(chunk_path)) {  // finished by an earlier, killed run
      const std::string bytes = ReadFileToString(chunk_path);
      size_t pos = 0;
      DecodeVertices(bytes, &pos, end - begin, n, chunk_path, &sparse);
      ++summary.reused_chunks;
    } else {
      std::vector<uint32_t> ids(end - begin);
      for (size_t v = begin; v < end; ++v) ids[v - begin] = static_cast<uint32_t>(v);
      std::vector<float> maps;
      Timer ray_timer;
      BakeVisibilityMaps(mesh, caster, ids, options, &maps);
      ray_seconds += ray_timer.Seconds();
      sparse = CompressVisibilityMaps(maps, ids.size(), options);
      WriteFileAtomic(chunk_path, EncodeVertices(sparse, 0, sparse.size()));
    }
    for (size_t v = begin; v < end; ++v) {
      data.per_vertex[v] = std::move(sparse[v - begin]);
    }
    progress.Advance(static_cast<int64_t>(end - begin));
  }
  progress.Finish();
  double coefficient_sum = 0;
  for (const auto& s : data.per_vertex) {
    coefficient_sum += s.size();
    // The scaling coefficient is sum/N; the open fraction weights texels equally here (a coverage summary).
    if (!s.index.empty() && s.index[0] == 0) open_sum += s.value[0] / n;
  }
  WriteVisibility(JoinPath(output_dir, "visibility.bin"), data);
  std::error_code ec;
  fs::remove_all(JoinPath(output_dir, "chunks"), ec);

  summary.mean_open_fraction = open_sum / std::max<size_t>(1, summary.vertices);
  summary.mean_coefficients = coefficient_sum / std::max<size_t>(1, summary.vertices);
  const double rays = double(summary.vertices - summary.reused_chunks * chunk) * per_map * options.supersampling *
                      options.supersampling;
  summary.rays_per_second = ray_seconds > 0 ? rays / ray_seconds : 0;
  summary.seconds = timer.Seconds();
  OrderedJson j;
  j["vertices"] = summary.vertices;
  j["resolution"] = n;
  j["supersampling"] = options.supersampling;
  j["keep_energy"] = options.keep_energy;
  j["mean_open_fraction"] = summary.mean_open_fraction;
  j["mean_coefficients_per_vertex"] = summary.mean_coefficients;
  j["rays_per_second"] = summary.rays_per_second;
  j["reused_chunks"] = summary.reused_chunks;
  j["seconds"] = summary.seconds;
  WriteJsonAtomic(JoinPath(output_dir, "visibility_summary.json"), j);
  return summary;
}

}  // namespace relight
