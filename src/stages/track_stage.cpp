// facecap track: inverse-rendering tracking (paper 000 Sec. 8) of every frame of a file of
// segmentation targets, frames handed out by the dynamic work queue, resumable, identical
// for any number of ranks.
#include <algorithm>
#include <cmath>
#include <memory>
#include <mutex>

#include "stages/track_stage.h"

#include "io/config.h"
#include "io/hdf5.h"
#include "io/rig_io.h"
#include "lipsync/visemes.h"
#include "render/framing.h"
#include "io/camera_file.h"
#include "io/frames_file.h"
#include "stages/ingested_frames.h"
#include "stages/lip_track_filter.h"
#include "stages/track_file.h"
#include "stages/person_file.h"
#include "rig/arkit.h"
#include "stages/frame_loop.h"
#include "stages/resumable.h"
#include "track/tracker.h"
#include "util/bytes.h"
#include "util/errors.h"
#include "util/log.h"

namespace facecap::stages {
namespace {

// What the stage reads of a targets file.
struct TargetsInfo {
  std::string images;         // dataset of target images
  std::string landmarks;      // dataset of 2D landmarks or empty
  std::string visible;        // dataset of landmark visibility or empty
  std::vector<uint8_t> found; // per frame, 0: no face (nothing to track); empty: all frames
  int64_t frames = 0;
  int width = 0, height = 0;
  render::Camera camera;
  float distance_cm = 0.f;    // framing distance (0: unknown)
};

std::string FirstExisting(const io::H5File& f, std::initializer_list<std::string> names) {
  for (const auto& n : names) {
    if (!n.empty() && f.Exists(n)) return n;
  }
  return "";
}

TargetsInfo InspectTargets(const std::string& path, const std::string& dataset, bool need_camera) {
  io::H5File f = io::H5File::OpenRead(path);
  TargetsInfo info;
  info.images = FirstExisting(f, {dataset, "/samples/segmentation"});
  if (info.images.empty()) {
    throw FileIOError(path + ": no target dataset " + dataset + " (nor /samples/segmentation)");
  }
  const io::Shape shape = f.CheckShape(info.images, {-1, -1, -1, 3});
  info.frames = shape[0];
  info.height = static_cast<int>(shape[1]);
  info.width = static_cast<int>(shape[2]);
  info.camera.width = info.width;
  info.camera.height = info.height;
  if (!io::HasCamera(f)) {
    if (!need_camera) return info;
    throw FileIOError(path + ": no " + io::kCameraPath + " (name the ingest output with frames when "
                      "the targets translate its crops)");
  }
  const io::CameraRecord camera = io::ReadCamera(f);
  info.camera = camera.ToCamera();
  info.camera.width = info.width;
  info.camera.height = info.height;
  if (camera.distance_cm) info.distance_cm = static_cast<float>(*camera.distance_cm);
  const std::string group = info.images.substr(0, info.images.rfind('/'));
  info.landmarks = FirstExisting(f, {group + "/landmarks"});
  info.visible = info.landmarks.empty() ? "" : FirstExisting(f, {group + "/landmark_visible"});
  // Frames of real footage where ingest found no face (deepfake infer copies ingest's flags).
  if (f.Exists(group + "/found")) {
    f.CheckShape(group + "/found", {info.frames});
    info.found = f.ReadVector<uint8_t>(group + "/found", info.frames);
  }
  return info;
}

// A frame's target, its camera, and how a pose maps between the target's camera and the
// camera the track is written in (they differ for crops of footage).
struct FrameTarget {
  track::TrackTarget target;
  render::CropView view;      // roll 0 and the targets' camera when there is no crop
};

// One record of a frame's solution in a work unit's bytes (read back by CommitUnits).
void PutFrameSolution(ByteWriter* w, const rig::RigidPose& p, const Eigen::VectorXf& x, int S,
                      const track::FrameSummary& summary, int32_t termination) {
  const float angles[3] = {p.pitch, p.yaw, p.roll};
  w->PutArray(angles, 3);
  w->PutArray(p.translation.data(), 3);
  w->Put<float>(p.scale);
  w->PutArray(x.data(), S);
  w->Put<double>(summary.final_cost);
  w->Put<double>(summary.initial_cost);
  w->Put<int32_t>(summary.iterations);
  w->Put<int32_t>(summary.evaluations);
  w->Put<int32_t>(termination);
  w->Put<double>(summary.seconds);
}

// One track run: the rig, the targets and (for footage crops) the ingest output read on
// every rank, the solver set up, the output opened on rank 0, and the work units solved.
class TrackRun {
 public:
  TrackRun(const TrackOptions& o, const StageContext& ctx, const io::Config& resolved)
      : o_(o), ctx_(ctx), resolved_(resolved), comm_(ctx.comm), crops_(!o.frames.empty()) {}

