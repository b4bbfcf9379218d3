// Which photos of a large collection to match: image retrieval with a
// vocabulary of visual words built from the collection's own SIFT features
// (Nister and Stewenius, CVPR 2006: a tree of k-means clusters, words scored by
// tf-idf), so matching costs k pairs per photo instead of all of them and the
// user needs no vocabulary file.
//
// The clustering is OpenCV's cv::kmeans (seeded); the tree, quantisation and
// scoring are written here because no library on the stack does them in a form
// we can use: COLMAP 3.8's vocab_tree_retriever only prints its ranking to the
// log and searches unseeded kd-trees, so its pairs change between runs, and
// OpenCV's BOW classes quantise by a flat (FLANN, unseeded) search. The pairs
// are reproducible: repeated rankings of one database give the same pairs
// (tools/retrieval_recall), and sfm_synthetic_test's retrieval run gave the same
// 168 pairs, 23 of 24 photos registered at 0.207 deg, in three runs on two
// machines (2026-12-05).
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "sfm/descriptor_matching.h"

namespace relight {

struct ImageRetrievalOptions {
  int branching = 32;                     // children per node of the vocabulary tree
  int levels = 3;                         // depth of the tree: up to branching^levels words
  int max_training_descriptors = 250000;  // descriptors the tree is clustered on (evenly from every photo)
  int num_neighbors = 30;                 // most similar photos each photo is paired with
  uint64_t seed = 0;                      // k-means initialisation
};

// A vocabulary tree: centres of each level's clusters, children of node n at
// [first_child[n], first_child[n] + num_children[n]) in the next level.
class VocabularyTree {
 public:
  // Hierarchical k-means on `training` (rows of unit-length descriptors).
  static VocabularyTree Build(const DescriptorMatrix& training, const ImageRetrievalOptions& options);

  // Index of the leaf (visual word) each row of `descriptors` falls into.
  std::vector<int> Quantize(const DescriptorMatrix& descriptors) const;
  int num_words() const { return num_leaves_; }

 private:
  struct Node {
    Eigen::VectorXf centre;
    std::vector<int> children;  // empty for a leaf
    int leaf = -1;              // word index of a leaf
  };
  std::vector<Node> nodes_;  // nodes_[0] is the root (no centre)
  int num_leaves_ = 0;
};

struct RetrievalResult {
  std::vector<std::pair<int, int>> pairs;                  // (i, j), i < j, indices into the photo list
  std::vector<std::vector<std::pair<int, float>>> ranked;  // per photo: (photo, similarity), best first
  int num_words = 0;                                       // leaves of the tree
  double build_seconds = 0, query_seconds = 0;
};

// Builds a tree on a sample of every photo's descriptors, scores every photo against every other by the
// cosine of their tf-idf word histograms, and pairs each photo with its `num_neighbors` best (a pair
// chosen by either photo is kept). With at most num_neighbors + 1 photos every pair is returned.
RetrievalResult RetrieveImagePairs(const std::vector<DescriptorMatrix>& descriptors,
                                   const ImageRetrievalOptions& options);

}  // namespace relight
