#include "face/align.h"

#include <opencv2/imgproc.hpp>

#include "util/errors.h"

namespace facecap::face {

bool CropOptions::Check(std::string* why) const {
  if (size < 16 || size > 1024) { *why = "crop size must be in [16, 1024]"; return false; }
  if (!(padding >= -0.4 && padding <= 2.0)) { *why = "crop padding must be in [-0.4, 2]"; return false; }
  if (!(raise >= -0.5 && raise <= 0.5)) { *why = "crop raise must be in [-0.5, 0.5]"; return false; }
  return true;
}

bool SubjectTrackerOptions::Check(std::string* why) const {
  if (!(min_iou > 0.f && min_iou < 1.f)) { *why = "min_iou must be in (0, 1)"; return false; }
  if (max_gap < 0) { *why = "max_gap must be >= 0"; return false; }
  return true;
}

Eigen::Matrix<double, kNumLandmarks, 2, Eigen::RowMajor> CropTemplate(const CropOptions& options) {
  const double p = options.padding;
  Eigen::Matrix<double, kNumLandmarks, 2, Eigen::RowMajor> t =
      ((MeanFaceShape().array() + p) / (1.0 + 2.0 * p) * options.size).matrix();
  t.col(1).array() -= options.raise * options.size;
  return t;
}

AlignedCrop AlignFace(const Image8& image, const Landmarks& landmarks, const CropOptions& options) {
  if (image.channels != 3 || image.empty()) throw InvalidInputError("AlignFace: needs an RGB image");
  const std::vector<int>& idx = CropAlignmentLandmarks();
  AlignedCrop crop;
  crop.transform = FitSimilarity(SelectRows(landmarks, idx), SelectRows(CropTemplate(options), idx));
  const Eigen::Matrix<double, 2, 3> m = crop.transform.Matrix();
  cv::Mat affine(2, 3, CV_64F);
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 3; ++c) affine.at<double>(r, c) = m(r, c);
  const cv::Mat src(image.height, image.width, CV_8UC3, const_cast<uint8_t*>(image.data.data()));
  crop.image = Image8(options.size, options.size, 3);
  cv::Mat dst(options.size, options.size, CV_8UC3, crop.image.data.data());
  cv::warpAffine(src, dst, affine, dst.size(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  for (int i = 0; i < kNumLandmarks; ++i) {
    const Eigen::Vector2d q = crop.transform.Apply(landmarks.row(i).transpose().cast<double>());
    crop.landmarks.row(i) = q.transpose().cast<float>();
  }
  return crop;
}

std::vector<int> FollowSubject(const std::vector<std::vector<FaceBox>>& faces,
                               const SubjectTrackerOptions& options) {
  std::vector<int> chosen(faces.size(), -1);
  bool tracking = false;
  FaceBox subject;
  int gap = 0;
  auto largest = [](const std::vector<FaceBox>& boxes) {
    int best = 0;
    for (int j = 1; j < static_cast<int>(boxes.size()); ++j) {
      if (boxes[j].Area() > boxes[best].Area()) best = j;
    }
    return best;
  };
  for (size_t i = 0; i < faces.size(); ++i) {
    const std::vector<FaceBox>& boxes = faces[i];
    if (boxes.empty()) {
      ++gap;
      continue;
    }
    int pick = -1;
    if (!tracking || gap >= options.max_gap) {
      pick = largest(boxes);
    } else {
      float best_iou = options.min_iou;
      for (int j = 0; j < static_cast<int>(boxes.size()); ++j) {
        const float iou = IntersectionOverUnion(boxes[j], subject);
        if (iou >= best_iou) {
          best_iou = iou;
          pick = j;
        }
      }
    }
    if (pick < 0) {
      ++gap;
      continue;
    }
    chosen[i] = pick;
    subject = boxes[pick];
    tracking = true;
    gap = 0;
  }
  return chosen;
}

}  // namespace facecap::face