  StageSummary Run() {
    ReadInputs();
    PlanFrames();
    auto tracker = std::make_unique<track::Tracker>(rig_, model_colors_, SolverOptions());
    if (!o_.solve_controls.empty()) tracker->HoldShapesFixed(held_shapes_);
    tracker_ = std::move(tracker);
    StageSummary summary{o_.out, "frames", frames_, 0};
    if (OpenOutput()) return summary;
    // Every rank reads its targets; HDF5 reads are serialized within the rank.
    dist::CoordinateExceptions(comm_, [&] { targets_file_ = io::H5File::OpenRead(o_.targets); });
    neutral_weights_ = Eigen::VectorXf::Zero(S_);
    neutral_pose_ = NeutralPoseIn(crops_ ? out_camera_ : info_.camera);
    FrameLoopOptions loop;
    loop.what = "track";
    loop.batch = o_.batch;
    loop.dynamic = true;
    loop.threads = ThreadsPerRank(o_.threads);
    const int64_t solved_units = RunFrameLoopAndCommit(
        comm_, pending_, units_, loop, [&](int64_t unit, int /*thread*/) { return SolveUnit(unit); },
        [&](const std::vector<int64_t>& done_units, const std::vector<std::vector<uint8_t>>& results) {
          CommitUnits(done_units, results);
        },
        &output_);
    if (comm_.IsMainRank()) FC_INFO("track: {} frames -> {}", frames_, o_.out);
    summary.computed = std::min(frames_, solved_units * unit_frames_);
    return summary;
  }

 private:
  // The options checked, the rig, the targets' layout and the ingest output read (every rank).
  void ReadInputs() {
    dist::CoordinateExceptions(comm_, [&] {
      std::string why;
      if (!o_.Check(&why)) throw InvalidInputError("track: " + why);
      rig_ = io::ReadRigFile(o_.rig);
      held_shapes_ = HeldShapes();
      info_ = InspectTargets(o_.targets, o_.targets_dataset, !crops_);
      if (crops_) {
        ingested_ = IngestedFrames::Read(o_.frames);
        if (ingested_.NumFrames() != info_.frames) {
          throw FileIOError(o_.frames + " has " + std::to_string(ingested_.NumFrames()) + " frames, " +
                            o_.targets + " has " + std::to_string(info_.frames) +
                            ": the targets must translate these frames");
        }
        if (rig_.landmarks.size() != 68) {
          throw FileIOError(o_.rig + ": tracking crops of footage needs the rig's 68 landmarks");
        }
        info_.found = ingested_.found();
      } else if ((o_.init == "landmarks" || o_.tracker.objective == "landmarks") &&
                 info_.landmarks.empty()) {
        throw FileIOError(o_.targets + ": init or objective with landmarks needs a landmarks "
                          "dataset beside " + info_.images + " (or name the ingest output with "
                          "frames)");
      }
    });
  }

  // The shapes outside solve_controls; InvalidInputError for a name the rig does not have.
  std::vector<int> HeldShapes() const {
    if (o_.solve_controls.empty()) return {};
    std::vector<char> solved(rig_.NumShapes(), 0);
    std::string unknown;
    for (const std::string& name : o_.solve_controls) {
      const int s = rig_.ShapeIndex(name);
      if (s < 0) unknown += (unknown.empty() ? "" : ", ") + name;
      else solved[s] = 1;
    }
    if (!unknown.empty()) {
      throw InvalidInputError("track: solve_controls names controls that " + o_.rig +
                              " does not have: " + unknown);
    }
    std::vector<int> held;
    for (int s = 0; s < rig_.NumShapes(); ++s) {
      if (!solved[s]) held.push_back(s);
    }
    return held;
  }

