#include "synth/clip.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "render/framing.h"
#include "render/gbuffer_images.h"
#include "synth/samples.h"
#include "util/errors.h"
#include "util/random.h"

namespace facecap::synth {

namespace {

constexpr float kPi = 3.14159265358979f;
constexpr float kDegToRad = kPi / 180.f;

// Independent random streams of a seed.
enum Stream : uint64_t {
  kExpressionStream = 1,
  kPoseStream = 2,
  kBlinkStream = 3,
  kDriftStream = 4,
  kLightStream = 5,
  kPanStream = 6,
  kWhiteBalanceStream = 7,
  kBackgroundStream = 8,
  kDegradationSeed = 0xC0FFEE,
};

float Smoothstep01(float t) {
  t = std::clamp(t, 0.f, 1.f);
  return t * t * (3.f - 2.f * t);
}

// A keyframe of the performance: time (s), weights, pose angles (rad), offset (cm).
struct Keyframe {
  float time = 0.f;
  Eigen::VectorXf weights;
  Eigen::Vector3f angles = Eigen::Vector3f::Zero();  // pitch, yaw, roll
  Eigen::Vector3f offset = Eigen::Vector3f::Zero();
};

// Index k of the keyframe segment [k, k + 1] holding time t, and the smoothstep fraction.
void Segment(const std::vector<float>& times, float t, int* k, float* s) {
  if (times.size() == 1 || t <= times.front()) { *k = 0; *s = 0.f; return; }
  if (t >= times.back()) { *k = static_cast<int>(times.size()) - 2; *s = 1.f; return; }
  int i = static_cast<int>(std::upper_bound(times.begin(), times.end(), t) - times.begin()) - 1;
  i = std::clamp(i, 0, static_cast<int>(times.size()) - 2);
  *k = i;
  *s = Smoothstep01((t - times[i]) / (times[i + 1] - times[i]));
}

// Splits "TIME key=value, key=value" into the time and the assignments.
bool ParseKeyframeText(const std::string& text, float* time,
                       std::vector<std::pair<std::string, float>>* assignments,
                       std::string* why) {
  std::string spaced = text;
  for (char& c : spaced) if (c == ',' || c == ';' || c == '\t') c = ' ';
  std::istringstream in(spaced);
  std::string token;
  if (!(in >> token)) { *why = "empty keyframe"; return false; }
  try {
    size_t used = 0;
    *time = std::stof(token, &used);
    if (used != token.size()) throw std::invalid_argument(token);
  } catch (const std::exception&) {
    *why = "keyframe '" + text + "' does not start with a time in seconds";
    return false;
  }
  assignments->clear();
  while (in >> token) {
    const size_t eq = token.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == token.size()) {
      *why = "keyframe '" + text + "': '" + token + "' is not key=value";
      return false;
    }
    try {
      size_t used = 0;
      const std::string value = token.substr(eq + 1);
      const float v = std::stof(value, &used);
      if (used != value.size() || !std::isfinite(v)) throw std::invalid_argument(value);
      assignments->emplace_back(token.substr(0, eq), v);
    } catch (const std::exception&) {
      *why = "keyframe '" + text + "': the value of '" + token + "' is not a number";
      return false;
    }
  }
  return true;
}

std::vector<Keyframe> ScriptedKeyframes(const rig::Rig& rig, const ClipOptions& o) {
  std::vector<Keyframe> keys;
  for (const std::string& text : o.keyframes) {
    Keyframe key;
    std::vector<std::pair<std::string, float>> assignments;
    std::string why;
    if (!ParseKeyframeText(text, &key.time, &assignments, &why)) throw InvalidInputError(why);
    key.weights = Eigen::VectorXf::Zero(rig.NumShapes());
    for (const auto& [name, value] : assignments) {
      if (name == "pitch_deg") key.angles[0] = value * kDegToRad;
      else if (name == "yaw_deg") key.angles[1] = value * kDegToRad;
      else if (name == "roll_deg") key.angles[2] = value * kDegToRad;
      else if (name == "tx_cm") key.offset[0] = value;
      else if (name == "ty_cm") key.offset[1] = value;
      else if (name == "tz_cm") key.offset[2] = value;
      else {
        const int s = rig.ShapeIndex(name);
        if (s < 0) {
          throw InvalidInputError("keyframe '" + text + "': '" + name +
                                  "' is neither a shape of the rig nor one of pitch_deg, "
                                  "yaw_deg, roll_deg, tx_cm, ty_cm, tz_cm");
        }
        if (!(value >= 0.f && value <= 1.f)) {
          throw InvalidInputError("keyframe '" + text + "': weight of " + name +
                                  " must be in [0, 1]");
        }
        key.weights[s] = value;
      }
    }
    keys.push_back(key);
  }
  return keys;
}

// Sparse random expression keyframes.
std::vector<Keyframe> RandomExpressionKeyframes(const rig::Rig& rig, const ClipOptions& o,
                                                float duration) {
  SampleOptions so;
  so.sparsity_groups = o.sparsity_groups;
  so.sparsity_max_active = o.sparsity_max_active;
  const Sparsity sparsity = ResolveSparsity(rig, so);
  Rng rng(static_cast<uint64_t>(o.motion_seed), kExpressionStream);
  std::vector<Keyframe> keys;
  float t = 0.f;
  while (true) {
    Keyframe key;
    key.time = t;
    key.weights = Eigen::VectorXf::Zero(rig.NumShapes());
    const bool neutral = keys.empty() || rng.Uniform() < o.neutral_probability;
    for (size_t g = 0; g < sparsity.group_shapes.size(); ++g) {
      std::vector<int> shapes = sparsity.group_shapes[g];
      const int limit = std::min<int>(sparsity.max_active[g], static_cast<int>(shapes.size()));
      const int active = static_cast<int>(rng.UniformInt(limit + 1));
      for (int k = 0; k < active; ++k) {
        const int j = k + static_cast<int>(rng.UniformInt(static_cast<int64_t>(shapes.size()) - k));
        std::swap(shapes[k], shapes[j]);
        const float w = static_cast<float>(rng.Uniform()) * o.weight_max;
        if (!neutral) key.weights[shapes[k]] = w;
      }
    }
    keys.push_back(key);
    if (t > duration) break;
    t += o.expression_seconds * static_cast<float>(rng.Uniform(0.6, 1.4));
  }
  return keys;
}

// Random head-pose keyframes.
std::vector<Keyframe> RandomPoseKeyframes(const ClipOptions& o, float duration) {
  Rng rng(static_cast<uint64_t>(o.motion_seed), kPoseStream);
  std::vector<Keyframe> keys;
  float t = 0.f;
  bool any_extreme = false;
  while (true) {
    Keyframe key;
    float yaw_deg;
    if (!keys.empty() && rng.Uniform() < o.extreme_yaw_probability) {
      const double sign = rng.Uniform() < 0.5 ? -1.0 : 1.0;
      yaw_deg = static_cast<float>(sign * rng.Uniform(o.extreme_yaw_min_deg, o.yaw_limit_deg));
      any_extreme = true;
    } else {
      yaw_deg = static_cast<float>(rng.TruncatedNormal(0.0, o.yaw_sigma_deg, -o.yaw_limit_deg,
                                                       o.yaw_limit_deg));
    }
    const float pitch_deg = static_cast<float>(
        rng.TruncatedNormal(0.0, o.pitch_sigma_deg, -o.pitch_limit_deg, o.pitch_limit_deg));
    const float roll_deg = static_cast<float>(
        rng.TruncatedNormal(0.0, o.roll_sigma_deg, -o.roll_limit_deg, o.roll_limit_deg));
    key.angles = Eigen::Vector3f(pitch_deg, yaw_deg, roll_deg) * kDegToRad;
    if (!keys.empty()) {
      // Far turns take longer: smoothstep peaks at 1.5 times the mean speed.
      const float turn_deg = std::abs(key.angles[1] - keys.back().angles[1]) / kDegToRad;
      const float span = std::max(o.pose_seconds * static_cast<float>(rng.Uniform(0.6, 1.4)),
                                  1.5f * turn_deg / o.yaw_speed_deg);
      t += span;
    }
    key.time = t;
    keys.push_back(key);
    if (t > duration) break;
  }
  // Make sure the clip shows an extreme yaw: turn the keyframe with the largest |yaw| (not
  // the last one, which lies past the end of the clip).
  if (!any_extreme && keys.size() >= 3 && o.extreme_yaw_probability > 0.f) {
    size_t best = 1;
    for (size_t k = 1; k + 1 < keys.size(); ++k) {
      if (std::abs(keys[k].angles[1]) > std::abs(keys[best].angles[1])) best = k;
    }
    const float sign = keys[best].angles[1] < 0.f ? -1.f : 1.f;
    const float yaw_deg = 0.5f * (o.extreme_yaw_min_deg + o.yaw_limit_deg);
    keys[best].angles[1] = sign * yaw_deg * kDegToRad;
    // Keep the turn speed bounded: delay the later keyframes where a turn grew.
    for (size_t k = best; k < keys.size(); ++k) {
      const float turn_deg = std::abs(keys[k].angles[1] - keys[k - 1].angles[1]) / kDegToRad;
      const float deficit = 1.5f * turn_deg / o.yaw_speed_deg - (keys[k].time - keys[k - 1].time);
      if (deficit > 0.f) {
        for (size_t j = k; j < keys.size(); ++j) keys[j].time += deficit;
      }
    }
  }
  return keys;
}

}  // namespace

