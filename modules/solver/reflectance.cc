#include "solver/reflectance.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>

#include "core/error.h"
#include "solver/lighting.h"
#include "solver/qp.h"
#include "sphere/envmap.h"

namespace relight {

namespace {

// Fixed blocks of a range for parallel sums that are added in block order, so
// that a sum does not depend on which thread took which block (tbb::combinable's
// per-thread sums do): at least 4,096 items per block, at most 256 blocks.
struct BlockLayout {
  size_t size, block, count;
  explicit BlockLayout(size_t n)
      : size(n), block(std::max<size_t>(4096, (n + 255) / 256)), count((n + block - 1) / block) {}
  size_t begin(size_t b) const { return b * block; }
  size_t end(size_t b) const { return std::min(size, (b + 1) * block); }
};

}  // namespace

std::vector<float> ComputeLobeResponses(const TransportStore& transport, const ObservationSet& observations,
                                        const std::vector<uint32_t>& ids, const LightingState& lighting) {
  const int b_count = transport.num_lobes();
  const int dim = transport.dim();
  // The three channels' coefficients interleaved per photo, so one pass over a
  // row's (index, value) pairs serves all three channels. Each channel's sum is
  // accumulated in the row's order, as LobePredictions does, so the result is
  // the same to the bit.
  std::vector<std::vector<float>> rgb(lighting.coefficients.size());
  for (size_t i = 0; i < rgb.size(); ++i) {
    rgb[i].resize(size_t(dim) * 3);
    for (int c = 0; c < 3; ++c) {
      const std::vector<float>& lc = lighting.coefficients[i][c];
      RELIGHT_CHECK_EQ(lc.size(), size_t(dim)) << "lighting and transport rows of different dimension";
      for (int k = 0; k < dim; ++k) rgb[i][size_t(k) * 3 + c] = lc[k];
    }
  }
  std::vector<float> out(ids.size() * b_count * 3);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, ids.size(), 1024), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t k = r.begin(); k < r.end(); ++k) {
      const Observation& ob = observations.records[ids[k]];
      const float* l = rgb[ob.photo].data();
      float* o = out.data() + k * b_count * 3;
      for (int b = 0; b < b_count; ++b) {
        const TransportStore::Row row = transport.Get(ids[k], ob.vertex, b);
        float s0 = 0.0f, s1 = 0.0f, s2 = 0.0f;
        for (uint32_t q = 0; q < row.size; ++q) {
          const float v = row.value[q];
          const float* lq = l + size_t(row.index[q]) * 3;
          s0 += v * lq[0];
          s1 += v * lq[1];
          s2 += v * lq[2];
        }
        o[b * 3 + 0] = s0;
        o[b * 3 + 1] = s1;
        o[b * 3 + 2] = s2;
      }
    }
    // Rows on disk leave the resident set once read (ids ascend in every caller; the range covers them anyway).
    const auto [lo, hi] = std::minmax_element(ids.begin() + r.begin(), ids.begin() + r.end());
    transport.Evict(*lo, *hi + size_t(1));
  });
  transport.EvictAll();  // the vertex rows every block shared
  return out;
}

void ScaleResponses(const Eigen::Vector3d& s, std::vector<float>* responses) {
  RELIGHT_CHECK(responses->size() % 3 == 0) << "responses come in RGB triples";
  const float s0 = static_cast<float>(s[0]), s1 = static_cast<float>(s[1]), s2 = static_cast<float>(s[2]);
  float* r = responses->data();
  for (size_t k = 0; k < responses->size(); k += 3) {
    r[k] *= s0;
    r[k + 1] *= s1;
    r[k + 2] *= s2;
  }
}

