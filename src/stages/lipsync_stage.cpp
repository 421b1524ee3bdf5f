// facecap lipsync blend: the mouth controls of a second source (a frontal lip video solved by
// lipsync track) blended into the video's solve, aligned in time by the sound of both videos.
// facecap lipsync audio: a mouth source from the video's own sound (phones recognized by
// pocketsphinx, visemes, dominance coarticulation).
// facecap eval lipsync: mouth and upper-face control errors, pose error and lip-closure
// detection of tracks against a talking clip's truth, beside the neutral mouth.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <utility>

#include "stages/lipsync_stage.h"

#include "dist/comm.h"
#include "io/atomic_file.h"
#include "io/audio.h"
#include "io/hdf5.h"
#include "io/rig_io.h"
#include "lipsync/audio_align.h"
#include "lipsync/phone_recognizer.h"
#include "lipsync/speech_track.h"
#include "lipsync/visemes.h"
#include "rig/compare.h"
#include "rig/pose.h"
#include "io/camera_file.h"
#include "io/clip_file.h"
#include "stages/speech_file.h"
#include "stages/track_file.h"
#include "util/errors.h"
#include "util/json.h"
#include "util/log.h"

namespace facecap::stages {
namespace {

using RowMatrixF = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// The offset of the mouth source: measured from the sound of both videos, or given.
double BlendOffset(const LipsyncBlendOptions& o) {
  if (o.video.empty()) return o.offset_seconds;
  constexpr int kRate = 16000;
  const io::Audio a = io::DecodeAudio(o.video, kRate);
  const io::Audio b = io::DecodeAudio(o.mouth_video, kRate);
  lipsync::AlignOptions align;
  align.max_offset_seconds = o.max_offset_seconds;
  const lipsync::AlignResult r = lipsync::EstimateOffset(a.samples, b.samples, kRate, align);
  FC_INFO("lipsync blend: the sound of {} runs {:.1f} ms behind {}'s (correlation {:.2f})",
          o.mouth_video, 1000. * r.offset_seconds, o.video, r.peak);
  if (r.peak < 0.3) {
    FC_WARN("lipsync blend: the two sound tracks correlate weakly ({:.2f}); check that they "
            "carry the same speech, or give offset_seconds", r.peak);
  }
  return r.offset_seconds;
}

struct LipsyncRow {
  std::string name;
  int64_t frames = 0;
  double mouth_mae = 0., upper_mae = 0., pose_deg = 0.;
  lipsync::DetectionScore closures;
  std::vector<int64_t> source_index;       // per frame of the track
  std::vector<float> truth_gap, gap;       // inner lip gaps (IOD), the truth's and the row's
};

// What eval lipsync reads of the truth.
struct LipsyncTruth {
  rig::Rig rig;
  std::vector<std::string> names;
  RowMatrixF weights, pose;
  double fps = 0.;
};

// Scores one track (rows of the clip by source index; frames without a face are held and
// count for closures, not for the control errors).
LipsyncRow ScoreLipsync(const EvalLipsyncOptions& o, const LipsyncTruth& truth,
                        const TrackTimeline& track, const std::string& path, bool neutral_mouth) {
  LipsyncRow row;
  const int S = truth.rig.NumShapes();
  std::vector<char> is_mouth(S, 0);
  for (int s : lipsync::ShapeIndices(truth.names, o.mouth_controls)) is_mouth[s] = 1;
  std::vector<int> column(S, -1);
  for (int s = 0; s < S; ++s) column[s] = track.Column(truth.names[s]);
  Eigen::MatrixXf truth_rows(track.frames(), S), estimate(track.frames(), S);
  int mouth_n = 0, upper_n = 0;
  for (int64_t f = 0; f < track.frames(); ++f) {
    const int64_t r = track.source_index[f];
    if (r < 0 || r >= truth.weights.rows()) {
      throw FileIOError(path + ": frame " + std::to_string(f) + " is source frame " + std::to_string(r) +
                        ", but " + o.truth + " has " + std::to_string(truth.weights.rows()));
    }
    for (int s = 0; s < S; ++s) {
      truth_rows(f, s) = truth.weights(r, s);
      estimate(f, s) = column[s] >= 0 ? track.weights(f, column[s]) : 0.f;
      if (neutral_mouth && is_mouth[s]) estimate(f, s) = 0.f;
    }
    if (!track.Solved(f)) continue;
    ++row.frames;
    for (int s = 0; s < S; ++s) {
      const double e = std::abs(estimate(f, s) - truth_rows(f, s));
      if (is_mouth[s]) { row.mouth_mae += e; ++mouth_n; }
      else { row.upper_mae += e; ++upper_n; }
    }
    rig::RigidPose a, b;
    a.pitch = truth.pose(r, 0); a.yaw = truth.pose(r, 1); a.roll = truth.pose(r, 2);
    b.pitch = track.pose(f, 0); b.yaw = track.pose(f, 1); b.roll = track.pose(f, 2);
    row.pose_deg += rig::RotationAngleDeg(a, b);
  }
  row.mouth_mae /= std::max(1, mouth_n);
  row.upper_mae /= std::max(1, upper_n);
  row.pose_deg /= std::max<int64_t>(1, row.frames);
  // Closures on the clip's clock: the truth rig at both rows' weights.
  const double fps = truth.fps;
  row.source_index = track.source_index;
  row.truth_gap = lipsync::InnerLipGaps(truth.rig, truth_rows);
  row.gap = lipsync::InnerLipGaps(truth.rig, estimate);
  const std::vector<lipsync::Closure> t = lipsync::FindClosures(row.truth_gap, o.closure_gap, fps);
  const std::vector<lipsync::Closure> e = lipsync::FindClosures(row.gap, o.closure_gap, fps);
  row.closures = lipsync::MatchClosures(t, e, o.closure_tolerance_seconds);
  return row;
}

}  // namespace

StageSummary RunLipsyncBlend(const LipsyncBlendOptions& o, const StageContext& ctx,
                             const io::Config& resolved) {
  StageSummary summary{o.out, "frames", 0, 0};
  dist::CoordinateExceptions(ctx.comm, [&] {
    if (!ctx.comm.IsMainRank()) return;
    std::string why;
    if (!o.Check(&why)) throw InvalidInputError("lipsync blend: " + why);
    const TrackTimeline video = ReadTimeline(o.track);
    const TrackTimeline mouth = ReadTimeline(o.mouth);
    const double offset = BlendOffset(o);
    // The mouth source's solved frames, and its values at the video's times plus the offset.
    std::vector<double> mouth_times;
    std::vector<int> rows;
    for (int64_t f = 0; f < mouth.frames(); ++f) {
      if (mouth.Solved(f)) {
        rows.push_back(static_cast<int>(f));
        mouth_times.push_back(mouth.times[f]);
      }
    }
    if (rows.empty()) throw FileIOError(o.mouth + ": no frame of the mouth source was solved");
    std::vector<double> at;
    for (double t : video.times) at.push_back(t + offset);
    // Columns: the mouth controls both tracks have.
    const int64_t F = video.frames();
    const int S = static_cast<int>(video.names.size());
    Eigen::MatrixXf source(static_cast<int>(rows.size()), S);
    source.setZero();
    Eigen::VectorXf crossfade = Eigen::VectorXf::Zero(S);
    int blended = 0;
    for (size_t k = 0; k < o.mouth_controls.size(); ++k) {
      const int vc = video.Column(o.mouth_controls[k]), mc = mouth.Column(o.mouth_controls[k]);
      if (vc < 0 || mc < 0) continue;
      for (size_t r = 0; r < rows.size(); ++r) source(static_cast<int>(r), vc) = mouth.weights(rows[r], mc);
      crossfade[vc] = o.crossfade.size() == 1 ? o.crossfade[0] : o.crossfade[k];
      ++blended;
    }
    if (blended == 0) {
      throw FileIOError(o.mouth + " and " + o.track + " share none of the mouth controls");
    }
    const Eigen::MatrixXf mouth_at = lipsync::ResampleAtTimes(source, mouth_times, at);
    const Eigen::MatrixXf video_w = video.weights.cast<float>();
    Eigen::MatrixXf out = lipsync::BlendControls(video_w, mouth_at, crossfade);
    // Outside the mouth source's time span its end rows fade out to the video's solve.
    const std::vector<float> shares =
        lipsync::CoverageShares(at, mouth_times.front(), mouth_times.back(), o.edge_fade_seconds);
    int64_t covered = 0;
    for (int64_t f = 0; f < F; ++f) {
      if (shares[f] == 1.f) ++covered;
      else out.row(f) = video_w.row(f) + shares[f] * (out.row(f) - video_w.row(f));
    }
    // The video's track file with the blended weights, written beside out and renamed.
    const std::string partial = io::H5File::PartialPath(o.out);
    std::error_code ec;
    std::filesystem::copy_file(o.track, partial, std::filesystem::copy_options::overwrite_existing, ec);
    if (ec) throw OutputError(partial + ": cannot copy " + o.track + ": " + ec.message());
    {
      io::H5File f = io::H5File::OpenReadWrite(partial);
      const RowMatrixF row_major = out;
      f.WriteFrames<float>("/track/weights", 0, F, row_major.data());
      f.SetAttribute("/track", "lipsync_mouth", o.mouth);
      f.SetAttribute("/track", "lipsync_offset_seconds", offset);
      f.WriteProvenance(MakeProvenance(ctx, "lipsync blend", resolved));
      f.Close();
    }
    std::filesystem::rename(partial, o.out, ec);
    if (ec) throw OutputError(o.out + ": cannot rename " + partial + ": " + ec.message());
    FC_INFO("lipsync blend: {} mouth controls of {} over {} of {} frames (offset {:.1f} ms) -> {}",
            blended, o.mouth, covered, F, 1000. * offset, o.out);
    summary.items = summary.computed = F;
  });
  return summary;
}

StageSummary RunLipsyncAudio(const LipsyncAudioOptions& o, const StageContext& ctx,
                             const io::Config& resolved) {
  StageSummary summary{o.out, "frames", 0, 0};
  dist::CoordinateExceptions(ctx.comm, [&] {
    if (!ctx.comm.IsMainRank()) return;
    std::string why;
    if (!o.Check(&why)) throw InvalidInputError("lipsync audio: " + why);
    const rig::Rig rig = io::ReadRigFile(o.rig);
    std::vector<std::string> names;
    for (const auto& shape : rig.shapes) names.push_back(shape.name);
    if (lipsync::ShapeIndices(names, lipsync::DefaultMouthControls()).empty()) {
      throw FileIOError(o.rig + ": the rig has none of the ARKit mouth controls (jawOpen, mouth*)");
    }
    const io::Audio sound = io::DecodeAudio(o.video, lipsync::kRecognizerRate);
    lipsync::RecognizerOptions recognizer;
    recognizer.model_dir = o.model_dir;
    recognizer.transcript = o.transcript;
    const std::vector<lipsync::PhoneSegment> phones = lipsync::RecognizePhones(sound.samples, recognizer);
    const double seconds = static_cast<double>(sound.samples.size()) / sound.rate;
    const int frames = std::max(1, static_cast<int>(std::ceil(seconds * o.fps)));
    const Eigen::MatrixXf mouth = lipsync::MouthFromPhones(phones, names, frames, o.fps, o.dominance);
    io::H5File f = io::H5File::CreateAtomic(o.out);
    f.WriteStrings("/track/shape_names", names);
    f.WriteMatrix("/track/weights", RowMatrixF(mouth));
    f.WriteMatrix("/track/pose", RowMatrixF::Zero(frames, 3));
    f.SetAttribute("/track/pose", "meaning", std::string("none: a mouth source has no head pose"));
    f.WriteVector<int32_t>("/track/termination", std::vector<int32_t>(frames, 0));
    std::vector<double> timecode(frames);
    for (int i = 0; i < frames; ++i) timecode[i] = i / o.fps;
    f.WriteVector<double>("/track/timecode", timecode);
    f.SetAttribute("/track/timecode", "units", std::string("seconds from the start of the sound"));
    f.SetAttribute("/track", "fps", o.fps);
    f.SetAttribute("/track", "source", o.video);
    WritePhones(&f, "/lipsync", phones, "ARPAbet (pocketsphinx)", "s, the sound's clock");
    f.WriteProvenance(MakeProvenance(ctx, "lipsync audio", resolved));
    f.Commit();
    int speech = 0;
    for (const auto& p : phones) speech += p.viseme != 0;
    FC_INFO("lipsync audio: {} phones ({} spoken) in {:.1f} s of {}{} -> {} frames of mouth controls in {}",
            phones.size(), speech, seconds, o.video, o.transcript.empty() ? "" : " (transcript aligned)",
            frames, o.out);
    summary.items = summary.computed = frames;
  });
  return summary;
}

StageSummary RunEvalLipsync(const EvalLipsyncOptions& o, const StageContext& ctx,
                            const io::Config& /*resolved*/) {
  if (!ctx.comm.IsMainRank()) return StageSummary{o.out, "files", 0, 0};
  std::string why;
  if (!o.Check(&why)) throw InvalidInputError("eval lipsync: " + why);
  LipsyncTruth truth;
  {
    io::H5File f = io::H5File::OpenRead(o.truth);
    io::ClipTruth clip = io::ReadClipTruth(f);
    if (!f.Exists("/rig/neutral")) {
      throw FileIOError(o.truth + ": no /rig/neutral (not a clip from synth clip?)");
    }
    truth.rig = io::ReadRig(f);
    truth.names = std::move(clip.names);
    truth.weights = std::move(clip.weights);
    truth.pose = std::move(clip.pose);
    truth.fps = clip.fps;
    if (!(truth.fps > 0.)) throw FileIOError(o.truth + ": no frame rate (" + io::kCameraPath + "@fps)");
    if (truth.names.size() != static_cast<size_t>(truth.rig.NumShapes()) ||
        truth.weights.cols() != truth.rig.NumShapes()) {
      throw FileIOError(o.truth + ": its weights, shape names and rig do not agree");
    }
    if (!f.Exists("/speech/phones")) {
      FC_WARN("eval lipsync: {} has no speech (/speech/phones): scoring a clip that does not talk", o.truth);
    }
  }
  std::vector<LipsyncRow> rows;
  for (size_t k = 0; k < o.tracks.size(); ++k) {
    const TrackTimeline track = ReadTimeline(o.tracks[k]);
    const std::string name = o.names.empty() ? std::filesystem::path(o.tracks[k]).filename().string() : o.names[k];
    if (k == 0) {
      LipsyncRow neutral = ScoreLipsync(o, truth, track, o.tracks[k], true);
      neutral.name = "neutral mouth (" + name + " with every mouth control 0)";
      rows.push_back(neutral);
    }
    LipsyncRow row = ScoreLipsync(o, truth, track, o.tracks[k], false);
    row.name = name;
    rows.push_back(row);
  }
  std::ostringstream js;
  js << "{\"truth\": " << JsonString(o.truth) << ", \"closures_true\": " << rows.front().closures.truth
     << ", \"rows\": [";
  for (size_t k = 0; k < rows.size(); ++k) {
    const LipsyncRow& r = rows[k];
    js << (k ? ", " : "") << "{\"name\": " << JsonString(r.name) << ", \"frames\": " << r.frames
       << ", \"mouth_mae\": " << JsonNumber(r.mouth_mae) << ", \"upper_mae\": " << JsonNumber(r.upper_mae)
       << ", \"pose_err_deg\": " << JsonNumber(r.pose_deg)
       << ", \"closures_found\": " << r.closures.found << ", \"closures_matched\": " << r.closures.matched
       << ", \"closure_precision\": " << JsonNumber(r.closures.precision)
       << ", \"closure_recall\": " << JsonNumber(r.closures.recall)
       << ", \"closure_f1\": " << JsonNumber(r.closures.f1) << "}";
  }
  js << "]}";
  if (o.json) {
    std::cout << js.str() << std::endl;
  } else {
    std::printf("%-60s %7s %9s %9s %8s %11s\n", "row", "frames", "mouth MAE", "upper MAE", "pose deg",
                "closure F1");
    for (const LipsyncRow& r : rows) {
      std::printf("%-60s %7lld %9.4f %9.4f %8.3f %5.2f (%d/%d/%d)\n", r.name.c_str(),
                  static_cast<long long>(r.frames), r.mouth_mae, r.upper_mae, r.pose_deg, r.closures.f1,
                  r.closures.matched, r.closures.found, r.closures.truth);
    }
    std::printf("closure F1 (matched / found / true): lips within %.3f IOD, centres within %.0f ms\n",
                o.closure_gap, 1000. * o.closure_tolerance_seconds);
  }
  if (!o.out.empty()) io::WriteFileAtomically(o.out, js.str() + "\n");
  if (!o.gaps.empty()) {
    // A row name as a CSV field: quoted, inner quotes doubled.
    const auto field = [](const std::string& text) {
      std::string q = "\"";
      for (char c : text) q += c == '"' ? std::string("\"\"") : std::string(1, c);
      return q + "\"";
    };
    std::ostringstream csv;
    csv << "row,frame,source_index,seconds,truth_gap,gap\n";
    for (const LipsyncRow& r : rows) {
      for (size_t f = 0; f < r.gap.size(); ++f) {
        csv << field(r.name) << ',' << f << ',' << r.source_index[f] << ','
            << JsonNumber(static_cast<double>(r.source_index[f]) / truth.fps) << ',' << JsonNumber(r.truth_gap[f])
            << ',' << JsonNumber(r.gap[f]) << '\n';
      }
    }
    io::WriteFileAtomically(o.gaps, csv.str());
  }
  // The JSON file at out, counted when written (out empty: the JSON was only printed).
  const int64_t files = o.out.empty() ? 0 : 1;
  return StageSummary{o.out, "files", files, files};
}

}  // namespace facecap::stages
