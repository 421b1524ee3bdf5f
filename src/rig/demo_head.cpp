#include "rig/demo_head.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <random>
#include <stdexcept>
#include <utility>

#include <Eigen/Geometry>

#include "rig/arkit.h"

namespace facecap::rig {
namespace {

constexpr float kPi = 3.14159265358979323846f;
constexpr float kEyeballRadius = 1.2f;  // cm

float Clamp01(float x) { return std::min(1.f, std::max(0.f, x)); }
float Smoothstep(float edge0, float edge1, float x) {
  const float t = Clamp01((x - edge0) / (edge1 - edge0));
  return t * t * (3.f - 2.f * t);
}
float Gauss(float x) { return std::exp(-x * x); }
float Lerp(float a, float b, float t) { return a + (b - a) * t; }
float Square(float x) { return x * x; }
// Polynomial smooth maximum with blend width k.
float SmoothMax(float a, float b, float k) {
  const float h = Clamp01(0.5f + 0.5f * (a - b) / k);
  return b + (a - b) * h + k * h * (1.f - h);
}
// Piecewise-linear table lookup, xs ascending.
float Table(const std::vector<std::pair<float, float>>& table, float x) {
  if (x <= table.front().first) return table.front().second;
  for (size_t k = 1; k < table.size(); ++k) {
    if (x <= table[k].first) {
      const float t = (x - table[k - 1].first) / (table[k].first - table[k - 1].first);
      return Lerp(table[k - 1].second, table[k].second, t);
    }
  }
  return table.back().second;
}

// ---- shape parameters ------------------------------------------------------------------------

// Everything that shapes one person's head; the defaults are the mean face. Lengths in cm,
// heights relative to the eye row (y = eye_y) unless a name says otherwise.
struct HeadParams {
  float width_scale = 1.f;          // scales the half-width of every cross-section above the jaw
  float front_depth_scale = 1.f;    // scales the depth of the face in front of the ear plane
  float back_depth_scale = 1.f;     // scales the depth of the skull behind the ear plane
  float crown_height = 8.8f;        // top of the head above the forehead base
  float face_length_scale = 1.f;    // scales heights below the eyes (nose base, mouth, chin)
  float jaw_width = 6.0f;           // half-width of the lower face at the jaw angle
  float neck_width = 5.2f;          // half-width of the neck
  float eye_y = 0.f;                // height of the eye slits
  float eye_half_spacing = 3.15f;   // x of each eyeball centre
  float eye_half_width = 1.42f;     // half the width of each eye opening
  float eye_recess = 1.95f;         // eyeball centre behind the undecorated face surface
  float upper_lid_open = 0.55f;     // upper lid margin above the slit at the widest point
  float lower_lid_open = 0.36f;     // lower lid margin below the slit at the widest point
  float socket_depth = 1.0f;        // depth of the eye sockets
  float brow_height = 1.75f;        // brow line above the eye row
  float brow_ridge = 0.55f;         // forward bulge of the brow ridge
  float nose_length = 3.8f;         // nasion to nose tip, vertically
  float nose_projection = 2.35f;     // nose tip in front of the face
  float nose_bridge = 0.75f;        // bridge height at the nasion
  float nose_width = 0.95f;         // half-width of the nose tip
  float ala = 0.55f;                // bulge of the nostril wings
  float mouth_y = -6.4f;            // height of the lip slit
  float mouth_half_width = 2.45f;   // half the lip slit width
  float upper_lip = 0.42f;          // forward bulge of the upper lip
  float lower_lip = 0.5f;           // forward bulge of the lower lip
  float muzzle = 0.8f;              // forward bulge of the tooth arch
  float chin_y = -10.4f;            // height of the bottom of the chin
  float chin = 0.55f;               // forward bulge of the chin
  float cheekbone = 0.45f;          // forward bulge of the cheekbones
  float cheek_fullness = 0.3f;      // forward bulge of the cheeks beside the mouth
};

struct IdentityModeDef {
  const char* name;
  float HeadParams::*member;
  float std_dev;  // one standard deviation of the parameter
};

const std::vector<IdentityModeDef>& IdentityModeDefs() {
  static const std::vector<IdentityModeDef> kDefs = {
      {"head_width", &HeadParams::width_scale, 0.045f},
      {"face_length", &HeadParams::face_length_scale, 0.05f},
      {"nose_length", &HeadParams::nose_length, 0.35f},
      {"nose_projection", &HeadParams::nose_projection, 0.3f},
      {"nose_width", &HeadParams::nose_width, 0.18f},
      {"jaw_width", &HeadParams::jaw_width, 0.4f},
      {"chin_height", &HeadParams::chin_y, 0.45f},
      {"chin_projection", &HeadParams::chin, 0.3f},
      {"eye_spacing", &HeadParams::eye_half_spacing, 0.15f},
      {"eye_height", &HeadParams::eye_y, 0.3f},
      {"upper_lip_thickness", &HeadParams::upper_lip, 0.15f},
      {"lower_lip_thickness", &HeadParams::lower_lip, 0.17f},
      {"mouth_width", &HeadParams::mouth_half_width, 0.22f},
      {"brow_height", &HeadParams::brow_height, 0.25f},
      {"brow_ridge", &HeadParams::brow_ridge, 0.2f},
      {"cheek_fullness", &HeadParams::cheek_fullness, 0.25f},
      {"cheekbones", &HeadParams::cheekbone, 0.22f},
      {"head_depth_front", &HeadParams::front_depth_scale, 0.035f},
      {"head_depth_back", &HeadParams::back_depth_scale, 0.05f},
      {"crown_height", &HeadParams::crown_height, 0.6f},
      {"nose_bridge", &HeadParams::nose_bridge, 0.25f},
      {"mouth_height", &HeadParams::mouth_y, 0.3f},
      {"neck_width", &HeadParams::neck_width, 0.4f},
      {"muzzle", &HeadParams::muzzle, 0.25f},
      {"nostril_wings", &HeadParams::ala, 0.15f},
      {"socket_depth", &HeadParams::socket_depth, 0.2f},
      {"eye_depth", &HeadParams::eye_recess, 0.1f},
  };
  return kDefs;
}

// ---- head surface ----------------------------------------------------------------------------

struct ProfileKey {
  float y;            // height of the cross-section
  float half_width;   // W: half-width at the ear plane
  float front_depth;  // depth in front of the ear plane (z of the face at x = 0)
  float back_depth;   // depth behind the ear plane
};

constexpr float kFrontExponent = 2.f / 2.5f;  // superellipse exponent of the front half
constexpr float kBackExponent = 2.f / 2.2f;   // and of the back half

// The skin as a function of (theta, t): theta is the column angle (0 at the face front,
// +pi/2 at the left ear), t the profile parameter (0 at the crown, NumKeys()-1 under the neck).
class HeadSurface {
 public:
  explicit HeadSurface(const HeadParams& p) : p_(p) {
    const float ws = p.width_scale, fs = p.front_depth_scale, bs = p.back_depth_scale;
    const float fl = p.face_length_scale;
    const float y_forehead = p.eye_y + 3.f;
    // Dome: squarish superellipse from the crown down to the forehead base.
    const int dome_keys = 7;
    for (int k = 0; k < dome_keys; ++k) {
      const float psi = 0.5f * kPi * (1.f - static_cast<float>(k) / (dome_keys - 1));
      const float c = std::pow(std::max(0.f, std::cos(psi)), 0.8f);
      const float s = std::pow(std::max(0.f, std::sin(psi)), 0.9f);
      keys_.push_back({y_forehead + p.crown_height * s, 7.45f * ws * c, 9.05f * fs * c,
                       9.9f * bs * c});
    }
    dome_end_key_ = dome_keys - 1;
    eye_key_ = static_cast<int>(keys_.size());
    keys_.push_back({p.eye_y, 7.4f * ws, 9.0f * fs, 9.6f * bs});
    keys_.push_back({p.eye_y - 3.1f * fl, 7.25f * ws, 8.9f * fs, 8.6f * bs});
    mouth_key_ = static_cast<int>(keys_.size());
    keys_.push_back({p.eye_y + p.mouth_y * fl, 6.5f * ws, 8.75f * fs, 6.9f * bs});
    keys_.push_back({p.eye_y - 8.6f * fl, p.jaw_width * ws, 8.3f * fs, 6.1f * bs});
    chin_key_ = static_cast<int>(keys_.size());
    const float y_chin = p.eye_y + p.chin_y * fl;
    keys_.push_back({y_chin, (p.jaw_width - 0.5f) * ws, 7.4f * fs, 5.9f * bs});
    keys_.push_back({y_chin - 0.9f, p.neck_width + 0.1f, 5.9f, 5.8f});
    neck_key_ = static_cast<int>(keys_.size());
    keys_.push_back({y_chin - 2.4f, p.neck_width, 4.8f, 5.7f});
    keys_.push_back({y_chin - 5.5f, p.neck_width + 0.2f, 4.9f, 5.8f});
    keys_.push_back({y_chin - 7.5f, p.neck_width + 0.6f, 5.3f, 6.1f});
    keys_.push_back({y_chin - 8.2f, 0.6f * (p.neck_width + 0.6f), 3.2f, 3.7f});
    keys_.push_back({y_chin - 8.5f, 0.f, 0.f, 0.f});
    // Monotone cubic (PCHIP) tangents per channel: no overshoot, y stays monotone.
    const int n = static_cast<int>(keys_.size());
    tangents_.resize(n);
    for (int ch = 0; ch < 4; ++ch) {
      for (int k = 0; k < n; ++k) {
        float m;
        if (k == 0) {
          m = Channel(keys_[1], ch) - Channel(keys_[0], ch);
        } else if (k == n - 1) {
          m = Channel(keys_[n - 1], ch) - Channel(keys_[n - 2], ch);
        } else {
          const float d1 = Channel(keys_[k], ch) - Channel(keys_[k - 1], ch);
          const float d2 = Channel(keys_[k + 1], ch) - Channel(keys_[k], ch);
          m = d1 * d2 <= 0.f ? 0.f : 2.f * d1 * d2 / (d1 + d2);
        }
        Channel(tangents_[k], ch) = m;
      }
    }
    // Anchors of the face features.
    y_eye_ = p.eye_y;
    y_mouth_ = keys_[mouth_key_].y;
    y_chin_ = y_chin;
    y_nasion_ = p.eye_y + 0.45f;
    y_nose_tip_ = y_nasion_ - p.nose_length * fl;
    y_subnasale_ = y_nose_tip_ - 0.75f * fl;
    // Eyeball centre: behind the undecorated eye-row surface at x = eye_half_spacing.
    const ProfileKey& eye = keys_[eye_key_];
    const float s = std::pow(std::min(0.99f, p.eye_half_spacing / eye.half_width),
                             1.f / kFrontExponent);
    const float base_z = eye.front_depth * std::pow(std::sqrt(1.f - s * s), kFrontExponent);
    eye_center_ = Eigen::Vector3f(p.eye_half_spacing, p.eye_y + 0.5f * (p.upper_lid_open - p.lower_lid_open),
                                  base_z - p.eye_recess);
  }