namespace {

// Hue in [0,1), saturation in [0,1] of a linear RGB colour (HSV on the values).
void HueSaturation(const Eigen::Vector3d& rgb, double* hue, double* sat) {
  const double mx = rgb.maxCoeff(), mn = rgb.minCoeff(), d = mx - mn;
  *sat = mx > 0 ? d / mx : 0.0;
  if (d <= 0) {
    *hue = 0;
    return;
  }
  double h;
  if (mx == rgb.x()) {
    h = (rgb.y() - rgb.z()) / d;
  } else if (mx == rgb.y()) {
    h = 2 + (rgb.z() - rgb.x()) / d;
  } else {
    h = 4 + (rgb.x() - rgb.y()) / d;
  }
  h /= 6.0;
  *hue = h - std::floor(h);
}

int FirstLambertian(const std::vector<BrdfLobe>& basis) {
  for (size_t b = 0; b < basis.size(); ++b)
    if (basis[b].model == BrdfModel::kLambertian) return static_cast<int>(b);
  return -1;
}

// Observations of `train` grouped by vertex: positions k into train.
void GroupByVertex(const ObservationSet& observations, const std::vector<uint32_t>& train, size_t num_vertices,
                   std::vector<uint32_t>* first, std::vector<uint32_t>* items) {
  first->assign(num_vertices + 1, 0);
  for (uint32_t o : train) ++(*first)[observations.records[o].vertex + 1];
  for (size_t v = 0; v < num_vertices; ++v) (*first)[v + 1] += (*first)[v];
  items->resize(train.size());
  std::vector<uint32_t> cursor(first->begin(), first->end() - 1);
  for (size_t k = 0; k < train.size(); ++k) (*items)[cursor[observations.records[train[k]].vertex]++] = k;
}

// k-means++ with `attempts` restarts, reproducible from `seed`; one cluster: the mean.
void SeededKMeans(const cv::Mat& features, int k, int attempts, int seed, cv::Mat* labels, cv::Mat* centers) {
  if (k > 1) {
    cv::theRNG().state = static_cast<uint64_t>(seed) * 2654435761ULL + 1;
    cv::kmeans(features, k, *labels, cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-5),
               attempts, cv::KMEANS_PP_CENTERS, *centers);
  } else {
    *labels = cv::Mat::zeros(features.rows, 1, CV_32S);
    cv::reduce(features, *centers, 0, cv::REDUCE_AVG);
  }
}

}  // namespace

