// Deterministic procedural demo head: a closed, UV-mapped head mesh with eyeballs, eyelids that
// close, a lip slit in front of a closed mouth cavity, 12+ segmentation regions, 68 iBUG
// landmarks, the 52 ARKit shapes (jaw shapes through jaw skinning, paper 000 Sec. 6) and smooth
// identity modes. It is the stand-in for a personalised rig wherever the papers use one.
//
// Construction: the skin is one (row, column) grid over a profile-swept head (superellipse
// cross-sections stacked along a sagittal profile) with sculpted height fields for nose, brows,
// sockets, cheeks, lips and chin. The eye slits and the mouth slit are grid rows whose interior
// vertices are doubled (upper and lower margin); each hole is closed by a pocket (eye socket,
// mouth cavity). Eyelids open by warping grid rows away from the slit over a shell that covers
// the eyeball, so a blink is the same surface with the warp undone. Identity modes are finite
// differences of the builder with respect to its shape parameters.
#ifndef FACECAP_RIG_DEMO_HEAD_H_
#define FACECAP_RIG_DEMO_HEAD_H_

#include <string>
#include <vector>

#include "rig/rig.h"

namespace facecap::rig {

struct DemoHeadOptions {
  // Grid columns around the head at the default 100 (about 9,000 vertices); rows and all
  // feature spans scale with it. Range [60, 300].
  int resolution = 100;
  // Number of identity modes to build (rig.identity_modes). Range [0, MaxDemoIdentityModes()].
  int num_identity_modes = 24;
  // Longitude segments of each eyeball sphere; it has half as many latitude bands. Range [8, 64].
  int eyeball_segments = 16;
  // Jaw rotation of jawOpen about +x at weight 1 (degrees). Range (0, 40].
  float jaw_open_degrees = 22.f;
  // Eyeball rotation of eyeLookIn/Out at weight 1 (degrees); up/down use 0.8 times it.
  float eye_look_degrees = 25.f;
  // Scale of every identity mode (1 = one standard deviation of each shape parameter).
  float identity_mode_scale = 1.f;

  // Returns false and says which field is out of range.
  bool Check(std::string* why) const;
};

// Number of identity modes the demo head can provide.
int MaxDemoIdentityModes();

// Names of the identity modes, in the order of rig.identity_modes ("nose_length", ...).
const std::vector<std::string>& DemoIdentityModeNames();

// Builds the demo head: the mean face with its shapes, regions, landmarks and identity modes.
// The same options give byte-identical output. Throws std::invalid_argument when !Check().
Rig MakeDemoHead(const DemoHeadOptions& options = DemoHeadOptions());

// Returns `rig` with neutral N + magnitude * sum_k alpha_k mode_k, alpha_k ~ N(0, 1) drawn from
// `identity_seed` (std::mt19937 and an explicit Box-Muller transform, clamped to [-2.5, 2.5],
// so the draw is the same with every compiler). Seed 0 returns the mean face unchanged.
Rig WithIdentity(const Rig& rig, int identity_seed, float magnitude = 1.f);

// The identity coefficients alpha WithIdentity draws for `identity_seed` (size num_modes).
std::vector<float> DemoIdentityCoefficients(int identity_seed, int num_modes);

}  // namespace facecap::rig

#endif  // FACECAP_RIG_DEMO_HEAD_H_
