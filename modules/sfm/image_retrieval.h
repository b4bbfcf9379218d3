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
// OpenCV's BOW classes quantise by a flat (FLANN, unseeded) search.
//
// The same descriptors give the same pairs (tools/retrieval_recall ranks one
// database repeatably), but the descriptors of the same photos are not always
// the same: COLMAP 3.8's CPU SIFT returns the odd keypoint's descriptor
// differently from run to run (on synthetic_bunny's photos one keypoint of one
// photo came out all zeros in 4 of 8 runs, with 1 or 2 threads alike), and one
// changed training descriptor changes the k-means vocabulary. That collection's
// retrieval gave 160 to 168 pairs from run to run, and a photo could fall out
// of the model; RetrievalExpansion, which matches poorly linked photos
// further, makes the registration depend far less on which pairs came first.
#pragma once

#include <cstdint>
#include <functional>
#include <set>
#include <utility>
#include <vector>

#include "sfm/descriptor_matching.h"

namespace relight {

struct ImageRetrievalOptions {
  int branching = 32;                     // children per node of the vocabulary tree
  int levels = 3;                         // depth of the tree: up to branching^levels words
  int max_training_descriptors = 250000;  // descriptors the tree is clustered on (evenly from every photo)
  int num_neighbors = 30;                 // most similar photos each photo is paired with
  int num_ranked = 0;                     // candidates kept in RetrievalResult::ranked (at least num_neighbors)
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
  std::vector<std::vector<std::pair<int, float>>> ranked;  // per photo: (photo, similarity), best first; empty
                                                           // when every pair is returned
  int num_words = 0;                                       // leaves of the tree
  double build_seconds = 0, query_seconds = 0;
};

// Builds a tree on a sample of every photo's descriptors, scores every photo against every other by the
// cosine of their tf-idf word histograms, and pairs each photo with its `num_neighbors` best (a pair
// chosen by either photo is kept). With at most num_neighbors + 1 photos every pair is returned.
// `descriptors_of(i)` gives photo i's descriptors (rows of unit length); each photo's are asked for twice, so a
// large collection need not hold them all as floats.
RetrievalResult RetrieveImagePairs(int num_photos, const std::function<DescriptorMatrix(int)>& descriptors_of,
                                   const ImageRetrievalOptions& options);
inline RetrievalResult RetrieveImagePairs(const std::vector<DescriptorMatrix>& descriptors,
                                          const ImageRetrievalOptions& options) {
  return RetrieveImagePairs(
      static_cast<int>(descriptors.size()), [&](int i) { return descriptors[i]; }, options);
}

// Retrieval that adapts to photos that match poorly (a sky or light unlike their neighbours', a view few
// other photos share), whose first candidates hold few true neighbours. After the first round of matching,
// a photo verified with fewer partners than the median photo is matched with more photos, as many as
// `num_neighbors` times its shortfall (all `num_neighbors` for a photo with none): first those its
// partners are verified with (transitive candidates, most links first: near it whatever their light), then
// its next candidates of `ranked`. After later rounds, only while the round before found it a new partner.
// The photos a photo is matched with in all stay bounded by the length of `ranked`, so the cost stays
// linear in the photos, and mostly the collection's poorly linked tail pays it.
class RetrievalExpansion {
 public:
  RetrievalExpansion(std::vector<std::vector<std::pair<int, float>>> ranked, int num_neighbors,
                     const std::vector<std::pair<int, int>>& first_pairs);

  // Takes the verified pairs (i, j) of the round just matched and returns the next round's pairs (i < j,
  // none matched before); empty when matching is done.
  std::vector<std::pair<int, int>> Next(const std::vector<std::pair<int, int>>& verified);
  int num_expanded_last() const { return num_expanded_last_; }  // photos given new candidates by Next
  int median_partners() const { return median_partners_; }      // verified partners after the first round

 private:
  std::vector<std::vector<std::pair<int, float>>> ranked_;
  int num_neighbors_;
  int round_ = 0;
  std::vector<std::vector<int>> partners_;  // verified partners of each photo so far
  int median_partners_ = 0;                 // of the median photo after the first round
  std::vector<size_t> next_candidate_;      // rank of each photo's next candidate
  std::vector<int> num_extra_;              // photos each photo was matched with beyond its first candidates
  std::set<std::pair<int, int>> compared_;
  int num_expanded_last_ = 0;
};

}  // namespace relight