bool ClipOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& text) { *why = text; return false; };
  if (frames <= 0) return fail("frames must be positive, got " + std::to_string(frames));
  if (frames > 10000000) return fail("frames must be at most 10,000,000");
  if (!(fps > 0.f && fps <= 1000.f)) return fail("fps must be in (0, 1000]");
  if (size < 16 || size > 4096) return fail("size must be in [16, 4096], got " + std::to_string(size));
  if (supersample < 1 || supersample > 8) return fail("supersample must be in [1, 8]");
  if (!(fov_deg > 1.f && fov_deg < 120.f)) return fail("fov_deg must be in (1, 120)");
  if (!(fill > 0.1f && fill <= 2.f)) return fail("fill must be in (0.1, 2]");
  if (identity_seed < 0) return fail("identity_seed must be >= 0 (0: the mean face)");
  if (!(identity_magnitude >= 0.f && identity_magnitude <= 3.f)) {
    return fail("identity_magnitude must be in [0, 3]");
  }
  if (!(expression_seconds >= 0.05f)) return fail("expression_seconds must be >= 0.05");
  if (!(neutral_probability >= 0.f && neutral_probability <= 1.f)) {
    return fail("neutral_probability must be in [0, 1]");
  }
  if (!(weight_max > 0.f && weight_max <= 1.f)) return fail("weight_max must be in (0, 1]");
  if (sparsity_groups.size() != sparsity_max_active.size()) {
    return fail("sparsity_groups has " + std::to_string(sparsity_groups.size()) +
                " entries but sparsity_max_active has " + std::to_string(sparsity_max_active.size()));
  }
  for (size_t g = 0; g < sparsity_groups.size(); ++g) {
    if (sparsity_groups[g].empty()) return fail("sparsity_groups has an empty prefix");
    if (sparsity_max_active[g] < 0) {
      return fail("sparsity_max_active for '" + sparsity_groups[g] + "' is negative");
    }
  }
  if (!(blinks_per_minute >= 0.f && blinks_per_minute <= 120.f)) {
    return fail("blinks_per_minute must be in [0, 120]");
  }
  if (!(blink_seconds >= 0.05f && blink_seconds <= 2.f)) return fail("blink_seconds must be in [0.05, 2]");
  if (!(pose_seconds >= 0.05f)) return fail("pose_seconds must be >= 0.05");
  if (!(yaw_speed_deg > 0.f)) return fail("yaw_speed_deg must be positive");
  if (!(yaw_limit_deg >= 0.f && yaw_limit_deg <= 90.f)) return fail("yaw_limit_deg must be in [0, 90]");
  if (!(pitch_limit_deg >= 0.f && pitch_limit_deg <= 60.f)) return fail("pitch_limit_deg must be in [0, 60]");
  if (!(roll_limit_deg >= 0.f && roll_limit_deg <= 60.f)) return fail("roll_limit_deg must be in [0, 60]");
  if (!(yaw_sigma_deg >= 0.f) || !(pitch_sigma_deg >= 0.f) || !(roll_sigma_deg >= 0.f)) {
    return fail("yaw_sigma_deg, pitch_sigma_deg and roll_sigma_deg must be >= 0");
  }
  if (!(extreme_yaw_probability >= 0.f && extreme_yaw_probability <= 1.f)) {
    return fail("extreme_yaw_probability must be in [0, 1]");
  }
  if (extreme_yaw_probability > 0.f && !(extreme_yaw_min_deg >= 0.f && extreme_yaw_min_deg <= yaw_limit_deg)) {
    return fail("the extreme-yaw range [extreme_yaw_min_deg, yaw_limit_deg] = [" +
                std::to_string(extreme_yaw_min_deg) + ", " + std::to_string(yaw_limit_deg) +
                "] is empty; lower extreme_yaw_min_deg or set extreme_yaw_probability = 0");
  }
  if (!(translation_jitter_cm >= 0.f && translation_jitter_cm <= 20.f)) {
    return fail("translation_jitter_cm must be in [0, 20]");
  }
  if (!(light_period_seconds > 0.f)) return fail("light_period_seconds must be positive");
  if (!(key_intensity >= 0.f && key_intensity <= 20.f)) return fail("key_intensity must be in [0, 20]");
  if (!(environment_intensity >= 0.f && environment_intensity <= 20.f)) {
    return fail("environment_intensity must be in [0, 20]");
  }
  float previous = -1e30f;
  for (const std::string& text : keyframes) {
    float time = 0.f;
    std::vector<std::pair<std::string, float>> assignments;
    if (!ParseKeyframeText(text, &time, &assignments, why)) return false;
    if (!(time > previous)) return fail("keyframe times must be strictly ascending: '" + text + "'");
    previous = time;
  }
  if (!texture.Check(why)) return false;
  return degradation.Check(why);
}