ReflectanceState InitializeReflectance(const ObservationSet& observations, const std::vector<uint32_t>& train,
                                       size_t num_vertices, const std::vector<BrdfLobe>& basis, int num_materials,
                                       int seed, double gloss, const std::vector<char>* lobe_enabled) {
  ReflectanceState state;
  state.basis = basis;
  const int b_count = static_cast<int>(basis.size());
  std::vector<Eigen::Vector3d> mean(num_vertices, Eigen::Vector3d::Zero());
  std::vector<double> weight(num_vertices, 0.0);
  for (uint32_t o : train) {
    const Observation& ob = observations.records[o];
    mean[ob.vertex] += ob.confidence * Eigen::Vector3d(ob.rgb[0], ob.rgb[1], ob.rgb[2]);
    weight[ob.vertex] += ob.confidence;
  }
  std::vector<uint32_t> observed;
  for (size_t v = 0; v < num_vertices; ++v) {
    if (weight[v] > 0) {
      mean[v] /= weight[v];
      observed.push_back(static_cast<uint32_t>(v));
    }
  }
  const int k = std::max(1, std::min<int>(num_materials, static_cast<int>(observed.size())));
  state.num_materials = k;
  // Features (cos 2πH, sin 2πH, S); hue counts only where saturation makes it meaningful.
  cv::Mat features(static_cast<int>(std::max<size_t>(1, observed.size())), 3, CV_32F, cv::Scalar(0));
  for (size_t q = 0; q < observed.size(); ++q) {
    double hue, sat;
    HueSaturation(mean[observed[q]], &hue, &sat);
    const double hue_weight = std::min(1.0, sat / 0.1);
    features.at<float>(static_cast<int>(q), 0) = static_cast<float>(hue_weight * std::cos(2 * M_PI * hue));
    features.at<float>(static_cast<int>(q), 1) = static_cast<float>(hue_weight * std::sin(2 * M_PI * hue));
    features.at<float>(static_cast<int>(q), 2) = static_cast<float>(sat);
  }
  cv::Mat labels, centers;
  SeededKMeans(features, observed.size() >= static_cast<size_t>(k) ? k : 1, 4, seed, &labels, &centers);
  // Each region's median colour is its material's diffuse colour.
  const int lambert = FirstLambertian(basis);
  auto glossy = [&](int b) { return b != lambert && (lobe_enabled == nullptr || (*lobe_enabled)[b]); };
  int num_glossy = 0;
  for (int b = 0; b < b_count; ++b) num_glossy += glossy(b);
  state.coefficients.assign(size_t(k) * b_count, Eigen::Vector3d::Zero());
  for (int m = 0; m < k; ++m) {
    std::array<std::vector<double>, 3> channel;
    for (size_t q = 0; q < observed.size(); ++q) {
      if (labels.at<int>(static_cast<int>(q)) != m) continue;
      for (int c = 0; c < 3; ++c) channel[c].push_back(mean[observed[q]][c]);
    }
    Eigen::Vector3d median = Eigen::Vector3d::Constant(0.5);
    for (int c = 0; c < 3; ++c) {
      if (channel[c].empty()) continue;
      std::nth_element(channel[c].begin(), channel[c].begin() + channel[c].size() / 2, channel[c].end());
      median[c] = channel[c][channel[c].size() / 2];
    }
    if (lambert >= 0) {
      state.coefficients[m * b_count + lambert] = median.cwiseMax(1e-6);
      // A neutral specular (dielectric highlights keep the light's colour),
      // `gloss` of the diffuse luminance, shared by the enabled glossy lobes.
      for (int b = 0; b < b_count; ++b)
        if (gloss > 0 && glossy(b))
          state.coefficients[m * b_count + b] = Eigen::Vector3d::Constant(gloss * Luminance(median) / num_glossy);
    } else {  // no diffuse lobe: start every lobe at the region's colour
      for (int b = 0; b < b_count; ++b) state.coefficients[m * b_count + b] = median.cwiseMax(1e-6);
    }
  }
  // Soft weights from the distances to the centroids.
  state.weights.assign(num_vertices * k, 1.0f / k);
  double sigma2 = 0;
  std::vector<std::vector<double>> d2(observed.size(), std::vector<double>(k));
  for (size_t q = 0; q < observed.size(); ++q) {
    double best = 1e300;
    for (int m = 0; m < k; ++m) {
      double s = 0;
      for (int f = 0; f < 3; ++f) {
        const double diff = features.at<float>(static_cast<int>(q), f) - centers.at<float>(m, f);
        s += diff * diff;
      }
      d2[q][m] = s;
      best = std::min(best, s);
    }
    sigma2 += best;
  }
  sigma2 = std::max(1e-6, sigma2 / std::max<size_t>(1, observed.size()));
  for (size_t q = 0; q < observed.size(); ++q) {
    double total = 0;
    std::vector<double> w(k);
    const double best = *std::min_element(d2[q].begin(), d2[q].end());
    for (int m = 0; m < k; ++m) total += w[m] = std::exp(-(d2[q][m] - best) / (2 * sigma2));
    for (int m = 0; m < k; ++m) state.weights[size_t(observed[q]) * k + m] = static_cast<float>(w[m] / total);
  }
  return state;
}