  // Frames, work units, the output camera, the framing distance and the region colours.
  void PlanFrames() {
    frames_ = o_.count > 0 ? std::min<int64_t>(o_.count, info_.frames) : info_.frames;
    S_ = rig_.NumShapes();
    unit_frames_ = o_.init == "previous" ? o_.segment_frames : 1;
    units_ = (frames_ + unit_frames_ - 1) / unit_frames_;
    // The camera the track is written in: the source camera of footage, else the targets'.
    int64_t first_found = 0;
    while (crops_ && first_found + 1 < frames_ && !ingested_.Found(first_found)) ++first_found;
    out_camera_ = crops_ ? ingested_.SourceCamera(first_found) : info_.camera;
    distance_ = info_.distance_cm > 0.f
                    ? info_.distance_cm
                    : render::FramingDistance(rig_, out_camera_, crops_ ? 0.56f : 0.7f);
    seg_colors_ = track::RigRegionColors(rig_);
    model_colors_ = o_.texture == "skin" ? track::SkinRegionColors(rig_) : seg_colors_;
  }

  // The solver's options. The landmark term in units of each point's noise that person fit
  // measured for the rig; the term fits the landmarks a detector found in footage (frames);
  // targets of their own (rig samples) are tracked without it.
  track::TrackerOptions SolverOptions() {
    track::TrackerOptions tracker_options = o_.tracker;
    if (o_.frontal) tracker_options.solve_rotation = false;
    if (!crops_) tracker_options.landmark_weight = 0.f;
    if (tracker_options.landmark_weight <= 0.f) return tracker_options;
    LandmarkNoise noise;
    dist::CoordinateExceptions(comm_, [&] { noise = ReadLandmarkNoise(o_.rig); });
    if (noise.px.empty()) return tracker_options;
    tracker_options.landmark_point_weights.resize(68);
    double inner = 0.;
    for (int l = 0; l < 68; ++l) {
      const double sigma = noise.AtSize(l, info_.width);
      tracker_options.landmark_point_weights[l] = static_cast<float>(1. / (sigma * sigma));
      if (l >= 17) inner += sigma * sigma / 51.;
    }
    if (comm_.IsMainRank()) {
      FC_INFO("track: the landmark term weighs each point by its inverse squared noise (person "
              "fit's; {:.3f} px RMS off the jaw at {} pixels)", std::sqrt(inner), info_.width);
    }
    return tracker_options;
  }

  // Rank 0 opens (or continues) the output; true on every rank when it is up to date.
  bool OpenOutput() {
    FrameOutput opened = OpenFrameOutput(
        ctx_, resolved_, "track", o_.out, units_,
        [&](io::H5File* f, bool resumed) {
          CreateTrackDatasets(f, frames_, S_);
          if (!resumed) WriteRecords(f);
        },
        "work units");
    output_ = std::move(opened.output);
    pending_ = std::move(opened.pending);
    return opened.up_to_date;
  }

  // The shape names, the camera and where the targets come from (a new output).
  void WriteRecords(io::H5File* f) {
    std::vector<std::string> names;
    for (const auto& s : rig_.shapes) names.push_back(s.name);
    WriteTrackRecords(f, names, out_camera_, distance_);
    f->SetAttribute("/track", "targets", o_.targets);
    f->SetAttribute("/track", "targets_dataset", info_.images);
    f->SetAttribute("/track", "rig", o_.rig);
    if (crops_) {
      WriteSourceFrames(f, ingested_, o_.frames, frames_);
    } else if (io::H5File::IsHdf5(o_.targets)) {
      io::H5File t = io::H5File::OpenRead(o_.targets);
      const std::optional<double> fps = io::HasCamera(t) ? io::ReadCamera(t).fps : std::nullopt;
      if (fps) f->SetAttribute("/track", "fps", *fps);
    }
  }