std::vector<ClipFrameParams> MakeClipTrajectory(const rig::Rig& rig, const ClipOptions& o) {
  std::string why;
  if (!o.Check(&why)) throw InvalidInputError("synth clip: " + why);
  const int S = rig.NumShapes();
  const float duration = static_cast<float>(o.frames - 1) / o.fps;
  std::vector<ClipFrameParams> frames(o.frames);

  if (!o.keyframes.empty()) {
    const std::vector<Keyframe> keys = ScriptedKeyframes(rig, o);
    std::vector<float> times;
    for (const Keyframe& k : keys) times.push_back(k.time);
    for (int f = 0; f < o.frames; ++f) {
      int k;
      float s;
      Segment(times, f / o.fps, &k, &s);
      const Keyframe& a = keys[k];
      const Keyframe& b = keys.size() > 1 ? keys[k + 1] : keys[k];
      ClipFrameParams& p = frames[f];
      p.weights = a.weights + s * (b.weights - a.weights);
      const Eigen::Vector3f angles = a.angles + s * (b.angles - a.angles);
      p.pitch = angles[0];
      p.yaw = angles[1];
      p.roll = angles[2];
      p.translation_offset = a.offset + s * (b.offset - a.offset);
    }
    return frames;
  }

  const std::vector<Keyframe> expressions = RandomExpressionKeyframes(rig, o, duration);
  const std::vector<Keyframe> poses = RandomPoseKeyframes(o, duration);
  std::vector<float> expression_times, pose_times;
  for (const Keyframe& k : expressions) expression_times.push_back(k.time);
  for (const Keyframe& k : poses) pose_times.push_back(k.time);

  // Blinks: a renewal process with exponential gaps (at least two blink lengths).
  std::vector<float> blink_starts;
  if (o.blinks_per_minute > 0.f) {
    Rng rng(static_cast<uint64_t>(o.motion_seed), kBlinkStream);
    const float mean_gap = 60.f / o.blinks_per_minute;
    float t = static_cast<float>(rng.Uniform()) * mean_gap;
    while (t < duration + o.blink_seconds) {
      blink_starts.push_back(t);
      const float gap = static_cast<float>(-std::log(1.0 - rng.Uniform())) * mean_gap;
      t += std::max(gap, 2.f * o.blink_seconds);
    }
  }
  const int blink_left = rig.ShapeIndex("eyeBlinkLeft"), blink_right = rig.ShapeIndex("eyeBlinkRight");

  // Drift: two sinusoids per axis.
  Rng drift_rng(static_cast<uint64_t>(o.motion_seed), kDriftStream);
  float drift_freq[3][2], drift_phase[3][2];
  for (int a = 0; a < 3; ++a) {
    for (int h = 0; h < 2; ++h) {
      drift_freq[a][h] = static_cast<float>(drift_rng.Uniform(0.08, 0.35)) * (h + 1);
      drift_phase[a][h] = static_cast<float>(drift_rng.Uniform()) * 2.f * kPi;
    }
  }

  for (int f = 0; f < o.frames; ++f) {
    const float t = f / o.fps;
    ClipFrameParams& p = frames[f];
    int k;
    float s;
    Segment(expression_times, t, &k, &s);
    p.weights = expressions[k].weights + s * (expressions[k + 1].weights - expressions[k].weights);
    if (p.weights.size() != S) p.weights = Eigen::VectorXf::Zero(S);
    float blink = 0.f;
    for (float start : blink_starts) {
      const float u = (t - start) / o.blink_seconds;
      if (u > 0.f && u < 1.f) blink = std::max(blink, std::pow(std::sin(kPi * u), 2.f));
    }
    if (blink_left >= 0) p.weights[blink_left] = std::max(p.weights[blink_left], blink);
    if (blink_right >= 0) p.weights[blink_right] = std::max(p.weights[blink_right], blink);
    p.weights = p.weights.cwiseMax(0.f).cwiseMin(1.f);

    Segment(pose_times, t, &k, &s);
    const Eigen::Vector3f angles = poses[k].angles + s * (poses[k + 1].angles - poses[k].angles);
    p.pitch = angles[0];
    p.yaw = angles[1];
    p.roll = angles[2];
    for (int a = 0; a < 3; ++a) {
      const float v = 0.65f * std::sin(2.f * kPi * drift_freq[a][0] * t + drift_phase[a][0]) +
                      0.35f * std::sin(2.f * kPi * drift_freq[a][1] * t + drift_phase[a][1]);
      p.translation_offset[a] = o.translation_jitter_cm * (a == 2 ? 2.f : 1.f) * v;
    }
  }
  return frames;
}

