// facecap synth clip: a wild clip of one person with the truth of every frame (pose, weights,
// landmarks, the segmentation render of the same frame), spread across ranks, resumable,
// identical for any rank count; `--video` adds an mp4. facecap synth sheet: wild frames beside
// their segmentation renders in one contact sheet.
#include <algorithm>
#include <filesystem>
#include <memory>

#include "stages/synth_clip_stage.h"

#include "io/audio.h"
#include "io/image_io.h"
#include "io/rig_io.h"
#include "io/texture_file.h"
#include "render/contact_sheet.h"
#include "rig/demo_head.h"
#include "io/camera_file.h"
#include "stages/frame_loop.h"
#include "io/frames_file.h"
#include "stages/frames_video.h"
#include "stages/resumable.h"
#include "stages/speech_file.h"
#include "synth/appearance.h"
#include "synth/clip.h"
#include "synth/speech.h"
#include "util/bytes.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/random.h"

namespace facecap::stages {
namespace {

constexpr int kNumLandmarks = 68;
constexpr int kNumDegradationColumns = 6;

// The mp4 and the WAV beside a clip.
std::string VideoPath(const std::string& out) {
  return std::filesystem::path(out).replace_extension(".mp4").string();
}

std::string WavPath(const std::string& out) {
  return std::filesystem::path(out).replace_extension(".wav").string();
}

// The photo for the background: the folder's image files sorted by name, one picked by seed.
Image8 BackgroundPhoto(const std::string& folder, int background_seed) {
  if (folder.empty()) return Image8();
  std::error_code ec;
  if (!std::filesystem::is_directory(folder, ec)) {
    throw FileIOError("background_folder " + folder + " is not a folder");
  }
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(folder)) {
    if (!entry.is_regular_file()) continue;
    std::string ext = entry.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".bmp" || ext == ".tif" ||
        ext == ".tiff" || ext == ".exr") {
      files.push_back(entry.path().string());
    }
  }
  if (files.empty()) {
    throw FileIOError("background_folder " + folder + " holds no image (png, jpg, bmp, tif, exr)");
  }
  std::sort(files.begin(), files.end());
  Rng rng(static_cast<uint64_t>(background_seed), 0xF0D0u);
  return io::ReadImage8(files[rng.UniformInt(static_cast<int64_t>(files.size()))], 3);
}

// Per-thread rendering state.
struct ClipThread {
  synth::ClipRenderer::Workspace workspace;
  synth::ClipRenderer::Frame frame;
};

// The per-frame datasets of a clip in a new or continued output.
void CreateClipDatasets(io::H5File* f, int H, int W, int S, int64_t frames) {
  f->CreateFrames<uint8_t>(io::frames::kImage, {H, W, 3}, frames, 1);
  f->SetAttribute(io::frames::kImage, "layout", std::string("frame, y, x, RGB (sRGB)"));
  f->CreateFrames<uint8_t>(io::frames::kSegmentation, {H, W, 3}, frames, 1);
  f->SetAttribute(io::frames::kSegmentation, "layout",
                  std::string("frame, y, x, RGB; region colours of /regions/colors"));
  f->CreateFrames<float>(io::frames::kPose, {3}, frames, 1024);
  f->SetAttribute(io::frames::kPose, "columns", std::string("pitch, yaw, roll"));
  f->SetAttribute(io::frames::kPose, "units", std::string("rad"));
  f->CreateFrames<float>(io::frames::kTranslation, {3}, frames, 1024);
  f->SetAttribute(io::frames::kTranslation, "units",
                  std::string("cm, camera space (x right, y up, camera looks down -z)"));
  f->CreateFrames<float>(io::frames::kWeights, {S}, frames, 256);
  f->CreateFrames<float>(io::frames::kLandmarks, {kNumLandmarks, 2}, frames, 256);
  f->SetAttribute(io::frames::kLandmarks, "units", std::string("pixels (x right, y down), iBUG 68"));
  f->CreateFrames<uint8_t>(io::frames::kLandmarkVisible, {kNumLandmarks}, frames, 1024);
  f->CreateFrames<float>(io::frames::kDegradation, {kNumDegradationColumns}, frames, 1024);
  f->SetAttribute(io::frames::kDegradation, "columns",
                  std::string("exposure, defocus_sigma_px, motion_blur_px, motion_blur_angle_rad, "
                              "noise_sigma_levels, jpeg_quality (0: none)"));
}

