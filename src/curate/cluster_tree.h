// The hierarchy of k-means clusters of paper 000 Sec. 3.1 over features f_1 ... f_n: level i
// (i < n) splits each node of level i-1 into up to k_i clusters of f_i; the n-th level is a
// flat list of items (with their f_n) under each node of level n-1. With f = (pose,
// lighting, expression) and k = (9, 3): 9 pose centres, 27 lighting centres, and the
// expression features of the frames in each of the 27 lighting clusters.
//
// A query with (q_1, ..., q_n) keeps the q_1 nearest level-1 centres, then within each kept
// node its q_2 nearest children, ..., and within each kept leaf node its q_n nearest items:
// with (2, 3, 1), 2 poses x 3 lightings x 1 expression = 6 frames.
//
// Deterministic: k-means++ seeding from util/random.h's Rng(seed, node), ties broken by the
// lower index.
#ifndef FACECAP_CURATE_CLUSTER_TREE_H_
#define FACECAP_CURATE_CLUSTER_TREE_H_

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace facecap::curate {

using FeatureMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct ClusterTreeOptions {
  // k_1 ... k_{n-1}: clusters per node at each clustered level (one fewer than features).
  std::vector<int> clusters = {9, 3};
  // Seed of the k-means++ initialisation.
  uint64_t seed = 1;
  // Lloyd iterations at most (stops earlier when assignments no longer change).
  int max_iterations = 50;

  bool Check(int num_levels, std::string* why) const;
};

// Level i (0-based) of the tree: its nodes' centres and how they hang together.
struct ClusterLevel {
  FeatureMatrix centers;              // #nodes by dim(f_{i+1})
  std::vector<int32_t> parent;        // #nodes: node of the level above (-1 at the top)
  std::vector<int32_t> first_child;   // #nodes + 1: children of node j are first_child[j] ..
                                      // first_child[j+1]-1 on the next level, or, on the last
                                      // clustered level, items leaf_items[first_child[j] ..]
};

class ClusterTree {
 public:
  ClusterTree() = default;
  // Builds the tree over `features` (one matrix per level, rows = items, equal row counts).
  // InvalidInputError for mismatched sizes or options; an empty item set is an error.
  static ClusterTree Build(const std::vector<FeatureMatrix>& features,
                           const ClusterTreeOptions& options);

  // The items (rows of the features) a query picks, in order of traversal, each once.
  // `query` holds f_1 ... f_n of the query; `picks` holds q_1 ... q_n.
  std::vector<int64_t> Query(const std::vector<Eigen::VectorXf>& query,
                             const std::vector<int>& picks) const;

  // The same selection by brute force: every node of a level is ranked against the query,
  // then the kept ones filtered by their parent. For tests.
  std::vector<int64_t> QueryBruteForce(const std::vector<Eigen::VectorXf>& query,
                                       const std::vector<int>& picks) const;

  int NumLevels() const { return static_cast<int>(levels_.size()) + 1; }  // incl. the flat one
  int64_t NumItems() const { return static_cast<int64_t>(leaf_items_.size()); }
  const std::vector<ClusterLevel>& levels() const { return levels_; }
  const std::vector<int64_t>& leaf_items() const { return leaf_items_; }
  const FeatureMatrix& flat_features() const { return flat_; }

  // For storage: rebuilds a tree from its parts (checks that they fit together).
  static ClusterTree FromParts(std::vector<ClusterLevel> levels, std::vector<int64_t> leaf_items,
                               FeatureMatrix flat_features);

 private:
  std::vector<ClusterLevel> levels_;   // the n-1 clustered levels
  std::vector<int64_t> leaf_items_;    // items grouped by node of the last clustered level
  FeatureMatrix flat_;                 // f_n of every item (row = item)
  int flat_dims_ = 0;
};

// Many queries at once (e.g. the renders of a turntable, paper 000 Sec. 5.2): each query's
// picks, and the unique items over all of them in query order.
struct MultiQueryResult {
  std::vector<std::vector<int64_t>> per_query;  // items each query picked, traversal order
  std::vector<int64_t> unique;                  // items over all queries, each once
  std::vector<int> picks;                       // q_1 ... q_n used (after any widening)
};

// Runs every query with `picks`. With target_unique > 0, while fewer than target_unique
// unique items come back and the picks do not yet take every item, the picks are widened one
// step at a time from the bottom level up: q_n grows by one until it reaches the largest leaf
// node, then q_{n-1} up to the most children any node has, ..., then q_1; the pose level,
// which decides how close the picks' poses are, is widened last. The step that reaches the
// target adds its new items round-robin over the queries (each query's in traversal order)
// until exactly target_unique are unique, so the result has target_unique items, or all
// items when the tree holds fewer.
MultiQueryResult QueryMany(const ClusterTree& tree,
                           const std::vector<std::vector<Eigen::VectorXf>>& queries,
                           const std::vector<int>& picks, int64_t target_unique = 0);

// k-means with k-means++ seeding on `rows` of `data`: returns the centres (<= k rows: empty
// clusters are dropped) and each row's cluster.
void KMeans(const FeatureMatrix& data, const std::vector<int64_t>& rows, int k, uint64_t seed,
            uint64_t stream, int max_iterations, FeatureMatrix* centers,
            std::vector<int32_t>* assignment);

}  // namespace facecap::curate

#endif  // FACECAP_CURATE_CLUSTER_TREE_H_