  int NumKeys() const { return static_cast<int>(keys_.size()); }
  int DomeEndKey() const { return dome_end_key_; }
  int EyeKey() const { return eye_key_; }
  int MouthKey() const { return mouth_key_; }
  int ChinKey() const { return chin_key_; }
  int NeckKey() const { return neck_key_; }
  float EyeY() const { return y_eye_; }
  float MouthY() const { return y_mouth_; }
  float ChinY() const { return y_chin_; }
  float NasionY() const { return y_nasion_; }
  float NoseTipY() const { return y_nose_tip_; }
  float SubnasaleY() const { return y_subnasale_; }
  // Eyeball centre of eye `side` (0: left, +x; 1: right, -x).
  Eigen::Vector3f EyeCenter(int side) const {
    Eigen::Vector3f c = eye_center_;
    if (side == 1) c.x() = -c.x();
    return c;
  }
  const HeadParams& Params() const { return p_; }

  ProfileKey Profile(float t) const {
    const int n = NumKeys();
    t = std::min(std::max(t, 0.f), static_cast<float>(n - 1));
    const int k = std::min(static_cast<int>(t), n - 2);
    const float f = t - k;
    const float h00 = 2 * f * f * f - 3 * f * f + 1, h10 = f * f * f - 2 * f * f + f;
    const float h01 = -2 * f * f * f + 3 * f * f, h11 = f * f * f - f * f;
    ProfileKey out{};
    for (int ch = 0; ch < 4; ++ch) {
      Channel(out, ch) = h00 * Channel(keys_[k], ch) + h10 * Channel(tangents_[k], ch) +
                         h01 * Channel(keys_[k + 1], ch) + h11 * Channel(tangents_[k + 1], ch);
    }
    return out;
  }

  // Profile parameter t with Profile(t).y == y, searched in [t_lo, t_hi] (y decreases with t).
  float ParameterAtHeight(float y, float t_lo, float t_hi) const {
    for (int it = 0; it < 40; ++it) {
      const float mid = 0.5f * (t_lo + t_hi);
      if (Profile(mid).y > y) t_lo = mid; else t_hi = mid;
    }
    return 0.5f * (t_lo + t_hi);
  }

  // Column angle whose front cross-section at key `key` passes through x (x >= 0).
  float ThetaAtX(float x, int key) const {
    const float s = std::pow(std::min(0.999f, x / keys_[key].half_width), 1.f / kFrontExponent);
    return std::asin(s);
  }

  // Height of the nose above the face (cm) at (x, y).
  float NoseHeight(float x, float y) const {
    const HeadParams& p = p_;
    const float fl = p.face_length_scale;
    float h, w;
    if (y >= y_nasion_) {
      h = p.nose_bridge * Gauss((y - y_nasion_) / 0.9f);
      w = 0.55f;
    } else if (y >= y_nose_tip_) {
      const float u = (y_nasion_ - y) / (y_nasion_ - y_nose_tip_);
      h = p.nose_bridge + (p.nose_projection - p.nose_bridge) * std::pow(u, 1.5f);
      w = Lerp(0.5f, p.nose_width, Smoothstep(0.f, 1.f, u));
    } else if (y >= y_subnasale_) {
      const float u = (y_nose_tip_ - y) / (y_nose_tip_ - y_subnasale_);
      h = p.nose_projection * std::sqrt(std::max(0.f, 1.f - 0.8f * u * u));
      w = p.nose_width;
    } else {
      h = p.nose_projection * std::sqrt(0.2f) * Gauss((y_subnasale_ - y) / (0.3f * fl));
      w = p.nose_width;
    }
    // Rounded tip.
    h += 0.25f * Gauss((y - y_nose_tip_ - 0.1f) / 0.5f) * Gauss(x / 0.7f);
    float height = h * Gauss(x / w);
    // Nostril wings.
    const float ala_x = 1.2f * p.nose_width;
    height += p.ala * Gauss((std::abs(x) - ala_x) / 0.42f) * Gauss((y - y_subnasale_ - 0.3f) / 0.45f);
    return height;
  }

  // Height of the brow line at |x|.
  float BrowLineY(float ax) const {
    const float u = (ax - p_.eye_half_spacing) / 2.3f;
    return y_eye_ + p_.brow_height + 0.3f * (1.f - u * u) - 0.15f * Smoothstep(0.f, 1.f, u);
  }
  // Upper and lower vermilion borders (heights) at x.
  float UpperVermilionY(float x) const {
    const float q = std::min(1.f, std::abs(x) / p_.mouth_half_width);
    return y_mouth_ + (p_.upper_lip / 0.42f) * (0.8f * std::pow(1.f - q * q, 0.45f) +
                                               0.1f * Gauss((std::abs(x) - 0.45f) / 0.25f) -
                                               0.08f * Gauss(x / 0.2f));
  }
  float LowerVermilionY(float x) const {
    const float q = std::min(1.f, std::abs(x) / p_.mouth_half_width);
    return y_mouth_ - (p_.lower_lip / 0.5f) * 0.95f * std::pow(1.f - q * q, 0.5f);
  }

  // Forward displacement of the face features at (x, y).
  float FeatureHeight(float x, float y) const {
    const HeadParams& p = p_;
    const float ax = std::abs(x);
    const float ex = p.eye_half_spacing;
    float dz = 0.f;
    // Brow ridge along the brow line, fading at the temples.
    dz += p.brow_ridge * Gauss((y - BrowLineY(ax) + 0.25f) / 0.75f) * (1.f - Smoothstep(4.f, 6.5f, ax));
    // Eye sockets.
    dz -= p.socket_depth * Gauss((ax - ex) / 1.75f) * Gauss((y - y_eye_ - 0.1f) / 1.3f);
    // Temples.
    dz -= 0.35f * Gauss((ax - 6.2f) / 1.2f) * Gauss((y - y_eye_ - 2.f) / 2.f);
    // Nose.
    dz += NoseHeight(x, y);
    // Cheekbones and cheeks.
    dz += p.cheekbone * Gauss((ax - 3.9f) / 1.35f) * Gauss((y - y_eye_ + 2.2f) / 1.2f);
    dz += p.cheek_fullness * Gauss((ax - 3.6f) / 1.5f) * Gauss((y - y_mouth_ - 1.3f) / 1.5f);
    // Nasolabial groove.
    dz -= 0.18f * Gauss((ax - 1.9f - 0.25f * (y_subnasale_ - y)) / 0.35f) *
          Gauss((y - 0.5f * (y_subnasale_ + y_mouth_)) / 1.1f);
    // Tooth arch under the lips.
    dz += p.muzzle * Gauss(x / 3.0f) * Gauss((y - y_mouth_ - 0.2f) / 2.3f);
    // Lips: two rolls meeting in a groove at the slit; corners tucked in.
    const float q = ax / p.mouth_half_width;
    const float lateral = 1.f - Smoothstep(0.35f, 1.08f, q);
    dz += p.upper_lip * lateral * Gauss((y - y_mouth_ - 0.42f) / 0.33f);
    dz += p.lower_lip * lateral * Gauss((y - y_mouth_ + 0.5f) / 0.4f);
    dz -= 0.3f * Gauss((ax - p.mouth_half_width) / 0.45f) * Gauss((y - y_mouth_) / 0.45f);
    // Philtrum.
    dz -= 0.1f * Gauss(x / 0.3f) * Smoothstep(y_mouth_ + 0.7f, y_mouth_ + 1.f, y) *
          (1.f - Smoothstep(y_subnasale_ - 0.4f, y_subnasale_, y));
    // Chin and the groove above it.
    dz -= 0.25f * Gauss(x / 2.f) * Gauss((y - y_mouth_ + 1.55f) / 0.5f);
    dz += p.chin * Gauss(x / 1.6f) * Gauss((y - y_chin_ - 1.3f) / 1.1f);
    return dz;
  }

  // Superellipse exponent of the front half at height y: rounded at the eyes and mouth, pointed
  // towards the chin, rounder again on the neck.
  float FrontExponent(float y) const {
    const float n = 2.5f - 0.8f * Smoothstep(y_mouth_ - 0.5f, y_chin_, y) +
                    0.6f * Smoothstep(y_chin_, y_chin_ - 2.5f, y);
    return 2.f / n;
  }

  // Height of the jaw line (face above, neck below) at column angle theta.
  float JawLineY(float theta) const {
    const float deg = std::abs(theta) * 180.f / kPi;
    const float ye = y_eye_, yc = y_chin_;
    return Table({{0.f, yc}, {25.f, yc + 0.35f}, {45.f, yc + 1.0f}, {62.f, yc + 1.9f},
                  {72.f, ye - 7.3f}, {80.f, ye - 5.6f}, {90.f, ye - 3.4f}, {110.f, ye - 6.0f},
                  {180.f, ye - 7.0f}},
                 deg);
  }

  // Shell over the eyeball that the closed lids lie on; -infinity outside it.
  float EyeCoverZ(float x, float y) const {
    float best = -std::numeric_limits<float>::infinity();
    for (int side = 0; side < 2; ++side) {
      const Eigen::Vector3f c = EyeCenter(side);
      const float dx = (x - c.x()) / (p_.eye_half_width + 0.45f);
      const float dy = (y - c.y()) / 1.55f;
      const float r2 = 1.f - dx * dx - dy * dy;
      if (r2 > 0.f) best = std::max(best, c.z() + (kEyeballRadius + 0.22f) * std::sqrt(r2));
    }
    return best;
  }

  Eigen::Vector3f Position(float theta, float t) const {
    const ProfileKey key = Profile(t);
    const float s = std::sin(theta), c = std::cos(theta);
    const float e = c >= 0.f ? FrontExponent(key.y) : kBackExponent;
    // Jaw edge: below the jaw line the sides of the face step in towards the neck.
    const float lateral = Smoothstep(0.2f, 0.8f, std::abs(theta)) * (1.f - Smoothstep(1.0f, 1.3f, std::abs(theta)));
    const float below_jaw = 1.f - Smoothstep(-1.2f, 0.4f, key.y - JawLineY(theta));
    const float half_width = key.half_width * (1.f - 0.08f * lateral * below_jaw);
    const float x = half_width * std::copysign(std::pow(std::abs(s), e), s);
    float z = (c >= 0.f ? key.front_depth : -key.back_depth) * std::pow(std::abs(c), e);
    const float frontness = Smoothstep(0.05f, 0.55f, c);
    if (frontness > 0.f) {
      z += frontness * FeatureHeight(x, key.y);
      const float cover = EyeCoverZ(x, key.y);
      if (cover > z - 0.5f) z = SmoothMax(z, cover, 0.2f);
    }
    return Eigen::Vector3f(x, key.y, z);
  }

 private:
  static float& Channel(ProfileKey& k, int ch) {
    return ch == 0 ? k.y : ch == 1 ? k.half_width : ch == 2 ? k.front_depth : k.back_depth;
  }
  static float Channel(const ProfileKey& k, int ch) {
    return ch == 0 ? k.y : ch == 1 ? k.half_width : ch == 2 ? k.front_depth : k.back_depth;
  }