  // A frame's target image (recoloured for the skin texture), landmarks and camera.
  FrameTarget ReadTarget(int64_t frame) {
    const int W = info_.width, H = info_.height;
    FrameTarget ft;
    track::TrackTarget& t = ft.target;
    t.camera = info_.camera;
    ft.view.camera = info_.camera;
    Image8 image(W, H, 3);
    Eigen::Matrix<float, Eigen::Dynamic, 2, Eigen::RowMajor> lm;
    std::vector<uint8_t> visible;
    {
      std::lock_guard<std::mutex> lock(read_mutex_);
      targets_file_.ReadFrames<uint8_t>(info_.images, frame, 1, image.data.data());
      if (!crops_ && !info_.landmarks.empty()) {
        const io::Shape ls = targets_file_.DatasetShape(info_.landmarks);
        lm.resize(ls[1], 2);
        targets_file_.ReadFrames<float>(info_.landmarks, frame, 1, lm.data());
        if (!info_.visible.empty()) {
          visible.resize(ls[1]);
          targets_file_.ReadFrames<uint8_t>(info_.visible, frame, 1, visible.data());
        }
      }
    }
    if (crops_) {
      if (W != H) throw FileIOError(o_.targets + ": translations of crops must be square");
      ft.view = ingested_.CropCamera(frame, W);
      t.camera = ft.view.camera;
      lm = ingested_.CropLandmarks(frame, W);
    }
    t.image = track::ToFloatImage(image);
    if (o_.texture == "skin") {
      t.image = track::RecolorSegmentation(t.image, seg_colors_, model_colors_,
                                           o_.tracker.soft.background_color);
    }
    t.landmarks = lm;
    t.landmark_visible = visible;
    return ft;
  }

  // The neutral frontal head, framed in the middle of the camera's image.
  rig::RigidPose NeutralPoseIn(const render::Camera& camera) const {
    const float d = crops_ ? render::FramingDistance(rig_, camera, 0.56f) : distance_;
    rig::RigidPose p = render::FramedPose(rig_, d, 0.f, 0.f);
    p.translation += camera.RayDirection(0.5f * camera.width, 0.5f * camera.height) * d -
                     Eigen::Vector3f(0.f, 0.f, -d);
    return p;
  }

  // Solves the frames of one work unit (a segment when init = previous), in order.
  std::vector<uint8_t> SolveUnit(int64_t unit) {
    ByteWriter w;
    const int64_t first = unit * unit_frames_;
    const int64_t last = std::min(frames_, first + unit_frames_);
    // The solution so far, in the output camera; none before the segment's first face.
    rig::RigidPose pose = neutral_pose_;
    Eigen::VectorXf weights = neutral_weights_;
    bool have_previous = false;
    for (int64_t frame = first; frame < last; ++frame) {
      if (!info_.found.empty() && !info_.found[frame]) {
        // No face here: nothing to solve. The solution so far is held (the neutral when the
        // frames are independent), so exports stay continuous and the next frame of a
        // sequential segment starts from the last face seen, not from a fit to an empty image.
        if (o_.init != "previous") {
          pose = neutral_pose_;
          weights = neutral_weights_;
        }
        track::FrameSummary none;
        none.final_cost = none.initial_cost = std::nan("");
        PutFrameSolution(&w, pose, weights, S_, none, kNoTarget);
        continue;
      }
      const FrameTarget ft = ReadTarget(frame);
      rig::RigidPose start = PoseInCrop(pose, ft.view);
      const bool from_landmarks = o_.init == "landmarks" || (crops_ && !have_previous);
      if (o_.init != "previous" || !have_previous) {
        start = crops_ ? NeutralPoseIn(ft.target.camera) : neutral_pose_;
        weights = neutral_weights_;
      }
      if (o_.frontal) {
        // Frontal to the source camera, seen in the crop's camera.
        rig::RigidPose in_source = PoseInSource(start, ft.view);
        in_source.pitch = in_source.yaw = in_source.roll = 0.f;
        start = PoseInCrop(in_source, ft.view);
      }
      if (from_landmarks) start = tracker_->PoseFromLandmarks(ft.target, start, neutral_weights_);
      const track::TrackResult r = tracker_->Solve(ft.target, start, weights);
      pose = PoseInSource(r.pose, ft.view);
      weights = r.weights;
      have_previous = true;
      PutFrameSolution(&w, pose, weights, S_, r.summary, static_cast<int32_t>(r.summary.termination));
    }
    return std::move(w.bytes());
  }

