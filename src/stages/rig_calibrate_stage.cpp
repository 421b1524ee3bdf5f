// facecap rig calibrate: places a rig's 68 landmark vertices where dlib's landmark detector
// finds the iBUG points on renders of the rig (render/landmark_calibration.h). People of the
// rig's identity modes (seeds that no other stage uses) are rendered as wild clips over a
// range of poses and expressions, dlib detects their landmarks as ingest does, and each
// landmark moves to the vertex whose projections match the detections best. Views are
// rendered and detected across ranks; the choice is made on rank 0 from the views in order,
// so the result is the same for any number of ranks.
#include <algorithm>
#include <cmath>
#include <memory>

#include "stages/rig_calibrate_stage.h"

#include "face/face_analyzer.h"
#include "io/hdf5.h"
#include "io/rig_io.h"
#include "render/landmark_calibration.h"
#include "rig/demo_head.h"
#include "rig/evaluate.h"
#include "stages/frame_loop.h"
#include "synth/clip.h"
#include "util/bytes.h"
#include "util/errors.h"
#include "util/log.h"

namespace facecap::stages {
namespace {

// The wild clip of person p: poses and expressions as a clip, yaw within the range.
synth::ClipOptions CalibrationClip(const RigCalibrateOptions& o, int person) {
  synth::ClipOptions c;
  c.frames = o.frames;
  c.size = o.size;
  c.fov_deg = o.fov_deg;
  c.fill = o.fill;
  c.identity_seed = o.first_identity_seed + person;
  c.motion_seed = c.lighting_seed = c.background_seed = c.camera_seed = 9001 + person;
  c.yaw_sigma_deg = o.max_yaw_deg / 2.f;
  c.yaw_limit_deg = o.max_yaw_deg;
  c.extreme_yaw_probability = 0.f;
  c.pose_seconds = 0.4f;
  c.expression_seconds = 0.3f;
  return c;
}

}  // namespace

StageSummary RunRigCalibrate(const RigCalibrateOptions& o, const StageContext& ctx,
                             const io::Config& resolved) {
  const dist::Comm& comm = ctx.comm;
  rig::Rig rig;
  std::vector<rig::Rig> people;
  std::vector<std::vector<synth::ClipFrameParams>> trajectories;
  std::vector<std::unique_ptr<synth::ClipRenderer>> renderers;
  const int threads = ThreadsPerRank(o.threads);
  std::vector<std::unique_ptr<face::FaceAnalyzer>> analyzers(threads);
  dist::CoordinateExceptions(comm, [&] {
    std::string why;
    if (!o.Check(&why)) throw InvalidInputError("rig calibrate: " + why);
    rig = io::ReadRigFile(o.rig);
    if (rig.landmarks.size() != 68) throw FileIOError(o.rig + ": the rig has no 68 landmarks");
    people.reserve(o.people);
    for (int p = 0; p < o.people; ++p) {
      const synth::ClipOptions c = CalibrationClip(o, p);
      if (!c.Check(&why)) throw InvalidInputError("rig calibrate: " + why);
      people.push_back(rig::WithIdentity(rig, c.identity_seed));
    }
    for (int p = 0; p < o.people; ++p) {
      const synth::ClipOptions c = CalibrationClip(o, p);
      trajectories.push_back(synth::MakeClipTrajectory(people[p], c));
      renderers.push_back(std::make_unique<synth::ClipRenderer>(people[p], c, nullptr));
    }
    face::FaceAnalyzerOptions a;
    a.landmark_model = o.landmark_model;
    analyzers[0] = std::make_unique<face::FaceAnalyzer>(a);
    for (int t = 1; t < threads; ++t) analyzers[t] = analyzers[0]->Clone();
  });
  const int64_t views = static_cast<int64_t>(o.people) * o.frames;
  std::vector<std::vector<uint8_t>> results(views);
  FrameLoopOptions loop;
  loop.what = "rig calibrate: render and detect";
  loop.threads = threads;
  auto compute = [&](int64_t k, int thread) {
    const int p = static_cast<int>(k / o.frames), f = static_cast<int>(k % o.frames);
    synth::ClipRenderer::Workspace ws;
    synth::ClipRenderer::Frame frame;
    renderers[p]->Render(f, trajectories[p][f], &ws, &frame);
    const std::vector<face::FaceBox> faces = analyzers[thread]->Detect(frame.image);
    ByteWriter w;
    const rig::RigidPose& q = frame.pose;
    const float pose[7] = {q.pitch, q.yaw, q.roll, q.translation.x(), q.translation.y(),
                           q.translation.z(), q.scale};
    w.PutArray(pose, 7);
    w.Put<int32_t>(faces.empty() ? 0 : 1);
    if (!faces.empty()) {
      const face::Landmarks lm = analyzers[thread]->FitLandmarks(frame.image, faces[0]);
      w.PutArray(lm.data(), 136);
    }
    return std::move(w.bytes());
  };
  auto commit = [&](const std::vector<int64_t>& done, const std::vector<std::vector<uint8_t>>& r) {
    for (size_t i = 0; i < done.size(); ++i) results[done[i]] = r[i];
  };
  std::vector<int64_t> all(views);
  for (int64_t k = 0; k < views; ++k) all[k] = k;
  RunFrameLoop(comm, all, views, loop, compute, commit);

  dist::CoordinateExceptions(comm, [&] {
    if (!comm.IsMainRank()) return;
    std::vector<render::CalibrationView> calibration;
    for (int64_t k = 0; k < views; ++k) {
      ByteReader r(results[k]);
      const std::vector<float> q = r.GetVector<float>();
      if (r.Get<int32_t>() == 0) continue;
      const std::vector<float> lm = r.GetVector<float>();
      const int p = static_cast<int>(k / o.frames), f = static_cast<int>(k % o.frames);
      rig::RigidPose pose;
      pose.pitch = q[0];
      pose.yaw = q[1];
      pose.roll = q[2];
      pose.translation = Eigen::Vector3f(q[3], q[4], q[5]);
      pose.scale = q[6];
      render::CalibrationView v;
      const rig::RigEvaluator evaluator(people[p]);
      evaluator.EvaluatePosed(pose, trajectories[p][f].weights, &v.posed);
      v.camera = renderers[p]->camera();
      v.detected = Eigen::Map<const Eigen::Matrix<float, 68, 2, Eigen::RowMajor>>(lm.data());
      v.detected.array() += 0.5f;  // dlib's pixel centres at integers, the camera's at + 0.5
      calibration.push_back(std::move(v));
    }
    if (calibration.size() < 4) {
      throw FileIOError("rig calibrate: dlib found a face in " + std::to_string(calibration.size()) +
                        " of " + std::to_string(views) + " renders; too few to calibrate");
    }
    const render::LandmarkCalibration c = render::CalibrateLandmarks(rig, calibration, o.radius_cm);
    double before = 0., after = 0.;
    int moved = 0;
    for (int l = 0; l < 68; ++l) {
      before += c.error_before[l] / 68.;
      after += c.error_after[l] / 68.;
      moved += c.landmarks[l] != rig.landmarks[l];
    }
    FC_INFO("rig calibrate: dlib found {} of {} faces; {} of 68 landmarks moved; mean distance "
            "to dlib's points {:.4f} -> {:.4f} of the eye-corner distance",
            calibration.size(), views, moved, before, after);
    rig::Rig out = rig;
    out.landmarks = c.landmarks;
    io::H5File file = io::H5File::CreateAtomic(o.out);
    file.WriteProvenance(MakeProvenance(ctx, "rig calibrate", resolved));
    io::WriteRig(out, &file);
    file.WriteVector("/calibration/error_before", c.error_before);
    file.WriteVector("/calibration/error_after", c.error_after);
    file.SetAttribute("/calibration/error_before", "meaning",
                      std::string("per landmark: mean distance of the rig's landmark to dlib's over "
                                  "the calibration renders, over the outer-eye-corner distance, "
                                  "before and after"));
    std::vector<int32_t> original(rig.landmarks.data(), rig.landmarks.data() + 68);
    file.WriteVector("/calibration/original_landmarks", original);
    file.SetAttribute("/calibration", "views", static_cast<int64_t>(calibration.size()));
    file.Commit();
    FC_INFO("rig calibrate: -> {}", o.out);
  });
  // Every view is rendered and detected by every run (the stage does not resume).
  return StageSummary{o.out, "views", views, views};
}

}  // namespace facecap::stages
