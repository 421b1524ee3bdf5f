#include "curate/cluster_tree.h"

#include <algorithm>
#include <limits>
#include <numeric>
#include <unordered_set>

#include "util/errors.h"
#include "util/random.h"

namespace facecap::curate {

bool ClusterTreeOptions::Check(int num_levels, std::string* why) const {
  if (num_levels < 1) { *why = "the tree needs at least one feature level"; return false; }
  if (static_cast<int>(clusters.size()) != num_levels - 1) {
    *why = "clusters needs one k per clustered level: " + std::to_string(num_levels - 1) +
           " for " + std::to_string(num_levels) + " feature levels, got " +
           std::to_string(clusters.size());
    return false;
  }
  for (int k : clusters) {
    if (k < 1 || k > 4096) { *why = "each k must be in [1, 4096]"; return false; }
  }
  if (max_iterations < 1) { *why = "max_iterations must be >= 1"; return false; }
  return true;
}

namespace {

// Squared distance of row `row` of `m` to `v`.
inline float Distance2(const FeatureMatrix& m, int64_t row, const Eigen::VectorXf& v) {
  return (m.row(row).transpose() - v).squaredNorm();
}

// Indices [begin, end) ranked by (distance, index); returns the first `keep`.
template <typename DistanceFn>
std::vector<int64_t> Nearest(int64_t begin, int64_t end, int keep, DistanceFn&& distance) {
  std::vector<std::pair<float, int64_t>> ranked;
  ranked.reserve(end - begin);
  for (int64_t i = begin; i < end; ++i) ranked.emplace_back(distance(i), i);
  const size_t k = std::min<size_t>(keep, ranked.size());
  std::partial_sort(ranked.begin(), ranked.begin() + k, ranked.end());
  std::vector<int64_t> out(k);
  for (size_t i = 0; i < k; ++i) out[i] = ranked[i].second;
  return out;
}

}  // namespace

void KMeans(const FeatureMatrix& data, const std::vector<int64_t>& rows, int k, uint64_t seed,
            uint64_t stream, int max_iterations, FeatureMatrix* centers,
            std::vector<int32_t>* assignment) {
  const int64_t m = static_cast<int64_t>(rows.size());
  const int dims = static_cast<int>(data.cols());
  assignment->assign(m, 0);
  if (m == 0) {
    centers->resize(0, dims);
    return;
  }
  k = static_cast<int>(std::min<int64_t>(k, m));
  Rng rng(seed, stream);
  // k-means++ seeding.
  FeatureMatrix c(k, dims);
  c.row(0) = data.row(rows[rng.UniformInt(m)]);
  std::vector<double> d2(m, std::numeric_limits<double>::max());
  for (int j = 1; j < k; ++j) {
    double total = 0.0;
    for (int64_t i = 0; i < m; ++i) {
      d2[i] = std::min<double>(d2[i], (data.row(rows[i]) - c.row(j - 1)).squaredNorm());
      total += d2[i];
    }
    int64_t pick = 0;
    if (total > 0.0) {
      double u = rng.Uniform() * total;
      for (pick = 0; pick < m - 1; ++pick) {
        u -= d2[pick];
        if (u < 0.0) break;
      }
    } else {
      pick = rng.UniformInt(m);
    }
    c.row(j) = data.row(rows[pick]);
  }
  // Lloyd iterations.
  std::vector<int32_t>& a = *assignment;
  std::vector<int64_t> counts(k);
  for (int it = 0; it < max_iterations; ++it) {
    bool changed = it == 0;
    for (int64_t i = 0; i < m; ++i) {
      int best = 0;
      float best_d = std::numeric_limits<float>::max();
      for (int j = 0; j < k; ++j) {
        const float d = (data.row(rows[i]) - c.row(j)).squaredNorm();
        if (d < best_d) { best_d = d; best = j; }
      }
      if (a[i] != best) { a[i] = best; changed = true; }
    }
    if (!changed) break;
    FeatureMatrix sum = FeatureMatrix::Zero(k, dims);
    std::fill(counts.begin(), counts.end(), 0);
    for (int64_t i = 0; i < m; ++i) {
      sum.row(a[i]) += data.row(rows[i]);
      ++counts[a[i]];
    }
    for (int j = 0; j < k; ++j) {
      if (counts[j] > 0) c.row(j) = sum.row(j) / static_cast<float>(counts[j]);
    }
  }
  // Drop empty clusters and renumber.
  std::fill(counts.begin(), counts.end(), 0);
  for (int32_t j : a) ++counts[j];
  std::vector<int32_t> renumber(k, -1);
  int kept = 0;
  for (int j = 0; j < k; ++j) if (counts[j] > 0) renumber[j] = kept++;
  centers->resize(kept, dims);
  for (int j = 0; j < k; ++j) if (renumber[j] >= 0) centers->row(renumber[j]) = c.row(j);
  for (int32_t& j : a) j = renumber[j];
}

ClusterTree ClusterTree::Build(const std::vector<FeatureMatrix>& features,
                               const ClusterTreeOptions& options) {
  std::string why;
  if (!options.Check(static_cast<int>(features.size()), &why)) throw InvalidInputError("cluster tree: " + why);
  const int64_t n = features[0].rows();
  if (n == 0) throw InvalidInputError("cluster tree: no items to cluster");
  for (const FeatureMatrix& f : features) {
    if (f.rows() != n) throw InvalidInputError("cluster tree: feature levels have different item counts");
  }
  ClusterTree tree;
  std::vector<std::vector<int64_t>> groups(1);
  groups[0].resize(n);
  std::iota(groups[0].begin(), groups[0].end(), 0);
  const int clustered = static_cast<int>(features.size()) - 1;
  for (int level = 0; level < clustered; ++level) {
    ClusterLevel out;
    std::vector<std::vector<int64_t>> next;
    std::vector<FeatureMatrix> centre_blocks;
    std::vector<int32_t> offsets{0};
    for (size_t g = 0; g < groups.size(); ++g) {
      FeatureMatrix centers;
      std::vector<int32_t> assignment;
      KMeans(features[level], groups[g], options.clusters[level], options.seed,
             (static_cast<uint64_t>(level) << 32) + g, options.max_iterations, &centers, &assignment);
      std::vector<std::vector<int64_t>> members(centers.rows());
      for (size_t i = 0; i < groups[g].size(); ++i) members[assignment[i]].push_back(groups[g][i]);
      for (auto& m : members) {
        next.push_back(std::move(m));
        out.parent.push_back(level == 0 ? -1 : static_cast<int32_t>(g));
      }
      centre_blocks.push_back(std::move(centers));
      offsets.push_back(static_cast<int32_t>(next.size()));
    }
    out.centers.resize(static_cast<int64_t>(next.size()), features[level].cols());
    int64_t row = 0;
    for (const FeatureMatrix& b : centre_blocks) {
      out.centers.middleRows(row, b.rows()) = b;
      row += b.rows();
    }
    if (level > 0) tree.levels_.back().first_child = offsets;
    tree.levels_.push_back(std::move(out));
    groups = std::move(next);
  }
  // Items under each node of the last clustered level (or all items when there is none).
  std::vector<int32_t> offsets{0};
  for (const auto& g : groups) {
    tree.leaf_items_.insert(tree.leaf_items_.end(), g.begin(), g.end());
    offsets.push_back(static_cast<int32_t>(tree.leaf_items_.size()));
  }
  if (!tree.levels_.empty()) tree.levels_.back().first_child = offsets;
  tree.flat_ = features.back();
  tree.flat_dims_ = static_cast<int>(tree.flat_.cols());
  return tree;
}

ClusterTree ClusterTree::FromParts(std::vector<ClusterLevel> levels, std::vector<int64_t> leaf_items,
                                   FeatureMatrix flat_features) {
  ClusterTree t;
  for (size_t l = 0; l < levels.size(); ++l) {
    const ClusterLevel& L = levels[l];
    const int64_t nodes = L.centers.rows();
    const int64_t below = l + 1 < levels.size() ? levels[l + 1].centers.rows()
                                                : static_cast<int64_t>(leaf_items.size());
    if (static_cast<int64_t>(L.parent.size()) != nodes ||
        static_cast<int64_t>(L.first_child.size()) != nodes + 1 || L.first_child.front() != 0 ||
        L.first_child.back() != below) {
      throw FileIOError("cluster tree: level " + std::to_string(l) + " does not fit together");
    }
  }
  for (int64_t item : leaf_items) {
    if (item < 0 || item >= flat_features.rows()) throw FileIOError("cluster tree: item out of range");
  }
  t.levels_ = std::move(levels);
  t.leaf_items_ = std::move(leaf_items);
  t.flat_ = std::move(flat_features);
  t.flat_dims_ = static_cast<int>(t.flat_.cols());
  return t;
}

namespace {

void CheckQuery(const ClusterTree& tree, const std::vector<Eigen::VectorXf>& query,
                const std::vector<int>& picks) {
  const int n = tree.NumLevels();
  if (static_cast<int>(query.size()) != n || static_cast<int>(picks.size()) != n) {
    throw InvalidInputError("cluster tree query: needs " + std::to_string(n) +
                            " features and picks, got " + std::to_string(query.size()) + " and " +
                            std::to_string(picks.size()));
  }
  for (int l = 0; l < n; ++l) {
    const int64_t dims = l + 1 < n ? tree.levels()[l].centers.cols() : tree.flat_features().cols();
    if (query[l].size() != dims) {
      throw InvalidInputError("cluster tree query: feature " + std::to_string(l + 1) + " has " +
                              std::to_string(query[l].size()) + " values, the tree " +
                              std::to_string(dims));
    }
    if (picks[l] < 1) throw InvalidInputError("cluster tree query: each q must be >= 1");
  }
}

}  // namespace

std::vector<int64_t> ClusterTree::Query(const std::vector<Eigen::VectorXf>& query,
                                        const std::vector<int>& picks) const {
  CheckQuery(*this, query, picks);
  const int clustered = static_cast<int>(levels_.size());
  std::vector<int64_t> selected;  // nodes of the current level
  if (clustered > 0) {
    const ClusterLevel& top = levels_[0];
    selected = Nearest(0, top.centers.rows(), picks[0],
                       [&](int64_t j) { return Distance2(top.centers, j, query[0]); });
  }
  for (int l = 1; l < clustered; ++l) {
    const ClusterLevel& above = levels_[l - 1];
    const ClusterLevel& here = levels_[l];
    std::vector<int64_t> next;
    for (int64_t s : selected) {
      const auto kept = Nearest(above.first_child[s], above.first_child[s + 1], picks[l],
                                [&](int64_t j) { return Distance2(here.centers, j, query[l]); });
      next.insert(next.end(), kept.begin(), kept.end());
    }
    selected = std::move(next);
  }
  // The flat level: the q_n nearest items under each kept node.
  std::vector<std::pair<int64_t, int64_t>> ranges;
  if (clustered == 0) {
    ranges.emplace_back(0, static_cast<int64_t>(leaf_items_.size()));
  } else {
    for (int64_t s : selected) ranges.emplace_back(levels_.back().first_child[s], levels_.back().first_child[s + 1]);
  }
  std::vector<int64_t> items;
  std::unordered_set<int64_t> seen;
  for (const auto& [begin, end] : ranges) {
    const auto kept = Nearest(begin, end, picks.back(), [&](int64_t p) {
      return Distance2(flat_, leaf_items_[p], query.back());
    });
    for (int64_t p : kept) {
      if (seen.insert(leaf_items_[p]).second) items.push_back(leaf_items_[p]);
    }
  }
  return items;
}

std::vector<int64_t> ClusterTree::QueryBruteForce(const std::vector<Eigen::VectorXf>& query,
                                                  const std::vector<int>& picks) const {
  CheckQuery(*this, query, picks);
  const int clustered = static_cast<int>(levels_.size());
  // Kept nodes of the previous level in traversal order; the root is "node -1".
  std::vector<int64_t> kept_above = {-1};
  for (int l = 0; l < clustered; ++l) {
    const ClusterLevel& here = levels_[l];
    std::vector<std::pair<float, int64_t>> all;
    for (int64_t j = 0; j < here.centers.rows(); ++j) all.emplace_back(Distance2(here.centers, j, query[l]), j);
    std::sort(all.begin(), all.end());
    std::vector<int64_t> kept;
    for (int64_t parent : kept_above) {
      int taken = 0;
      for (const auto& [d, j] : all) {
        if (taken == picks[l]) break;
        if (here.parent[j] == parent) { kept.push_back(j); ++taken; }
      }
    }
    kept_above = std::move(kept);
  }
  // Items ranked globally, then filtered by the leaf node they hang under.
  std::vector<int64_t> node_of(leaf_items_.size(), -1);
  if (clustered > 0) {
    const ClusterLevel& last = levels_.back();
    for (int64_t j = 0; j + 1 < static_cast<int64_t>(last.first_child.size()); ++j)
      for (int64_t p = last.first_child[j]; p < last.first_child[j + 1]; ++p) node_of[p] = j;
  }
  std::vector<std::pair<float, int64_t>> all;
  for (int64_t p = 0; p < static_cast<int64_t>(leaf_items_.size()); ++p)
    all.emplace_back(Distance2(flat_, leaf_items_[p], query.back()), p);
  std::sort(all.begin(), all.end());
  std::vector<int64_t> items;
  std::unordered_set<int64_t> seen;
  for (int64_t node : kept_above) {
    int taken = 0;
    for (const auto& [d, p] : all) {
      if (taken == picks.back()) break;
      if (node_of[p] == node) {
        ++taken;
        if (seen.insert(leaf_items_[p]).second) items.push_back(leaf_items_[p]);
      }
    }
  }
  return items;
}

namespace {

// The most children (items, on the flat level) any node of each level has: picks beyond it
// change nothing.
std::vector<int> MaxFanOut(const ClusterTree& tree) {
  std::vector<int> most;
  const auto& levels = tree.levels();
  if (levels.empty()) {
    most.push_back(static_cast<int>(std::min<int64_t>(tree.NumItems(), std::numeric_limits<int>::max())));
    return most;
  }
  most.push_back(static_cast<int>(levels[0].centers.rows()));
  for (const ClusterLevel& level : levels) {
    int widest = 0;
    for (size_t j = 0; j + 1 < level.first_child.size(); ++j) {
      widest = std::max(widest, level.first_child[j + 1] - level.first_child[j]);
    }
    most.push_back(std::max(1, widest));
  }
  return most;
}

MultiQueryResult RunAll(const ClusterTree& tree, const std::vector<std::vector<Eigen::VectorXf>>& queries,
                        const std::vector<int>& picks) {
  MultiQueryResult r;
  r.picks = picks;
  std::unordered_set<int64_t> seen;
  for (const auto& q : queries) {
    r.per_query.push_back(tree.Query(q, picks));
    for (int64_t item : r.per_query.back()) if (seen.insert(item).second) r.unique.push_back(item);
  }
  return r;
}

}  // namespace

MultiQueryResult QueryMany(const ClusterTree& tree, const std::vector<std::vector<Eigen::VectorXf>>& queries,
                           const std::vector<int>& picks, int64_t target_unique) {
  MultiQueryResult result = RunAll(tree, queries, picks);
  if (target_unique <= 0 || queries.empty()) return result;
  const int64_t target = std::min<int64_t>(target_unique, tree.NumItems());
  const std::vector<int> most = MaxFanOut(tree);
  std::vector<int> widened = picks;
  while (static_cast<int64_t>(result.unique.size()) < target) {
    int level = static_cast<int>(widened.size()) - 1;
    while (level >= 0 && widened[level] >= most[level]) --level;
    if (level < 0) break;  // every item is taken
    ++widened[level];
    MultiQueryResult next = RunAll(tree, queries, widened);
    if (static_cast<int64_t>(next.unique.size()) <= target) {
      result = std::move(next);
      continue;
    }
    // This step overshoots: keep what came before and add the step's new items round-robin
    // over the queries until the target is met.
    std::unordered_set<int64_t> seen(result.unique.begin(), result.unique.end());
    std::vector<size_t> cursor(queries.size(), 0);
    std::vector<std::unordered_set<int64_t>> had(queries.size());
    for (size_t i = 0; i < queries.size(); ++i) had[i].insert(result.per_query[i].begin(), result.per_query[i].end());
    bool added = true;
    while (static_cast<int64_t>(result.unique.size()) < target && added) {
      added = false;
      for (size_t i = 0; i < queries.size() && static_cast<int64_t>(result.unique.size()) < target; ++i) {
        const std::vector<int64_t>& items = next.per_query[i];
        while (cursor[i] < items.size() && had[i].count(items[cursor[i]])) ++cursor[i];
        if (cursor[i] == items.size()) continue;
        const int64_t item = items[cursor[i]++];
        had[i].insert(item);
        result.per_query[i].push_back(item);
        if (seen.insert(item).second) result.unique.push_back(item);
        added = true;
      }
    }
    result.picks = widened;
    break;
  }
  return result;
}

}  // namespace facecap::curate
