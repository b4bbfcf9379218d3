// How well image retrieval (modules/sfm/image_retrieval.h) finds the photo pairs that exhaustive matching
// verifies: reads a COLMAP database kept by an exhaustive sfm run (sfm.keep_database=true, sfm.matcher=exhaustive),
// ranks the photos with the given vocabulary settings and prints, per neighbour count, the share of the verified
// pairs (at least 15 inliers) the retrieved pairs contain, weighted by pair and by inliers, and the photos left
// with no verified partner among their retrieved pairs.
//
//   build/bin/retrieval_recall WS/cache/sfm/<key>/colmap/database.db --neighbors 6 10 20 30
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <map>
#include <set>

#include "core/timer.h"
#include "sfm/colmap_database.h"
#include "sfm/image_retrieval.h"

int main(int argc, char** argv) {
  using namespace relight;
  CLI::App app{"Recall of image retrieval against the verified pairs of an exhaustive COLMAP database"};
  std::string database;
  std::vector<int> neighbors = {6, 10, 20, 30};
  ImageRetrievalOptions options;
  app.add_option("DATABASE", database, "database.db of an exhaustive sfm run")->required()->check(CLI::ExistingFile);
  app.add_option("--neighbors", neighbors, "neighbour counts to score");
  app.add_option("--branching", options.branching, "children per node of the vocabulary tree");
  app.add_option("--levels", options.levels, "depth of the vocabulary tree");
  app.add_option("--training", options.max_training_descriptors, "descriptors the tree is clustered on");
  bool show_ranking = false;
  app.add_flag("--ranking", show_ranking, "print every photo's retrieved photos (similarity, verified inliers)");
  CLI11_PARSE(app, argc, argv);

  ColmapDatabase db(database);
  std::vector<DatabaseImage> images = db.ReadImages();
  std::sort(images.begin(), images.end(), [](const auto& a, const auto& b) { return a.name < b.name; });
  std::map<int, int> index;  // image id -> row
  std::vector<DescriptorMatrix> descriptors(images.size());
  for (size_t i = 0; i < images.size(); ++i) {
    index[images[i].image_id] = static_cast<int>(i);
    int rows = 0, cols = 0;
    const std::vector<uint8_t> data = db.ReadDescriptors(images[i].image_id, &rows, &cols);
    descriptors[i] = NormalizedDescriptors(data, rows, cols);
  }
  std::map<std::pair<int, int>, int> verified;  // (i, j), i < j -> inliers
  for (const auto& g : db.ReadTwoViewGeometries()) {
    if (g.inlier_matches.size() < 15) continue;
    const int a = index.at(g.image_id1), b = index.at(g.image_id2);
    verified[{std::min(a, b), std::max(a, b)}] = static_cast<int>(g.inlier_matches.size());
  }
  double total_inliers = 0;
  for (const auto& [pair, inliers] : verified) total_inliers += inliers;
  std::printf("%zu photos, %zu verified pairs of %zu\n", images.size(), verified.size(),
              images.size() * (images.size() - 1) / 2);
  std::printf("%-10s %-8s %-14s %-16s %-20s %s\n", "neighbors", "pairs", "recall (pairs)", "recall (inliers)",
              "photos w/o partner", "seconds (tree + ranking)");
  for (int k : neighbors) {
    options.num_neighbors = k;
    const RetrievalResult r = RetrieveImagePairs(descriptors, options);
    const std::set<std::pair<int, int>> got(r.pairs.begin(), r.pairs.end());
    int found = 0;
    double found_inliers = 0;
    std::vector<int> partners(images.size(), 0), verified_partners(images.size(), 0);
    for (const auto& [pair, inliers] : verified) {
      ++verified_partners[pair.first];
      ++verified_partners[pair.second];
      if (!got.count(pair)) continue;
      ++found;
      found_inliers += inliers;
      ++partners[pair.first];
      ++partners[pair.second];
    }
    if (show_ranking) {
      for (size_t i = 0; i < images.size(); ++i) {
        std::printf("  %s:", images[i].name.c_str());
        for (const auto& [j, score] : r.ranked[i]) {
          const auto it = verified.find({std::min<int>(i, j), std::max<int>(i, j)});
          std::printf(" %d(%.2f,%d)", j, score, it == verified.end() ? 0 : it->second);
        }
        std::printf("\n");
      }
    }
    int orphans = 0;
    for (size_t i = 0; i < images.size(); ++i) orphans += verified_partners[i] > 0 && partners[i] == 0;
    std::printf("%-10d %-8zu %-14.3f %-16.3f %-20d %.1f + %.1f (%d words)\n", k, r.pairs.size(),
                verified.empty() ? 0.0 : double(found) / verified.size(),
                total_inliers > 0 ? found_inliers / total_inliers : 0.0, orphans, r.build_seconds, r.query_seconds,
                r.num_words);
  }
  return 0;
}
