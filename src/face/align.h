// Similarity-aligned face crops, and following one subject through a sequence of frames.
#ifndef FACECAP_FACE_ALIGN_H_
#define FACECAP_FACE_ALIGN_H_

#include <string>
#include <vector>

#include "face/face_analyzer.h"
#include "face/landmarks68.h"
#include "util/image.h"

namespace facecap::face {

struct CropOptions {
  // Crop width and height in pixels.
  int size = 128;
  // Margin around the mean face in units of its size (dlib's face chips use 0.2-0.25): the
  // mean face's unit frame maps to [padding, 1 + padding] / (1 + 2 padding) of the crop.
  // Negative: the crop cuts into the face (with `raise`, e.g. a crop of the mouth and chin).
  double padding = 0.25;
  // Moves the face up in the crop by this fraction of the crop height (negative: down), e.g.
  // to frame crops the way the rig's synthetic renders are framed.
  double raise = 0.0;

  bool Check(std::string* why) const;
};

struct AlignedCrop {
  Image8 image;           // size x size x 3
  Landmarks landmarks;    // the 68 landmarks in crop pixels
  Similarity2 transform;  // image pixels -> crop pixels
};

// Where the mean face's landmarks land in a crop (68 by 2, crop pixels).
Eigen::Matrix<double, kNumLandmarks, 2, Eigen::RowMajor> CropTemplate(const CropOptions& options);

// Fits the similarity that takes the crop-alignment landmarks (CropAlignmentLandmarks) of
// `landmarks` onto CropTemplate, and resamples `image` (RGB) through it (bilinear; outside
// the image the border is replicated).
AlignedCrop AlignFace(const Image8& image, const Landmarks& landmarks, const CropOptions& options);

struct SubjectTrackerOptions {
  // A face continues the subject when its box overlaps the subject's last box by at least
  // this intersection over union.
  float min_iou = 0.25f;
  // After this many frames without the subject, the largest face becomes the subject.
  int max_gap = 10;

  bool Check(std::string* why) const;
};

// Follows one subject through frames given each frame's detected faces (any order): the
// subject starts as the largest face of the first frame with a face, and continues with the
// face that overlaps its last box most; after max_gap frames without it, the largest face
// takes over. A sequential pass over boxes only, so ranks can detect in parallel and agree on
// the subject. Returns, per frame, the index of the subject's face in that frame's list, or -1.
std::vector<int> FollowSubject(const std::vector<std::vector<FaceBox>>& faces,
                               const SubjectTrackerOptions& options = SubjectTrackerOptions());

}  // namespace facecap::face

#endif  // FACECAP_FACE_ALIGN_H_
