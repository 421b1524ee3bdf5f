// Wild clips: a person (an identity of the rig) filmed the way a camera sees a real actor,
// with the truth of every frame kept beside the pixels. The clip is a smooth performance of
// expressions and head motion, random with a seed (sparse expression keyframes under the
// per-region limits of paper 000 Sec. 7, head-pose keyframes that reach the paper's extreme
// yaws, blinks, translation jitter) or scripted keyframe by keyframe; the appearance is a
// procedural skin texture lit by lights that move over time, in front of a background, through
// a camera with blur, noise and JPEG compression (appearance.h).
//
// Every frame is a pure function of its index and the seeds (identity_seed, motion_seed,
// lighting_seed, background_seed, camera_seed): the trajectories are computed whole, and
// cheaply, wherever they are needed, so a clip is the same for any number of ranks and
// threads. Held-out people, lighting or backgrounds are other seeds.
#ifndef FACECAP_SYNTH_CLIP_H_
#define FACECAP_SYNTH_CLIP_H_

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "render/camera.h"
#include "render/landmarks.h"
#include "render/rasterizer.h"
#include "render/shading.h"
#include "rig/evaluate.h"
#include "rig/pose.h"
#include "rig/rig.h"
#include "synth/appearance.h"
#include "util/image.h"

namespace facecap::synth {

struct ClipOptions {
  int frames = 240;                // number of frames
  float fps = 30.f;                // frames per second (trajectory time and video)
  int size = 128;                  // frame width and height in pixels
  int supersample = 2;             // the wild image is rendered at size * supersample, box-filtered
  float fov_deg = 20.f;            // vertical field of view of the camera
  float fill = 0.7f;               // fraction of the frame height the face spans when frontal
  int identity_seed = 7;           // the person: rig identity modes and skin, hair, eye colours
  float identity_magnitude = 1.f;  // scale of the identity coefficients
  int motion_seed = 1;             // expressions, head motion, blinks
  int lighting_seed = 1;           // light colours, directions and their motion
  int background_seed = 1;         // background kind, colours, photo and camera pan
  int camera_seed = 1;             // exposure, white balance, blur, noise, compression

  // Expressions: keyframes about every expression_seconds (jittered), each a sparse random
  // activation (at most sparsity_max_active[g] shapes of group g, weights uniform in
  // [0, weight_max]) or, with neutral_probability, the neutral face; smoothstep in between.
  float expression_seconds = 1.2f;
  float neutral_probability = 0.25f;
  float weight_max = 1.f;
  std::vector<std::string> sparsity_groups = {"eye", "brow", "cheek", "nose",
                                              "jaw", "mouth", "tongue"};
  std::vector<int> sparsity_max_active = {2, 2, 1, 1, 1, 3, 0};
  float blinks_per_minute = 12.f;  // eyeBlinkLeft/Right pulses of blink_seconds; 0: none
  float blink_seconds = 0.3f;

  // Head pose: keyframes about every pose_seconds (jittered), smoothstep in between. Yaw is
  // Gaussian (yaw_sigma_deg) or, with extreme_yaw_probability, |yaw| in
  // [extreme_yaw_min_deg, yaw_limit_deg] (the paper's extreme yaws; a clip with three or more
  // pose keyframes and a non-zero probability has at least one); all angles truncated to
  // their limits. The head drifts by up to translation_jitter_cm (x, y; twice that in depth).
  float pose_seconds = 1.8f;
  float yaw_speed_deg = 150.f;     // peak yaw speed (deg/s): far turns take longer
  float yaw_sigma_deg = 30.f;
  float yaw_limit_deg = 80.f;
  float extreme_yaw_probability = 0.2f;
  float extreme_yaw_min_deg = 60.f;
  float pitch_sigma_deg = 8.f;
  float pitch_limit_deg = 20.f;
  float roll_sigma_deg = 5.f;
  float roll_limit_deg = 15.f;
  float translation_jitter_cm = 1.f;

  // A scripted performance instead of the random one: one keyframe per entry,
  // "TIME key=value key=value ..." with TIME in seconds (ascending), keys the rig's shape
  // names (weights in [0, 1]) and pitch_deg, yaw_deg, roll_deg, tx_cm, ty_cm, tz_cm; keys not
  // given are 0. Smoothstep between keyframes, held before the first and after the last.
  std::vector<std::string> keyframes = {};