render::Lighting ClipLighting(const ClipOptions& o, int64_t frame) {
  Rng rng(static_cast<uint64_t>(o.lighting_seed), kLightStream);
  const float t = static_cast<float>(frame) / o.fps;
  // Clip constants.
  const float warmth = static_cast<float>(rng.Uniform());
  const Eigen::Vector3f warm(1.0f, 0.86f, 0.72f), cool(0.82f, 0.9f, 1.05f);
  const Eigen::Vector3f key_color = cool + warmth * (warm - cool);
  const Eigen::Vector3f fill_color = warm + cool - key_color;
  const float azimuth0 = static_cast<float>(rng.Uniform(-70.0, 70.0)) * kDegToRad;
  const float swing = static_cast<float>(rng.Uniform(20.0, 60.0)) * kDegToRad;
  const float period = o.light_period_seconds * static_cast<float>(rng.Uniform(0.7, 1.3));
  const float phase = static_cast<float>(rng.Uniform()) * 2.f * kPi;
  const float elevation0 = static_cast<float>(rng.Uniform(5.0, 50.0)) * kDegToRad;
  const float key_gain = o.key_intensity * static_cast<float>(rng.Uniform(0.7, 1.2));
  const float flicker_phase = static_cast<float>(rng.Uniform()) * 2.f * kPi;
  const float fill_ratio = static_cast<float>(rng.Uniform(0.1, 0.4));
  const Eigen::Vector3f environment_color(static_cast<float>(rng.Uniform(0.75, 1.15)),
                                          static_cast<float>(rng.Uniform(0.8, 1.1)),
                                          static_cast<float>(rng.Uniform(0.75, 1.2)));
  const float sky_ratio = static_cast<float>(rng.Uniform(0.1, 0.5));
  const float env_gain = o.environment_intensity * static_cast<float>(rng.Uniform(0.7, 1.3));

  // Motion over time.
  const float azimuth = azimuth0 + swing * std::sin(2.f * kPi * t / period + phase);
  const float elevation = elevation0 + 0.15f * std::sin(2.f * kPi * t / (1.7f * period) + phase);
  const float intensity = key_gain * (1.f + 0.15f * std::sin(2.f * kPi * t / (0.63f * period) + flicker_phase));
  render::Lighting lighting;
  lighting.ambient = Eigen::Vector3f::Constant(0.02f);
  lighting.directional_lights.clear();
  render::DirectionalLight key;
  key.direction = Eigen::Vector3f(std::sin(azimuth) * std::cos(elevation), std::sin(elevation),
                                  std::cos(azimuth) * std::cos(elevation));
  key.color = intensity * key_color;
  lighting.directional_lights.push_back(key);
  render::DirectionalLight fill;
  fill.direction = Eigen::Vector3f(-0.8f * std::sin(azimuth), 0.1f, 0.8f).normalized();
  fill.color = fill_ratio * key_gain * fill_color;
  lighting.directional_lights.push_back(fill);
  // Environment: a constant term and light from above (Y_1^-1 ~ y), slowly breathing.
  const float env = env_gain * (1.f + 0.1f * std::sin(2.f * kPi * t / (1.3f * period)));
  lighting.spherical_harmonics.row(0) = env * std::sqrt(4.f * kPi) * environment_color.transpose();
  lighting.spherical_harmonics.row(1) =
      sky_ratio * env * std::sqrt(4.f * kPi / 3.f) * environment_color.transpose();
  return lighting;
}

