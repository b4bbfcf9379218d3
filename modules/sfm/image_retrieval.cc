#include "sfm/image_retrieval.h"

#include <tbb/parallel_for.h>

#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <opencv2/core.hpp>

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

RetrievalResult RetrieveImagePairs(const std::vector<DescriptorMatrix>& descriptors,
                                   const ImageRetrievalOptions& options) {
  RetrievalResult result;
  const int n = static_cast<int>(descriptors.size());
  if (n <= options.num_neighbors + 1) {
    for (int i = 0; i < n; ++i) {
      for (int j = i + 1; j < n; ++j) result.pairs.emplace_back(i, j);
    }
    return result;
  }
  Timer timer;
  // Training rows: evenly strided from every photo, the same share of each.
  // Photos without features (blank or tiny) add nothing to the tree and rank last for every photo.
  int dims = 0;
  for (const auto& d : descriptors) {
    if (d.rows() > 0) dims = static_cast<int>(d.cols());
  }
  if (dims == 0) {  // no features anywhere: nothing to rank by
    for (int i = 0; i < n; ++i) {
      for (int j = i + 1; j < n; ++j) result.pairs.emplace_back(i, j);
    }
    return result;
  }
  const int64_t per_photo = std::max<int64_t>(1, options.max_training_descriptors / n);
  std::vector<std::pair<int, int>> sample;  // (photo, row)
  for (int i = 0; i < n; ++i) {
    const int64_t rows = descriptors[i].rows();
    const int64_t take = std::min(rows, per_photo);
    for (int64_t t = 0; t < take; ++t) sample.emplace_back(i, static_cast<int>(t * rows / take));
  }
  DescriptorMatrix training(sample.size(), dims);
  for (size_t s = 0; s < sample.size(); ++s) training.row(s) = descriptors[sample[s].first].row(sample[s].second);
  const VocabularyTree tree = VocabularyTree::Build(training, options);
  result.num_words = tree.num_words();
  result.build_seconds = timer.Seconds();

  timer.Restart();
  // tf-idf histograms, one row per photo, unit length; the square root of a word's count damps repeated
  // texture (one brick pattern, one leafy background) that would otherwise dominate a photo's histogram.
  std::vector<std::vector<int>> words(n);
  for (int i = 0; i < n; ++i) {
    if (descriptors[i].rows() > 0) words[i] = tree.Quantize(descriptors[i]);
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
  result.ranked.resize(n);
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
      ranked.resize(options.num_neighbors);
      for (const auto& [j, s] : ranked) pairs.emplace_back(std::min(i, j), std::max(i, j));
      result.ranked[i] = std::move(ranked);
    }
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  result.pairs = std::move(pairs);
  result.query_seconds = timer.Seconds();
  return result;
}

}  // namespace relight