  // Lighting: a key light whose direction swings about the head with period
  // light_period_seconds, a weaker fill, and a coloured spherical-harmonics environment.
  float light_period_seconds = 7.f;
  float key_intensity = 1.6f;      // mean radiance scale of the key light
  float environment_intensity = 0.45f;  // mean radiance of the SH environment

  SkinTextureOptions texture;            // the person's albedo texture
  CameraDegradationOptions degradation;  // exposure, blur, noise, JPEG

  // The performance, lights, skin and camera options are grouped by concern ("group.key":
  // the job-file table [synth.clip.group]).
  template <class V>
  void Visit(V&& v) {
    v("frames", frames, "number of frames");
    v("fps", fps, "frames per second");
    v("size", size, "frame width and height in pixels");
    v("supersample", supersample, "render the wild image at size * supersample and box-filter it");
    v("fov_deg", fov_deg, "vertical field of view of the camera in degrees");
    v("fill", fill, "fraction of the frame height the face (68 landmarks) spans when frontal");
    v("identity_seed", identity_seed, "the person: identity modes and colours (0: the mean face)");
    v("identity_magnitude", identity_magnitude, "scale of the identity coefficients");
    v("motion_seed", motion_seed, "seed of expressions, head motion and blinks");
    v("lighting_seed", lighting_seed, "seed of light colours, directions and motion");
    v("background_seed", background_seed, "seed of the background and the camera pan");
    v("camera_seed", camera_seed, "seed of exposure, white balance, blur, noise, compression");
    v("expressions.expression_seconds", expression_seconds, "mean time between expression keyframes (s)");
    v("expressions.neutral_probability", neutral_probability, "chance that an expression keyframe is neutral");
    v("expressions.weight_max", weight_max, "largest weight of a random expression keyframe");
    v("expressions.sparsity_groups", sparsity_groups, "shape-name prefixes of the face regions");
    v("expressions.sparsity_max_active", sparsity_max_active,
      "most active shapes per region in an expression keyframe, one per group");
    v("expressions.blinks_per_minute", blinks_per_minute, "mean blink rate (0: no blinks)");
    v("expressions.blink_seconds", blink_seconds, "duration of a blink (s)");
    v("head_motion.pose_seconds", pose_seconds, "mean time between head-pose keyframes (s)");
    v("head_motion.yaw_speed_deg", yaw_speed_deg, "peak yaw speed (deg/s); far turns take longer");
    v("head_motion.yaw_sigma_deg", yaw_sigma_deg, "sigma of the Gaussian yaw keyframes (deg)");
    v("head_motion.yaw_limit_deg", yaw_limit_deg, "yaw is truncated to [-limit, limit] (deg)");
    v("head_motion.extreme_yaw_probability", extreme_yaw_probability,
      "chance that a pose keyframe turns to an extreme yaw");
    v("head_motion.extreme_yaw_min_deg", extreme_yaw_min_deg, "smallest |yaw| of an extreme-yaw keyframe");
    v("head_motion.pitch_sigma_deg", pitch_sigma_deg, "sigma of the pitch keyframes (deg)");
    v("head_motion.pitch_limit_deg", pitch_limit_deg, "pitch is truncated to [-limit, limit] (deg)");
    v("head_motion.roll_sigma_deg", roll_sigma_deg, "sigma of the roll keyframes (deg)");
    v("head_motion.roll_limit_deg", roll_limit_deg, "roll is truncated to [-limit, limit] (deg)");
    v("head_motion.translation_jitter_cm", translation_jitter_cm, "head drift in x and y (cm; twice in depth)");
    v("head_motion.keyframes", keyframes,
      "scripted keyframes \"TIME key=value ...\" (shape names, pitch_deg, yaw_deg, roll_deg, "
      "tx_cm, ty_cm, tz_cm); empty: random performance");
    v("lighting.light_period_seconds", light_period_seconds, "period of the key light's swing (s)");
    v("lighting.key_intensity", key_intensity, "mean radiance scale of the key light");
    v("lighting.environment_intensity", environment_intensity, "mean radiance of the SH environment");
    v("skin.texture_size", texture.texture_size, "albedo texture width and height (texels)");
    v("skin.blotch_strength", texture.blotch_strength, "low-frequency skin tone variation");
    v("skin.pore_strength", texture.pore_strength, "fine pore noise of the skin");
    v("skin.cheek_redness", texture.cheek_redness, "redness of cheeks and nose");
    v("skin.lash_darkness", texture.lash_darkness, "darkening of the lash lines, [0, 1]");
    v("skin.occlusion_strength", texture.occlusion_strength,
      "darkening of cavities (eye sockets, nostrils, folds), [0, 1]");
    v("camera.exposure_min", degradation.exposure_min, "smallest exposure gain");
    v("camera.exposure_max", degradation.exposure_max, "largest exposure gain");
    v("camera.white_balance_jitter", degradation.white_balance_jitter,
      "relative per-channel gain jitter of the clip");
    v("camera.defocus_sigma_min", degradation.defocus_sigma_min, "smallest defocus blur sigma (px)");
    v("camera.defocus_sigma_max", degradation.defocus_sigma_max, "largest defocus blur sigma (px)");
    v("camera.motion_blur_max", degradation.motion_blur_max, "longest motion-blur streak (px)");
    v("camera.motion_blur_probability", degradation.motion_blur_probability,
      "fraction of frames with motion blur");
    v("camera.noise_sigma_min", degradation.noise_sigma_min, "smallest sensor noise sigma (8-bit levels)");
    v("camera.noise_sigma_max", degradation.noise_sigma_max, "largest sensor noise sigma (8-bit levels)");
    v("camera.jpeg_quality_min", degradation.jpeg_quality_min, "lowest JPEG quality (1-100)");
    v("camera.jpeg_quality_max", degradation.jpeg_quality_max, "highest JPEG quality (0: no JPEG)");
  }
  bool Check(std::string* why) const;
};

// The truth of one frame.
struct ClipFrameParams {
  float pitch = 0.f;  // rad
  float yaw = 0.f;    // rad
  float roll = 0.f;   // rad
  Eigen::Vector3f translation_offset = Eigen::Vector3f::Zero();  // cm, added to the framing
  Eigen::VectorXf weights;                                       // #S, in [0, 1]
};

// The whole performance: random from options.motion_seed, or the scripted keyframes.
// InvalidInputError for a keyframe that does not parse, names an unknown shape, or is out of
// order, and for sparsity groups that match no shape of the rig.
std::vector<ClipFrameParams> MakeClipTrajectory(const rig::Rig& rig, const ClipOptions& options);

// The lights of frame `frame` (camera space), from options.lighting_seed.
render::Lighting ClipLighting(const ClipOptions& options, int64_t frame);

// Everything a frame's renders need that is the same for every frame; build it once per
// rank, then Render from any number of threads (one workspace each).
class ClipRenderer {
 public:
  // `person` is the personalised rig (rig::WithIdentity); `background_photo` an optional
  // 8-bit photo for the background (nullptr or empty: procedural).
  ClipRenderer(const rig::Rig& person, const ClipOptions& options,
               const Image8* background_photo);