ClipRenderer::ClipRenderer(const rig::Rig& person, const ClipOptions& options,
                           const Image8* background_photo)
    : person_(person), options_(options), evaluator_(person) {
  std::string why;
  if (!options.Check(&why)) throw InvalidInputError("synth clip: " + why);
  camera_ = render::Camera::FromFov(options.size, options.size, options.fov_deg);
  const int fine = options.size * options.supersample;
  camera_fine_ = render::Camera::FromFov(fine, fine, options.fov_deg);
  distance_ = render::FramingDistance(person, camera_, options.fill);
  colors_ = DrawPersonColors(static_cast<uint64_t>(options.identity_seed));
  texture_ = MakeSkinTexture(person, colors_, static_cast<uint64_t>(options.identity_seed),
                             options.texture);
  // The background is larger than the frame so the camera can pan over it.
  const int background_size = static_cast<int>(std::lround(fine * 1.3f));
  background_ = MakeBackground(background_size, background_size,
                               static_cast<uint64_t>(options.background_seed) * 7919u + kBackgroundStream,
                               background_photo, &background_kind_);
  Rng rng(static_cast<uint64_t>(options.camera_seed), kWhiteBalanceStream);
  for (int c = 0; c < 3; ++c) {
    white_balance_[c] = 1.f + options.degradation.white_balance_jitter *
                                  static_cast<float>(std::clamp(rng.Normal(), -2.0, 2.0));
  }
}

