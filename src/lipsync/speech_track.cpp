#include "lipsync/speech_track.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "lipsync/visemes.h"
#include "rig/evaluate.h"
#include "util/errors.h"

namespace facecap::lipsync {

namespace {

float Alpha(int viseme, const DominanceOptions& o) {
  switch (static_cast<Viseme>(viseme)) {
    case Viseme::kSilence: return o.silence_alpha;
    case Viseme::kPP:
    case Viseme::kFF: return o.closure_alpha;
    case Viseme::kAA:
    case Viseme::kE:
    case Viseme::kIH:
    case Viseme::kOH:
    case Viseme::kOU: return o.vowel_alpha;
    default: return o.consonant_alpha;
  }
}

}  // namespace

std::vector<int> ShapeIndices(const std::vector<std::string>& shape_names,
                              const std::vector<std::string>& names) {
  std::vector<int> out;
  for (const std::string& n : names) {
    const auto it = std::find(shape_names.begin(), shape_names.end(), n);
    if (it != shape_names.end()) out.push_back(static_cast<int>(it - shape_names.begin()));
  }
  return out;
}

Eigen::MatrixXf MouthFromPhones(const std::vector<PhoneSegment>& phones,
                                const std::vector<std::string>& shape_names, int frames, double fps,
                                const DominanceOptions& options) {
  const int S = static_cast<int>(shape_names.size());
  // Each viseme's pose as a vector over the shapes.
  Eigen::MatrixXf poses = Eigen::MatrixXf::Zero(kNumVisemes, S);
  for (int v = 0; v < kNumVisemes; ++v) {
    for (const auto& [name, weight] : VisemePose(static_cast<Viseme>(v))) {
      for (int s : ShapeIndices(shape_names, {name})) poses(v, s) = options.amplitude * weight;
    }
  }
  Eigen::MatrixXf out = Eigen::MatrixXf::Zero(frames, S);
  for (int f = 0; f < frames; ++f) {
    const double t = f / fps;
    // Silence everywhere as a weak background dominance, so that the mouth rests between words.
    double total = 1e-3 * options.silence_alpha;
    Eigen::VectorXf sum = Eigen::VectorXf::Zero(S);
    for (const PhoneSegment& p : phones) {
      const double duration = std::max(0., p.end - p.start);
      const double tau = options.spread * duration + options.tau0;
      const double centre = 0.5 * (p.start + p.end);
      const double d = std::max(0., std::abs(t - centre) - 0.5 * options.hold * duration) / tau;
      if (d > 12.) continue;
      const double D = Alpha(p.viseme, options) * std::exp(-std::pow(d, options.kappa));
      total += D;
      if (p.viseme > 0 && p.viseme < kNumVisemes) sum += static_cast<float>(D) * poses.row(p.viseme).transpose();
    }
    out.row(f) = (sum / static_cast<float>(total)).cwiseMax(0.f).cwiseMin(1.f).transpose();
  }
  return out;
}

Eigen::MatrixXf ResampleAtTimes(const Eigen::MatrixXf& source, const std::vector<double>& source_times,
                                const std::vector<double>& times, std::vector<char>* inside) {
  const int n = static_cast<int>(source.rows());
  if (static_cast<int>(source_times.size()) != n || n == 0) {
    throw InvalidInputError("resampling: " + std::to_string(n) + " rows but " +
                            std::to_string(source_times.size()) + " times");
  }
  for (int i = 1; i < n; ++i) {
    if (!(source_times[i] > source_times[i - 1])) {
      throw InvalidInputError("resampling: the source times are not ascending at row " + std::to_string(i));
    }
  }
  Eigen::MatrixXf out(static_cast<int>(times.size()), source.cols());
  if (inside) inside->assign(times.size(), 1);
  for (size_t f = 0; f < times.size(); ++f) {
    const double t = times[f];
    if (t <= source_times.front() || t >= source_times.back()) {
      const bool at_front = t <= source_times.front();
      out.row(f) = source.row(at_front ? 0 : n - 1);
      if (inside && t != source_times.front() && t != source_times.back()) (*inside)[f] = 0;
      continue;
    }
    const int i1 = static_cast<int>(std::upper_bound(source_times.begin(), source_times.end(), t) -
                                    source_times.begin());
    const int i0 = i1 - 1;
    const float a = static_cast<float>((t - source_times[i0]) / (source_times[i1] - source_times[i0]));
    out.row(f) = (1.f - a) * source.row(i0) + a * source.row(i1);
  }
  return out;
}

std::vector<float> CoverageShares(const std::vector<double>& times, double first, double last,
                                  double fade_seconds) {
  std::vector<float> shares(times.size(), 1.f);
  for (size_t f = 0; f < times.size(); ++f) {
    const double beyond = std::max(first - times[f], times[f] - last);
    if (beyond <= 0.) continue;
    shares[f] = fade_seconds > 0. ? static_cast<float>(std::max(0., 1. - beyond / fade_seconds)) : 0.f;
  }
  return shares;
}

Eigen::MatrixXf BlendControls(const Eigen::MatrixXf& video, const Eigen::MatrixXf& mouth,
                              const Eigen::VectorXf& crossfade) {
  if (video.rows() != mouth.rows() || video.cols() != mouth.cols() ||
      crossfade.size() != video.cols()) {
    throw InvalidInputError("lipsync blend: the video solve (" + std::to_string(video.rows()) + " x " +
                            std::to_string(video.cols()) + "), the mouth source (" +
                            std::to_string(mouth.rows()) + " x " + std::to_string(mouth.cols()) +
                            ") and the cross-fade (" + std::to_string(crossfade.size()) +
                            ") do not match");
  }
  Eigen::MatrixXf out = video;
  for (int s = 0; s < video.cols(); ++s) {
    const float c = crossfade[s];
    if (c == 0.f) continue;
    if (c == 1.f) {
      out.col(s) = mouth.col(s);
    } else {
      out.col(s) = (1.f - c) * video.col(s) + c * mouth.col(s);
    }
  }
  return out;
}

namespace {

// The rig's inner-lip gap at one weight vector, in units of iod; *v is workspace.
float InnerLipGap(const rig::Rig& rig, const Eigen::VectorXf& w, float iod, rig::Vertices* v) {
  rig::EvaluateShape(rig, w, v);
  const int upper[3] = {61, 62, 63}, lower[3] = {67, 66, 65};
  float gap = 0.f;
  for (int k = 0; k < 3; ++k) gap += (*v)(rig.landmarks[upper[k]], 1) - (*v)(rig.landmarks[lower[k]], 1);
  return gap / 3.f / iod;
}

// The rig's inter-ocular distance (outer eye corners 36, 45 at the neutral).
float NeutralIod(const rig::Rig& rig, rig::Vertices* v) {
  if (rig.landmarks.size() != 68) {
    throw InvalidInputError("lip gaps need the rig's 68 iBUG landmarks, it has " +
                            std::to_string(rig.landmarks.size()));
  }
  rig::EvaluateShape(rig, Eigen::VectorXf::Zero(rig.NumShapes()), v);
  return (v->row(rig.landmarks[36]) - v->row(rig.landmarks[45])).norm();
}

}  // namespace

std::vector<float> InnerLipGaps(const rig::Rig& rig, const Eigen::MatrixXf& weights) {
  rig::Vertices v;
  const float iod = NeutralIod(rig, &v);
  std::vector<float> gaps(weights.rows());
  for (int f = 0; f < weights.rows(); ++f) gaps[f] = InnerLipGap(rig, weights.row(f).transpose(), iod, &v);
  return gaps;
}

std::vector<char> LipsMayMeet(const std::vector<PhoneSegment>& phones, const std::vector<double>& times,
                              MeetRule rule) {
  const auto may_meet_in = [rule](int viseme) {
    const auto v = static_cast<Viseme>(viseme);
    if (rule == MeetRule::kBilabialsAndSilences) return v == Viseme::kSilence || v == Viseme::kPP;
    return !(v == Viseme::kAA || v == Viseme::kE || v == Viseme::kIH || v == Viseme::kOH || v == Viseme::kOU);
  };
  std::vector<char> may(times.size(), 1);
  for (size_t f = 0; f < times.size(); ++f) {
    for (const PhoneSegment& p : phones) {
      if (times[f] < p.start || times[f] >= p.end) continue;
      may[f] = may_meet_in(p.viseme);
      break;
    }
  }
  return may;
}

int PartLipsWhereSoundForbids(const rig::Rig& rig, const std::vector<char>& may_meet, float meet_gap,
                              float open_gap, Eigen::MatrixXf* weights) {
  int jaw = -1;
  for (int s = 0; s < rig.NumShapes(); ++s) {
    if (rig.shapes[s].name == "jawOpen") jaw = s;
  }
  if (jaw < 0) throw InvalidInputError("parting the lips needs the rig's jawOpen, it has none");
  if (weights->cols() != rig.NumShapes() || static_cast<size_t>(weights->rows()) != may_meet.size()) {
    throw InvalidInputError("parting the lips: " + std::to_string(weights->rows()) + " x " +
                            std::to_string(weights->cols()) + " weights for " + std::to_string(may_meet.size()) +
                            " frames and a rig of " + std::to_string(rig.NumShapes()) + " shapes");
  }
  rig::Vertices v;
  const float iod = NeutralIod(rig, &v);
  int parted = 0;
  for (int f = 0; f < weights->rows(); ++f) {
    if (may_meet[f]) continue;
    Eigen::VectorXf w = weights->row(f).transpose();
    if (InnerLipGap(rig, w, iod, &v) > meet_gap) continue;
    // Bisection on jawOpen in [its value, 1] for the least value whose gap reaches open_gap.
    float lo = w[jaw], hi = 1.f;
    w[jaw] = hi;
    if (InnerLipGap(rig, w, iod, &v) >= open_gap) {
      while (hi - lo > 1e-3f) {
        w[jaw] = 0.5f * (lo + hi);
        (InnerLipGap(rig, w, iod, &v) >= open_gap ? hi : lo) = w[jaw];
      }
    }
    (*weights)(f, jaw) = hi;
    ++parted;
  }
  return parted;
}

std::vector<Closure> FindClosures(const std::vector<float>& gaps, float threshold, double fps,
                                  int min_frames) {
  std::vector<Closure> out;
  const int n = static_cast<int>(gaps.size());
  int f = 0;
  while (f < n) {
    if (gaps[f] > threshold) {
      ++f;
      continue;
    }
    int end = f;
    while (end < n && gaps[end] <= threshold) ++end;
    if (end - f >= min_frames) {
      Closure c;
      c.begin = f;
      c.end = end;
      c.centre_seconds = 0.5 * (f + end - 1) / fps;
      out.push_back(c);
    }
    f = end;
  }
  return out;
}

DetectionScore MatchClosures(const std::vector<Closure>& truth, const std::vector<Closure>& found,
                             double tolerance_seconds) {
  DetectionScore s;
  s.truth = static_cast<int>(truth.size());
  s.found = static_cast<int>(found.size());
  struct Pair { double d; int t, f; };
  std::vector<Pair> pairs;
  for (int t = 0; t < s.truth; ++t) {
    for (int f = 0; f < s.found; ++f) {
      const double d = std::abs(truth[t].centre_seconds - found[f].centre_seconds);
      if (d <= tolerance_seconds) pairs.push_back({d, t, f});
    }
  }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) {
    return a.d != b.d ? a.d < b.d : (a.t != b.t ? a.t < b.t : a.f < b.f);
  });
  std::vector<char> used_t(s.truth, 0), used_f(s.found, 0);
  for (const Pair& p : pairs) {
    if (used_t[p.t] || used_f[p.f]) continue;
    used_t[p.t] = used_f[p.f] = 1;
    ++s.matched;
  }
  s.precision = s.found > 0 ? static_cast<double>(s.matched) / s.found : (s.truth == 0 ? 1. : 0.);
  s.recall = s.truth > 0 ? static_cast<double>(s.matched) / s.truth : 1.;
  s.f1 = s.precision + s.recall > 0 ? 2 * s.precision * s.recall / (s.precision + s.recall) : 0.;
  return s;
}

}  // namespace facecap::lipsync