  // Rank 0: the solved units' frames into the output, then the units marked done.
  void CommitUnits(const std::vector<int64_t>& done_units,
                   const std::vector<std::vector<uint8_t>>& results) {
    io::H5File& f = output_.file;
    for (size_t k = 0; k < done_units.size(); ++k) {
      ByteReader r(results[k]);
      const int64_t first = done_units[k] * unit_frames_;
      const int64_t last = std::min(frames_, first + unit_frames_);
      for (int64_t frame = first; frame < last; ++frame) {
        const auto angles = r.GetVector<float>();
        const auto translation = r.GetVector<float>();
        const float scale = r.Get<float>();
        const auto weights = r.GetVector<float>();
        const double cost = r.Get<double>(), initial = r.Get<double>();
        const int32_t iterations = r.Get<int32_t>(), evaluations = r.Get<int32_t>();
        const int32_t termination = r.Get<int32_t>();
        const double seconds = r.Get<double>();
        f.WriteFrames<float>("/track/pose", frame, 1, angles.data());
        f.WriteFrames<float>("/track/translation", frame, 1, translation.data());
        f.WriteFrames<float>("/track/scale", frame, 1, &scale);
        f.WriteFrames<float>("/track/weights", frame, 1, weights.data());
        f.WriteFrames<double>("/track/cost", frame, 1, &cost);
        f.WriteFrames<double>("/track/initial_cost", frame, 1, &initial);
        f.WriteFrames<int32_t>("/track/iterations", frame, 1, &iterations);
        f.WriteFrames<int32_t>("/track/evaluations", frame, 1, &evaluations);
        f.WriteFrames<int32_t>("/track/termination", frame, 1, &termination);
        f.WriteFrames<double>("/track/seconds", frame, 1, &seconds);
      }
    }
    io::DoneMask mask(&f, units_);
    mask.MarkDone(done_units);
  }

  const TrackOptions& o_;
  const StageContext& ctx_;
  const io::Config& resolved_;
  const dist::Comm& comm_;
  const bool crops_;  // the targets translate the crops of an ingest output (frames)
  rig::Rig rig_;
  TargetsInfo info_;
  IngestedFrames ingested_;
  int64_t frames_ = 0, unit_frames_ = 1, units_ = 0;
  int S_ = 0;
  render::Camera out_camera_;  // the camera the track is written in
  float distance_ = 0.f;
  std::vector<Eigen::Vector3f> seg_colors_, model_colors_;
  std::unique_ptr<const track::Tracker> tracker_;
  ResumableOutput output_;  // rank 0
  std::vector<int64_t> pending_;
  io::H5File targets_file_;
  std::mutex read_mutex_;
  Eigen::VectorXf neutral_weights_;
  rig::RigidPose neutral_pose_;
  std::vector<int> held_shapes_;  // shapes outside solve_controls
};

}  // namespace

StageSummary RunTrack(const TrackOptions& options, const StageContext& ctx,
                      const io::Config& resolved) {
  return TrackRun(options, ctx, resolved).Run();
}

StageSummary RunLipsyncTrack(const LipsyncTrackOptions& o, const StageContext& ctx,
                             const io::Config& resolved) {
  dist::CoordinateExceptions(ctx.comm, [&] {
    std::string why;
    if (!o.filter.Check(&why)) throw InvalidInputError("lipsync track: " + why);
    if (ctx.comm.IsMainRank()) CheckLipTrackSound(o.filter);
  });
  StageSummary summary = TrackRun(o, ctx, resolved).Run();
  dist::CoordinateExceptions(ctx.comm, [&] {
    if (ctx.comm.IsMainRank()) FilterLipTrack(o.out, o.frames, o.rig, o.filter);
  });
  return summary;
}

}  // namespace facecap::stages
