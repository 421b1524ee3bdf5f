// Where a landmark detector puts the 68 iBUG points on a rig: for each landmark, the vertex
// whose projections best match the detector's points over many renders of known geometry
// (people, poses and expressions whose posed vertices are known). A rig whose landmark
// vertices are placed this way can be fitted to the detector's landmarks on real footage
// without the fit absorbing the difference between the detector's convention and the rig's.
#ifndef FACECAP_RENDER_LANDMARK_CALIBRATION_H_
#define FACECAP_RENDER_LANDMARK_CALIBRATION_H_

#include <vector>

#include <Eigen/Core>

#include "render/camera.h"
#include "rig/rig.h"

namespace facecap::render {

// One render: the posed mesh (camera space) and the detector's 68 points on it, in the
// camera's coordinates (pixel centres at i + 0.5).
struct CalibrationView {
  rig::Vertices posed;                                   // #V x 3
  Camera camera;
  Eigen::Matrix<float, Eigen::Dynamic, 2, Eigen::RowMajor> detected;  // 68 x 2
};

struct LandmarkCalibration {
  Eigen::VectorXi landmarks;        // the chosen vertex of each landmark
  // Mean distance of each landmark's projection to the detected point over the views, over
  // the detected outer-eye-corner distance, with the rig's landmarks before and after.
  std::vector<double> error_before, error_after;
};

// How far a candidate vertex's jaw skinning weight may be from the landmark's own: the points of
// the inner lower lip stay on the lower lip even where a detector puts them close to the upper
// lip's (a mouth a little open).
inline constexpr float kJawWeightTolerance = 0.25f;

// For each landmark l, the vertex within `radius` (rig units, in the neutral) of rig.landmarks[l],
// on the skin and with a jaw skinning weight within kJawWeightTolerance of its own, whose
// projections minimise the mean squared distance to the detected points, normalised per
// view by the detected outer-eye-corner distance. InvalidInputError for views of another
// vertex count, fewer than 68 detections, or no view.
LandmarkCalibration CalibrateLandmarks(const rig::Rig& rig,
                                       const std::vector<CalibrationView>& views, float radius);

}  // namespace facecap::render

#endif  // FACECAP_RENDER_LANDMARK_CALIBRATION_H_
