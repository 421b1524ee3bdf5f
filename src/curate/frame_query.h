// Queries of a curation tree by faces (paper 000 Sec. 3): each query crop's features at the
// tree's levels, the tree's picks (QueryMany, with its widening to a number of unique items),
// and the picked items as the frames they are.
#ifndef FACECAP_CURATE_FRAME_QUERY_H_
#define FACECAP_CURATE_FRAME_QUERY_H_

#include <cstdint>
#include <vector>

#include "curate/cluster_tree.h"
#include "curate/features.h"
#include "face/landmarks68.h"
#include "util/image.h"

namespace facecap::curate {

// A tree over frames: the feature of each level, top first, and the frame (a row of the
// ingest output's /frames) that each item of the tree is.
struct FrameTree {
  std::vector<FeatureKind> kinds;
  std::vector<int64_t> frame_of_item;
  ClusterTree tree;
};

// The picks of a set of queries, as frames.
struct FramePicks {
  FeatureTable features;                         // of the queries
  std::vector<int32_t> picks_per_level;          // q_1 ... q_n used (after any widening)
  std::vector<std::vector<int64_t>> per_query;   // frames each query picked, traversal order
  std::vector<int64_t> unique;                   // every picked frame once, in query order
  std::vector<int64_t> offsets{0}, all;          // query i picked all[offsets[i] : offsets[i+1]]
  double query_s = 0.;                           // time spent in the tree
};

// Queries by the face crops `crops` with their 68 landmarks in crop pixels (the crops framed
// as the tree's frames were), `picks` = q_1 ... q_n, widened until `unique_frames` unique
// frames come back (0: as given; QueryMany).
FramePicks PickFrames(const FrameTree& tree, const std::vector<const Image8*>& crops,
                      const std::vector<face::Landmarks>& landmarks, const std::vector<int>& picks,
                      int64_t unique_frames);

}  // namespace facecap::curate

#endif  // FACECAP_CURATE_FRAME_QUERY_H_
