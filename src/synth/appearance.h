// How a camera sees a person, for wild clips: a procedural skin-like albedo texture in the
// rig's UV space, backgrounds, and the degradations of a real camera (defocus and motion
// blur, sensor noise, JPEG compression). Everything is a pure function of its seeds, so any
// frame can be made alone on any rank.
//
// The texture is baked in UV space: every texel learns which triangle covers it, hence its
// face region (by the region's name: skin, lips, brows, eyelids, sclera, iris, pupil, hair,
// neck, mouth interior) and its position on the neutral mesh, and its colour is a function
// of both: a base tone drawn per person, 3D noise (low-frequency blotches, fine pores) that
// is continuous across UV seams, redder cheeks, nose and lips, dark lash lines, darker
// brows, coloured irises and hair.
//
// OpenCV stays inside appearance.cpp.
#ifndef FACECAP_SYNTH_APPEARANCE_H_
#define FACECAP_SYNTH_APPEARANCE_H_

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "rig/rig.h"
#include "util/image.h"

namespace facecap::synth {

// The colours of one person, linear RGB in [0, 1].
struct PersonColors {
  Eigen::Vector3f skin{0.6f, 0.4f, 0.3f};    // base skin albedo
  Eigen::Vector3f lips{0.5f, 0.2f, 0.2f};    // lip albedo
  Eigen::Vector3f hair{0.05f, 0.03f, 0.02f}; // scalp and brow hair
  Eigen::Vector3f iris{0.1f, 0.05f, 0.02f};  // iris
  Eigen::Vector3f sclera{0.7f, 0.65f, 0.6f}; // eye white
};

// A person's colours drawn from `seed`: skin tones from light to dark, lips redder than the
// skin, hair black, brown, blond, red or grey, irises brown, hazel, green, blue or grey.
PersonColors DrawPersonColors(uint64_t seed);

struct SkinTextureOptions {
  int texture_size = 512;          // albedo texture width and height in texels
  float blotch_strength = 0.12f;   // relative amplitude of the low-frequency tone variation
  float pore_strength = 0.10f;     // relative amplitude of the fine pore noise
  float cheek_redness = 0.35f;     // how much cheeks, nose tip and ears shift towards red
  float lash_darkness = 0.75f;     // darkening of the eyelid margins (lash lines), [0, 1]
  float occlusion_strength = 0.45f; // darkening of cavities (sockets, nostrils, folds), [0, 1]

  bool Check(std::string* why) const;
};

// Bakes the albedo texture (linear RGB, texture_size^2, OBJ UV convention as in
// render::SampleBilinear) of `rig` for a person with `colors`; `seed` drives the noise.
// Texels that no triangle covers take the colour of the nearest covered texel, so bilinear
// lookups near chart borders do not bleed. The rig needs uvs, uv_triangles, triangle_region
// and its 68 landmarks (they place cheeks and lash lines); InvalidInputError otherwise.
ImageF MakeSkinTexture(const rig::Rig& rig, const PersonColors& colors, uint64_t seed,
                       const SkinTextureOptions& options);

enum class BackgroundKind { kGradient, kBlobs, kStripes, kPhoto };

// A background of width x height, linear RGB. The kind and its colours come from `seed`: a
// gradient with a soft light fall-off, blurred colour blobs (out-of-focus room lights and
// objects), or soft stripes (curtains, shelves); with a non-empty `photo` (8-bit sRGB) it
// is that photo, cropped at a seed-chosen place and scaled to fill. `kind` receives the kind.
ImageF MakeBackground(int width, int height, uint64_t seed, const Image8* photo = nullptr,
                      BackgroundKind* kind = nullptr);

// The rectangle of `background` centred at (center_x, center_y) with size window_width x
// window_height (background pixels), resampled bilinearly to width x height: a camera that
// pans and zooms over a background larger than the frame.
void BackgroundWindow(const ImageF& background, float center_x, float center_y,
                      float window_width, float window_height, int width, int height,
                      ImageF* window);

// Box-filter downsampling of a linear image by an integer factor (antialiasing of a render
// made at factor times the resolution). factor 1 copies.
void DownsampleBox(const ImageF& image, int factor, ImageF* out);

// A real camera's degradations, each drawn per frame from its range.
struct CameraDegradationOptions {
  float exposure_min = 0.8f;          // linear gain range of the frame (auto exposure)
  float exposure_max = 1.25f;
  float white_balance_jitter = 0.06f; // per-channel gain jitter (relative) per clip
  float defocus_sigma_min = 0.f;      // Gaussian blur sigma range, output pixels
  float defocus_sigma_max = 0.8f;
  float motion_blur_max = 3.f;        // longest motion-blur streak, output pixels
  float motion_blur_probability = 0.3f;  // fraction of frames with motion blur
  float noise_sigma_min = 1.f;        // sensor noise sigma range, 8-bit levels (at mid grey)
  float noise_sigma_max = 5.f;
  int jpeg_quality_min = 35;          // JPEG quality range (1-100); 0 max: no compression
  int jpeg_quality_max = 90;

  bool Check(std::string* why) const;
};

// What DegradeFrame drew (stored beside the frame).
struct FrameDegradation {
  float exposure = 1.f;
  float defocus_sigma = 0.f;
  float motion_blur_length = 0.f;
  float motion_blur_angle = 0.f;  // rad
  float noise_sigma = 0.f;
  int jpeg_quality = 0;           // 0: none
};

// Applies exposure and white balance (`white_balance` per-channel gains), defocus and motion
// blur to the linear frame, encodes it to 8-bit sRGB, adds sensor noise (shot plus read
// noise) and passes it through JPEG. All draws come from Rng(seed, frame).
FrameDegradation DegradeFrame(const ImageF& linear, const Eigen::Vector3f& white_balance,
                              uint64_t seed, int64_t frame,
                              const CameraDegradationOptions& options, Image8* image);

// Writes frames (8-bit RGB, all of one size) to a video file with OpenCV's ffmpeg backend:
// codec avc1 (H.264) when the build has it, else mp4v. OutputError when no codec opens.
// Returns the codec used.
std::string WriteVideo(const std::string& path, const std::vector<Image8>& frames, double fps);

// Nearest-neighbour upscale by an integer factor (for viewing small frames in sheets).
Image8 UpscaleNearest(const Image8& image, int factor);

}  // namespace facecap::synth

#endif  // FACECAP_SYNTH_APPEARANCE_H_