  HeadParams p_;
  std::vector<ProfileKey> keys_, tangents_;
  int dome_end_key_ = 0, eye_key_ = 0, mouth_key_ = 0, chin_key_ = 0, neck_key_ = 0;
  float y_eye_ = 0, y_mouth_ = 0, y_chin_ = 0, y_nasion_ = 0, y_nose_tip_ = 0, y_subnasale_ = 0;
  Eigen::Vector3f eye_center_;
};

// ---- mesh layout -------------------------------------------------------------------------------

// Vertex and grid bookkeeping; depends on the options only, never on the shape parameters, so
// every identity has the same topology.
struct Layout {
  int half_cols = 0;   // H: columns from the face front (j = H) to the back (j = 0)
  int cols = 0;        // 2H, the grid wraps around
  int rows = 0;        // grid rows between the two poles
  std::vector<int> col_segments;  // columns per segment on one side: nose, eye-mouth, eye, cheek, back
  std::vector<int> row_segments;  // rows per segment: dome, forehead, midface, lower face, under chin, neck
  int row_eye = 0, row_mouth = 0, row_chin = 0;
  int k_eye_inner = 0, k_eye_outer = 0, k_mouth_corner = 0;  // column offsets from the front
  int top_pole = 0, bottom_pole = 0;
  int eye_dup_begin[2] = {0, 0};
  int eye_dup_count = 0;
  int mouth_dup_begin = 0, mouth_dup_count = 0;
  int eye_pocket_begin[2] = {0, 0};
  int eye_loop = 0;                   // vertices around an eye opening
  int mouth_pocket_begin = 0, mouth_loop = 0;
  int mouth_rings = 3;
  int eyeball_begin[2] = {0, 0};
  int eyeball_count = 0, eyeball_segments = 16, eyeball_bands = 8;
  int num_vertices = 0;

  int Grid(int i, int j) const { return i * cols + ((j % cols) + cols) % cols; }
  // Column j of offset k on side (0: +x, 1: -x).
  int Column(int side, int k) const { return side == 0 ? half_cols + k : half_cols - k; }
  // Lowest and highest column of the slit of eye `side`.
  int EyeLo(int side) const { return side == 0 ? Column(0, k_eye_inner) : Column(1, k_eye_outer); }
  int EyeHi(int side) const { return side == 0 ? Column(0, k_eye_outer) : Column(1, k_eye_inner); }
  int MouthLo() const { return half_cols - k_mouth_corner; }
  int MouthHi() const { return half_cols + k_mouth_corner; }
  // Vertex at (i, j); on a slit row, `below` picks the lower margin copy.
  int Vertex(int i, int j, bool below) const {
    j = ((j % cols) + cols) % cols;
    if (below && i == row_eye) {
      for (int side = 0; side < 2; ++side) {
        if (j > EyeLo(side) && j < EyeHi(side)) return eye_dup_begin[side] + (j - EyeLo(side) - 1);
      }
    }
    if (below && i == row_mouth && j > MouthLo() && j < MouthHi()) {
      return mouth_dup_begin + (j - MouthLo() - 1);
    }
    return Grid(i, j);
  }
  // Closed loop around an opening: lo corner, upper margin, hi corner, lower margin back.
  std::vector<int> Loop(int lo, int hi, int row) const {
    std::vector<int> loop;
    for (int j = lo; j <= hi; ++j) loop.push_back(Grid(row, j));
    for (int j = hi - 1; j > lo; --j) loop.push_back(Vertex(row, j, true));
    return loop;
  }
};

int Scaled(int base, int resolution) {
  return std::max(2, static_cast<int>(std::lround(base * resolution / 100.0)));
}

Layout MakeLayout(const DemoHeadOptions& options) {
  Layout l;
  const int r = options.resolution;
  l.col_segments = {Scaled(8, r), Scaled(4, r), Scaled(10, r), Scaled(12, r), Scaled(12, r)};
  l.row_segments = {Scaled(14, r), Scaled(12, r), Scaled(32, r), Scaled(16, r), Scaled(7, r),
                    Scaled(8, r)};
  l.half_cols = 0;
  for (int n : l.col_segments) l.half_cols += n;
  l.cols = 2 * l.half_cols;
  l.k_eye_inner = l.col_segments[0];
  l.k_mouth_corner = l.k_eye_inner + l.col_segments[1];
  l.k_eye_outer = l.k_mouth_corner + l.col_segments[2];
  l.rows = 0;
  for (int n : l.row_segments) l.rows += n;
  l.rows -= 1;  // the last segment ends at the bottom pole
  l.row_eye = l.row_segments[0] + l.row_segments[1] - 1;
  l.row_mouth = l.row_eye + l.row_segments[2];
  l.row_chin = l.row_mouth + l.row_segments[3];
  int v = l.rows * l.cols;
  l.top_pole = v++;
  l.bottom_pole = v++;
  l.eye_dup_count = l.k_eye_outer - l.k_eye_inner - 1;
  for (int side = 0; side < 2; ++side) {
    l.eye_dup_begin[side] = v;
    v += l.eye_dup_count;
  }
  l.mouth_dup_count = 2 * l.k_mouth_corner - 1;
  l.mouth_dup_begin = v;
  v += l.mouth_dup_count;
  l.eye_loop = 2 * l.eye_dup_count + 2;
  for (int side = 0; side < 2; ++side) {
    l.eye_pocket_begin[side] = v;
    v += l.eye_loop + 1;  // one inner ring and a centre
  }
  l.mouth_loop = 2 * l.mouth_dup_count + 2;
  l.mouth_pocket_begin = v;
  v += l.mouth_rings * l.mouth_loop + 1;
  l.eyeball_segments = options.eyeball_segments;
  l.eyeball_bands = std::max(4, options.eyeball_segments / 2);
  l.eyeball_count = (l.eyeball_bands - 1) * l.eyeball_segments + 2;
  for (int side = 0; side < 2; ++side) {
    l.eyeball_begin[side] = v;
    v += l.eyeball_count;
  }
  l.num_vertices = v;
  return l;
}

// Polar angles of the eyeball rings from the front pole: pupil edge, iris edge, then even.
std::vector<float> EyeballRingAngles(int bands) {
  std::vector<float> angles = {0.2f, 0.46f};
  const int rest = bands - 1 - 2;
  for (int k = 1; k <= rest; ++k) angles.push_back(0.46f + (kPi - 0.46f) * k / (rest + 1));
  return angles;
}

// ---- builder ---------------------------------------------------------------------------------

// Opening of one eye: scales of the upper and lower lid openings and how far the upper lid
// has come down to the lower one (1 = closed).
struct LidState {
  float upper_scale = 1.f;
  float lower_scale = 1.f;
  float closure = 0.f;
};

struct EyeballRotation {
  Eigen::Matrix3f rotation = Eigen::Matrix3f::Identity();
};

// Places all vertices of one head (one parameter set) on the fixed layout.
class HeadBuilder {
 public:
  HeadBuilder(const HeadParams& params, const Layout& layout)
      : surface_(params), layout_(layout) {
    PlaceRows();
    PlaceColumns();
  }

  const HeadSurface& Surface() const { return surface_; }
  const Layout& GetLayout() const { return layout_; }
  // Column angle of grid vertex (i, j): the eye-row layout above the nose, the mouth-row layout
  // below it, blended in between, so that eye and mouth features never share columns.
  float ColumnTheta(int i, int j) const {
    j = ((j % layout_.cols) + layout_.cols) % layout_.cols;
    if (j == 0) return kPi;
    return Lerp(eye_column_theta_[j], mouth_column_theta_[j], row_blend_[i]);
  }
  float RowT(int i) const { return row_t_[i]; }
  float ThetaEyeInner() const { return theta_eye_inner_; }
  float ThetaEyeOuter() const { return theta_eye_outer_; }

  // Fraction across eye `side` of column j: 0 at the inner corner, 1 at the outer corner.
  float EyeFraction(int j) const {
    j = ((j % layout_.cols) + layout_.cols) % layout_.cols;
    const float th = j == 0 ? kPi : std::abs(eye_column_theta_[j]);
    return (th - theta_eye_inner_) / (theta_eye_outer_ - theta_eye_inner_);
  }
  // Upper and lower lid openings (cm above / below the slit) at fraction u.
  float UpperOpening(float u) const {
    if (u <= 0.f || u >= 1.f) return 0.f;
    return surface_.Params().upper_lid_open * std::pow(std::sin(kPi * std::pow(u, 0.85f)), 0.7f);
  }
  float LowerOpening(float u) const {
    if (u <= 0.f || u >= 1.f) return 0.f;
    return surface_.Params().lower_lid_open * std::pow(std::sin(kPi * std::pow(u, 1.15f)), 0.8f);
  }

  // Skin vertex at grid (i, j); `below` marks the lower margin copy on a slit row.
  Eigen::Vector3f SkinVertex(int i, int j, bool below, const LidState lids[2]) const {
    const float theta = ColumnTheta(i, j);
    float t = row_t_[i];
    // Eyelid warp: rows move away from the eye slit.
    const int side = theta >= 0.f ? 0 : 1;
    const float u = EyeFraction(j);
    if (u > 0.f && u < 1.f) {
      const LidState& lid = lids[side];
      const float y = surface_.Profile(t).y;
      const float d = y - surface_.EyeY();
      const bool lower = i > layout_.row_eye || (i == layout_.row_eye && below);
      float shift;
      if (lower) {
        shift = -lid.lower_scale * LowerOpening(u) * Gauss(d / 0.6f);
      } else {
        const float open = lid.upper_scale * UpperOpening(u);
        const float closed = -lid.lower_scale * LowerOpening(u);
        shift = Lerp(open, closed, lid.closure) * Gauss(d / 0.75f);
      }
      if (std::abs(shift) > 1e-6f) {
        t = surface_.ParameterAtHeight(y + shift, surface_.DomeEndKey() - 1.f,
                                       static_cast<float>(surface_.MouthKey()));
      }
    }
    return surface_.Position(theta, t);
  }

