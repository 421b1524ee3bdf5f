// facecap synth samples: random rig samples rendered as segmentation images (paper 000
// Sec. 7), spread across ranks, resumable.
#include <memory>

#include "face/align.h"
#include "io/rig_io.h"
#include "render/camera.h"
#include "render/framing.h"
#include "render/gbuffer_images.h"
#include "render/landmarks.h"
#include "render/rasterizer.h"
#include "rig/evaluate.h"
#include "stages/cli.h"
#include "stages/crop_framing.h"
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

// The per-sample datasets in a new or continued output.
void CreateSampleDatasets(io::H5File* f, int H, int W, int S, int64_t count, const std::string& framing) {
  f->CreateFrames<uint8_t>("/samples/segmentation", {H, W, 3}, count, 16, 1);
  f->SetAttribute("/samples/segmentation", "layout", std::string("frame, y, x, RGB"));
  f->CreateFrames<float>("/samples/weights", {S}, count, 256, 4);
  f->CreateFrames<float>("/samples/pose", {3}, count, 1024, 4);
  f->SetAttribute("/samples/pose", "columns", std::string("pitch, yaw, roll"));
  f->SetAttribute("/samples/pose", "units", std::string("rad"));
  f->CreateFrames<float>("/samples/landmarks", {kNumLandmarks, 2}, count, 256, 4);
  f->SetAttribute("/samples/landmarks", "units", std::string("pixels (x right, y down)"));
  f->CreateFrames<uint8_t>("/samples/landmark_visible", {kNumLandmarks}, count, 1024, 4);
  f->CreateFrames<float>("/samples/camera", {4}, count, 1024, 4);
  f->SetAttribute("/samples/camera", "columns",
                  std::string("fx, fy, cx, cy (pixels) of the camera each sample is rendered "
                              "with (" + framing + " framing)"));
}

// The rig's shape and region names, region colours and the camera (a new output).
void WriteSampleRecords(io::H5File* f, const rig::Rig& rig, const render::Camera& camera,
                        float distance) {
  std::vector<std::string> names;
  for (const auto& s : rig.shapes) names.push_back(s.name);
  f->WriteStrings("/samples/shape_names", names);
  std::vector<std::string> region_names;
  Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> colors(rig.regions.size(), 3);
  for (size_t r = 0; r < rig.regions.size(); ++r) {
    region_names.push_back(rig.regions[r].name);
    colors.row(r) = rig.regions[r].color.transpose();
  }
  f->WriteStrings("/regions/names", region_names);
  f->WriteMatrix("/regions/colors", colors);
  f->WriteVector<double>("/camera/intrinsics", {camera.fx, camera.fy, camera.cx, camera.cy});
  f->SetAttribute("/camera/intrinsics", "columns", std::string("fx, fy, cx, cy (pixels)"));
  f->SetAttribute("/camera/intrinsics", "distance_cm", static_cast<double>(distance));
}

// One synth samples run: the rig read on every rank (each sample is a pure function of its
// index), the output on rank 0, and the samples rendered.
class SynthSamplesRun {
 public:
  SynthSamplesRun(const SynthSamplesOptions& o, const StageContext& ctx, const io::Config& resolved)
      : o_(o), so_(o.sample), ctx_(ctx), resolved_(resolved), comm_(ctx.comm),
        crop_(o.framing == "crop") {}

  void Run() {
    ReadRig();
    S_ = rig_.NumShapes();
    camera_ = synth::SampleCamera(so_);
    distance_ = render::FramingDistance(rig_, camera_, so_.fill);
    evaluator_ = std::make_unique<const rig::RigEvaluator>(rig_);
    crop_template_ = face::CropTemplate({so_.size, o_.crop_padding, o_.crop_raise});
    if (OpenOutput()) return;
    const int threads = ThreadsPerRank(o_.threads);
    renderers_ = std::vector<SampleRenderer>(threads);
    FrameLoopOptions loop;
    loop.what = "synth samples";
    loop.batch = o_.batch;
    loop.threads = threads;
    RunFrameLoopAndCommit(
        comm_, pending_, so_.count, loop,
        [&](int64_t index, int thread) { return RenderSample(index, thread); },
        [&](const std::vector<int64_t>& frames, const std::vector<std::vector<uint8_t>>& results) {
          CommitSamples(frames, results);
        },
        &output_);
    if (comm_.IsMainRank()) FC_INFO("synth samples: {} samples -> {}", so_.count, o_.out);
  }