void ClipRenderer::Render(int64_t frame, const ClipFrameParams& params, Workspace* w,
                          Frame* out) const {
  const ClipOptions& o = options_;
  out->pose = render::FramedPose(person_, distance_, params.pitch, params.yaw, params.roll);
  out->pose.translation += params.translation_offset;
  evaluator_.EvaluatePosed(out->pose, params.weights, &w->posed);

  // The truth: segmentation and landmarks on the frame's camera.
  render::Rasterize(w->posed, person_.triangles, camera_, &w->gbuffer);
  render::RenderSegmentation(w->gbuffer, person_.triangle_region, person_.regions,
                             Eigen::Vector3f::Zero(), &out->segmentation);
  render::ProjectLandmarks(w->posed, person_.triangles, person_.landmarks, camera_, w->gbuffer,
                           &out->landmarks);

  // The wild frame: textured, lit, over the background, at supersample times the size.
  const render::Camera& fine = o.supersample > 1 ? camera_fine_ : camera_;
  render::GBuffer* gbuffer = &w->gbuffer;
  if (o.supersample > 1) {
    render::Rasterize(w->posed, person_.triangles, fine, &w->gbuffer_fine);
    gbuffer = &w->gbuffer_fine;
  }
  render::VertexNormals(w->posed, person_.triangles, &w->normals);
  Rng pan(static_cast<uint64_t>(o.background_seed), kPanStream);
  const float t = static_cast<float>(frame) / o.fps;
  float pan_xy[2];
  for (float& v : pan_xy) {
    const float f1 = static_cast<float>(pan.Uniform(0.03, 0.12));
    const float p1 = static_cast<float>(pan.Uniform()) * 2.f * kPi;
    const float f2 = static_cast<float>(pan.Uniform(0.15, 0.4));
    const float p2 = static_cast<float>(pan.Uniform()) * 2.f * kPi;
    v = 0.7f * std::sin(2.f * kPi * f1 * t + p1) + 0.3f * std::sin(2.f * kPi * f2 * t + p2);
  }
  const float margin = 0.5f * (background_.width - fine.width);
  BackgroundWindow(background_, 0.5f * background_.width + 0.9f * margin * pan_xy[0],
                   0.5f * background_.height + 0.9f * margin * pan_xy[1],
                   static_cast<float>(fine.width), static_cast<float>(fine.height), fine.width,
                   fine.height, &w->background);
  render::ShadingOptions shading;
  shading.albedo_source = render::AlbedoSource::kTexture;
  shading.specular_strength = 0.07f;
  shading.shininess = 14.f;
  render::RenderShaded(*gbuffer, w->posed, w->normals, person_, ClipLighting(o, frame), shading,
                       &texture_, &w->background, &w->shaded_fine);
  // Auto exposure: the face's mean luminance towards mid grey.
  double luminance = 0.0;
  int64_t covered = 0;
  for (int i = 0; i < gbuffer->NumPixels(); ++i) {
    if (gbuffer->triangle[i] < 0) continue;
    const float* c = &w->shaded_fine.data[static_cast<size_t>(i) * 3];
    luminance += 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2];
    ++covered;
  }
  const float mean = covered > 0 ? static_cast<float>(luminance / covered) : 0.2f;
  const float auto_gain = std::clamp(0.2f / std::max(mean, 1e-4f), 0.5f, 3.f);
  if (o.supersample > 1) {
    DownsampleBox(w->shaded_fine, o.supersample, &w->shaded);
  } else {
    w->shaded = w->shaded_fine;
  }
  out->degradation = DegradeFrame(w->shaded, auto_gain * white_balance_,
                                  static_cast<uint64_t>(o.camera_seed) + kDegradationSeed, frame,
                                  o.degradation, &out->image);
}

}  // namespace facecap::synth