  // All vertices with the given lid states and eyeball rotations.
  Vertices Build(const LidState lids[2], const EyeballRotation eyes[2]) const {
    const Layout& l = layout_;
    Vertices v(l.num_vertices, 3);
#pragma omp parallel for schedule(static)
    for (int i = 0; i < l.rows; ++i) {
      for (int j = 0; j < l.cols; ++j) v.row(l.Grid(i, j)) = SkinVertex(i, j, false, lids);
    }
    v.row(l.top_pole) = surface_.Position(0.f, 0.f);
    v.row(l.bottom_pole) = surface_.Position(0.f, surface_.NumKeys() - 1.f);
    for (int side = 0; side < 2; ++side) {
      for (int j = l.EyeLo(side) + 1; j < l.EyeHi(side); ++j) {
        v.row(l.Vertex(l.row_eye, j, true)) = SkinVertex(l.row_eye, j, true, lids);
      }
    }
    for (int j = l.MouthLo() + 1; j < l.MouthHi(); ++j) {
      v.row(l.Vertex(l.row_mouth, j, true)) = SkinVertex(l.row_mouth, j, true, lids);
    }
    // Eye pockets: a ring pulled towards the eyeball centre, then a centre vertex.
    for (int side = 0; side < 2; ++side) {
      const Eigen::Vector3f c = surface_.EyeCenter(side);
      const std::vector<int> loop = l.Loop(l.EyeLo(side), l.EyeHi(side), l.row_eye);
      for (int k = 0; k < l.eye_loop; ++k) {
        const Eigen::Vector3f p = v.row(loop[k]).transpose();
        v.row(l.eye_pocket_begin[side] + k) = (c + 0.72f * (p - c)).transpose();
      }
      v.row(l.eye_pocket_begin[side] + l.eye_loop) = (c - Eigen::Vector3f(0, 0, 0.35f)).transpose();
    }
    // Mouth cavity: rings that widen vertically and recede, then a centre vertex.
    {
      const std::vector<int> loop = l.Loop(l.MouthLo(), l.MouthHi(), l.row_mouth);
      const float mhw = surface_.Params().mouth_half_width;
      const float y_m = surface_.MouthY();
      const float z_front = v(l.Grid(l.row_mouth, l.half_cols), 2);
      const float spread[3] = {0.35f, 1.1f, 0.9f};
      const float depth[3] = {0.45f, 1.6f, 3.2f};
      const float narrow[3] = {0.93f, 0.85f, 0.6f};
      for (int k = 0; k < l.mouth_loop; ++k) {
        const Eigen::Vector3f p = v.row(loop[k]).transpose();
        const bool upper = k <= l.mouth_dup_count + 1;
        const bool corner = k == 0 || k == l.mouth_dup_count + 1;
        const float s = std::min(1.f, std::abs(p.x()) / mhw);
        const float vertical = corner ? 0.f : (upper ? 1.f : -1.f) * std::sqrt(1.f - s * s);
        for (int r = 0; r < l.mouth_rings; ++r) {
          const float z = r < 2 ? p.z() - depth[r] : z_front - depth[r];
          v.row(l.mouth_pocket_begin + r * l.mouth_loop + k) =
              Eigen::Vector3f(narrow[r] * p.x(), y_m - 0.1f * r + spread[r] * vertical, z).transpose();
        }
      }
      v.row(l.mouth_pocket_begin + l.mouth_rings * l.mouth_loop) =
          Eigen::Vector3f(0.f, y_m - 0.3f, z_front - 3.7f).transpose();
    }
    // Eyeballs: spheres with the pupil at the front pole.
    const std::vector<float> rings = EyeballRingAngles(l.eyeball_bands);
    for (int side = 0; side < 2; ++side) {
      const Eigen::Vector3f c = surface_.EyeCenter(side);
      const Eigen::Matrix3f& rot = eyes[side].rotation;
      int idx = l.eyeball_begin[side];
      v.row(idx++) = (c + rot * Eigen::Vector3f(0, 0, kEyeballRadius)).transpose();
      for (float a : rings) {
        for (int b = 0; b < l.eyeball_segments; ++b) {
          const float phi = 2.f * kPi * b / l.eyeball_segments;
          const Eigen::Vector3f d(std::sin(a) * std::cos(phi), std::sin(a) * std::sin(phi), std::cos(a));
          v.row(idx++) = (c + rot * (kEyeballRadius * d)).transpose();
        }
      }
      v.row(idx++) = (c + rot * Eigen::Vector3f(0, 0, -kEyeballRadius)).transpose();
    }
    return v;
  }

  Vertices BuildNeutral() const {
    const LidState lids[2];
    const EyeballRotation eyes[2];
    return Build(lids, eyes);
  }

 private:
  // Arc-length placement of n points in (a, b] (or (a, b) when open_end) along the measure.
  template <typename Measure>
  static std::vector<float> ArcLengthPlace(float a, float b, int n, bool open_end, Measure measure) {
    const int samples = 256;
    std::vector<float> ts(samples + 1), lengths(samples + 1, 0.f);
    for (int s = 0; s <= samples; ++s) ts[s] = Lerp(a, b, static_cast<float>(s) / samples);
    for (int s = 1; s <= samples; ++s) lengths[s] = lengths[s - 1] + measure(ts[s - 1], ts[s]);
    std::vector<float> out;
    const int count = open_end ? n - 1 : n;
    int s = 1;
    for (int k = 1; k <= count; ++k) {
      if (!open_end && k == n) { out.push_back(b); break; }
      const float target = lengths[samples] * k / n;
      while (s < samples && lengths[s] < target) ++s;
      const float seg = lengths[s] - lengths[s - 1];
      const float f = seg > 0.f ? (target - lengths[s - 1]) / seg : 0.f;
      out.push_back(Lerp(ts[s - 1], ts[s], f));
    }
    return out;
  }

  void PlaceRows() {
    const HeadSurface& hs = surface_;
    const float theta_eye = hs.ThetaAtX(hs.Params().eye_half_spacing, hs.EyeKey());
    auto measure = [&](float t0, float t1) {
      return (hs.Position(0.f, t1) - hs.Position(0.f, t0)).norm() +
             (hs.Position(theta_eye, t1) - hs.Position(theta_eye, t0)).norm();
    };
    const float knots[7] = {0.f,
                            static_cast<float>(hs.DomeEndKey()),
                            static_cast<float>(hs.EyeKey()),
                            static_cast<float>(hs.MouthKey()),
                            static_cast<float>(hs.ChinKey()),
                            static_cast<float>(hs.NeckKey()),
                            hs.NumKeys() - 1.f};
    row_t_.clear();
    for (int seg = 0; seg < 6; ++seg) {
      const std::vector<float> ts =
          ArcLengthPlace(knots[seg], knots[seg + 1], layout_.row_segments[seg], seg == 5, measure);
      row_t_.insert(row_t_.end(), ts.begin(), ts.end());
    }
  }

  void PlaceColumns() {
    const HeadSurface& hs = surface_;
    const HeadParams& p = hs.Params();
    theta_eye_inner_ = hs.ThetaAtX(p.eye_half_spacing - p.eye_half_width, hs.EyeKey());
    theta_eye_outer_ = hs.ThetaAtX(p.eye_half_spacing + p.eye_half_width, hs.EyeKey());
    const float theta_mouth = std::min(hs.ThetaAtX(p.mouth_half_width, hs.MouthKey()),
                                       theta_eye_outer_ - 0.05f);
    const std::vector<int>& n = layout_.col_segments;
    // Eye rows: knots at the eye corners, arc length along the eye row.
    eye_column_theta_ = Side(hs.EyeKey(), {0.f, theta_eye_inner_, theta_eye_outer_, 0.5f * kPi, kPi},
                             {n[0], n[1] + n[2], n[3], n[4]});
    // Mouth rows: knots at the mouth corners, arc length along the mouth row.
    mouth_column_theta_ = Side(hs.MouthKey(), {0.f, theta_mouth, theta_eye_outer_, 0.5f * kPi, kPi},
                               {n[0] + n[1], n[2], n[3], n[4]});
    row_blend_.resize(layout_.rows);
    for (int i = 0; i < layout_.rows; ++i) {
      const float y = hs.Profile(row_t_[i]).y;
      row_blend_[i] = Smoothstep(hs.EyeY() - 1.7f, hs.MouthY() + 1.3f, y);
    }
  }

  // Full ring of column angles (index j) from one side's knots and segment counts.
  std::vector<float> Side(int key, const std::vector<float>& knots, const std::vector<int>& counts) const {
    const HeadSurface& hs = surface_;
    const float t = static_cast<float>(key);
    auto measure = [&](float a0, float a1) {
      return (hs.Position(a1, t) - hs.Position(a0, t)).norm();
    };
    std::vector<float> side = {0.f};
    for (size_t seg = 0; seg + 1 < knots.size(); ++seg) {
      const std::vector<float> ts = ArcLengthPlace(knots[seg], knots[seg + 1], counts[seg], false, measure);
      side.insert(side.end(), ts.begin(), ts.end());
    }
    std::vector<float> ring(layout_.cols, 0.f);
    for (int k = 0; k <= layout_.half_cols; ++k) {
      ring[layout_.Column(0, k) % layout_.cols] = side[k];
      if (k > 0 && k < layout_.half_cols) ring[layout_.Column(1, k)] = -side[k];
    }
    ring[0] = kPi;
    return ring;
  }