// The person's shape and region names and region colours (a new output).
void WriteShapesAndRegions(io::H5File* f, const rig::Rig& person) {
  std::vector<std::string> names;
  for (const auto& s : person.shapes) names.push_back(s.name);
  f->WriteStrings(io::frames::kShapeNames, names);
  std::vector<std::string> region_names;
  Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> colors(person.regions.size(), 3);
  for (size_t r = 0; r < person.regions.size(); ++r) {
    region_names.push_back(person.regions[r].name);
    colors.row(r) = person.regions[r].color.transpose();
  }
  f->WriteStrings("/regions/names", region_names);
  f->WriteMatrix("/regions/colors", colors);
}

// The person's identity: seed, coefficients and colours (a new output).
void WriteIdentity(io::H5File* f, const rig::Rig& person, const synth::ClipOptions& co,
                   const synth::PersonColors& pc) {
  f->WriteVector<int>("/identity/seed", {co.identity_seed});
  f->WriteVector<float>("/identity/coefficients",
                        rig::DemoIdentityCoefficients(co.identity_seed,
                                                      static_cast<int>(person.identity_modes.size())));
  f->SetAttribute("/identity/coefficients", "magnitude", static_cast<double>(co.identity_magnitude));
  Eigen::Matrix<float, 5, 3, Eigen::RowMajor> person_colors;
  person_colors << pc.skin.transpose(), pc.lips.transpose(), pc.hair.transpose(),
      pc.iris.transpose(), pc.sclera.transpose();
  f->WriteMatrix("/identity/colors", person_colors);
  f->SetAttribute("/identity/colors", "rows", std::string("skin, lips, hair, iris, sclera (linear RGB)"));
}

// One synth clip run. Every rank builds the person, the trajectory and the renderer: each
// frame is a pure function of its index and the seeds. Rank 0 writes the output.
class SynthClipRun {
 public:
  SynthClipRun(const SynthClipOptions& o, const StageContext& ctx, const io::Config& resolved)
      : o_(o), co_(o.clip), ctx_(ctx), resolved_(resolved), comm_(ctx.comm) {}

  StageSummary Run() {
    BuildPerson();
    S_ = person_.NumShapes();
    StageSummary summary{o_.out, "frames", co_.frames, 0};
    if (!OpenOutput()) {
      const int threads = ThreadsPerRank(o_.threads);
      workers_ = std::vector<ClipThread>(threads);
      FrameLoopOptions loop;
      loop.what = "synth clip";
      loop.batch = o_.batch;
      loop.threads = threads;
      summary.computed = RunFrameLoopAndCommit(
          comm_, pending_, co_.frames, loop,
          [&](int64_t index, int thread) { return RenderFrame(index, thread); },
          [&](const std::vector<int64_t>& frames, const std::vector<std::vector<uint8_t>>& results) {
            CommitFrames(frames, results);
          },
          &output_);
      if (comm_.IsMainRank()) FC_INFO("synth clip: {} frames -> {}", co_.frames, o_.out);
    }
    if (!o_.speech.empty()) WriteSound();
    if (o_.video) WriteVideo();
    return summary;
  }

 private:
  // The person of the rig and identity_seed, its trajectory, background and renderer.
  void BuildPerson() {
    dist::CoordinateExceptions(comm_, [&] {
      const rig::Rig rig = io::ReadRigFile(o_.rig);
      if (rig.landmarks.size() != kNumLandmarks) {
        throw FileIOError(o_.rig + ": the rig has " + std::to_string(rig.landmarks.size()) +
                          " landmarks, synth clip needs the 68 iBUG landmarks");
      }
      if (co_.identity_seed != 0 && rig.identity_modes.empty()) {
        throw FileIOError(o_.rig + ": the rig has no identity modes, so identity_seed " +
                          std::to_string(co_.identity_seed) + " cannot make a person of it "
                          "(use identity_seed = 0)");
      }
      person_ = rig::WithIdentity(rig, co_.identity_seed, co_.identity_magnitude);
      trajectory_ = synth::MakeClipTrajectory(person_, co_);
      if (!o_.speech.empty()) {
        speech_ = synth::Speak(o_.speech, o_.voice);
        speech_.phones = synth::ShiftPhones(speech_.phones, o_.speech_start_seconds);
        synth::ApplySpeech(person_, speech_.phones, synth::SpeakerStyleOf(co_.identity_seed),
                           co_.fps, o_.lips_view, &trajectory_);
      }
      photo_ = BackgroundPhoto(o_.background_folder, co_.background_seed);
      renderer_ = std::make_unique<synth::ClipRenderer>(person_, co_, &photo_);
    });
  }

