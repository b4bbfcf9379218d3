#include "sfm/image_retrieval.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <random>
#include <set>

namespace relight {
namespace {

// A ring of `n` photos over a ring of landmarks: photo i sees the landmarks whose angle is within
// `half_window` of its own, each as the landmark's descriptor plus noise, and as many clutter features that no
// other photo shares (sky, people). Two photos share more landmarks the closer they are on the ring.
std::vector<DescriptorMatrix> RingCollection(int n, int landmarks, double half_window, double noise, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> gauss(0.0f, 1.0f);
  const auto random_descriptor = [&] {
    Eigen::VectorXf d(128);
    for (int k = 0; k < 128; ++k) d[k] = std::abs(gauss(rng));  // SIFT descriptors are non-negative
    return Eigen::VectorXf(d.normalized());
  };
  std::vector<Eigen::VectorXf> world(landmarks);
  for (auto& d : world) d = random_descriptor();
  std::vector<DescriptorMatrix> photos(n);
  for (int i = 0; i < n; ++i) {
    const double angle = 2 * M_PI * i / n;
    std::vector<Eigen::VectorXf> rows;
    for (int l = 0; l < landmarks; ++l) {
      const double a = 2 * M_PI * l / landmarks;
      const double diff = std::abs(std::remainder(a - angle, 2 * M_PI));
      if (diff > half_window) continue;
      Eigen::VectorXf d = world[l];
      for (int k = 0; k < 128; ++k) d[k] = std::max(0.0f, d[k] + static_cast<float>(noise) * gauss(rng));
      rows.push_back(d.normalized());
    }
    const size_t shared = rows.size();
    for (size_t c = 0; c < shared; ++c) rows.push_back(random_descriptor());
    photos[i].resize(rows.size(), 128);
    for (size_t r = 0; r < rows.size(); ++r) photos[i].row(r) = rows[r].transpose();
  }
  return photos;
}

TEST(ImageRetrievalTest, RanksRingNeighboursFirstAndPairsEachPhotoWithThem) {
  // 40 photos 9 degrees apart, each seeing 60 degrees of the ring: neighbours 1..6 steps away share
  // 85 %..10 % of their landmarks, farther ones none.
  const int n = 40;
  const auto photos = RingCollection(n, 2400, M_PI / 6, 0.02, 7);
  ImageRetrievalOptions options;
  options.num_neighbors = 4;
  options.max_training_descriptors = 40000;
  options.branching = 16;  // 32,000 descriptors: a 4,096-word tree (the default 32 suits real collections' 250,000)
  const RetrievalResult result = RetrieveImagePairs(photos, options);
  EXPECT_GT(result.num_words, 1000);
  ASSERT_EQ(result.ranked.size(), size_t(n));
  int adjacent_first = 0;
  for (int i = 0; i < n; ++i) {
    std::set<int> got, want;
    for (const auto& [j, score] : result.ranked[i]) got.insert(j);
    for (int step : {-2, -1, 1, 2}) want.insert((i + step + n) % n);
    EXPECT_EQ(got, want) << "photo " << i;
    const int first = result.ranked[i][0].first;
    adjacent_first += std::min((first - i + n) % n, (i - first + n) % n) == 1;
  }
  // Scores fall with the distance on the ring: nearly always an adjacent photo (85 % shared) ranks first,
  // ahead of those two steps away (70 %).
  EXPECT_GE(adjacent_first, n * 9 / 10);
  // Every photo paired with its 4 ring neighbours and no others: 2 n pairs.
  EXPECT_EQ(result.pairs.size(), size_t(2 * n));
  for (const auto& [i, j] : result.pairs) {
    EXPECT_LT(i, j);
    const int step = std::min(j - i, n - (j - i));
    EXPECT_LE(step, 2) << i << "-" << j;
  }
}

TEST(ImageRetrievalTest, SameSeedSamePairs) {
  const auto photos = RingCollection(30, 1500, M_PI / 5, 0.05, 3);
  ImageRetrievalOptions options;
  options.num_neighbors = 5;
  options.max_training_descriptors = 20000;
  const RetrievalResult a = RetrieveImagePairs(photos, options);
  const RetrievalResult b = RetrieveImagePairs(photos, options);
  EXPECT_EQ(a.pairs, b.pairs);
  EXPECT_EQ(a.num_words, b.num_words);
}

TEST(ImageRetrievalTest, PhotoWithoutFeaturesIsRankedLastNotACrash) {
  auto photos = RingCollection(40, 2400, M_PI / 6, 0.02, 7);
  photos[0] = DescriptorMatrix(0, 0);  // a blank photo: SIFT found nothing
  ImageRetrievalOptions options;
  options.num_neighbors = 4;
  options.branching = 16;
  const RetrievalResult result = RetrieveImagePairs(photos, options);
  ASSERT_EQ(result.ranked.size(), size_t(40));
  for (int i = 2; i < 39; ++i) {  // photos whose two-step neighbourhood does not hold the blank one
    for (const auto& [j, score] : result.ranked[i]) EXPECT_NE(j, 0) << "photo " << i;
  }
  std::vector<DescriptorMatrix> blank(40, DescriptorMatrix(0, 0));
  EXPECT_EQ(RetrieveImagePairs(blank, options).pairs.size(), size_t(40 * 39 / 2));
}

TEST(ImageRetrievalTest, SmallCollectionGetsEveryPair) {
  const auto photos = RingCollection(6, 300, M_PI / 4, 0.05, 5);
  ImageRetrievalOptions options;
  options.num_neighbors = 5;
  const RetrievalResult result = RetrieveImagePairs(photos, options);
  EXPECT_EQ(result.pairs.size(), size_t(15));
  EXPECT_EQ(result.num_words, 0);  // no vocabulary needed
}

TEST(ImageRetrievalTest, QuantizeSendsEachTrainingClusterToItsOwnWord) {
  // Four tight, well separated clusters and a one-level tree of branching 4: one word per cluster.
  std::mt19937 rng(11);
  std::normal_distribution<float> gauss(0.0f, 1.0f);
  DescriptorMatrix training(400, 128);
  for (int r = 0; r < 400; ++r) {
    Eigen::VectorXf d = Eigen::VectorXf::Zero(128);
    d.segment((r % 4) * 32, 32).setConstant(1.0f);
    for (int k = 0; k < 128; ++k) d[k] += 0.01f * gauss(rng);
    training.row(r) = d.normalized().transpose();
  }
  ImageRetrievalOptions options;
  options.branching = 4;
  options.levels = 1;
  const VocabularyTree tree = VocabularyTree::Build(training, options);
  ASSERT_EQ(tree.num_words(), 4);
  const std::vector<int> words = tree.Quantize(training);
  std::set<int> distinct;
  for (int r = 0; r < 400; ++r) {
    EXPECT_EQ(words[r], words[r % 4]) << r;
    distinct.insert(words[r]);
  }
  EXPECT_EQ(distinct.size(), size_t(4));
}

// Photos whose first candidates hold few true neighbours (their sky or light is unlike their neighbours')
// are matched with their partners' partners and further down their ranking, while that finds them partners.
TEST(RetrievalExpansionTest, MatchesPoorlyLinkedPhotosFurtherWhileThatFindsPartners) {
  // A ring of 40 photos; a pair verifies when the photos are at most 2 steps apart (4 true partners each).
  const int n = 40, k = 4;
  const auto distance = [&](int i, int j) { return std::min((i - j + n) % n, (j - i + n) % n); };
  const auto verifies = [&](int i, int j) { return distance(i, j) <= 2; };
  // Photos 5, 12 and 30 look unlike their neighbours: no other photo ranks them among its first 16, and
  // their own rankings start with photos across the ring. 5 holds two true partners at ranks 4-7, 12 one at
  // ranks 4-7 and one more at 8-11, 30 none in its 16 candidates.
  const std::set<int> shy = {5, 12, 30};
  std::vector<std::vector<std::pair<int, float>>> ranked(n);
  for (int i = 0; i < n; ++i) {
    std::vector<int> order;
    for (int j = 0; j < n; ++j) {
      if (j != i && !shy.count(j)) order.push_back(j);
    }
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return distance(i, a) < distance(i, b); });
    if (i == 5) order = {20, 21, 22, 23, 24, 25, 4, 6, 26, 27, 28, 29, 31, 32, 33, 34};
    if (i == 12) order = {25, 26, 27, 28, 29, 31, 32, 11, 33, 13, 34, 35, 36, 37, 38, 39};
    if (i == 30) order = {0, 1, 2, 3, 4, 6, 7, 8, 9, 10, 11, 13, 14, 15, 16, 17};
    order.resize(4 * k);
    for (size_t r = 0; r < order.size(); ++r) ranked[i].emplace_back(order[r], 1.0f - 0.01f * r);
  }
  std::set<std::pair<int, int>> first;
  for (int i = 0; i < n; ++i) {
    for (int r = 0; r < k; ++r) first.emplace(std::min(i, ranked[i][r].first), std::max(i, ranked[i][r].first));
  }
  std::vector<std::pair<int, int>> pairs(first.begin(), first.end());
  RetrievalExpansion expansion(ranked, k, pairs);
  std::vector<int> partners(n, 0), compared(n, 0), partners_after_first(n, 0);
  std::set<std::pair<int, int>> all;
  size_t total = 0;
  int rounds = 0;
  while (!pairs.empty()) {
    ++rounds;
    std::vector<std::pair<int, int>> verified;
    for (const auto& [i, j] : pairs) {
      ++compared[i], ++compared[j];
      if (verifies(i, j)) verified.emplace_back(i, j), ++partners[i], ++partners[j];
    }
    all.insert(pairs.begin(), pairs.end());
    total += pairs.size();
    if (rounds == 1) partners_after_first = partners;
    pairs = expansion.Next(verified);
    if (rounds == 1) {
      EXPECT_EQ(expansion.median_partners(), 4);
      // Every later pair has a photo that was short of the median photo's 4 partners after the first round.
      for (const auto& [i, j] : pairs) EXPECT_TRUE(partners_after_first[i] < 4 || partners_after_first[j] < 4);
    }
  }
  EXPECT_EQ(all.size(), total) << "a pair was matched twice";
  // The three photos find partners; 30, whose ranking holds no neighbour and which has no partner to go
  // through, is given up after one fruitless round of k more candidates.
  EXPECT_GE(partners[5], 2);
  EXPECT_GE(partners[12], 2);
  EXPECT_EQ(partners[30], 0);
  EXPECT_EQ(compared[30], 2 * k);
  // Photo 12's partner 11 leads it to 10 and 13, whom its ranking holds low or not at all.
  EXPECT_TRUE(all.count({10, 12}) && all.count({12, 13}));
  for (int i = 0; i < n; ++i) {
    if (!shy.count(i)) EXPECT_GE(partners[i], 3) << "photo " << i;
    EXPECT_LE(compared[i], 4 * k + 4 * k) << "photo " << i;  // its own 4k candidates and others' choices
  }
  std::printf("retrieval expansion: %d rounds, %zu pairs after the first %zu\n", rounds, total - first.size(),
              first.size());
}

TEST(RetrievalExpansionTest, EveryPairMatchedLeavesNothingToExpand) {
  std::vector<std::pair<int, int>> pairs;
  for (int i = 0; i < 5; ++i) {
    for (int j = i + 1; j < 5; ++j) pairs.emplace_back(i, j);
  }
  RetrievalExpansion expansion(std::vector<std::vector<std::pair<int, float>>>(5), 4, pairs);
  EXPECT_TRUE(expansion.Next({}).empty());  // no partner verified, but no candidate left either
}

}  // namespace
}  // namespace relight
