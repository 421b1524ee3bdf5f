// facecap synth samples: random rig samples rendered as segmentation images (paper 000
// Sec. 7), spread across ranks, resumable.
#include "face/align.h"
#include "io/rig_io.h"
#include "render/camera.h"
#include "render/framing.h"
#include "render/gbuffer_images.h"
#include "render/landmarks.h"
#include "render/rasterizer.h"
#include "rig/evaluate.h"
#include "stages/cli.h"
#include "stages/frame_loop.h"
#include "stages/ingested_frames.h"
#include "stages/registry.h"
#include "stages/resumable.h"
#include "synth/samples.h"
#include "util/bytes.h"
#include "util/errors.h"
#include "util/log.h"

namespace facecap::stages {
namespace {

// [synth.samples]
struct SynthSamplesOptions {
  std::string rig = "rig.h5";        // rig file
  std::string out = "samples.h5";    // output file
  int batch = 32;                    // samples per rank per round (a checkpoint per round)
  int threads = 0;                   // OpenMP threads per rank (0: cores / ranks on the node)
  // Framing: "centered" (the head framed on the optical axis, fill of the image) or "crop"
  // (each sample framed as ingest crops footage: the head filmed by a camera of fov_deg at
  // fill, then the similarity-aligned crop of its 68 landmarks with crop_padding and
  // crop_raise, rendered directly through the crop's camera).
  std::string framing = "centered";
  double crop_padding = 0.4;
  double crop_raise = 0.04;
  synth::SampleOptions sample;       // the sampling and rendering options