  // Rank 0 opens (or continues) the output; true on every rank when it is up to date.
  bool OpenOutput() {
    FrameOutput opened = OpenFrameOutput(
        ctx_, resolved_, "synth clip", o_.out, co_.frames,
        [&](io::H5File* f, bool resumed) {
          CreateClipDatasets(f, co_.size, co_.size, S_, co_.frames);
          if (!resumed) WriteRecords(f);
        },
        "frames");
    output_ = std::move(opened.output);
    pending_ = std::move(opened.pending);
    return opened.up_to_date;
  }

  // The person, the camera and the person's own rig, so that trackers can be scored against
  // the true rig (a new output).
  void WriteRecords(io::H5File* f) {
    const render::Camera& camera = renderer_->camera();
    const int H = co_.size, W = co_.size;
    WriteShapesAndRegions(f, person_);
    io::CameraRecord record = io::CameraRecord::Of(camera);
    record.width = W;
    record.height = H;
    record.distance_cm = renderer_->distance();
    record.fps = co_.fps;
    io::WriteCamera(f, record);
    WriteIdentity(f, person_, co_, renderer_->colors());
    io::WriteColorTexture(f, io::kTrueAlbedoPath, renderer_->albedo_texture());
    io::WriteRig(person_, f, "/rig");
    if (!o_.speech.empty()) WriteSpeech(f);
  }

  // The speech's truth: its phones with times in the clip's clock and their visemes, and the
  // sound of the whole clip.
  void WriteSpeech(io::H5File* f) {
    WritePhones(f, "/speech", speech_.phones, "IPA (espeak-ng)", "s, the clip's clock");
    f->SetAttribute("/speech/phones", "text", o_.speech);
    f->SetAttribute("/speech/phones", "voice", o_.voice);
    const io::Audio audio = ClipAudio();
    f->WriteVector<float>("/audio/samples", audio.samples);
    f->SetAttribute("/audio/samples", "rate", static_cast<int64_t>(audio.rate));
    f->SetAttribute("/audio/samples", "units", std::string("mono, [-1, 1]"));
  }

  // The clip's sound: silence, the speech from speech_start_seconds, silence to the end.
  io::Audio ClipAudio() const {
    io::Audio audio;
    audio.rate = speech_.rate;
    const int64_t length = static_cast<int64_t>(std::ceil(co_.frames / co_.fps * audio.rate));
    const int64_t start = static_cast<int64_t>(std::lround(o_.speech_start_seconds * audio.rate));
    audio.samples.assign(length, 0.f);
    for (int64_t i = 0; i < static_cast<int64_t>(speech_.samples.size()) && start + i < length; ++i) {
      audio.samples[start + i] = speech_.samples[i];
    }
    return audio;
  }

