#include "stages/crop_framing.h"

#include <vector>

#include "face/align.h"
#include "stages/ingested_frames.h"

namespace facecap::stages {

render::Camera IngestCropCamera(const rig::Rig& rig, const rig::RigEvaluator& evaluator,
                                const render::Camera& camera,
                                const Eigen::Matrix<double, 68, 2, Eigen::RowMajor>& crop_template,
                                int size, const Eigen::VectorXf& weights, rig::RigidPose* pose,
                                rig::Vertices* posed) {
  evaluator.EvaluatePosed(*pose, weights, posed);
  face::Landmarks lm;
  for (int l = 0; l < 68; ++l) {
    lm.row(l) = (camera.Project(posed->row(rig.landmarks[l]).transpose()).head<2>() -
                 Eigen::Vector2f(0.5f, 0.5f)).transpose();
  }
  const std::vector<int>& idx = face::CropAlignmentLandmarks();
  const face::Similarity2 m =
      face::FitSimilarity(face::SelectRows(lm, idx), face::SelectRows(crop_template, idx));
  const render::CropView view = render::CameraOfCrop(camera, m.Matrix().cast<float>(), size, size);
  *pose = PoseInCrop(*pose, view);
  return view.camera;
}

}  // namespace facecap::stages