  template <class V>
  void Visit(V&& v) {
    v("rig", rig, "rig file (HDF5)");
    v("out", out, "output file (HDF5)");
    v("batch", batch, "samples per rank per round; each round is a checkpoint");
    v("threads", threads, "OpenMP threads per rank (0: the cores divided among the node's ranks)");
    v("framing", framing,
      "centered: the head on the optical axis filling `fill` of the image; crop: framed as "
      "ingest crops footage (the aligned crop of the 68 landmarks, crop_padding, crop_raise), "
      "so that the samples look like the crops a deepfake translates; each sample's camera in "
      "/samples/camera");
    v("crop_padding", crop_padding, "framing = crop: ingest's crop_padding");
    v("crop_raise", crop_raise, "framing = crop: ingest's crop_raise");
    sample.Visit(v);
  }
  bool Check(std::string* why) const {
    if (batch <= 0) { *why = "batch must be positive"; return false; }
    if (threads < 0) { *why = "threads must be >= 0"; return false; }
    if (framing != "centered" && framing != "crop") {
      *why = "framing must be centered or crop, not " + framing;
      return false;
    }
    face::CropOptions crop{sample.size, crop_padding, crop_raise};
    if (!crop.Check(why)) return false;
    return sample.Check(why);
  }
};

constexpr int kNumLandmarks = 68;

// Per-thread rendering state.
struct SampleRenderer {
  render::GBuffer gbuffer;
  rig::Vertices posed;
  Image8 segmentation;
  std::vector<render::Landmark2D> landmarks;
};

void RunSynthSamples(const StageFlags& flags, AppState* state) {
  StageContext ctx{state->comm, {}, state->command_line};
  io::Config resolved;
  const auto o = ResolveStageOptions<SynthSamplesOptions>(flags, &ctx, &resolved);
  const dist::Comm& comm = ctx.comm;
  const synth::SampleOptions& so = o.sample;

  rig::Rig rig;
  synth::Sparsity sparsity;
  dist::CoordinateExceptions(comm, [&] {
    rig = io::ReadRigFile(o.rig);
    if (rig.landmarks.size() != kNumLandmarks) {
      throw FileIOError(o.rig + ": the rig has " + std::to_string(rig.landmarks.size()) +
                        " landmarks, synth samples needs the 68 iBUG landmarks");
    }
    sparsity = synth::ResolveSparsity(rig, so);
  });
  if (comm.IsMainRank() && !sparsity.ungrouped.empty()) {
    FC_WARN("synth samples: {} shapes belong to no sparsity group and stay at 0 (first: {})",
            sparsity.ungrouped.size(), rig.shapes[sparsity.ungrouped[0]].name);
  }
  const int S = rig.NumShapes(), H = so.size, W = so.size;
  const render::Camera camera = synth::SampleCamera(so);
  const float distance = render::FramingDistance(rig, camera, so.fill);
  const rig::RigEvaluator evaluator(rig);
  const bool crop = o.framing == "crop";
  const auto crop_template = face::CropTemplate({so.size, o.crop_padding, o.crop_raise});

  // Rank 0 opens the output and knows what is pending.
  ResumableOutput output;
  std::vector<int64_t> pending;
  int up_to_date = 0;
  dist::CoordinateExceptions(comm, [&] {
    if (!comm.IsMainRank()) return;
    output = OpenResumableOutput(o.out, resolved.ToToml(), MakeProvenance(ctx, "synth samples", resolved));
    if (output.up_to_date) {
      up_to_date = 1;
      return;
    }
    io::H5File& f = output.file;
    f.CreateFrames<uint8_t>("/samples/segmentation", {H, W, 3}, so.count, 16, 1);
    f.SetAttribute("/samples/segmentation", "layout", std::string("frame, y, x, RGB"));
    f.CreateFrames<float>("/samples/weights", {S}, so.count, 256, 4);
    f.CreateFrames<float>("/samples/pose", {3}, so.count, 1024, 4);
    f.SetAttribute("/samples/pose", "columns", std::string("pitch, yaw, roll"));
    f.SetAttribute("/samples/pose", "units", std::string("rad"));
    f.CreateFrames<float>("/samples/landmarks", {kNumLandmarks, 2}, so.count, 256, 4);
    f.SetAttribute("/samples/landmarks", "units", std::string("pixels (x right, y down)"));
    f.CreateFrames<uint8_t>("/samples/landmark_visible", {kNumLandmarks}, so.count, 1024, 4);
    f.CreateFrames<float>("/samples/camera", {4}, so.count, 1024, 4);
    f.SetAttribute("/samples/camera", "columns",
                   std::string("fx, fy, cx, cy (pixels) of the camera each sample is rendered "
                               "with (" + o.framing + " framing)"));
    if (!output.resumed) {
      std::vector<std::string> names;
      for (const auto& s : rig.shapes) names.push_back(s.name);
      f.WriteStrings("/samples/shape_names", names);
      std::vector<std::string> region_names;
      Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> colors(rig.regions.size(), 3);
      for (size_t r = 0; r < rig.regions.size(); ++r) {
        region_names.push_back(rig.regions[r].name);
        colors.row(r) = rig.regions[r].color.transpose();
      }
      f.WriteStrings("/regions/names", region_names);
      f.WriteMatrix("/regions/colors", colors);
      f.WriteVector<double>("/camera/intrinsics", {camera.fx, camera.fy, camera.cx, camera.cy});
      f.SetAttribute("/camera/intrinsics", "columns", std::string("fx, fy, cx, cy (pixels)"));
      f.SetAttribute("/camera/intrinsics", "distance_cm", static_cast<double>(distance));
    }
    io::DoneMask mask(&f, so.count);
    pending = mask.Pending();
    if (output.resumed) {
      FC_INFO("synth samples: continuing {}: {} of {} samples already done",
              io::H5File::PartialPath(o.out), mask.NumDone(), so.count);
    }
  });
  comm.Broadcast(&up_to_date, sizeof(up_to_date));
  if (up_to_date) {
    if (comm.IsMainRank()) FC_INFO("synth samples: {} is up to date", o.out);
    return;
  }

  const int threads = ThreadsPerRank(o.threads);
  std::vector<SampleRenderer> renderers(threads);
  FrameLoopOptions loop;
  loop.what = "synth samples";
  loop.batch = o.batch;
  loop.threads = threads;
  auto compute = [&](int64_t index, int thread) {
    SampleRenderer& r = renderers[thread];
    const synth::SampleParams p = synth::DrawSample(sparsity, so, S, index);
    rig::RigidPose pose = render::FramedPose(rig, distance, p.pitch, p.yaw);
    render::Camera view_camera = camera;
    if (crop) {
      // The crop of the landmarks as ingest aligns it, and the head seen through its camera.
      evaluator.EvaluatePosed(pose, p.weights, &r.posed);
      face::Landmarks lm;
      for (int l = 0; l < kNumLandmarks; ++l) {
        lm.row(l) = (camera.Project(r.posed.row(rig.landmarks[l]).transpose()).head<2>() -
                     Eigen::Vector2f(0.5f, 0.5f)).transpose();
      }
      const std::vector<int>& idx = face::CropAlignmentLandmarks();
      const face::Similarity2 m =
          face::FitSimilarity(face::SelectRows(lm, idx), face::SelectRows(crop_template, idx));
      const render::CropView view = render::CameraOfCrop(camera, m.Matrix().cast<float>(), H, H);
      view_camera = view.camera;
      pose = PoseInCrop(pose, view);
    }
    evaluator.EvaluatePosed(pose, p.weights, &r.posed);
    render::Rasterize(r.posed, rig.triangles, view_camera, &r.gbuffer);
    render::RenderSegmentation(r.gbuffer, rig.triangle_region, rig.regions,
                               Eigen::Vector3f::Zero(), &r.segmentation);
    render::ProjectLandmarks(r.posed, rig.triangles, rig.landmarks, view_camera, r.gbuffer,
                             &r.landmarks);
    ByteWriter w;
    w.PutVector(r.segmentation.data);
    w.PutArray(p.weights.data(), S);
    const float angles[3] = {pose.pitch, pose.yaw, pose.roll};
    w.PutArray(angles, 3);
    std::vector<float> xy;
    std::vector<uint8_t> visible;
    for (const auto& l : r.landmarks) {
      xy.push_back(l.position.x());
      xy.push_back(l.position.y());
      visible.push_back(l.visible ? 1 : 0);
    }
    w.PutVector(xy);
    w.PutVector(visible);
    const float intrinsics[4] = {view_camera.fx, view_camera.fy, view_camera.cx, view_camera.cy};
    w.PutArray(intrinsics, 4);
    return std::move(w.bytes());
  };
  auto commit = [&](const std::vector<int64_t>& frames,
                    const std::vector<std::vector<uint8_t>>& results) {
    io::H5File& f = output.file;
    // Pending frames come in ascending runs; write each contiguous run at once.
    size_t k = 0;
    while (k < frames.size()) {
      size_t end = k + 1;
      while (end < frames.size() && frames[end] == frames[end - 1] + 1) ++end;
      const int64_t n = static_cast<int64_t>(end - k);
      std::vector<uint8_t> seg, vis;
      std::vector<float> weights, angles, xy, cameras;
      for (size_t j = k; j < end; ++j) {
        ByteReader r(results[j]);
        auto s = r.GetVector<uint8_t>();
        seg.insert(seg.end(), s.begin(), s.end());
        auto w = r.GetVector<float>();
        weights.insert(weights.end(), w.begin(), w.end());
        auto a = r.GetVector<float>();
        angles.insert(angles.end(), a.begin(), a.end());
        auto l = r.GetVector<float>();
        xy.insert(xy.end(), l.begin(), l.end());
        auto v = r.GetVector<uint8_t>();
        vis.insert(vis.end(), v.begin(), v.end());
        auto c = r.GetVector<float>();
        cameras.insert(cameras.end(), c.begin(), c.end());
      }
      f.WriteFrames<uint8_t>("/samples/segmentation", frames[k], n, seg.data());
      f.WriteFrames<float>("/samples/weights", frames[k], n, weights.data());
      f.WriteFrames<float>("/samples/pose", frames[k], n, angles.data());
      f.WriteFrames<float>("/samples/landmarks", frames[k], n, xy.data());
      f.WriteFrames<uint8_t>("/samples/landmark_visible", frames[k], n, vis.data());
      f.WriteFrames<float>("/samples/camera", frames[k], n, cameras.data());
      k = end;
    }
    io::DoneMask mask(&f, so.count);
    mask.MarkDone(frames);
  };
  RunFrameLoop(comm, pending, so.count, loop, compute, commit);
  dist::CoordinateExceptions(comm, [&] {
    if (comm.IsMainRank()) output.file.Commit();
  });
  if (comm.IsMainRank()) FC_INFO("synth samples: {} samples -> {}", so.count, o.out);
}

}  // namespace

void RegisterSynth(CLI::App* app, AppState* state) {
  CLI::App* synth = app->add_subcommand("synth", "Synthetic data with known truth");
  synth->require_subcommand(1);
  AddStage<SynthSamplesOptions>(
      synth, state, "samples", "synth.samples", "synth samples",
      "Random rig samples (controls uniform under per-region sparsity limits, pose from a "
      "truncated Gaussian) rendered as segmentation images with landmarks; spread across ranks, "
      "identical for any rank count, resumable",
      PathKeys{{"rig"}, {{"out", OutputKind::kHdf5}}},
      RunSynthSamples);
  RegisterSynthClip(synth, state);
  RegisterSynthCrops(synth, state);
}

}  // namespace facecap::stages