ReflectanceState InitializeReflectanceFromFits(const ObservationSet& observations, const std::vector<uint32_t>& train,
                                               const std::vector<float>& responses, size_t num_vertices,
                                               const std::vector<BrdfLobe>& basis, int num_materials, int seed) {
  const int lambert = FirstLambertian(basis);
  const int b_count = static_cast<int>(basis.size());
  if (lambert < 0 || b_count < 2) {
    return InitializeReflectance(observations, train, num_vertices, basis, num_materials, seed);
  }
  RELIGHT_CHECK(responses.size() == train.size() * b_count * 3) << "one response per training observation and lobe";
  std::vector<uint32_t> first, items;
  GroupByVertex(observations, train, num_vertices, &first, &items);
  // Mean response per lobe and channel: a lobe's typical radiance per unit coefficient.
  std::vector<double> mean_response(b_count * 3, 0.0);
  double confidence_sum = 0;
  for (size_t k = 0; k < train.size(); ++k) {
    const double a = observations.records[train[k]].confidence;
    for (int j = 0; j < b_count * 3; ++j) mean_response[j] += a * responses[k * b_count * 3 + j];
    confidence_sum += a;
  }
  for (double& r : mean_response) r /= std::max(1e-30, confidence_sum);

  // Per-vertex free fits ρ_{v,b,c} ≥ 0 (ridge 1e-3 of the largest diagonal value keeps them finite).
  std::vector<Eigen::VectorXd> fit(num_vertices);
  std::vector<double> vertex_confidence(num_vertices, 0.0);
  tbb::parallel_for(size_t(0), num_vertices, [&](size_t v) {
    if (first[v] == first[v + 1]) return;
    Eigen::VectorXd rho = Eigen::VectorXd::Zero(b_count * 3);
    Eigen::VectorXd u(b_count);
    for (int c = 0; c < 3; ++c) {
      Eigen::MatrixXd g = Eigen::MatrixXd::Zero(b_count, b_count);
      Eigen::VectorXd h = Eigen::VectorXd::Zero(b_count);
      for (uint32_t q = first[v]; q < first[v + 1]; ++q) {
        const uint32_t k = items[q];
        const Observation& ob = observations.records[train[k]];
        for (int b = 0; b < b_count; ++b) u[b] = responses[size_t(k) * b_count * 3 + b * 3 + c];
        g.noalias() += double(ob.confidence) * u * u.transpose();
        h += double(ob.confidence) * ob.rgb[c] * u;
      }
      g.diagonal().array() += 1e-3 * std::max(1e-30, g.diagonal().maxCoeff());
      Eigen::VectorXd x = Eigen::VectorXd::Zero(b_count);
      SolveNonNegativeQp(g, h, &x);
      for (int b = 0; b < b_count; ++b) rho[b * 3 + c] = x[b];
    }
    double conf = 0;
    for (uint32_t q = first[v]; q < first[v + 1]; ++q) conf += observations.records[train[items[q]]].confidence;
    fit[v] = std::move(rho);
    vertex_confidence[v] = conf;
  });

  // Features: unit diffuse RGB, then each other lobe's share s / (1 + s) of the appearance.
  const int dim = 3 + (b_count - 1);
  auto feature = [&](size_t v, float* f) {
    const Eigen::VectorXd& rho = fit[v];
    Eigen::Vector3d d(rho[lambert * 3], rho[lambert * 3 + 1], rho[lambert * 3 + 2]);
    const double norm = d.norm();
    double diffuse_radiance = 0;
    for (int c = 0; c < 3; ++c) diffuse_radiance += d[c] * mean_response[lambert * 3 + c];
    for (int c = 0; c < 3; ++c) f[c] = static_cast<float>(norm > 0 ? d[c] / norm : 0.0);
    int slot = 3;
    for (int b = 0; b < b_count; ++b) {
      if (b == lambert) continue;
      double lobe_radiance = 0;
      for (int c = 0; c < 3; ++c) lobe_radiance += rho[b * 3 + c] * mean_response[b * 3 + c];
      const double share = lobe_radiance / std::max(1e-12, diffuse_radiance);
      f[slot++] = static_cast<float>(share / (1 + share));
    }
  };
  std::vector<double> confidences;
  for (size_t v = 0; v < num_vertices; ++v)
    if (fit[v].size() > 0 && fit[v].norm() > 0) confidences.push_back(vertex_confidence[v]);
  if (confidences.size() < static_cast<size_t>(std::max(2, num_materials))) {
    return InitializeReflectance(observations, train, num_vertices, basis, num_materials, seed);
  }
  std::nth_element(confidences.begin(), confidences.begin() + confidences.size() / 4, confidences.end());
  const double min_confidence = confidences[confidences.size() / 4];
  std::vector<uint32_t> members;
  for (size_t v = 0; v < num_vertices; ++v)
    if (fit[v].size() > 0 && fit[v].norm() > 0 && vertex_confidence[v] >= min_confidence)
      members.push_back(static_cast<uint32_t>(v));
  const int k = std::max(1, std::min<int>(num_materials, static_cast<int>(members.size())));
  cv::Mat features(static_cast<int>(members.size()), dim, CV_32F);
  for (size_t q = 0; q < members.size(); ++q) feature(members[q], features.ptr<float>(static_cast<int>(q)));
  cv::Mat labels, centers;
  SeededKMeans(features, k, 8, seed, &labels, &centers);

  ReflectanceState state;
  state.basis = basis;
  state.num_materials = k;
  state.coefficients.assign(size_t(k) * b_count, Eigen::Vector3d::Zero());
  for (int m = 0; m < k; ++m) {
    std::vector<std::vector<double>> component(b_count * 3);
    for (size_t q = 0; q < members.size(); ++q) {
      if (labels.at<int>(static_cast<int>(q)) != m) continue;
      for (int j = 0; j < b_count * 3; ++j) component[j].push_back(fit[members[q]][j]);
    }
    for (int j = 0; j < b_count * 3; ++j) {
      std::vector<double>& x = component[j];
      double median = j / 3 == lambert ? 0.5 : 0.0;  // an empty group starts as a grey diffuse material
      if (!x.empty()) {
        std::nth_element(x.begin(), x.begin() + x.size() / 2, x.end());
        median = x[x.size() / 2];
      }
      state.coefficients[m * b_count + j / 3][j % 3] = median;
    }
    state.coefficients[m * b_count + lambert] = state.coefficients[m * b_count + lambert].cwiseMax(1e-6);
  }
  // Every vertex on its nearest material (feature distance), scaled to its fit in radiance terms.
  state.weights.assign(num_vertices * k, 1.0f / k);
  std::vector<float> f(dim);
  for (size_t v = 0; v < num_vertices; ++v) {
    if (fit[v].size() == 0) continue;
    int best = 0;
    if (fit[v].norm() > 0) {
      feature(v, f.data());
      double best_d2 = 1e300;
      for (int m = 0; m < k; ++m) {
        double d2 = 0;
        for (int j = 0; j < dim; ++j) d2 += (f[j] - centers.at<float>(m, j)) * (f[j] - centers.at<float>(m, j));
        if (d2 < best_d2) {
          best_d2 = d2;
          best = m;
        }
      }
    }
    double dot = 0, norm2 = 0;
    for (int j = 0; j < b_count * 3; ++j) {
      const double material = state.coefficients[best * b_count + j / 3][j % 3] * mean_response[j];
      dot += fit[v][j] * mean_response[j] * material;
      norm2 += material * material;
    }
    for (int m = 0; m < k; ++m) state.weights[v * k + m] = 0.0f;
    state.weights[v * k + best] = static_cast<float>(std::max(0.0, dot / std::max(1e-30, norm2)));
  }
  return state;
}

