// Queries by face crops pick frames, not tree items: a tree over eight crops that differ in
// their lighting only, its items standing for frames 3, 13, ..., 73. A query by one of the
// crops picks that crop's frame; widened to three unique frames, it picks three frames of the
// tree, its own among them, and the flat list and offsets hold each query's picks.
#include "curate/frame_query.h"

#include <set>
#include <vector>

#include <gtest/gtest.h>

namespace facecap::curate {
namespace {

constexpr int kCrops = 8;

class FrameQuery : public ::testing::Test {
 protected:
  FrameQuery() {
    face::Landmarks l = (face::MeanFaceShape() * 200.0).cast<float>();
    l.rowwise() += Eigen::RowVector2f(100.f, 80.f);
    for (int k = 0; k < kCrops; ++k) {
      crops_.emplace_back(400, 400, 3, static_cast<uint8_t>(40 + 25 * k));
      landmarks_.push_back(l);
    }
    std::vector<const Image8*> all;
    for (const Image8& c : crops_) all.push_back(&c);
    const FeatureTable table = ComputeFeatures(all, landmarks_);
    tree_.kinds = {FeatureKind::kPose, FeatureKind::kLighting};
    for (int k = 0; k < kCrops; ++k) tree_.frame_of_item.push_back(10 * k + 3);
    ClusterTreeOptions options;
    options.clusters = {1};
    tree_.tree = ClusterTree::Build({table.pose, table.lighting}, options);
  }

  FramePicks Query(const std::vector<int>& crops, int64_t unique_frames) const {
    std::vector<const Image8*> q;
    std::vector<face::Landmarks> l;
    for (int k : crops) {
      q.push_back(&crops_[k]);
      l.push_back(landmarks_[k]);
    }
    return PickFrames(tree_, q, l, {1, 1}, unique_frames);
  }

  std::vector<Image8> crops_;
  std::vector<face::Landmarks> landmarks_;
  FrameTree tree_;
};

TEST_F(FrameQuery, AQueryByACropPicksThatCropsFrame) {
  const FramePicks p = Query({2, 5}, 0);
  ASSERT_EQ(p.per_query.size(), 2u);
  EXPECT_EQ(p.per_query[0], std::vector<int64_t>({23}));
  EXPECT_EQ(p.per_query[1], std::vector<int64_t>({53}));
  EXPECT_EQ(p.unique, std::vector<int64_t>({23, 53}));
  EXPECT_EQ(p.all, std::vector<int64_t>({23, 53}));
  EXPECT_EQ(p.offsets, std::vector<int64_t>({0, 1, 2}));
  EXPECT_EQ(p.features.lighting.rows(), 2);
  EXPECT_EQ(p.picks_per_level, std::vector<int32_t>({1, 1}));
}

TEST_F(FrameQuery, WidenedPicksAreFramesOfTheTree) {
  const FramePicks p = Query({4}, 3);
  ASSERT_EQ(p.unique.size(), 3u);
  std::set<int64_t> frames(tree_.frame_of_item.begin(), tree_.frame_of_item.end());
  for (int64_t f : p.unique) EXPECT_TRUE(frames.count(f)) << f;
  EXPECT_TRUE(std::set<int64_t>(p.unique.begin(), p.unique.end()).count(43));
  EXPECT_GT(p.picks_per_level[1], 1);
  ASSERT_EQ(p.offsets.size(), 2u);
  EXPECT_EQ(p.offsets[1], static_cast<int64_t>(p.all.size()));
}

}  // namespace
}  // namespace facecap::curate