 private:
  // The rig and the sparsity groups of its shapes (every rank).
  void ReadRig() {
    dist::CoordinateExceptions(comm_, [&] {
      rig_ = io::ReadRigFile(o_.rig);
      if (rig_.landmarks.size() != kNumLandmarks) {
        throw FileIOError(o_.rig + ": the rig has " + std::to_string(rig_.landmarks.size()) +
                          " landmarks, synth samples needs the 68 iBUG landmarks");
      }
      sparsity_ = synth::ResolveSparsity(rig_, so_);
    });
    if (comm_.IsMainRank() && !sparsity_.ungrouped.empty()) {
      FC_WARN("synth samples: {} shapes belong to no sparsity group and stay at 0 (first: {})",
              sparsity_.ungrouped.size(), rig_.shapes[sparsity_.ungrouped[0]].name);
    }
  }

  // Rank 0 opens (or continues) the output; true on every rank when it is up to date.
  bool OpenOutput() {
    FrameOutput opened = OpenFrameOutput(
        ctx_, resolved_, "synth samples", o_.out, so_.count,
        [&](io::H5File* f, bool resumed) {
          CreateSampleDatasets(f, so_.size, so_.size, S_, so_.count, o_.framing);
          if (!resumed) WriteSampleRecords(f, rig_, camera_, distance_);
        },
        "samples");
    output_ = std::move(opened.output);
    pending_ = std::move(opened.pending);
    return opened.up_to_date;
  }

  // Draws and renders sample `index`: segmentation, weights, pose, landmarks and camera.
  std::vector<uint8_t> RenderSample(int64_t index, int thread) {
    SampleRenderer& r = renderers_[thread];
    const synth::SampleParams p = synth::DrawSample(sparsity_, so_, S_, index);
    rig::RigidPose pose = render::FramedPose(rig_, distance_, p.pitch, p.yaw);
    render::Camera view_camera = camera_;
    if (crop_) {
      view_camera = IngestCropCamera(rig_, *evaluator_, camera_, crop_template_, so_.size,
                                     p.weights, &pose, &r.posed);
    }
    evaluator_->EvaluatePosed(pose, p.weights, &r.posed);
    render::Rasterize(r.posed, rig_.triangles, view_camera, &r.gbuffer);
    render::RenderSegmentation(r.gbuffer, rig_.triangle_region, rig_.regions,
                               Eigen::Vector3f::Zero(), &r.segmentation);
    render::ProjectLandmarks(r.posed, rig_.triangles, rig_.landmarks, view_camera, r.gbuffer,
                             &r.landmarks);
    ByteWriter w;
    w.PutVector(r.segmentation.data);
    w.PutArray(p.weights.data(), S_);
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
  }

  // Rank 0: pending frames come in ascending runs; each contiguous run written at once.
  void CommitSamples(const std::vector<int64_t>& frames, const std::vector<std::vector<uint8_t>>& results) {
    io::H5File& f = output_.file;
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
    io::DoneMask mask(&f, so_.count);
    mask.MarkDone(frames);
  }

  const SynthSamplesOptions& o_;
  const synth::SampleOptions& so_;
  const StageContext& ctx_;
  const io::Config& resolved_;
  const dist::Comm& comm_;
  const bool crop_;  // framing = crop
  rig::Rig rig_;
  synth::Sparsity sparsity_;
  int S_ = 0;
  render::Camera camera_;
  float distance_ = 0.f;
  std::unique_ptr<const rig::RigEvaluator> evaluator_;
  Eigen::Matrix<double, face::kNumLandmarks, 2, Eigen::RowMajor> crop_template_;
  ResumableOutput output_;  // rank 0
  std::vector<int64_t> pending_;
  std::vector<SampleRenderer> renderers_;
};

void RunSynthSamples(const StageFlags& flags, AppState* state) {
  StageContext ctx{state->comm, {}, state->command_line};
  io::Config resolved;
  const auto o = ResolveStageOptions<SynthSamplesOptions>(flags, &ctx, &resolved);
  SynthSamplesRun(o, ctx, resolved).Run();
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
