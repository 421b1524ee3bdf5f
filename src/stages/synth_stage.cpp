// facecap synth samples: random rig samples rendered as segmentation images (paper 000
// Sec. 7), spread across ranks, resumable.
#include <functional>
#include <memory>
#include <mutex>

#include "stages/synth_stage.h"

#include "face/align.h"
#include "io/rig_io.h"
#include "render/camera.h"
#include "render/framing.h"
#include "render/gbuffer_images.h"
#include "render/landmarks.h"
#include "render/rasterizer.h"
#include "rig/evaluate.h"
#include "rig/identity_shapes.h"
#include "stages/crop_framing.h"
#include "stages/frame_loop.h"
#include "stages/ingested_frames.h"
#include "stages/resumable.h"
#include "stages/sample_file.h"
#include "synth/sample_set.h"
#include "synth/samples.h"
#include "util/errors.h"
#include "util/log.h"

namespace facecap::stages {
namespace {

// Per-thread rendering state.
struct SampleRenderer {
  render::GBuffer gbuffer;
  rig::Vertices posed;
  Image8 segmentation;
  std::vector<render::Landmark2D> landmarks;
};

// Where the samples of a run come from: drawn at random (synth samples), or rows copied from
// another samples file followed by samples of given parameters (synth expand).
struct SampleSource {
  std::string stage = "synth samples";  // log prefix and provenance
  std::string out;
  int64_t count = 0;                    // samples in the output
  const io::H5File* copy_from = nullptr;
  int64_t copied = 0;                   // rows [0, copied) copied from copy_from
  // Parameters of sample `index` >= copied; null: synth::DrawSample.
  std::function<synth::SampleParams(int64_t index)> params;
  // What a new output holds besides the samples (rank 0).
  std::function<void(io::H5File*)> records;
};

// One run: the rig read on every rank (each sample is a pure function of its index), the
// output on rank 0, and the samples rendered (or copied).
class SynthSamplesRun {
 public:
  SynthSamplesRun(const SynthSamplesOptions& o, SampleSource source, const StageContext& ctx,
                  const io::Config& resolved)
      : o_(o), so_(o.sample), source_(std::move(source)), ctx_(ctx), resolved_(resolved),
        comm_(ctx.comm), crop_(o.framing == "crop") {}

  StageSummary Run() {
    ReadRig();
    S_ = rig_.NumShapes();
    camera_ = synth::SampleCamera(so_);
    distance_ = render::FramingDistance(rig_, camera_, so_.fill);
    // With identity_sigma > 0 the evaluator's rig carries the identity modes as extra shapes.
    identity_modes_ = so_.identity_sigma > 0.f ? static_cast<int>(rig_.identity_modes.size()) : 0;
    if (identity_modes_ > 0) eval_rig_ = rig::WithIdentityShapes(rig_);
    evaluator_ = std::make_unique<const rig::RigEvaluator>(identity_modes_ > 0 ? eval_rig_ : rig_);
    crop_template_ = face::CropTemplate({so_.size, o_.crop_padding, o_.crop_raise});
    StageSummary summary{source_.out, "samples", source_.count, 0};
    if (OpenOutput()) return summary;
    const int threads = ThreadsPerRank(o_.threads);
    renderers_ = std::vector<SampleRenderer>(threads);
    FrameLoopOptions loop;
    loop.what = source_.stage;
    loop.batch = o_.batch;
    loop.threads = threads;
    summary.computed = RunFrameLoopAndCommit(
        comm_, pending_, source_.count, loop,
        [&](int64_t index, int thread) { return Sample(index, thread); },
        [&](const std::vector<int64_t>& frames, const std::vector<std::vector<uint8_t>>& results) {
          WriteSampleRows(&output_.file, frames, results);
          io::DoneMask mask(&output_.file, source_.count);
          mask.MarkDone(frames);
        },
        &output_);
    if (comm_.IsMainRank()) {
      FC_INFO("{}: {} samples -> {}", source_.stage, source_.count, source_.out);
    }
    return summary;
  }

  // The rig, and its shape names resolved into the sparsity groups (after Run or ReadRig).
  const rig::Rig& rig() const { return rig_; }
  const synth::Sparsity& sparsity() const { return sparsity_; }