  HeadSurface surface_;
  Layout layout_;
  std::vector<float> row_t_;
  std::vector<float> eye_column_theta_, mouth_column_theta_;  // per column j
  std::vector<float> row_blend_;                              // 0: eye layout, 1: mouth layout
  float theta_eye_inner_ = 0.f, theta_eye_outer_ = 0.f;
};

// ---- topology, UVs, regions -----------------------------------------------------------------

enum RegionId {
  kSkin, kHair, kNeck, kNose, kLeftBrow, kRightBrow, kLeftUpperLid, kLeftLowerLid,
  kRightUpperLid, kRightLowerLid, kSclera, kIris, kPupil, kUpperLip, kLowerLip,
  kMouthInterior, kNumRegions
};

std::vector<Region> MakeRegions() {
  return {
      {"skin", {0.85f, 0.62f, 0.48f}},
      {"hair", {0.22f, 0.12f, 0.04f}},
      {"neck", {0.55f, 0.35f, 0.80f}},
      {"nose", {0.98f, 0.88f, 0.15f}},
      {"left_brow", {0.05f, 0.45f, 0.05f}},
      {"right_brow", {0.50f, 0.95f, 0.35f}},
      {"left_upper_eyelid", {1.00f, 0.35f, 0.75f}},
      {"left_lower_eyelid", {0.62f, 0.05f, 0.42f}},
      {"right_upper_eyelid", {0.35f, 0.85f, 1.00f}},
      {"right_lower_eyelid", {0.05f, 0.35f, 0.70f}},
      {"sclera", {1.00f, 1.00f, 1.00f}},
      {"iris", {0.00f, 0.70f, 0.55f}},
      {"pupil", {0.00f, 0.00f, 0.00f}},
      {"upper_lip", {0.95f, 0.08f, 0.08f}},
      {"lower_lip", {0.60f, 0.00f, 0.00f}},
      {"mouth_interior", {0.15f, 0.00f, 0.38f}},
  };
}

// Height of the hairline at column angle theta.
float HairLineY(const HeadSurface& hs, float theta) {
  const float deg = std::abs(theta) * 180.f / kPi;
  const float ye = hs.EyeY();
  return Table({{0.f, ye + 7.2f}, {25.f, ye + 7.0f}, {45.f, ye + 5.6f}, {62.f, ye + 4.2f},
                {78.f, ye + 3.0f}, {92.f, ye + 1.6f}, {104.f, ye - 1.0f}, {118.f, ye - 5.0f},
                {180.f, ye - 6.0f}},
               deg);
}

struct MeshTopology {
  Triangles triangles;
  Triangles uv_triangles;
  UVs uvs;
  Eigen::VectorXi triangle_region;
};

MeshTopology MakeTopology(const HeadBuilder& builder, const Vertices& neutral) {
  const Layout& l = builder.GetLayout();
  const HeadSurface& hs = builder.Surface();
  std::vector<Eigen::Vector3i> tris, uvtris;
  std::vector<int> region;
  std::vector<Eigen::Vector2f> uvs(l.num_vertices, Eigen::Vector2f::Zero());

  // Head UVs: u by column (seam at the back), v by the front arc length of the (warped) row.
  // Per-vertex v from the neutral height keeps the eye openings open in UV space too.
  const int seam_uv_begin = l.num_vertices;           // u = 1 copies of column 0, per row
  const int pole_uv_begin = seam_uv_begin + l.rows;   // per column: top then bottom
  uvs.resize(pole_uv_begin + 2 * l.cols, Eigen::Vector2f::Zero());
  const float y_top = neutral(l.top_pole, 1), y_bottom = neutral(l.bottom_pole, 1);
  auto head_v = [&](int vertex) {
    const float y = neutral(vertex, 1);
    return 0.22f + 0.76f * (y - y_bottom) / (y_top - y_bottom);
  };
  for (int i = 0; i < l.rows; ++i) {
    for (int j = 0; j < l.cols; ++j) {
      for (bool below : {false, true}) {
        const int vtx = l.Vertex(i, j, below);
        uvs[vtx] = Eigen::Vector2f(static_cast<float>(j) / l.cols, head_v(vtx));
      }
    }
    uvs[seam_uv_begin + i] = Eigen::Vector2f(1.f, head_v(l.Grid(i, 0)));
  }
  for (int j = 0; j < l.cols; ++j) {
    uvs[pole_uv_begin + 2 * j] = Eigen::Vector2f((j + 0.5f) / l.cols, 0.98f);
    uvs[pole_uv_begin + 2 * j + 1] = Eigen::Vector2f((j + 0.5f) / l.cols, 0.22f);
  }
  auto uv_of = [&](int i, int j, int vertex) {
    return j == l.cols ? seam_uv_begin + i : vertex;
  };

  auto add = [&](int a, int b, int c, int ua, int ub, int uc, int reg) {
    tris.emplace_back(a, b, c);
    uvtris.emplace_back(ua, ub, uc);
    region.push_back(reg);
  };

  // Region of a skin quad (rows i, i+1; columns j, j+1) from its neutral centre.
  auto skin_region = [&](int i, int j, const Eigen::Vector3f& centre) {
    const float x = centre.x(), y = centre.y();
    const float theta_a = builder.ColumnTheta(i, j);
    const float theta_b = j + 1 == l.cols ? kPi : builder.ColumnTheta(i, j + 1);
    const float theta = 0.5f * (theta_a + theta_b);
    for (int side = 0; side < 2; ++side) {
      if (j >= l.EyeLo(side) && j < l.EyeHi(side)) {
        const float u = 0.5f * (builder.EyeFraction(j) + builder.EyeFraction(j + 1));
        const float margin_up = hs.EyeY() + builder.UpperOpening(u);
        const float margin_low = hs.EyeY() - builder.LowerOpening(u);
        if (i < l.row_eye && (i == l.row_eye - 1 || y < margin_up + 0.55f + 0.15f * std::sin(kPi * u))) {
          if (i >= l.row_eye - 6) return side == 0 ? kLeftUpperLid : kRightUpperLid;
        }
        if (i >= l.row_eye && (i == l.row_eye || y > margin_low - 0.45f)) {
          if (i <= l.row_eye + 4) return side == 0 ? kLeftLowerLid : kRightLowerLid;
        }
      }
    }
    const float ax = std::abs(x);
    const float ex = hs.Params().eye_half_spacing;
    if (centre.z() > 0.f && ax > ex - 2.0f && ax < ex + 2.1f) {
      const float u = (ax - (ex - 2.0f)) / 4.1f;
      const float half = Lerp(0.42f, 0.2f, u);
      if (std::abs(y - hs.BrowLineY(ax)) < half) return x > 0.f ? kLeftBrow : kRightBrow;
    }
    if (j >= l.MouthLo() && j < l.MouthHi()) {
      if (i < l.row_mouth && (i == l.row_mouth - 1 || y < hs.UpperVermilionY(x))) {
        if (i >= l.row_mouth - 5) return kUpperLip;
      }
      if (i >= l.row_mouth && (i == l.row_mouth || y > hs.LowerVermilionY(x))) {
        if (i <= l.row_mouth + 5) return kLowerLip;
      }
    }
    if (centre.z() > 0.f && y < hs.NasionY() + 0.3f && y > hs.SubnasaleY() - 0.25f &&
        hs.NoseHeight(x, y) > 0.32f) {
      return kNose;
    }
    if (y < hs.JawLineY(theta)) return kNeck;
    if (y > HairLineY(hs, theta)) return kHair;
    return kSkin;
  };

  // Skin grid.
  for (int i = 0; i + 1 < l.rows; ++i) {
    for (int j = 0; j < l.cols; ++j) {
      const int jn = j + 1;
      const int a = l.Vertex(i, j, true), b = l.Vertex(i + 1, j, false);
      const int c = l.Vertex(i + 1, jn, false), d = l.Vertex(i, jn, true);
      const int ua = uv_of(i, j, a), ub = uv_of(i + 1, j, b);
      const int uc = uv_of(i + 1, jn, c), ud = uv_of(i, jn, d);
      const Eigen::Vector3f centre =
          0.25f * (neutral.row(a) + neutral.row(b) + neutral.row(c) + neutral.row(d)).transpose();
      const int reg = skin_region(i, j, centre);
      // Mirror-symmetric diagonals: a-c on the +x half, b-d on the -x half.
      if (j >= l.half_cols) {
        add(a, b, c, ua, ub, uc, reg);
        add(a, c, d, ua, uc, ud, reg);
      } else {
        add(a, b, d, ua, ub, ud, reg);
        add(b, c, d, ub, uc, ud, reg);
      }
    }
  }
  // Poles.
  for (int j = 0; j < l.cols; ++j) {
    const int jn = j + 1;
    add(l.top_pole, l.Grid(0, j), l.Grid(0, jn), pole_uv_begin + 2 * j, uv_of(0, j, l.Grid(0, j)),
        uv_of(0, jn, l.Grid(0, jn)), kHair);
    const int last = l.rows - 1;
    add(l.Grid(last, j), l.bottom_pole, l.Grid(last, jn), uv_of(last, j, l.Grid(last, j)),
        pole_uv_begin + 2 * j + 1, uv_of(last, jn, l.Grid(last, jn)), kNeck);
  }
  // Pockets: rings behind a loop, then a fan; the loop is used reversed so that every edge of
  // the opening is shared with opposite direction.
  auto pocket = [&](const std::vector<int>& loop, int ring_begin, int rings, int reg) {
    const int n = static_cast<int>(loop.size());
    std::vector<int> prev = loop;
    for (int r = 0; r < rings; ++r) {
      std::vector<int> next(n);
      for (int k = 0; k < n; ++k) next[k] = ring_begin + r * n + k;
      for (int k = 0; k < n; ++k) {
        const int kn = (k + 1) % n;
        add(prev[kn], prev[k], next[k], prev[kn], prev[k], next[k], reg);
        add(prev[kn], next[k], next[kn], prev[kn], next[k], next[kn], reg);
      }
      prev = next;
    }
    const int centre = ring_begin + rings * n;
    for (int k = 0; k < n; ++k) {
      const int kn = (k + 1) % n;
      add(prev[kn], prev[k], centre, prev[kn], prev[k], centre, reg);
    }
  };
  for (int side = 0; side < 2; ++side) {
    pocket(l.Loop(l.EyeLo(side), l.EyeHi(side), l.row_eye), l.eye_pocket_begin[side], 1, kSclera);
  }
  pocket(l.Loop(l.MouthLo(), l.MouthHi(), l.row_mouth), l.mouth_pocket_begin, l.mouth_rings,
         kMouthInterior);
  // Eyeballs.
  for (int side = 0; side < 2; ++side) {
    const int base = l.eyeball_begin[side], n = l.eyeball_segments;
    const int ring_count = l.eyeball_bands - 1;
    auto ring = [&](int r, int b) { return base + 1 + r * n + (b % n); };
    for (int b = 0; b < n; ++b) {
      add(base, ring(0, b), ring(0, b + 1), base, ring(0, b), ring(0, b + 1), kPupil);
    }
    for (int r = 0; r + 1 < ring_count; ++r) {
      const int reg = r == 0 ? kIris : kSclera;
      for (int b = 0; b < n; ++b) {
        add(ring(r, b), ring(r + 1, b), ring(r + 1, b + 1), ring(r, b), ring(r + 1, b),
            ring(r + 1, b + 1), reg);
        add(ring(r, b), ring(r + 1, b + 1), ring(r, b + 1), ring(r, b), ring(r + 1, b + 1),
            ring(r, b + 1), reg);
      }
    }
    const int back = base + l.eyeball_count - 1;
    for (int b = 0; b < n; ++b) {
      add(ring(ring_count - 1, b), back, ring(ring_count - 1, b + 1), ring(ring_count - 1, b), back,
          ring(ring_count - 1, b + 1), kSclera);
    }
  }
  // UVs of the parts that are not skin: front projections into boxes below the head chart.
  auto box_uv = [&](int begin, int count, float u0) {
    Eigen::Vector2f lo(1e9f, 1e9f), hi(-1e9f, -1e9f);
    for (int k = begin; k < begin + count; ++k) {
      lo = lo.cwiseMin(neutral.row(k).head<2>().transpose());
      hi = hi.cwiseMax(neutral.row(k).head<2>().transpose());
    }
    const Eigen::Vector2f size = (hi - lo).cwiseMax(Eigen::Vector2f(1e-3f, 1e-3f));
    for (int k = begin; k < begin + count; ++k) {
      const Eigen::Vector2f q = (neutral.row(k).head<2>().transpose() - lo).cwiseQuotient(size);
      uvs[k] = Eigen::Vector2f(u0 + 0.01f + 0.18f * q.x(), 0.01f + 0.18f * q.y());
    }
  };
  box_uv(l.eyeball_begin[0], l.eyeball_count, 0.0f);
  box_uv(l.eyeball_begin[1], l.eyeball_count, 0.2f);
  box_uv(l.eye_pocket_begin[0], l.eye_loop + 1, 0.4f);
  box_uv(l.eye_pocket_begin[1], l.eye_loop + 1, 0.6f);
  box_uv(l.mouth_pocket_begin, l.mouth_rings * l.mouth_loop + 1, 0.8f);
  uvs[l.top_pole] = Eigen::Vector2f(0.5f, 0.99f);
  uvs[l.bottom_pole] = Eigen::Vector2f(0.5f, 0.21f);

  MeshTopology out;
  out.triangles.resize(static_cast<int>(tris.size()), 3);
  out.uv_triangles.resize(static_cast<int>(tris.size()), 3);
  out.triangle_region.resize(static_cast<int>(tris.size()));
  for (int f = 0; f < static_cast<int>(tris.size()); ++f) {
    out.triangles.row(f) = tris[f].transpose();
    out.uv_triangles.row(f) = uvtris[f].transpose();
    out.triangle_region(f) = region[f];
  }
  out.uvs.resize(static_cast<int>(uvs.size()), 2);
  for (int k = 0; k < static_cast<int>(uvs.size()); ++k) out.uvs.row(k) = uvs[k].transpose();
  return out;
}

// ---- per-vertex facts ------------------------------------------------------------------------

enum class Part { kSkin, kEyePocket, kMouthPocket, kEyeball };

struct VertexFacts {
  Part part = Part::kSkin;
  int eye = -1;             // 0: left eye (+x), 1: right eye (-x), for eye parts
  bool below_mouth = false; // skin below the lip slit (lower margin included), lower cavity half
  float pocket_depth = 0.f; // 0 at the opening, 1 at the back of the mouth cavity
  int loop_index = -1;      // for mouth cavity vertices: index into the mouth loop
};

std::vector<VertexFacts> MakeFacts(const Layout& l) {
  std::vector<VertexFacts> facts(l.num_vertices);
  for (int i = 0; i < l.rows; ++i) {
    for (int j = 0; j < l.cols; ++j) facts[l.Grid(i, j)].below_mouth = i > l.row_mouth;
  }
  facts[l.bottom_pole].below_mouth = true;
  for (int k = 0; k < l.mouth_dup_count; ++k) facts[l.mouth_dup_begin + k].below_mouth = true;
  for (int side = 0; side < 2; ++side) {
    for (int k = 0; k < l.eye_dup_count; ++k) facts[l.eye_dup_begin[side] + k].below_mouth = false;
    for (int k = 0; k <= l.eye_loop; ++k) {
      facts[l.eye_pocket_begin[side] + k].part = Part::kEyePocket;
      facts[l.eye_pocket_begin[side] + k].eye = side;
    }
    for (int k = 0; k < l.eyeball_count; ++k) {
      facts[l.eyeball_begin[side] + k].part = Part::kEyeball;
      facts[l.eyeball_begin[side] + k].eye = side;
    }
  }
  for (int r = 0; r < l.mouth_rings; ++r) {
    for (int k = 0; k < l.mouth_loop; ++k) {
      VertexFacts& f = facts[l.mouth_pocket_begin + r * l.mouth_loop + k];
      f.part = Part::kMouthPocket;
      f.below_mouth = k > l.mouth_dup_count + 1;
      f.pocket_depth = static_cast<float>(r + 1) / (l.mouth_rings + 1);
      f.loop_index = k;
    }
  }
  VertexFacts& centre = facts[l.mouth_pocket_begin + l.mouth_rings * l.mouth_loop];
  centre.part = Part::kMouthPocket;
  centre.pocket_depth = 1.f;
  return facts;
}

// Rz * Ry * Rx from Euler angles (x, y, z), radians (the convention of rig/pose.h).
Eigen::Matrix3f EulerXyz(const Eigen::Vector3f& e) {
  return (Eigen::AngleAxisf(e.z(), Eigen::Vector3f::UnitZ()) *
          Eigen::AngleAxisf(e.y(), Eigen::Vector3f::UnitY()) *
          Eigen::AngleAxisf(e.x(), Eigen::Vector3f::UnitX()))
      .toRotationMatrix();
}

// Jaw skinning weight M of a skin vertex (paper 000 Sec. 6): 1 on the chin, lower lip and lower
// jaw, 0 on the skull, upper lip and nose, a smooth ramp between that rises towards the jaw
// joint beside the mouth, and a jump across the lip slit.
float SkinJawWeight(const HeadSurface& hs, const Eigen::Vector3f& p, bool below_mouth,
                    const Eigen::Vector3f& pivot) {
  const float mhw = hs.Params().mouth_half_width;
  const float ax = std::abs(p.x());
  const float y_ref = hs.MouthY() + (pivot.y() - hs.MouthY()) * Smoothstep(mhw, 7.5f, ax);
  const float d = p.y() - y_ref;
  const float c2 = Square(std::min(1.f, ax / mhw));
  const float width = Lerp(1.3f, 2.5f, Smoothstep(mhw, 6.f, ax));
  float m;
  if (below_mouth || d < 0.f) {
    m = 1.f - 0.5f * c2 * (1.f - Smoothstep(0.f, width, -d));
  } else {
    m = 0.5f * c2 * (1.f - Smoothstep(0.f, width, d));
  }
  m *= Smoothstep(hs.ChinY() - 3.5f, hs.ChinY() - 0.3f, p.y());  // the neck stays
  m *= Smoothstep(pivot.z() - 0.5f, pivot.z() + 3.5f, p.z());     // behind the joint stays
  return Clamp01(m);
}

Eigen::Vector3f JawPivot(const HeadSurface& hs) {
  return Eigen::Vector3f(0.f, hs.EyeY() - 2.8f, 1.0f);
}

Eigen::VectorXf MakeJawWeights(const HeadSurface& hs, const Layout& l, const Vertices& neutral,
                               const std::vector<VertexFacts>& facts) {
  const Eigen::Vector3f pivot = JawPivot(hs);
  Eigen::VectorXf m = Eigen::VectorXf::Zero(l.num_vertices);
  for (int v = 0; v < l.num_vertices; ++v) {
    if (facts[v].part == Part::kSkin) {
      m(v) = SkinJawWeight(hs, neutral.row(v).transpose(), facts[v].below_mouth, pivot);
    }
  }
  const std::vector<int> loop = l.Loop(l.MouthLo(), l.MouthHi(), l.row_mouth);
  for (int r = 0; r < l.mouth_rings; ++r) {
    for (int k = 0; k < l.mouth_loop; ++k) m(l.mouth_pocket_begin + r * l.mouth_loop + k) = m(loop[k]);
  }
  m(l.mouth_pocket_begin + l.mouth_rings * l.mouth_loop) = 0.5f;
  return m;
}

// ---- landmarks -------------------------------------------------------------------------------

Eigen::VectorXi MakeLandmarks(const HeadBuilder& b, const Vertices& n) {
  const Layout& l = b.GetLayout();
  const HeadSurface& hs = b.Surface();
  const HeadParams& p = hs.Params();
  Eigen::VectorXi lm(68);
  // Nearest original grid vertex on the front of the face to (x, y), rows in [r0, r1].
  auto nearest = [&](float x, float y, int r0, int r1) {
    int best = -1;
    float best_d = std::numeric_limits<float>::infinity();
    for (int i = std::max(0, r0); i <= std::min(l.rows - 1, r1); ++i) {
      for (int j = 0; j < l.cols; ++j) {
        if (std::cos(b.ColumnTheta(i, j)) < 0.3f) continue;
        const int v = l.Grid(i, j);
        const float d = Square(n(v, 0) - x) + Square(n(v, 1) - y);
        if (d < best_d) { best_d = d; best = v; }
      }
    }
    return best;
  };
  // Jaw contour 0-16: even arc-length samples of the jaw line from the right ear to the left.
  {
    std::vector<Eigen::Vector3f> curve;
    std::vector<float> length = {0.f};
    for (int k = 0; k <= 352; ++k) {
      const float theta = (-88.f + 0.5f * k) * kPi / 180.f;
      const float t = hs.ParameterAtHeight(hs.JawLineY(theta) + 0.15f, 0.f, hs.NumKeys() - 1.f);
      curve.push_back(hs.Position(theta, t));
      if (k > 0) length.push_back(length.back() + (curve[k] - curve[k - 1]).norm());
    }
    int s = 0;
    for (int m = 0; m < 17; ++m) {
      const float target = length.back() * m / 16.f;
      while (s + 1 < static_cast<int>(length.size()) && length[s] < target) ++s;
      int best = -1;
      float best_d = std::numeric_limits<float>::infinity();
      for (int i = 0; i < l.rows; ++i) {
        for (int j = 0; j < l.cols; ++j) {
          const int v = l.Grid(i, j);
          const float d = (n.row(v).transpose() - curve[s]).squaredNorm();
          if (d < best_d) { best_d = d; best = v; }
        }
      }
      lm(m) = best;
    }
  }
  // Brows 17-21 (right, outer to inner) and 22-26 (left, inner to outer).
  const float ex = p.eye_half_spacing;
  for (int k = 0; k < 5; ++k) {
    const float ax_right = ex + 1.9f - 0.925f * k;
    lm(17 + k) = nearest(-ax_right, hs.BrowLineY(ax_right), 0, l.row_eye);
    const float ax_left = ex - 1.8f + 0.925f * k;
    lm(22 + k) = nearest(ax_left, hs.BrowLineY(ax_left), 0, l.row_eye);
  }
  // Nose bridge 27-29 down the centre column, tip 30 the most forward centre vertex.
  int tip = l.Grid(0, l.half_cols);
  for (int i = 0; i < l.rows; ++i) {
    if (n(l.Grid(i, l.half_cols), 2) > n(tip, 2)) tip = l.Grid(i, l.half_cols);
  }
  for (int k = 0; k < 3; ++k) {
    const float y = Lerp(hs.NasionY() - 0.15f, hs.NoseTipY(), k / 3.f);
    lm(27 + k) = nearest(0.f, y, 0, l.row_mouth);
  }
  lm(30) = tip;
  // Nose base 31-35, right to left.
  for (int k = 0; k < 5; ++k) {
    lm(31 + k) = nearest(-1.0f + 0.5f * k, hs.SubnasaleY() + 0.1f + 0.15f * std::abs(k - 2),
                         l.row_eye, l.row_mouth - 1);
  }
  // Eyes: corners are the slit ends, lid points are margin vertices at 1/3 and 2/3 across.
  auto eye_column = [&](int side, float u) {
    int best = l.EyeLo(side) + 1;
    for (int j = l.EyeLo(side) + 1; j < l.EyeHi(side); ++j) {
      if (std::abs(b.EyeFraction(j) - u) < std::abs(b.EyeFraction(best) - u)) best = j;
    }
    return best;
  };
  const int re = l.row_eye;
  lm(36) = l.Grid(re, l.Column(1, l.k_eye_outer));
  lm(37) = l.Grid(re, eye_column(1, 2.f / 3.f));
  lm(38) = l.Grid(re, eye_column(1, 1.f / 3.f));
  lm(39) = l.Grid(re, l.Column(1, l.k_eye_inner));
  lm(40) = l.Vertex(re, eye_column(1, 1.f / 3.f), true);
  lm(41) = l.Vertex(re, eye_column(1, 2.f / 3.f), true);
  lm(42) = l.Grid(re, l.Column(0, l.k_eye_inner));
  lm(43) = l.Grid(re, eye_column(0, 1.f / 3.f));
  lm(44) = l.Grid(re, eye_column(0, 2.f / 3.f));
  lm(45) = l.Grid(re, l.Column(0, l.k_eye_outer));
  lm(46) = l.Vertex(re, eye_column(0, 2.f / 3.f), true);
  lm(47) = l.Vertex(re, eye_column(0, 1.f / 3.f), true);
  // Lips.
  const int rm = l.row_mouth;
  const float mhw = p.mouth_half_width;
  auto mouth_column = [&](float x) {
    int best = l.MouthLo() + 1;
    for (int j = l.MouthLo() + 1; j < l.MouthHi(); ++j) {
      if (std::abs(n(l.Grid(rm, j), 0) - x) < std::abs(n(l.Grid(rm, best), 0) - x)) best = j;
    }
    return best;
  };
  lm(48) = l.Grid(rm, l.MouthLo() - 1);
  lm(54) = l.Grid(rm, l.MouthHi() + 1);
  const float outer_x[5] = {-0.62f, -0.28f, 0.f, 0.28f, 0.62f};
  for (int k = 0; k < 5; ++k) {
    const float xu = outer_x[k] * mhw;
    lm(49 + k) = nearest(xu, hs.UpperVermilionY(xu), rm - 6, rm - 1);
    const float xl = -outer_x[k] * mhw;
    lm(55 + k) = nearest(xl, hs.LowerVermilionY(xl), rm + 1, rm + 6);
  }
  lm(60) = l.Grid(rm, l.MouthLo());
  lm(64) = l.Grid(rm, l.MouthHi());
  const float inner_x[3] = {-0.45f, 0.f, 0.45f};
  for (int k = 0; k < 3; ++k) {
    lm(61 + k) = l.Grid(rm, mouth_column(inner_x[k] * mhw));
    lm(65 + k) = l.Vertex(rm, mouth_column(-inner_x[k] * mhw), true);
  }
  return lm;
}

// ---- shapes ----------------------------------------------------------------------------------

SparseDelta ToSparse(const Vertices& dense) {
  SparseDelta d;
  for (int v = 0; v < dense.rows(); ++v) {
    const Eigen::Vector3f o = dense.row(v).transpose();
    if (o.squaredNorm() > 1e-10f) {
      d.vertex.push_back(v);
      d.offset.push_back(o);
    }
  }
  return d;
}

Eigen::Vector3f MirrorX(const Eigen::Vector3f& v) { return Eigen::Vector3f(-v.x(), v.y(), v.z()); }

class ShapeMaker {
 public:
  ShapeMaker(const HeadBuilder& builder, const Vertices& neutral, const std::vector<VertexFacts>& facts,
             const Eigen::VectorXf& jaw_weights, const DemoHeadOptions& options)
      : b_(builder), hs_(builder.Surface()), l_(builder.GetLayout()), n_(neutral), facts_(facts),
        jaw_weights_(jaw_weights), options_(options) {
    left_corner_ = n_.row(l_.Grid(l_.row_mouth, l_.MouthHi())).transpose();
  }

