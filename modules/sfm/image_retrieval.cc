#include "sfm/image_retrieval.h"

#include <tbb/parallel_for.h>

#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <opencv2/core.hpp>
#include <tuple>

#include "core/error.h"
#include "core/timer.h"

namespace relight {
namespace {

// k-means of the rows `rows` of `data` into at most `k` clusters; returns the centres (k x dims) and each
// row's cluster in `labels`.
Eigen::MatrixXf KMeans(const DescriptorMatrix& data, const std::vector<int>& rows, int k, uint64_t seed,
                       std::vector<int>* labels) {
  cv::Mat samples(static_cast<int>(rows.size()), static_cast<int>(data.cols()), CV_32F);
  for (size_t r = 0; r < rows.size(); ++r) {
    std::copy(data.row(rows[r]).data(), data.row(rows[r]).data() + data.cols(), samples.ptr<float>(int(r)));
  }
  cv::Mat cv_labels, centres;
  cv::theRNG() = cv::RNG(seed);
  cv::kmeans(samples, k, cv_labels, cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 10, 1e-4), 1,
             cv::KMEANS_PP_CENTERS, centres);
  labels->assign(cv_labels.begin<int>(), cv_labels.end<int>());
  Eigen::MatrixXf out(centres.rows, centres.cols);
  for (int i = 0; i < centres.rows; ++i) {
    for (int j = 0; j < centres.cols; ++j) out(i, j) = centres.at<float>(i, j);
  }
  return out;
}

}  // namespace

VocabularyTree VocabularyTree::Build(const DescriptorMatrix& training, const ImageRetrievalOptions& options) {
  RELIGHT_CHECK(options.branching >= 2 && options.levels >= 1) << "vocabulary tree: branching >= 2, levels >= 1";
  VocabularyTree tree;
  tree.nodes_.emplace_back();
  // Breadth first: (node, its training rows, its level).
  struct Pending {
    int node;
    std::vector<int> rows;
    int level;
  };
  std::vector<Pending> queue;
  std::vector<int> all(training.rows());
  std::iota(all.begin(), all.end(), 0);
  queue.push_back({0, std::move(all), 0});
  for (size_t q = 0; q < queue.size(); ++q) {
    const int node = queue[q].node;
    const int level = queue[q].level;
    std::vector<int> rows = std::move(queue[q].rows);
    std::vector<std::vector<int>> members;
    Eigen::MatrixXf centres;
    // A node splits when its children get about 4 training descriptors each or more: finer words would
    // separate the noisy copies of one feature.
    if (level < options.levels && static_cast<int>(rows.size()) >= 4 * options.branching) {
      std::vector<int> labels;
      centres = KMeans(training, rows, options.branching, options.seed + node, &labels);
      members.resize(centres.rows());
      for (size_t r = 0; r < rows.size(); ++r) members[labels[r]].push_back(rows[r]);
    }
    const auto filled = std::count_if(members.begin(), members.end(), [](const auto& m) { return !m.empty(); });
    if (filled < 2) {  // deep enough, too few rows, or all rows alike: a word
      tree.nodes_[node].leaf = tree.num_leaves_++;
      continue;
    }
    for (int c = 0; c < centres.rows(); ++c) {
      if (members[c].empty()) continue;
      const int child = static_cast<int>(tree.nodes_.size());
      tree.nodes_.emplace_back();
      tree.nodes_[child].centre = centres.row(c).transpose();
      tree.nodes_[node].children.push_back(child);
      queue.push_back({child, std::move(members[c]), level + 1});
    }
  }
  return tree;
}

std::vector<int> VocabularyTree::Quantize(const DescriptorMatrix& descriptors) const {
  std::vector<int> words(descriptors.rows());
  tbb::parallel_for(Eigen::Index(0), descriptors.rows(), [&](Eigen::Index r) {
    const Eigen::VectorXf d = descriptors.row(r).transpose();
    int node = 0;
    while (nodes_[node].leaf < 0) {
      int best = -1;
      float best_distance = 0;
      for (int child : nodes_[node].children) {
        const float distance = (nodes_[child].centre - d).squaredNorm();
        if (best < 0 || distance < best_distance) best = child, best_distance = distance;
      }
      node = best;
    }
    words[r] = nodes_[node].leaf;
  });
  return words;
}