  // Renders frame `index`: the wild image, segmentation, pose, weights, landmarks, degradation.
  std::vector<uint8_t> RenderFrame(int64_t index, int thread) {
    ClipThread& t = workers_[thread];
    const synth::ClipFrameParams& p = trajectory_[index];
    renderer_->Render(index, p, &t.workspace, &t.frame);
    const synth::ClipRenderer::Frame& fr = t.frame;
    ByteWriter w;
    w.PutVector(fr.image.data);
    w.PutVector(fr.segmentation.data);
    const float angles[3] = {p.pitch, p.yaw, p.roll};
    w.PutArray(angles, 3);
    w.PutArray(fr.pose.translation.data(), 3);
    w.PutArray(p.weights.data(), S_);
    std::vector<float> xy;
    std::vector<uint8_t> visible;
    for (const auto& l : fr.landmarks) {
      xy.push_back(l.position.x());
      xy.push_back(l.position.y());
      visible.push_back(l.visible ? 1 : 0);
    }
    w.PutVector(xy);
    w.PutVector(visible);
    const float degradation[kNumDegradationColumns] = {
        fr.degradation.exposure, fr.degradation.defocus_sigma,
        fr.degradation.motion_blur_length, fr.degradation.motion_blur_angle,
        fr.degradation.noise_sigma, static_cast<float>(fr.degradation.jpeg_quality)};
    w.PutArray(degradation, kNumDegradationColumns);
    return std::move(w.bytes());
  }

  // Rank 0: each contiguous run of rendered frames written at once, then marked done.
  void CommitFrames(const std::vector<int64_t>& frames, const std::vector<std::vector<uint8_t>>& results) {
    io::H5File& f = output_.file;
    size_t k = 0;
    while (k < frames.size()) {
      size_t end = k + 1;
      while (end < frames.size() && frames[end] == frames[end - 1] + 1) ++end;
      const int64_t n = static_cast<int64_t>(end - k);
      std::vector<uint8_t> image, seg, vis;
      std::vector<float> angles, translation, weights, xy, degradation;
      auto append = [](auto* to, const auto& from) { to->insert(to->end(), from.begin(), from.end()); };
      for (size_t j = k; j < end; ++j) {
        ByteReader r(results[j]);
        append(&image, r.GetVector<uint8_t>());
        append(&seg, r.GetVector<uint8_t>());
        append(&angles, r.GetVector<float>());
        append(&translation, r.GetVector<float>());
        append(&weights, r.GetVector<float>());
        append(&xy, r.GetVector<float>());
        append(&vis, r.GetVector<uint8_t>());
        append(&degradation, r.GetVector<float>());
      }
      f.WriteFrames<uint8_t>(io::frames::kImage, frames[k], n, image.data());
      f.WriteFrames<uint8_t>(io::frames::kSegmentation, frames[k], n, seg.data());
      f.WriteFrames<float>(io::frames::kPose, frames[k], n, angles.data());
      f.WriteFrames<float>(io::frames::kTranslation, frames[k], n, translation.data());
      f.WriteFrames<float>(io::frames::kWeights, frames[k], n, weights.data());
      f.WriteFrames<float>(io::frames::kLandmarks, frames[k], n, xy.data());
      f.WriteFrames<uint8_t>(io::frames::kLandmarkVisible, frames[k], n, vis.data());
      f.WriteFrames<float>(io::frames::kDegradation, frames[k], n, degradation.data());
      k = end;
    }
    io::DoneMask mask(&f, co_.frames);
    mask.MarkDone(frames);
  }

  // Rank 0: the mp4 beside the clip, unless one newer than the clip is there.
  void WriteVideo() {
    dist::CoordinateExceptions(comm_, [&] {
      if (!comm_.IsMainRank()) return;
      const std::string video = VideoPath(o_.out);
      // An mp4 older than the clip belongs to another run.
      std::error_code ec;
      const bool fresh = std::filesystem::exists(video, ec) &&
                         std::filesystem::last_write_time(video, ec) >=
                             std::filesystem::last_write_time(o_.out, ec);
      if (fresh) {
        FC_INFO("synth clip: {} is up to date", video);
      } else {
        WriteFramesVideo(o_.out, video, co_.fps, "synth clip");
        if (!o_.speech.empty()) {
          io::MuxAudio(video, WavPath(o_.out), video);
          FC_INFO("synth clip: the speech is the sound track of {}", video);
        }
      }
    });
  }

  // Rank 0: the clip's sound as a WAV beside the clip.
  void WriteSound() {
    dist::CoordinateExceptions(comm_, [&] {
      if (!comm_.IsMainRank()) return;
      io::WriteWav(WavPath(o_.out), ClipAudio());
      FC_INFO("synth clip: the speech ({}) -> {}", o_.voice, WavPath(o_.out));
    });
  }