  // The rig and the sparsity groups of its shapes (every rank).
  void ReadRig() {
    if (rig_read_) return;
    dist::CoordinateExceptions(comm_, [&] {
      rig_ = io::ReadRigFile(o_.rig);
      if (rig_.landmarks.size() != kSampleLandmarks) {
        throw FileIOError(o_.rig + ": the rig has " + std::to_string(rig_.landmarks.size()) +
                          " landmarks, " + source_.stage + " needs the 68 iBUG landmarks");
      }
      if (so_.identity_sigma > 0.f && rig_.identity_modes.empty()) {
        throw FileIOError(o_.rig + ": identity_sigma is " + std::to_string(so_.identity_sigma) +
                          " but the rig has no identity modes (/rig/identity_modes)");
      }
      try {
        sparsity_ = synth::ResolveSparsity(rig_, so_);
      } catch (const InvalidInputError& e) {
        throw InvalidInputError(o_.rig + ": " + e.what());
      }
    });
    rig_read_ = true;
    if (comm_.IsMainRank() && !sparsity_.ungrouped.empty()) {
      FC_WARN("{}: {} shapes belong to no sparsity group and stay at 0 (first: {})",
              source_.stage, sparsity_.ungrouped.size(), rig_.shapes[sparsity_.ungrouped[0]].name);
    }
  }

 private:
  // Rank 0 opens (or continues) the output; true on every rank when it is up to date.
  bool OpenOutput() {
    FrameOutput opened = OpenFrameOutput(
        ctx_, resolved_, source_.stage, source_.out, source_.count,
        [&](io::H5File* f, bool resumed) {
          CreateSampleDatasets(f, so_.size, S_, source_.count, o_.framing);
          if (resumed) return;
          WriteSampleRecords(f, rig_, camera_, distance_);
          if (source_.records) source_.records(f);
        },
        "samples");
    output_ = std::move(opened.output);
    pending_ = std::move(opened.pending);
    return opened.up_to_date;
  }

  std::vector<uint8_t> Sample(int64_t index, int thread) {
    if (index < source_.copied) {
      std::lock_guard<std::mutex> lock(copy_mutex_);
      return ReadSampleRow(*source_.copy_from, index);
    }
    return RenderSample(source_.params ? source_.params(index)
                                       : synth::DrawSample(sparsity_, so_, S_, index,
                                                           identity_modes_),
                        thread);
  }

  // Renders a sample: segmentation, weights, pose, landmarks and camera.
  std::vector<uint8_t> RenderSample(const synth::SampleParams& p, int thread) {
    SampleRenderer& r = renderers_[thread];
    rig::RigidPose pose = render::FramedPose(rig_, distance_, p.pitch, p.yaw);
    // The evaluator's weights: the controls, then the identity coefficients (0: the rig's head).
    Eigen::VectorXf weights = Eigen::VectorXf::Zero(S_ + identity_modes_);
    weights.head(S_) = p.weights;
    if (p.identity.size() == identity_modes_) weights.tail(identity_modes_) = p.identity;
    render::Camera view_camera = camera_;
    if (crop_) {
      view_camera = IngestCropCamera(rig_, *evaluator_, camera_, crop_template_, so_.size,
                                     weights, &pose, &r.posed);
    }
    evaluator_->EvaluatePosed(pose, weights, &r.posed);
    render::Rasterize(r.posed, rig_.triangles, view_camera, &r.gbuffer);
    render::RenderSegmentation(r.gbuffer, rig_.triangle_region, rig_.regions,
                               Eigen::Vector3f::Zero(), &r.segmentation);
    render::ProjectLandmarks(r.posed, rig_.triangles, rig_.landmarks, view_camera, r.gbuffer,
                             &r.landmarks);
    const float angles[3] = {pose.pitch, pose.yaw, pose.roll};
    std::vector<float> xy;
    std::vector<uint8_t> visible;
    for (const auto& l : r.landmarks) {
      xy.push_back(l.position.x());
      xy.push_back(l.position.y());
      visible.push_back(l.visible ? 1 : 0);
    }
    const float intrinsics[4] = {view_camera.fx, view_camera.fy, view_camera.cx, view_camera.cy};
    return PackSampleRow(r.segmentation.data, p.weights.data(), S_, angles, xy, visible,
                         intrinsics);
  }