std::vector<float> ReflectanceRobustWeights(const ObservationSet& observations, const std::vector<uint32_t>& train,
                                            const std::vector<float>& responses, const ReflectanceState& state,
                                            const std::string& loss, double scale) {
  std::vector<float> out(train.size(), 1.0f);
  if (loss == "none" || train.empty()) return out;
  const int b_count = state.num_lobes();
  // RGB residual magnitudes under the current model, as the lighting step measures them.
  std::vector<double> residual(train.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, train.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
    std::vector<float> rho(b_count * 3);
    for (size_t k = r.begin(); k < r.end(); ++k) {
      const Observation& ob = observations.records[train[k]];
      state.VertexLobeWeights(ob.vertex, rho.data());
      const float* resp = responses.data() + k * b_count * 3;
      double e2 = 0;
      for (int c = 0; c < 3; ++c) {
        double pred = 0;
        for (int b = 0; b < b_count; ++b) pred += rho[b * 3 + c] * resp[b * 3 + c];
        const double e = CensoredResidual(ob, c, static_cast<float>(pred));
        e2 += e * e;
      }
      residual[k] = std::sqrt(e2);
    }
  });
  // The robust sigma is per photo (exposure and lighting differ between photos).
  std::vector<std::vector<uint32_t>> by_photo(observations.num_photos);
  for (size_t k = 0; k < train.size(); ++k) {
    const uint32_t photo = observations.records[train[k]].photo;
    RELIGHT_CHECK(photo < by_photo.size()) << "observation of photo " << photo << " beyond num_photos";
    by_photo[photo].push_back(static_cast<uint32_t>(k));
  }
  tbb::parallel_for(size_t(0), by_photo.size(), [&](size_t i) {
    const std::vector<uint32_t>& positions = by_photo[i];
    std::vector<double> r(positions.size());
    for (size_t q = 0; q < positions.size(); ++q) r[q] = residual[positions[q]];
    const std::vector<double> w = RobustWeights(r, loss, scale);
    for (size_t q = 0; q < positions.size(); ++q) out[positions[q]] = static_cast<float>(w[q]);
  });
  return out;
}

