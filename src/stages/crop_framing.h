// Renders framed as ingest frames footage: the crop ingest would cut around a rendered head.
// Apart from ingested_frames.h, whose readers build without the face module.
#ifndef FACECAP_STAGES_CROP_FRAMING_H_
#define FACECAP_STAGES_CROP_FRAMING_H_

#include <Eigen/Core>

#include "render/camera.h"
#include "rig/evaluate.h"
#include "rig/pose.h"
#include "rig/rig.h"

namespace facecap::stages {

// A rendered head framed the way ingest crops footage: the head posed at *pose with `weights`
// in `camera`, its 68 landmark vertices projected, the similarity that takes their
// crop-alignment landmarks onto `crop_template` (face::CropTemplate of the crop options), and
// that crop as a camera of size x size pixels. Returns the crop's camera; *pose becomes the
// same head seen by it; *posed receives the head's vertices posed at the original pose.
render::Camera IngestCropCamera(const rig::Rig& rig, const rig::RigEvaluator& evaluator,
                                const render::Camera& camera,
                                const Eigen::Matrix<double, 68, 2, Eigen::RowMajor>& crop_template,
                                int size, const Eigen::VectorXf& weights, rig::RigidPose* pose,
                                rig::Vertices* posed);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_CROP_FRAMING_H_