  std::vector<Shape> MakeAll() const {
    std::vector<Shape> shapes;
    for (const std::string& name : ArkitShapeNames()) shapes.push_back(Make(name));
    return shapes;
  }

 private:
  using Field = std::function<Eigen::Vector3f(const Eigen::Vector3f&, const VertexFacts&)>;

  // Dense delta of a displacement field over the skin and the mouth cavity (attenuated with
  // depth). `mirror` evaluates the field for the subject's right side.
  Vertices FieldDelta(const Field& f, bool mirror) const {
    Vertices d = Vertices::Zero(l_.num_vertices, 3);
    for (int v = 0; v < l_.num_vertices; ++v) {
      const VertexFacts& fact = facts_[v];
      if (fact.part == Part::kEyeball || fact.part == Part::kEyePocket) continue;
      const Eigen::Vector3f p = n_.row(v).transpose();
      Eigen::Vector3f o = mirror ? MirrorX(f(MirrorX(p), fact)) : f(p, fact);
      if (fact.part == Part::kMouthPocket) o *= Square(1.f - fact.pocket_depth);
      d.row(v) = o.transpose();
    }
    return d;
  }

  Vertices LidDelta(int side, const LidState& lid, const Eigen::Matrix3f& eye_rotation) const {
    LidState lids[2];
    EyeballRotation eyes[2];
    lids[side] = lid;
    eyes[side].rotation = eye_rotation;
    Vertices d = b_.Build(lids, eyes) - n_;
    // Only the lids of this eye and its eyeball move; clean the round-off elsewhere.
    for (int v = 0; v < l_.num_vertices; ++v) {
      if (d.row(v).squaredNorm() < 1e-12f) d.row(v).setZero();
    }
    return d;
  }

