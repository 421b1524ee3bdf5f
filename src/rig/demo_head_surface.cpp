// Demo head shape parameters and identity mode definitions, and the head surface: the skin
// swept along the sagittal profile with the sculpted face features.
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Core>

#include "rig/demo_head_internal.h"

namespace facecap::rig::demo_head_internal {

// ---- shape parameters ------------------------------------------------------------------------

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

namespace {

constexpr float kFrontExponent = 2.f / 2.5f;  // superellipse exponent of the front half
constexpr float kBackExponent = 2.f / 2.2f;   // and of the back half

}  // namespace

HeadSurface::HeadSurface(const HeadParams& p) : p_(p) {
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

Eigen::Vector3f HeadSurface::EyeCenter(int side) const {
  Eigen::Vector3f c = eye_center_;
  if (side == 1) c.x() = -c.x();
  return c;
}

ProfileKey HeadSurface::Profile(float t) const {
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

float HeadSurface::ParameterAtHeight(float y, float t_lo, float t_hi) const {
  for (int it = 0; it < 40; ++it) {
    const float mid = 0.5f * (t_lo + t_hi);
    if (Profile(mid).y > y) t_lo = mid; else t_hi = mid;
  }
  return 0.5f * (t_lo + t_hi);
}

float HeadSurface::ThetaAtX(float x, int key) const {
  const float s = std::pow(std::min(0.999f, x / keys_[key].half_width), 1.f / kFrontExponent);
  return std::asin(s);
}

float HeadSurface::NoseHeight(float x, float y) const {
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

float HeadSurface::BrowLineY(float ax) const {
  const float u = (ax - p_.eye_half_spacing) / 2.3f;
  return y_eye_ + p_.brow_height + 0.3f * (1.f - u * u) - 0.15f * Smoothstep(0.f, 1.f, u);
}

float HeadSurface::UpperVermilionY(float x) const {
  const float q = std::min(1.f, std::abs(x) / p_.mouth_half_width);
  return y_mouth_ + (p_.upper_lip / 0.42f) * (0.8f * std::pow(1.f - q * q, 0.45f) +
                                             0.1f * Gauss((std::abs(x) - 0.45f) / 0.25f) -
                                             0.08f * Gauss(x / 0.2f));
}

float HeadSurface::LowerVermilionY(float x) const {
  const float q = std::min(1.f, std::abs(x) / p_.mouth_half_width);
  return y_mouth_ - (p_.lower_lip / 0.5f) * 0.95f * std::pow(1.f - q * q, 0.5f);
}

float HeadSurface::FeatureHeight(float x, float y) const {
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

float HeadSurface::FrontExponent(float y) const {
  const float n = 2.5f - 0.8f * Smoothstep(y_mouth_ - 0.5f, y_chin_, y) +
                  0.6f * Smoothstep(y_chin_, y_chin_ - 2.5f, y);
  return 2.f / n;
}

float HeadSurface::JawLineY(float theta) const {
  const float deg = std::abs(theta) * 180.f / kPi;
  const float ye = y_eye_, yc = y_chin_;
  return Table({{0.f, yc}, {25.f, yc + 0.35f}, {45.f, yc + 1.0f}, {62.f, yc + 1.9f},
                {72.f, ye - 7.3f}, {80.f, ye - 5.6f}, {90.f, ye - 3.4f}, {110.f, ye - 6.0f},
                {180.f, ye - 7.0f}},
               deg);
}

float HeadSurface::EyeCoverZ(float x, float y) const {
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

Eigen::Vector3f HeadSurface::Position(float theta, float t) const {
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

float& HeadSurface::Channel(ProfileKey& k, int ch) {
  return ch == 0 ? k.y : ch == 1 ? k.half_width : ch == 2 ? k.front_depth : k.back_depth;
}

float HeadSurface::Channel(const ProfileKey& k, int ch) {
  return ch == 0 ? k.y : ch == 1 ? k.half_width : ch == 2 ? k.front_depth : k.back_depth;
}

}  // namespace facecap::rig::demo_head_internal