std::vector<std::vector<uint32_t>> VertexNeighbours(const TriangleMesh& mesh) {
  std::vector<std::vector<uint32_t>> n(mesh.num_vertices());
  for (const auto& f : mesh.faces) {
    for (int k = 0; k < 3; ++k) {
      n[f[k]].push_back(static_cast<uint32_t>(f[(k + 1) % 3]));
      n[f[k]].push_back(static_cast<uint32_t>(f[(k + 2) % 3]));
    }
  }
  for (auto& list : n) {
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
  }
  return n;
}

void SolveWeights(const ObservationSet& observations, const std::vector<uint32_t>& train,
                  const std::vector<float>& responses, double sparsity, ReflectanceState* state,
                  const std::vector<std::vector<uint32_t>>* neighbours, double smoothness,
                  const std::vector<float>* robust, const std::vector<uint8_t>* censored) {
  RELIGHT_CHECK(robust == nullptr || robust->size() == train.size()) << "one robust weight per observation";
  RELIGHT_CHECK(censored == nullptr || censored->empty() || censored->size() == 3 * train.size())
      << "one censoring flag per observation and channel";
  const int m_count = state->num_materials, b_count = state->num_lobes();
  const size_t nv = state->weights.size() / m_count;
  const std::vector<float> previous = smoothness > 0 ? state->weights : std::vector<float>();
  std::vector<uint32_t> first, items;
  GroupByVertex(observations, train, nv, &first, &items);
  // Normal equations per vertex (m_count² + m_count doubles each), then the
  // smoothness weight relative to the *typical* vertex's data term (the median
  // of the per-vertex mean diagonals): a vertex with little data (seen only in
  // shadow or at grazing angles) is then held by its neighbours instead of
  // fitting noise with huge weights.
  std::vector<Eigen::MatrixXd> gs(nv);
  std::vector<Eigen::VectorXd> hs(nv);
  tbb::parallel_for(size_t(0), nv, [&](size_t v) {
    if (first[v] == first[v + 1]) return;
    Eigen::MatrixXd& g = gs[v];
    Eigen::VectorXd& h = hs[v];
    g = Eigen::MatrixXd::Zero(m_count, m_count);
    h = Eigen::VectorXd::Zero(m_count);
    Eigen::VectorXd u(m_count);
    for (uint32_t q = first[v]; q < first[v + 1]; ++q) {
      const uint32_t k = items[q];
      const Observation& ob = observations.records[train[k]];
      const double alpha = robust != nullptr ? double(ob.confidence) * (*robust)[k] : double(ob.confidence);
      const float* resp = responses.data() + size_t(k) * b_count * 3;
      for (int c = 0; c < 3; ++c) {
        if (censored != nullptr && !censored->empty() && (*censored)[size_t(k) * 3 + c]) continue;
        for (int m = 0; m < m_count; ++m) {
          double s = 0;
          for (int b = 0; b < b_count; ++b) s += state->coefficients[m * b_count + b][c] * resp[b * 3 + c];
          u[m] = s;
        }
        g.noalias() += alpha * u * u.transpose();
        h += alpha * ob.rgb[c] * u;
      }
    }
  });
  double typical_scale = 0;
  {
    std::vector<double> diag;
    for (size_t v = 0; v < nv; ++v) {
      if (gs[v].size() > 0) diag.push_back(gs[v].diagonal().mean());
    }
    if (!diag.empty()) {
      std::nth_element(diag.begin(), diag.begin() + diag.size() / 2, diag.end());
      typical_scale = diag[diag.size() / 2];
    }
  }
  tbb::parallel_for(size_t(0), nv, [&](size_t v) {
    if (first[v] == first[v + 1]) return;
    Eigen::MatrixXd& g = gs[v];
    Eigen::VectorXd& h = hs[v];
    const double scale = std::max(1e-30, g.diagonal().maxCoeff());
    g.diagonal().array() += 1e-9 * scale;
    const double beta = sparsity * std::max(0.0, h.maxCoeff());
    Eigen::VectorXd q = h.array() - beta;
    if (smoothness > 0 && neighbours != nullptr && !(*neighbours)[v].empty()) {
      // Jacobi step of the neighbour coupling, relative to the typical data term's scale.
      const double mu = smoothness * std::max(typical_scale, g.diagonal().mean());
      const auto& nb = (*neighbours)[v];
      g.diagonal().array() += mu * nb.size();
      for (uint32_t u : nb)
        for (int m = 0; m < m_count; ++m) q[m] += mu * previous[size_t(u) * m_count + m];
    }

    Eigen::VectorXd w(m_count);
    for (int m = 0; m < m_count; ++m) w[m] = state->weights[v * m_count + m];
    SolveNonNegativeQp(g, q, &w);
    for (int m = 0; m < m_count; ++m) state->weights[v * m_count + m] = static_cast<float>(w[m]);
  });
}

