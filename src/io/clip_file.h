// The truth of a synthetic clip (synth clip), under /frames (frames_file.h names the
// datasets): the rig's shape names [S], each frame's weights [N, S], head pose [N, 3] (pitch,
// yaw, roll rad) and, where written, translation [N, 3] cm, and the clip's frame rate (the
// camera's `fps`, camera_file.h). The clip's images, landmarks and rig are read elsewhere.
#ifndef FACECAP_IO_CLIP_FILE_H_
#define FACECAP_IO_CLIP_FILE_H_

#include <string>
#include <vector>

#include <Eigen/Core>

#include "io/hdf5.h"

namespace facecap::io {

struct ClipTruth {
  using RowMatrixF = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

  std::vector<std::string> names;  // [S] the weights' columns
  RowMatrixF weights;              // [N, S] in [0, 1]
  RowMatrixF pose;                 // [N, 3] pitch, yaw, roll rad
  RowMatrixF translation;          // [N, 3] cm; 0 rows when the file has none
  double fps = 0.;                 // the camera's `fps`; 0 when the file has none

  int64_t frames() const { return weights.rows(); }
};

// The truth of a clip. FileIOError naming the file and the dataset when shape names, weights
// or pose are missing (not a clip from synth clip), or when weights are not [N, S] with S the
// shape names, pose not [N, 3] or translation (when present) not [N, 3].
ClipTruth ReadClipTruth(const H5File& f);

}  // namespace facecap::io

#endif  // FACECAP_IO_CLIP_FILE_H_