  const SynthClipOptions& o_;
  const synth::ClipOptions& co_;
  const StageContext& ctx_;
  const io::Config& resolved_;
  const dist::Comm& comm_;
  rig::Rig person_;
  std::vector<synth::ClipFrameParams> trajectory_;
  synth::SpeechAudio speech_;  // with speech: the audio and phones (clip clock)
  Image8 photo_;  // the renderer's background photo
  std::unique_ptr<synth::ClipRenderer> renderer_;
  int S_ = 0;
  ResumableOutput output_;  // rank 0
  std::vector<int64_t> pending_;
  std::vector<ClipThread> workers_;
};

}  // namespace

void SynthClipOptions::DerivedOutputs(std::vector<NamedPath>* outputs) const {
  if (video) {
    outputs->push_back({"video (out with .mp4)",
                        std::filesystem::path(out).replace_extension(".mp4").string(),
                        OutputKind::kVideo});
  }
  if (!speech.empty()) {
    outputs->push_back({"speech audio (out with .wav)", WavPath(out), OutputKind::kAudio});
  }
}

StageSummary RunSynthClip(const SynthClipOptions& o, const StageContext& ctx,
                          const io::Config& resolved) {
  return SynthClipRun(o, ctx, resolved).Run();
}

StageSummary RunSynthSheet(const SynthSheetOptions& o, const StageContext& ctx,
                           const io::Config& /*resolved*/) {
  if (!ctx.comm.IsMainRank()) return StageSummary{o.out, "files", 0, 0};
  io::H5File f = io::H5File::OpenRead(o.clip);
  for (const char* name : {io::frames::kImage, io::frames::kSegmentation, io::frames::kLandmarks,
                           io::frames::kLandmarkVisible}) {
    if (!f.Exists(name)) throw FileIOError(o.clip + ": no " + std::string(name) + " (not a clip from synth clip?)");
  }
  const io::Shape shape = f.DatasetShape(io::frames::kImage);
  const int64_t num_frames = shape[0];
  const int H = static_cast<int>(shape[1]), W = static_cast<int>(shape[2]);
  const int shown = static_cast<int>(std::min<int64_t>(o.frames, num_frames));
  std::vector<Image8> tiles;
  for (int i = 0; i < shown; ++i) {
    const int64_t frame = shown == 1 ? 0 : (i * (num_frames - 1)) / (shown - 1);
    Image8 image(W, H, 3), seg(W, H, 3);
    f.ReadFrames<uint8_t>(io::frames::kImage, frame, 1, image.data.data());
    f.ReadFrames<uint8_t>(io::frames::kSegmentation, frame, 1, seg.data.data());
    Image8 seg_big = synth::UpscaleNearest(seg, o.scale);
    if (o.landmarks) {
      std::vector<float> xy(kNumLandmarks * 2);
      std::vector<uint8_t> visible(kNumLandmarks);
      f.ReadFrames<float>(io::frames::kLandmarks, frame, 1, xy.data());
      f.ReadFrames<uint8_t>(io::frames::kLandmarkVisible, frame, 1, visible.data());
      for (int l = 0; l < kNumLandmarks; ++l) {
        if (!visible[l]) continue;
        const int cx = static_cast<int>(xy[2 * l] * o.scale), cy = static_cast<int>(xy[2 * l + 1] * o.scale);
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) {
            const int x = cx + dx, y = cy + dy;
            if (x < 0 || y < 0 || x >= seg_big.width || y >= seg_big.height) continue;
            seg_big.at(x, y, 0) = 255;
            seg_big.at(x, y, 1) = 255;
            seg_big.at(x, y, 2) = 255;
          }
        }
      }
    }
    tiles.push_back(synth::UpscaleNearest(image, o.scale));
    tiles.push_back(std::move(seg_big));
  }
  render::ContactSheetOptions sheet;
  sheet.columns = 2 * std::min(o.pairs_per_row, shown);
  sheet.border = 2;
  io::WriteImage(o.out, render::ContactSheet(tiles, sheet));
  FC_INFO("synth sheet: {} frames of {} (wild | segmentation) -> {}", shown, o.clip, o.out);
  return StageSummary{o.out, "files", 1, 1};
}

}  // namespace facecap::stages