  float Front(const Eigen::Vector3f& p) const { return Smoothstep(0.f, 3.f, p.z()); }
  float Mhw() const { return hs_.Params().mouth_half_width; }
  // Weight around the left mouth corner with radius r.
  float CornerWeight(const Eigen::Vector3f& p, float r) const {
    return Gauss((p.head<2>() - left_corner_.head<2>()).norm() / r) * Front(p);
  }
  float LipWeight(const Eigen::Vector3f& p, float vertical = 1.1f) const {
    return (1.f - Smoothstep(0.6f * Mhw(), 1.35f * Mhw(), std::abs(p.x()))) *
           Gauss((p.y() - hs_.MouthY()) / vertical) * Front(p);
  }
  static float LeftSide(const Eigen::Vector3f& p) { return Smoothstep(-0.8f, 0.8f, p.x()); }
  float BrowWeight(const Eigen::Vector3f& p, float centre_offset, float width) const {
    const float ex = hs_.Params().eye_half_spacing;
    return Gauss((p.x() - ex - centre_offset) / width) *
           Gauss((p.y() - hs_.BrowLineY(std::abs(p.x())) - 0.2f) / 1.3f) * Front(p);
  }

  Shape Make(const std::string& name) const {
    Shape s;
    s.name = name;
    const bool right = name.size() > 5 && name.compare(name.size() - 5, 5, "Right") == 0;
    const std::string base = right ? name.substr(0, name.size() - 5)
                                   : (name.size() > 4 && name.compare(name.size() - 4, 4, "Left") == 0
                                          ? name.substr(0, name.size() - 4)
                                          : name);
    const int side = right ? 1 : 0;
    const float look = options_.eye_look_degrees * kPi / 180.f;
    const Eigen::Matrix3f identity = Eigen::Matrix3f::Identity();
    // Eyes.
    if (base == "eyeBlink") {
      s.delta = ToSparse(LidDelta(side, {1.f, 1.f, 1.f}, identity));
    } else if (base == "eyeSquint") {
      Vertices d = LidDelta(side, {0.78f, 0.45f, 0.f}, identity);
      d += FieldDelta([&](const Eigen::Vector3f& p, const VertexFacts&) -> Eigen::Vector3f {
             const float ex = hs_.Params().eye_half_spacing;
             return Eigen::Vector3f(0.f, 0.18f, 0.08f) * Gauss((p.x() - ex) / 1.5f) *
                    Gauss((p.y() - hs_.EyeY() + 1.9f) / 0.9f) * Front(p);
           }, right);
      s.delta = ToSparse(d);
    } else if (base == "eyeWide") {
      s.delta = ToSparse(LidDelta(side, {1.45f, 1.12f, 0.f}, identity));
    } else if (base == "eyeLookUp") {
      s.delta = ToSparse(LidDelta(side, {1.2f, 0.95f, 0.f},
                                  EulerXyz(Eigen::Vector3f(-0.8f * look, 0.f, 0.f))));
    } else if (base == "eyeLookDown") {
      s.delta = ToSparse(LidDelta(side, {0.55f, 1.1f, 0.f},
                                  EulerXyz(Eigen::Vector3f(0.8f * look, 0.f, 0.f))));
    } else if (base == "eyeLookIn" || base == "eyeLookOut") {
      // In turns the gaze towards the nose: -x for the left eye, +x for the right eye.
      const float sign = (base == "eyeLookIn" ? -1.f : 1.f) * (right ? -1.f : 1.f);
      s.delta = ToSparse(LidDelta(side, {1.f, 1.f, 0.f},
                                  EulerXyz(Eigen::Vector3f(0.f, sign * look, 0.f))));
    }
    // Jaw: skinning only (R_i, T_i), no de-skinned delta.
    else if (name == "jawOpen") {
      s.jaw_euler = Eigen::Vector3f(options_.jaw_open_degrees * kPi / 180.f, 0.f, 0.f);
      s.jaw_translation = Eigen::Vector3f(0.f, 0.f, 0.15f);
    } else if (name == "jawForward") {
      s.jaw_translation = Eigen::Vector3f(0.f, 0.f, 0.9f);
    } else if (name == "jawLeft" || name == "jawRight") {
      const float sign = name == "jawLeft" ? 1.f : -1.f;
      s.jaw_euler = Eigen::Vector3f(0.f, sign * 0.1f, 0.f);
      s.jaw_translation = Eigen::Vector3f(sign * 0.35f, 0.f, 0.f);
    } else if (name == "mouthClose") {
      // Undo the jawOpen rotation on the lower lip (de-skinned), so that jawOpen + mouthClose
      // keeps the lips together: D = f (R^T (N - pivot - T) + pivot - N).
      const Eigen::Matrix3f r = EulerXyz(Eigen::Vector3f(options_.jaw_open_degrees * kPi / 180.f, 0, 0));
      const Eigen::Vector3f t(0.f, 0.f, 0.15f);
      const Eigen::Vector3f pivot = JawPivot(hs_);
      s.delta = ToSparse(FieldDelta([&](const Eigen::Vector3f& p, const VertexFacts& f) -> Eigen::Vector3f {
        if (!f.below_mouth) {
          return Eigen::Vector3f(0.f, -0.08f, 0.f) * LipWeight(p, 0.8f);
        }
        const float w = LipWeight(p, 1.4f) / std::max(1e-3f, LipWeight(Eigen::Vector3f(p.x(), hs_.MouthY(), p.z())));
        const Eigen::Vector3f back = r.transpose() * (p - pivot - t) + pivot - p;
        return Eigen::Vector3f(back * std::min(1.f, w) * (1.f - Smoothstep(0.8f * Mhw(), 1.3f * Mhw(), std::abs(p.x()))));
      }, false));
    } else if (name == "mouthFunnel") {
      s.delta = ToSparse(FieldDelta([&](const Eigen::Vector3f& p, const VertexFacts& f) -> Eigen::Vector3f {
        const float w = LipWeight(p, 0.9f);
        return Eigen::Vector3f(-0.25f * p.x(), f.below_mouth ? -0.35f : 0.25f, 0.75f) * w;
      }, false));
    } else if (name == "mouthPucker") {
      s.delta = ToSparse(FieldDelta([&](const Eigen::Vector3f& p, const VertexFacts& f) -> Eigen::Vector3f {
        const float w = LipWeight(p, 1.0f);
        return Eigen::Vector3f(-0.42f * p.x(), f.below_mouth ? 0.05f : -0.05f, 0.9f) * w;
      }, false));
    } else if (name == "mouthLeft" || name == "mouthRight") {
      s.delta = ToSparse(FieldDelta([&](const Eigen::Vector3f& p, const VertexFacts&) -> Eigen::Vector3f {
        return Eigen::Vector3f(0.9f, 0.f, -0.15f * p.x() / Mhw()) * Gauss(p.x() / 3.2f) *
               Gauss((p.y() - hs_.MouthY()) / 1.7f) * Front(p);
      }, name == "mouthRight"));
    } else if (base == "mouthSmile") {
      s.delta = ToSparse(FieldDelta([&](const Eigen::Vector3f& p, const VertexFacts&) -> Eigen::Vector3f {
        const float ex = hs_.Params().eye_half_spacing;
        const Eigen::Vector3f corner = Eigen::Vector3f(0.5f, 0.8f, -0.45f) * CornerWeight(p, 1.7f);
        const Eigen::Vector3f cheek = Eigen::Vector3f(0.1f, 0.35f, 0.25f) *
                                      Gauss((p.x() - ex - 0.3f) / 1.4f) *
                                      Gauss((p.y() - hs_.MouthY() - 3.2f) / 1.4f) * Front(p);
        return Eigen::Vector3f(corner + cheek);
      }, right));
    } else if (base == "mouthFrown") {
      s.delta = ToSparse(FieldDelta([&](const Eigen::Vector3f& p, const VertexFacts&) -> Eigen::Vector3f {
        return Eigen::Vector3f(Eigen::Vector3f(0.12f, -0.7f, -0.1f) * CornerWeight(p, 1.5f));
      }, right));
    } else if (base == "mouthDimple") {
      s.delta = ToSparse(FieldDelta([&](const Eigen::Vector3f& p, const VertexFacts&) -> Eigen::Vector3f {
        return Eigen::Vector3f(Eigen::Vector3f(0.25f, 0.05f, -0.45f) * CornerWeight(p, 1.1f));
      }, right));
    } else if (base == "mouthStretch") {
      s.delta = ToSparse(FieldDelta([&](const Eigen::Vector3f& p, const VertexFacts&) -> Eigen::Vector3f {
        return Eigen::Vector3f(Eigen::Vector3f(0.7f, -0.3f, -0.2f) * CornerWeight(p, 2.0f));
      }, right));
    } else if (base == "mouthPress") {
      s.delta = ToSparse(FieldDelta([&](const Eigen::Vector3f& p, const VertexFacts& f) -> Eigen::Vector3f {
        const float w = LipWeight(p, 0.8f) * LeftSide(p);
        return Eigen::Vector3f(0.f, f.below_mouth ? 0.15f : -0.12f, -0.18f) * w;
      }, right));
    } else if (base == "mouthLowerDown") {
      s.delta = ToSparse(FieldDelta([&](const Eigen::Vector3f& p, const VertexFacts& f) -> Eigen::Vector3f {
        if (!f.below_mouth) return Eigen::Vector3f::Zero().eval();
        const float w = LipWeight(p, 1.3f) * LeftSide(p);
        return Eigen::Vector3f(0.f, -0.6f, 0.1f) * w;
      }, right));
    } else if (base == "mouthUpperUp") {
      s.delta = ToSparse(FieldDelta([&](const Eigen::Vector3f& p, const VertexFacts& f) -> Eigen::Vector3f {
        if (f.below_mouth) return Eigen::Vector3f::Zero().eval();
        const float w = LipWeight(p, 1.2f) * LeftSide(p);
        return Eigen::Vector3f(0.f, 0.55f, 0.1f) * w;
      }, right));
    } else if (name == "mouthRollLower" || name == "mouthRollUpper") {
      const bool lower = name == "mouthRollLower";
      s.delta = ToSparse(FieldDelta([&](const Eigen::Vector3f& p, const VertexFacts& f) -> Eigen::Vector3f {
        if (f.below_mouth != lower) return Eigen::Vector3f::Zero().eval();
        const float w = LipWeight(p, 0.8f);
        return Eigen::Vector3f(0.f, lower ? 0.2f : -0.2f, -0.4f) * w;
      }, false));
    } else if (name == "mouthShrugLower") {
      s.delta = ToSparse(FieldDelta([&](const Eigen::Vector3f& p, const VertexFacts& f) -> Eigen::Vector3f {
        if (!f.below_mouth) return Eigen::Vector3f::Zero().eval();
        return Eigen::Vector3f(0.f, 0.35f, 0.2f) * Gauss(p.x() / 2.5f) *
               Gauss((p.y() - hs_.MouthY() + 1.5f) / 1.8f) * Front(p);
      }, false));
    } else if (name == "mouthShrugUpper") {
      s.delta = ToSparse(FieldDelta([&](const Eigen::Vector3f& p, const VertexFacts& f) -> Eigen::Vector3f {
        if (f.below_mouth) return Eigen::Vector3f::Zero().eval();
        return Eigen::Vector3f(0.f, 0.3f, 0.15f) * Gauss(p.x() / 2.5f) *
               Gauss((p.y() - hs_.MouthY() - 0.5f) / 0.9f) * Front(p);
      }, false));
    }
    // Brows.
    else if (base == "browDown") {
      s.delta = ToSparse(FieldDelta([&](const Eigen::Vector3f& p, const VertexFacts&) -> Eigen::Vector3f {
        return Eigen::Vector3f(-0.12f, -0.45f, 0.06f) * BrowWeight(p, -0.4f, 1.8f);
      }, right));
    } else if (name == "browInnerUp") {
      s.delta = ToSparse(FieldDelta([&](const Eigen::Vector3f& p, const VertexFacts&) -> Eigen::Vector3f {
        const Eigen::Vector3f q(std::abs(p.x()), p.y(), p.z());
        return Eigen::Vector3f(0.f, 0.6f, 0.f) * BrowWeight(q, -1.3f, 1.2f);
      }, false));
    } else if (base == "browOuterUp") {
      s.delta = ToSparse(FieldDelta([&](const Eigen::Vector3f& p, const VertexFacts&) -> Eigen::Vector3f {
        return Eigen::Vector3f(0.f, 0.55f, 0.f) * BrowWeight(p, 1.3f, 1.3f);
      }, right));
    }
    // Cheeks and nose.
    else if (name == "cheekPuff") {
      s.delta = ToSparse(FieldDelta([&](const Eigen::Vector3f& p, const VertexFacts&) -> Eigen::Vector3f {
        const float w = Gauss((std::abs(p.x()) - 4.0f) / 1.6f) *
                        Gauss((p.y() - hs_.MouthY() - 1.0f) / 1.8f) * Front(p);
        return Eigen::Vector3f(std::copysign(0.8f, p.x()), 0.f, 0.35f) * w;
      }, false));
    } else if (base == "cheekSquint") {
      s.delta = ToSparse(FieldDelta([&](const Eigen::Vector3f& p, const VertexFacts&) -> Eigen::Vector3f {
        const float ex = hs_.Params().eye_half_spacing;
        return Eigen::Vector3f(0.f, 0.35f, 0.15f) * Gauss((p.x() - ex) / 1.6f) *
               Gauss((p.y() - hs_.EyeY() + 1.9f) / 1.0f) * Front(p);
      }, right));
    } else if (base == "noseSneer") {
      s.delta = ToSparse(FieldDelta([&](const Eigen::Vector3f& p, const VertexFacts&) -> Eigen::Vector3f {
        return Eigen::Vector3f(0.05f, 0.35f, 0.05f) * Gauss((p.x() - 1.15f) / 0.75f) *
               Gauss((p.y() - hs_.SubnasaleY() - 0.7f) / 1.0f) * Front(p);
      }, right));
    } else if (name == "tongueOut") {
      s.delta = ToSparse(FieldDelta([&](const Eigen::Vector3f& p, const VertexFacts& f) -> Eigen::Vector3f {
        if (!f.below_mouth) return Eigen::Vector3f::Zero().eval();
        if (f.part == Part::kMouthPocket) {
          if (f.pocket_depth >= 1.f) return Eigen::Vector3f::Zero();
          // Undo the depth attenuation so the cavity floor comes forward as a tongue.
          return Eigen::Vector3f(Eigen::Vector3f(0.f, 0.1f, 1.6f) * Gauss(p.x() / 1.3f) /
                                 Square(1.f - f.pocket_depth));
        }
        return Eigen::Vector3f(0.f, -0.25f, 0.5f) * Gauss(p.x() / 1.3f) *
               Gauss((p.y() - hs_.MouthY() + 0.45f) / 0.7f) * Front(p);
      }, false));
    }
    return s;
  }