void SolveMaterials(const ObservationSet& observations, const std::vector<uint32_t>& train,
                    const std::vector<float>& responses, ReflectanceState* state,
                    const std::vector<float>* robust, const std::vector<uint8_t>* censored) {
  RELIGHT_CHECK(robust == nullptr || robust->size() == train.size()) << "one robust weight per observation";
  RELIGHT_CHECK(censored == nullptr || censored->empty() || censored->size() == 3 * train.size())
      << "one censoring flag per observation and channel";
  const int m_count = state->num_materials, b_count = state->num_lobes();
  const int dim = m_count * b_count;
  for (int c = 0; c < 3; ++c) {
    struct Acc {
      Eigen::MatrixXd g;
      Eigen::VectorXd h;
    };
    // One partial sum per fixed block, added in block order: the same result on every run.
    const BlockLayout layout(train.size());
    std::vector<Acc> partial(layout.count);
    tbb::parallel_for(size_t(0), layout.count, [&](size_t blk) {
      Acc& a = partial[blk];
      a.g = Eigen::MatrixXd::Zero(dim, dim);
      a.h = Eigen::VectorXd::Zero(dim);
      Eigen::VectorXd phi(dim);
      for (size_t k = layout.begin(blk); k < layout.end(blk); ++k) {
        if (censored != nullptr && !censored->empty() && (*censored)[k * 3 + c]) continue;
        const Observation& ob = observations.records[train[k]];
        const double alpha = robust != nullptr ? double(ob.confidence) * (*robust)[k] : double(ob.confidence);
        const float* w = state->weights.data() + size_t(ob.vertex) * m_count;
        const float* resp = responses.data() + k * b_count * 3;
        for (int m = 0; m < m_count; ++m)
          for (int b = 0; b < b_count; ++b) phi[m * b_count + b] = double(w[m]) * resp[b * 3 + c];
        a.g.selfadjointView<Eigen::Lower>().rankUpdate(phi, alpha);
        a.h += alpha * ob.rgb[c] * phi;
      }
    });
    Eigen::MatrixXd g = Eigen::MatrixXd::Zero(dim, dim);
    Eigen::VectorXd h = Eigen::VectorXd::Zero(dim);
    for (const Acc& a : partial) {
      g += a.g;
      h += a.h;
    }
    g = Eigen::MatrixXd(g.selfadjointView<Eigen::Lower>());
    g.diagonal().array() += 1e-9 * std::max(1e-30, g.diagonal().maxCoeff());
    // Disabled lobes (model selection) are pinned at zero.
    for (int m = 0; m < m_count; ++m)
      for (int b = 0; b < b_count; ++b) {
        if (state->enabled(b)) continue;
        const int k = m * b_count + b;
        g.row(k).setZero();
        g.col(k).setZero();
        g(k, k) = 1.0;
        h[k] = 0.0;
      }
    Eigen::VectorXd x(dim);
    for (int m = 0; m < m_count; ++m)
      for (int b = 0; b < b_count; ++b) x[m * b_count + b] = state->coefficients[m * b_count + b][c];
    SolveNonNegativeQp(g, h, &x);
    for (int m = 0; m < m_count; ++m)
      for (int b = 0; b < b_count; ++b) state->coefficients[m * b_count + b][c] = x[m * b_count + b];
  }
}