  const SynthSamplesOptions& o_;
  const synth::SampleOptions& so_;
  const SampleSource source_;
  const StageContext& ctx_;
  const io::Config& resolved_;
  const dist::Comm& comm_;
  const bool crop_;  // framing = crop
  bool rig_read_ = false;
  rig::Rig rig_;
  synth::Sparsity sparsity_;
  int S_ = 0;
  int identity_modes_ = 0;  // identity coefficients per sample (0: the rig's own head)
  rig::Rig eval_rig_;       // the rig with its identity modes as shapes, when identity_modes_ > 0
  render::Camera camera_;
  float distance_ = 0.f;
  std::unique_ptr<const rig::RigEvaluator> evaluator_;
  Eigen::Matrix<double, face::kNumLandmarks, 2, Eigen::RowMajor> crop_template_;
  ResumableOutput output_;  // rank 0
  std::vector<int64_t> pending_;
  std::vector<SampleRenderer> renderers_;
  std::mutex copy_mutex_;
};

}  // namespace

StageSummary RunSynthSamples(const SynthSamplesOptions& o, const StageContext& ctx,
                             const io::Config& resolved) {
  SampleSource source;
  source.out = o.out;
  source.count = o.sample.count;
  return SynthSamplesRun(o, std::move(source), ctx, resolved).Run();
}

namespace {

// The [synth.samples] options a samples file was made with.
SynthSamplesOptions SamplingOptionsOf(const io::H5File& f) {
  const io::Config config = io::Config::Parse(SamplingConfig(f), f.path() + " (sampling config)");
  for (const std::string& group : config.Tables("")) {
    for (const std::string& table : config.Tables(group)) {
      if (config.Has(group + "." + table, "count")) {
        return io::ResolveOptions<SynthSamplesOptions>(config, group + "." + table);
      }
    }
  }
  throw FileIOError(f.path() + ": its sampling config holds no [synth.samples] table");
}

// Rank 0: the real frames farthest from every sample in the deepfake's latent space, and the
// tracker's solutions on them.
struct Gaps {
  std::vector<int64_t> frames;   // indices into the frames (and the track), ascending
  std::vector<double> score;     // every real frame's mean distance to its nearest samples
  double threshold = 0;
  int64_t real_frames = 0;       // frames with a face
  std::vector<synth::SeedParams> seeds;
};

Gaps FindGaps(const SynthExpandOptions& o, const io::H5File& samples, int num_shapes) {
  const io::H5File codes = io::H5File::OpenRead(o.frame_codes);
  std::vector<int64_t> real;
  const synth::CodeMatrix real_codes = ReadCodes(codes, kFrameCodes, &real);
  const int64_t frames = codes.CheckShape(kFrameCodes, {-1, -1})[0];
  const io::Shape sample_shape = samples.CheckShape("/samples/latent", {-1, -1});
  if (real_codes.cols() != sample_shape[1]) {
    throw FileIOError(o.frame_codes + ": codes of " + std::to_string(real_codes.cols()) +
                      " values, " + o.samples + " has codes of " + std::to_string(sample_shape[1]) +
                      " (made by another deepfake)");
  }
  const io::H5File track = io::H5File::OpenRead(o.track);
  track.CheckShape("/track/weights", {frames, num_shapes});
  track.CheckShape("/track/pose", {frames, 3});
  if (real.empty()) throw FileIOError(o.frame_codes + ": no frame with a face");
  Gaps gaps;
  gaps.real_frames = static_cast<int64_t>(real.size());
  const std::vector<double> score = synth::MeanNearestDistance(
      real_codes, samples.ReadMatrix<float>("/samples/latent"), o.neighbors, false, nullptr);
  gaps.score.assign(frames, 0.0);
  for (size_t j = 0; j < real.size(); ++j) gaps.score[real[j]] = score[j];
  gaps.threshold = synth::FractionThreshold(score, o.gap_fraction);
  for (int64_t j : synth::ScoresAbove(score, gaps.threshold)) gaps.frames.push_back(real[j]);
  if (gaps.frames.empty()) gaps.frames.push_back(real[0]);
  const auto weights = track.ReadMatrix<float>("/track/weights");
  const auto pose = track.ReadMatrix<float>("/track/pose");
  for (int64_t frame : gaps.frames) {
    synth::SeedParams seed;
    seed.pitch = pose(frame, 0);
    seed.yaw = pose(frame, 1);
    seed.weights = weights.row(frame).transpose();
    gaps.seeds.push_back(std::move(seed));
  }
  return gaps;
}

}  // namespace

StageSummary RunSynthExpand(const SynthExpandOptions& o, const StageContext& ctx,
                            const io::Config& resolved) {
  const dist::Comm& comm = ctx.comm;
  io::H5File samples;
  SynthSamplesOptions sampling;
  int64_t kept = 0;
  dist::CoordinateExceptions(comm, [&] {
    samples = io::H5File::OpenRead(o.samples);
    sampling = SamplingOptionsOf(samples);
    kept = samples.CheckShape("/samples/segmentation", {-1, sampling.sample.size, sampling.sample.size, 3})[0];
    samples.CheckShape("/samples/latent", {kept, -1});
  });
  sampling.rig = o.rig;
  sampling.batch = o.batch;
  sampling.threads = o.threads;
  const int64_t count = o.count > 0 ? o.count : sampling.sample.count;
  if (count < kept) {
    throw InvalidInputError("synth expand: count " + std::to_string(count) + " is below the " +
                            std::to_string(kept) + " samples of " + o.samples);
  }
  // The gaps on rank 0, their seeds on every rank.
  Gaps gaps;
  std::vector<float> seed_values;  // pitch, yaw, weights per seed
  int S = 0;
  dist::CoordinateExceptions(comm, [&] {
    S = static_cast<int>(samples.ReadStrings("/samples/shape_names").size());
    if (!comm.IsMainRank()) return;
    gaps = FindGaps(o, samples, S);
    for (const auto& seed : gaps.seeds) {
      seed_values.push_back(seed.pitch);
      seed_values.push_back(seed.yaw);
      seed_values.insert(seed_values.end(), seed.weights.data(), seed.weights.data() + S);
    }
  });
  comm.Broadcast(&seed_values);
  std::vector<synth::SeedParams> seeds(seed_values.size() / (2 + S));
  for (size_t i = 0; i < seeds.size(); ++i) {
    const float* v = seed_values.data() + i * (2 + S);
    seeds[i].pitch = v[0];
    seeds[i].yaw = v[1];
    seeds[i].weights = Eigen::Map<const Eigen::VectorXf>(v + 2, S);
  }
  if (comm.IsMainRank()) {
    FC_INFO("synth expand: {} of {} real frames with a face are gaps (mean code distance to the "
            "{} nearest samples above {:.4g}); {} samples kept + {} new from their solutions",
            gaps.frames.size(), gaps.real_frames, o.neighbors, gaps.threshold, kept, count - kept);
  }
  SampleSource source;
  source.stage = "synth expand";
  source.out = o.out;
  source.count = count;
  source.copy_from = &samples;
  source.copied = kept;
  synth::Sparsity sparsity;  // the rig's, once read
  source.params = [&](int64_t index) {
    return synth::ExpandSample(seeds, sparsity, sampling.sample, o.expansion, index - kept);
  };
  const std::string sampling_config = SamplingConfig(samples);
  source.records = [&](io::H5File* f) {
    f->SetAttribute("/samples", "sampling_config", sampling_config);
    std::vector<uint8_t> origin(count, 0);
    for (int64_t i = kept; i < count; ++i) origin[i] = 1;
    f->WriteVector("/samples/origin", origin);
    f->SetAttribute("/samples/origin", "meaning",
                    std::string("0: a sample of " + o.samples + ", 1: new, seeded by a gap frame"));
    f->WriteVector("/expansion/gap_frames", gaps.frames);
    f->SetAttribute("/expansion/gap_frames", "meaning",
                    std::string("frames of " + o.frame_codes + " whose solutions seed the new samples"));
    f->WriteVector("/expansion/gap_score", gaps.score);
    f->SetAttribute("/expansion/gap_score", "meaning",
                    std::string("each real frame's mean code distance to its nearest samples (0: no face)"));
    f->SetAttribute("/expansion", "threshold", gaps.threshold);
  };
  SynthSamplesRun run(sampling, std::move(source), ctx, resolved);
  run.ReadRig();
  std::vector<std::string> rig_names;
  for (const auto& shape : run.rig().shapes) rig_names.push_back(shape.name);
  if (rig_names != samples.ReadStrings("/samples/shape_names")) {
    throw InvalidInputError(o.rig + ": its " + std::to_string(rig_names.size()) +
                            " shapes are not the " + std::to_string(S) + " shapes of " +
                            o.samples + " (give the rig the samples were rendered with)");
  }
  sparsity = run.sparsity();
  return run.Run();
}

}  // namespace facecap::stages