RetrievalResult RetrieveImagePairs(int num_photos, const std::function<DescriptorMatrix(int)>& descriptors_of,
                                   const ImageRetrievalOptions& options) {
  RetrievalResult result;
  const int n = num_photos;
  result.ranked.resize(n);  // stays empty for each photo when every pair is returned
  const auto every_pair = [&] {
    for (int i = 0; i < n; ++i) {
      for (int j = i + 1; j < n; ++j) result.pairs.emplace_back(i, j);
    }
    return result;
  };
  if (n <= options.num_neighbors + 1) return every_pair();
  Timer timer;
  // Training rows: evenly strided from every photo, the same share of each.
  // Photos without features (blank or tiny) add nothing to the tree and rank last for every photo.
  const int64_t per_photo = std::max<int64_t>(1, options.max_training_descriptors / n);
  std::vector<DescriptorMatrix> samples(n);
  std::vector<int64_t> num_rows(n, 0);
  int dims = 0;
  int64_t num_samples = 0;
  for (int i = 0; i < n; ++i) {
    const DescriptorMatrix d = descriptors_of(i);
    num_rows[i] = d.rows();
    if (d.rows() == 0) continue;
    dims = static_cast<int>(d.cols());
    const int64_t take = std::min<int64_t>(d.rows(), per_photo);
    samples[i].resize(take, d.cols());
    for (int64_t t = 0; t < take; ++t) samples[i].row(t) = d.row(t * d.rows() / take);
    num_samples += take;
  }
  if (dims == 0) return every_pair();  // no features anywhere: nothing to rank by
  DescriptorMatrix training(num_samples, dims);
  int64_t next_row = 0;
  for (auto& s : samples) {
    if (s.rows() == 0) continue;
    training.middleRows(next_row, s.rows()) = s;
    next_row += s.rows();
    s = DescriptorMatrix();
  }
  const VocabularyTree tree = VocabularyTree::Build(training, options);
  result.num_words = tree.num_words();
  result.build_seconds = timer.Seconds();

  timer.Restart();
  // tf-idf histograms, one row per photo, unit length; the square root of a word's count damps repeated
  // texture (one brick pattern, one leafy background) that would otherwise dominate a photo's histogram.
  std::vector<std::vector<int>> words(n);
  for (int i = 0; i < n; ++i) {
    if (num_rows[i] > 0) words[i] = tree.Quantize(descriptors_of(i));
  }
  std::vector<int> photos_with_word(tree.num_words(), 0);
  std::vector<std::vector<std::pair<int, float>>> histograms(n);
  for (int i = 0; i < n; ++i) {
    std::vector<int> counts(tree.num_words(), 0);
    for (int w : words[i]) ++counts[w];
    for (int w = 0; w < tree.num_words(); ++w) {
      if (counts[w] > 0) {
        histograms[i].emplace_back(w, std::sqrt(static_cast<float>(counts[w])));
        ++photos_with_word[w];
      }
    }
  }
  std::vector<Eigen::Triplet<float>> triplets;
  for (int i = 0; i < n; ++i) {
    double norm2 = 0;
    for (auto& [w, v] : histograms[i]) {
      v *= static_cast<float>(std::log(static_cast<double>(n) / photos_with_word[w]));
      norm2 += double(v) * v;
    }
    const float inv = norm2 > 0 ? static_cast<float>(1.0 / std::sqrt(norm2)) : 0.0f;
    for (const auto& [w, v] : histograms[i]) triplets.emplace_back(i, w, v * inv);
  }
  Eigen::SparseMatrix<float, Eigen::RowMajor> tfidf(n, tree.num_words());
  tfidf.setFromTriplets(triplets.begin(), triplets.end());
  const Eigen::SparseMatrix<float, Eigen::ColMajor> tfidf_t = tfidf.transpose();

  // Rank in blocks of photos (similarities of a block against all: block x n).
  const int block = 256;
  std::vector<std::pair<int, int>> pairs;
  for (int b = 0; b < n; b += block) {
    const int rows = std::min(block, n - b);
    const Eigen::MatrixXf scores = Eigen::MatrixXf(tfidf.middleRows(b, rows) * tfidf_t);
    for (int r = 0; r < rows; ++r) {
      const int i = b + r;
      std::vector<std::pair<int, float>> ranked;
      for (int j = 0; j < n; ++j) {
        if (j != i) ranked.emplace_back(j, scores(r, j));
      }
      std::stable_sort(ranked.begin(), ranked.end(), [](const auto& x, const auto& y) { return x.second > y.second; });
      ranked.resize(std::min<size_t>(ranked.size(), std::max(options.num_neighbors, options.num_ranked)));
      for (int r = 0; r < options.num_neighbors; ++r) {
        const int j = ranked[r].first;
        pairs.emplace_back(std::min(i, j), std::max(i, j));
      }
      result.ranked[i] = std::move(ranked);
    }
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  result.pairs = std::move(pairs);
  result.query_seconds = timer.Seconds();
  return result;
}

RetrievalExpansion::RetrievalExpansion(std::vector<std::vector<std::pair<int, float>>> ranked, int num_neighbors,
                                       const std::vector<std::pair<int, int>>& first_pairs)
    : ranked_(std::move(ranked)),
      num_neighbors_(num_neighbors),
      partners_(ranked_.size()),
      next_candidate_(ranked_.size(), static_cast<size_t>(num_neighbors)),
      num_extra_(ranked_.size(), 0),
      compared_(first_pairs.begin(), first_pairs.end()) {}

std::vector<std::pair<int, int>> RetrievalExpansion::Next(const std::vector<std::pair<int, int>>& verified) {
  const int n = static_cast<int>(ranked_.size());
  std::vector<char> gained(n, 0);
  for (const auto& [i, j] : verified) {
    RELIGHT_CHECK(i >= 0 && i < n && j >= 0 && j < n) << "retrieval expansion: pair " << i << "-" << j << " of " << n;
    partners_[i].push_back(j);
    partners_[j].push_back(i);
    gained[i] = gained[j] = 1;
  }
  if (round_ == 0 && n > 0) {
    std::vector<size_t> counts(n);
    for (int i = 0; i < n; ++i) counts[i] = partners_[i].size();
    std::nth_element(counts.begin(), counts.begin() + n / 2, counts.end());
    median_partners_ = static_cast<int>(counts[n / 2]);
  }
  std::vector<std::pair<int, int>> pairs;
  num_expanded_last_ = 0;
  for (int i = 0; i < n; ++i) {
    const int shortfall = std::max(median_partners_, 1) - static_cast<int>(partners_[i].size());
    if (shortfall <= 0 || (round_ > 0 && !gained[i])) continue;
    // num_neighbors in proportion to the shortfall (all of them for a photo with no partner), and no more
    // in all than `ranked` holds beyond the first num_neighbors.
    const int wanted = (num_neighbors_ * shortfall + std::max(median_partners_, 1) - 1) / std::max(median_partners_, 1);
    const int budget = std::min(wanted, static_cast<int>(ranked_[i].size()) - num_neighbors_ - num_extra_[i]);
    if (budget <= 0) continue;
    const auto rank_of = [&](int j) {
      for (size_t r = 0; r < ranked_[i].size(); ++r) {
        if (ranked_[i][r].first == j) return r;
      }
      return ranked_[i].size();
    };
    const auto take = [&](int j) {
      if (!compared_.emplace(std::min(i, j), std::max(i, j)).second) return false;
      pairs.emplace_back(std::min(i, j), std::max(i, j));
      return true;
    };
    // Transitive candidates first: photos verified with this photo's partners, most links first, then by
    // similarity. They are near it whatever their light, where the appearance ranking is least reliable.
    std::map<int, int> links;
    for (int p : partners_[i]) {
      for (int q : partners_[p]) {
        if (q != i && !compared_.count({std::min(i, q), std::max(i, q)})) ++links[q];
      }
    }
    struct Candidate {
      int photo, links;
      size_t rank;
    };
    std::vector<Candidate> transitive;
    for (const auto& [q, count] : links) transitive.push_back({q, count, rank_of(q)});
    std::sort(transitive.begin(), transitive.end(), [](const Candidate& a, const Candidate& b) {
      return std::tie(b.links, a.rank, a.photo) < std::tie(a.links, b.rank, b.photo);
    });
    int taken = 0;
    for (size_t t = 0; t < transitive.size() && taken < budget; ++t) taken += take(transitive[t].photo);
    // Then the next candidates of the ranking.
    for (; next_candidate_[i] < ranked_[i].size() && taken < budget; ++next_candidate_[i]) {
      taken += take(ranked_[i][next_candidate_[i]].first);
    }
    num_extra_[i] += taken;
    num_expanded_last_ += taken > 0;
  }
  std::sort(pairs.begin(), pairs.end());
  ++round_;
  return pairs;
}

}  // namespace relight