void FillUnobservedWeights(const TriangleMesh& mesh, const std::vector<char>& observed, ReflectanceState* state) {
  const int m_count = state->num_materials;
  const size_t nv = mesh.num_vertices();
  std::vector<std::vector<uint32_t>> neighbours(nv);
  for (const auto& f : mesh.faces) {
    for (int k = 0; k < 3; ++k) {
      neighbours[f[k]].push_back(static_cast<uint32_t>(f[(k + 1) % 3]));
      neighbours[f[k]].push_back(static_cast<uint32_t>(f[(k + 2) % 3]));
    }
  }
  std::vector<char> known(observed.begin(), observed.end());
  for (int iter = 0; iter < 1000; ++iter) {
    std::vector<uint32_t> newly;
    for (size_t v = 0; v < nv; ++v) {
      if (known[v]) continue;
      std::vector<double> sum(m_count, 0.0);
      int n = 0;
      for (uint32_t u : neighbours[v]) {
        if (!known[u]) continue;
        for (int m = 0; m < m_count; ++m) sum[m] += state->weights[size_t(u) * m_count + m];
        ++n;
      }
      if (n == 0) continue;
      for (int m = 0; m < m_count; ++m) state->weights[v * m_count + m] = static_cast<float>(sum[m] / n);
      newly.push_back(static_cast<uint32_t>(v));
    }
    if (newly.empty()) break;
    for (uint32_t v : newly) known[v] = 1;
  }
}

std::vector<uint8_t> MetLowerBounds(const ObservationSet& observations, const std::vector<uint32_t>& ids,
                                    const std::vector<float>& responses, const ReflectanceState& state) {
  std::vector<uint8_t> met;
  bool any = false;
  for (uint32_t o : ids) any |= observations.records[o].lower_bound();
  if (!any) return met;
  met.assign(ids.size() * 3, 0);
  const int b_count = state.num_lobes();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, ids.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
    std::vector<float> rho(b_count * 3);
    for (size_t k = r.begin(); k < r.end(); ++k) {
      const Observation& ob = observations.records[ids[k]];
      if (!ob.lower_bound()) continue;
      state.VertexLobeWeights(ob.vertex, rho.data());
      const float* resp = responses.data() + k * b_count * 3;
      for (int c = 0; c < 3; ++c) {
        float pred = 0;
        for (int b = 0; b < b_count; ++b) pred += rho[b * 3 + c] * resp[b * 3 + c];
        met[k * 3 + c] = ob.lower_bound(c) && pred >= ob.rgb[c];
      }
    }
  });
  return met;
}

void ResidualStats(const ObservationSet& observations, const std::vector<uint32_t>& ids,
                   const std::vector<float>& responses, const ReflectanceState& state, double* sse, double* weight,
                   const std::vector<float>* robust) {
  RELIGHT_CHECK(robust == nullptr || robust->size() == ids.size()) << "one robust weight per observation";
  const int b_count = state.num_lobes();
  struct Acc {
    double sse = 0, w = 0;
  };
  const BlockLayout layout(ids.size());  // fixed blocks summed in order: reproducible
  std::vector<Acc> partial(layout.count);
  tbb::parallel_for(size_t(0), layout.count, [&](size_t blk) {
    Acc& a = partial[blk];
    std::vector<float> rho(b_count * 3);
    for (size_t k = layout.begin(blk); k < layout.end(blk); ++k) {
      const Observation& ob = observations.records[ids[k]];
      const double alpha = robust != nullptr ? double(ob.confidence) * (*robust)[k] : double(ob.confidence);
      state.VertexLobeWeights(ob.vertex, rho.data());
      const float* resp = responses.data() + k * b_count * 3;
      for (int c = 0; c < 3; ++c) {
        double pred = 0;
        for (int b = 0; b < b_count; ++b) pred += rho[b * 3 + c] * resp[b * 3 + c];
        const double e = CensoredResidual(ob, c, static_cast<float>(pred));
        a.sse += alpha * e * e;
      }
      a.w += 3 * alpha;
    }
  });
  *sse = 0;
  *weight = 0;
  for (const Acc& a : partial) {
    *sse += a.sse;
    *weight += a.w;
  }
}

}  // namespace relight