  // Per-thread scratch buffers.
  struct Workspace {
    rig::Vertices posed;
    rig::Vertices normals;
    render::GBuffer gbuffer;
    render::GBuffer gbuffer_fine;
    ImageF shaded_fine;
    ImageF shaded;
    ImageF background;
  };
  // One frame's outputs.
  struct Frame {
    Image8 image;         // the wild frame, size x size sRGB
    Image8 segmentation;  // the flat segmentation render of the same parameters and camera
    std::vector<render::Landmark2D> landmarks;  // 68, on the segmentation's camera
    rig::RigidPose pose;                        // full rigid pose (framing + offset)
    FrameDegradation degradation;
  };
  void Render(int64_t frame, const ClipFrameParams& params, Workspace* workspace,
              Frame* out) const;

  const render::Camera& camera() const { return camera_; }
  float distance() const { return distance_; }
  const ImageF& albedo_texture() const { return texture_; }
  const PersonColors& colors() const { return colors_; }
  BackgroundKind background_kind() const { return background_kind_; }

 private:
  const rig::Rig& person_;
  ClipOptions options_;
  rig::RigEvaluator evaluator_;
  render::Camera camera_, camera_fine_;
  float distance_ = 0.f;
  PersonColors colors_;
  ImageF texture_;
  ImageF background_;
  BackgroundKind background_kind_ = BackgroundKind::kGradient;
  Eigen::Vector3f white_balance_ = Eigen::Vector3f::Ones();
};

}  // namespace facecap::synth

#endif  // FACECAP_SYNTH_CLIP_H_
