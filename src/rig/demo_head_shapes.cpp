// Demo head shapes: the 52 ARKit shapes as eyelid and eyeball rebuilds, displacement fields
// and jaw skinning.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "rig/arkit.h"
#include "rig/demo_head_internal.h"

namespace facecap::rig::demo_head_internal {

namespace {

// Rz * Ry * Rx from Euler angles (x, y, z), radians (the convention of rig/pose.h).
Eigen::Matrix3f EulerXyz(const Eigen::Vector3f& e) {
  return (Eigen::AngleAxisf(e.z(), Eigen::Vector3f::UnitZ()) *
          Eigen::AngleAxisf(e.y(), Eigen::Vector3f::UnitY()) *
          Eigen::AngleAxisf(e.x(), Eigen::Vector3f::UnitX()))
      .toRotationMatrix();
}

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

}  // namespace

ShapeMaker::ShapeMaker(const HeadBuilder& builder, const Vertices& neutral,
                       const std::vector<VertexFacts>& facts, const Eigen::VectorXf& jaw_weights,
                       const DemoHeadOptions& options)
    : b_(builder), hs_(builder.Surface()), l_(builder.GetLayout()), n_(neutral), facts_(facts),
      jaw_weights_(jaw_weights), options_(options) {
  left_corner_ = n_.row(l_.Grid(l_.row_mouth, l_.MouthHi())).transpose();
}

std::vector<Shape> ShapeMaker::MakeAll() const {
  std::vector<Shape> shapes;
  for (const std::string& name : ArkitShapeNames()) shapes.push_back(Make(name));
  return shapes;
}

Vertices ShapeMaker::FieldDelta(const Field& f, bool mirror) const {
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

Vertices ShapeMaker::LidDelta(int side, const LidState& lid,
                              const Eigen::Matrix3f& eye_rotation) const {
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

float ShapeMaker::CornerWeight(const Eigen::Vector3f& p, float r) const {
  return Gauss((p.head<2>() - left_corner_.head<2>()).norm() / r) * Front(p);
}

float ShapeMaker::LipWeight(const Eigen::Vector3f& p, float vertical) const {
  return (1.f - Smoothstep(0.6f * Mhw(), 1.35f * Mhw(), std::abs(p.x()))) *
         Gauss((p.y() - hs_.MouthY()) / vertical) * Front(p);
}

float ShapeMaker::BrowWeight(const Eigen::Vector3f& p, float centre_offset, float width) const {
  const float ex = hs_.Params().eye_half_spacing;
  return Gauss((p.x() - ex - centre_offset) / width) *
         Gauss((p.y() - hs_.BrowLineY(std::abs(p.x())) - 0.2f) / 1.3f) * Front(p);
}

// Eyes: the head rebuilt with another lid state and, for the look shapes, a turned eyeball.
void ShapeMaker::MakeEyeShape(const std::string& name, const std::string& base, bool right,
                              Shape& s) const {
  const int side = right ? 1 : 0;
  const float look = options_.eye_look_degrees * kPi / 180.f;
  const Eigen::Matrix3f identity = Eigen::Matrix3f::Identity();
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
}

// Jaw: skinning only (R_i, T_i), no de-skinned delta.
void ShapeMaker::MakeJawShape(const std::string& name, const std::string& base, bool right,
                              Shape& s) const {
  if (name == "jawOpen") {
    s.jaw_euler = Eigen::Vector3f(options_.jaw_open_degrees * kPi / 180.f, 0.f, 0.f);
    s.jaw_translation = Eigen::Vector3f(0.f, 0.f, 0.15f);
  } else if (name == "jawForward") {
    s.jaw_translation = Eigen::Vector3f(0.f, 0.f, 0.9f);
  } else if (name == "jawLeft" || name == "jawRight") {
    const float sign = name == "jawLeft" ? 1.f : -1.f;
    s.jaw_euler = Eigen::Vector3f(0.f, sign * 0.1f, 0.f);
    s.jaw_translation = Eigen::Vector3f(sign * 0.35f, 0.f, 0.f);
  }
}

// Mouth: shapes of the whole mouth and of its corners.
void ShapeMaker::MakeMouthShape(const std::string& name, const std::string& base, bool right,
                                Shape& s) const {
  if (name == "mouthClose") {
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
  }
}

// Mouth: shapes that move one lip.
void ShapeMaker::MakeOneLipShape(const std::string& name, const std::string& base, bool right,
                                 Shape& s) const {
  if (base == "mouthLowerDown") {
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
}

// Brows.
void ShapeMaker::MakeBrowShape(const std::string& name, const std::string& base, bool right,
                               Shape& s) const {
  if (base == "browDown") {
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
}

// Cheeks and nose, and the tongue.
void ShapeMaker::MakeCheekNoseTongueShape(const std::string& name, const std::string& base,
                                          bool right, Shape& s) const {
  if (name == "cheekPuff") {
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
}

Shape ShapeMaker::Make(const std::string& name) const {
  Shape s;
  s.name = name;
  const bool right = name.size() > 5 && name.compare(name.size() - 5, 5, "Right") == 0;
  const std::string base = right ? name.substr(0, name.size() - 5)
                                 : (name.size() > 4 && name.compare(name.size() - 4, 4, "Left") == 0
                                        ? name.substr(0, name.size() - 4)
                                        : name);
  // No name is in two groups, so one group at most fills s; a name in none has no motion.
  MakeEyeShape(name, base, right, s);
  MakeJawShape(name, base, right, s);
  MakeMouthShape(name, base, right, s);
  MakeOneLipShape(name, base, right, s);
  MakeBrowShape(name, base, right, s);
  MakeCheekNoseTongueShape(name, base, right, s);
  return s;
}

}  // namespace facecap::rig::demo_head_internal
