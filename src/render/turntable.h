// Turntable views (paper 000 Sec. 5.2): head poses that evenly cover a range of pitch and
// yaw. Unlike a classic turntable (fixed pitch, varying yaw) the pitch varies too, as the
// paper recommends.
#ifndef FACECAP_RENDER_TURNTABLE_H_
#define FACECAP_RENDER_TURNTABLE_H_

#include <utility>
#include <vector>

#include "rig/pose.h"

namespace facecap::render {

// Evenly spread (pitch, yaw) pairs: the views are laid out on rows of constant pitch, the
// number of rows chosen so that the spacing along pitch and along yaw is about equal
// (rows = round(sqrt(num_views * pitch_range / yaw_range)), at least 1). Row pitches are
// evenly spaced with both ends included; each row's views are evenly spaced in yaw with both
// ends included; rows differ in size by at most one view. The order is a serpentine, so that
// consecutive views are neighbours, like a rotating stage: row 0 sweeps yaw upwards, row 1
// downwards, and so on. A range of zero width (min == max) gives that single value; a row of
// one view sits at the yaw range's centre, as does a single row in pitch.
//
// Inputs:
//   num_views            number of views N >= 1
//   pitch_min, pitch_max pitch range (any angle unit; the output uses the same)
//   yaw_min, yaw_max     yaw range
// Returns N (pitch, yaw) pairs.
// Throws InvalidInputError when num_views < 1 or a range is reversed or not finite.
std::vector<std::pair<float, float>> TurntableAngles(int num_views, float pitch_min,
                                                     float pitch_max, float yaw_min,
                                                     float yaw_max);

// TurntableAngles as rigid poses: copies of base_pose with pitch and yaw (radians) replaced.
//
// Inputs:
//   num_views, pitch_min, pitch_max, yaw_min, yaw_max  as for TurntableAngles, in radians
//   base_pose   roll, translation and scale shared by all views
// Returns N poses.
std::vector<rig::RigidPose> TurntablePoses(int num_views, float pitch_min, float pitch_max,
                                           float yaw_min, float yaw_max,
                                           const rig::RigidPose& base_pose);

}  // namespace facecap::render

#endif  // FACECAP_RENDER_TURNTABLE_H_