  const HeadBuilder& b_;
  const HeadSurface& hs_;
  const Layout& l_;
  const Vertices& n_;
  const std::vector<VertexFacts>& facts_;
  const Eigen::VectorXf& jaw_weights_;
  const DemoHeadOptions& options_;
  Eigen::Vector3f left_corner_;
};

}  // namespace

// ---- public API ------------------------------------------------------------------------------

bool DemoHeadOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& message) {
    if (why) *why = message;
    return false;
  };
  if (resolution < 60 || resolution > 300) {
    return fail("resolution must be in [60, 300], got " + std::to_string(resolution));
  }
  if (num_identity_modes < 0 || num_identity_modes > MaxDemoIdentityModes()) {
    return fail("num_identity_modes must be in [0, " + std::to_string(MaxDemoIdentityModes()) +
                "], got " + std::to_string(num_identity_modes));
  }
  if (eyeball_segments < 8 || eyeball_segments > 64) {
    return fail("eyeball_segments must be in [8, 64], got " + std::to_string(eyeball_segments));
  }
  if (!(jaw_open_degrees > 0.f && jaw_open_degrees <= 40.f)) {
    return fail("jaw_open_degrees must be in (0, 40], got " + std::to_string(jaw_open_degrees));
  }
  if (!(eye_look_degrees > 0.f && eye_look_degrees <= 45.f)) {
    return fail("eye_look_degrees must be in (0, 45], got " + std::to_string(eye_look_degrees));
  }
  if (!(identity_mode_scale > 0.f && identity_mode_scale <= 3.f)) {
    return fail("identity_mode_scale must be in (0, 3], got " + std::to_string(identity_mode_scale));
  }
  return true;
}

int MaxDemoIdentityModes() { return static_cast<int>(IdentityModeDefs().size()); }

const std::vector<std::string>& DemoIdentityModeNames() {
  static const std::vector<std::string> kNames = [] {
    std::vector<std::string> names;
    for (const IdentityModeDef& def : IdentityModeDefs()) names.push_back(def.name);
    return names;
  }();
  return kNames;
}

Rig MakeDemoHead(const DemoHeadOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw std::invalid_argument("DemoHeadOptions: " + why);
  const Layout layout = MakeLayout(options);
  const HeadParams mean;
  const HeadBuilder builder(mean, layout);

  Rig rig;
  rig.neutral = builder.BuildNeutral();
  MeshTopology topology = MakeTopology(builder, rig.neutral);
  rig.triangles = std::move(topology.triangles);
  rig.uvs = std::move(topology.uvs);
  rig.uv_triangles = std::move(topology.uv_triangles);
  rig.triangle_region = std::move(topology.triangle_region);
  rig.regions = MakeRegions();
  const std::vector<VertexFacts> facts = MakeFacts(layout);
  rig.jaw_pivot = JawPivot(builder.Surface());
  rig.jaw_weights = MakeJawWeights(builder.Surface(), layout, rig.neutral, facts);
  rig.landmarks = MakeLandmarks(builder, rig.neutral);
  rig.shapes = ShapeMaker(builder, rig.neutral, facts, rig.jaw_weights, options).MakeAll();

  // Identity modes: finite differences of the builder, one standard deviation per parameter.
  const std::vector<IdentityModeDef>& defs = IdentityModeDefs();
  rig.identity_modes.assign(options.num_identity_modes, Vertices());
#pragma omp parallel for schedule(dynamic)
  for (int k = 0; k < options.num_identity_modes; ++k) {
    HeadParams varied = mean;
    varied.*(defs[k].member) += options.identity_mode_scale * defs[k].std_dev;
    rig.identity_modes[k] = HeadBuilder(varied, layout).BuildNeutral() - rig.neutral;
  }
  return rig;
}

std::vector<float> DemoIdentityCoefficients(int identity_seed, int num_modes) {
  std::vector<float> alpha(std::max(0, num_modes), 0.f);
  if (identity_seed == 0) return alpha;
  std::mt19937 generator(static_cast<std::uint32_t>(identity_seed));
  for (int k = 0; k < num_modes; ++k) {
    // Box-Muller on two 32-bit draws; u1 in (0, 1] so the logarithm is finite.
    const double u1 = (static_cast<double>(generator()) + 1.0) / 4294967296.0;
    const double u2 = static_cast<double>(generator()) / 4294967296.0;
    const double normal = std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * 3.14159265358979323846 * u2);
    alpha[k] = static_cast<float>(std::min(2.5, std::max(-2.5, normal)));
  }
  return alpha;
}

Rig WithIdentity(const Rig& rig, int identity_seed, float magnitude) {
  Rig out = rig;
  const std::vector<float> alpha =
      DemoIdentityCoefficients(identity_seed, static_cast<int>(rig.identity_modes.size()));
  for (size_t k = 0; k < alpha.size(); ++k) {
    if (alpha[k] != 0.f) out.neutral += (magnitude * alpha[k]) * rig.identity_modes[k];
  }
  return out;
}

}  // namespace facecap::rig
