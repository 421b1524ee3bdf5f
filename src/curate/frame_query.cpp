#include "curate/frame_query.h"

#include <chrono>

namespace facecap::curate {

FramePicks PickFrames(const FrameTree& tree, const std::vector<const Image8*>& crops,
                      const std::vector<face::Landmarks>& landmarks, const std::vector<int>& picks,
                      int64_t unique_frames) {
  FramePicks p;
  p.features = ComputeFeatures(crops, landmarks, 0);
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::vector<Eigen::VectorXf>> query_features(crops.size());
  for (size_t i = 0; i < crops.size(); ++i) {
    for (FeatureKind k : tree.kinds) {
      query_features[i].push_back(p.features.Of(k).row(static_cast<int>(i)).transpose());
    }
  }
  const MultiQueryResult result = QueryMany(tree.tree, query_features, picks, unique_frames);
  p.query_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  p.per_query.resize(crops.size());
  for (size_t i = 0; i < crops.size(); ++i) {
    for (int64_t item : result.per_query[i]) p.per_query[i].push_back(tree.frame_of_item[item]);
  }
  for (int64_t item : result.unique) p.unique.push_back(tree.frame_of_item[item]);
  for (const auto& q : p.per_query) {
    p.all.insert(p.all.end(), q.begin(), q.end());
    p.offsets.push_back(static_cast<int64_t>(p.all.size()));
  }
  p.picks_per_level.assign(result.picks.begin(), result.picks.end());
  return p;
}

}  // namespace facecap::curate
