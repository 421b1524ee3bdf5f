#include "assets/template_shapes.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "rig/arkit.h"
#include "rig/evaluate.h"
#include "util/errors.h"

namespace facecap::assets {
namespace {

float SmoothStep(float edge0, float edge1, float x) {
  const float t = std::clamp((x - edge0) / (edge1 - edge0), 0.f, 1.f);
  return t * t * (3.f - 2.f * t);
}

}  // namespace

int LinearShapes::ShapeIndex(const std::string& name) const {
  for (size_t i = 0; i < names.size(); ++i) {
    if (names[i] == name) return static_cast<int>(i);
  }
  return -1;
}

LinearShapes LinearizeRig(const rig::Rig& rig) {
  LinearShapes out;
  out.neutral = rig.neutral;
  const int V = rig.NumVertices(), S = rig.NumShapes();
  out.deltas.setZero(3 * V, S);
  rig::Vertices evaluated;
  Eigen::VectorXf weights = Eigen::VectorXf::Zero(S);
  for (int i = 0; i < S; ++i) {
    out.names.push_back(rig.shapes[i].name);
    if (!rig.shapes[i].UsesJaw()) {
      const auto& d = rig.shapes[i].delta;
      for (size_t k = 0; k < d.vertex.size(); ++k) {
        out.deltas.block<3, 1>(3 * d.vertex[k], i) = d.offset[k];
      }
      continue;
    }
    weights.setZero();
    weights[i] = 1.f;
    rig::EvaluateShape(rig, weights, &evaluated);
    const rig::Vertices diff = evaluated - rig.neutral;
    out.deltas.col(i) = Eigen::Map<const Eigen::VectorXf>(diff.data(), 3 * V);
  }
  return out;
}

rig::Rig RigFromLinearShapes(const LinearShapes& shapes, const rig::Rig& topology) {
  rig::Rig out;
  out.neutral = shapes.neutral;
  out.triangles = topology.triangles;
  out.uvs = topology.uvs;
  out.uv_triangles = topology.uv_triangles;
  out.triangle_region = topology.triangle_region;
  out.regions = topology.regions;
  out.landmarks = topology.landmarks;
  out.jaw_weights = Eigen::VectorXf::Zero(shapes.NumVertices());
  out.jaw_pivot = topology.jaw_pivot;
  for (int i = 0; i < shapes.NumShapes(); ++i) {
    rig::Shape s;
    s.name = shapes.names[i];
    for (int v = 0; v < shapes.NumVertices(); ++v) {
      const Eigen::Vector3f d = shapes.deltas.block<3, 1>(3 * v, i);
      if (d.cwiseAbs().maxCoeff() > 1e-6f) {
        s.delta.vertex.push_back(v);
        s.delta.offset.push_back(d);
      }
    }
    out.shapes.push_back(std::move(s));
  }
  return out;
}

bool TemplateShapeOptions::Check(std::string* why) const {
  if (!(midline_blend_cm > 0.f && midline_blend_cm < 10.f)) {
    *why = "midline_blend_cm must be in (0, 10)";
    return false;
  }
  if (!(inner_brow_extent_cm > 0.f && inner_brow_extent_cm < 20.f)) {
    *why = "inner_brow_extent_cm must be in (0, 20)";
    return false;
  }
  return true;
}

const std::vector<std::string>& AsymmetricBrowShapeNames() {
  static const std::vector<std::string> names = {"browInnerUpLeft", "browInnerUpRight",
                                                 "browDownInnerLeft"};
  return names;
}

LinearShapes MakeTemplateShapes(const rig::Rig& rig, const TemplateShapeOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw InvalidInputError("template shapes: " + why);
  LinearShapes linear = LinearizeRig(rig);
  LinearShapes out;
  out.neutral = linear.neutral;
  const int V = linear.NumVertices();
  const auto& arkit = rig::ArkitShapeNames();
  out.deltas.setZero(3 * V, static_cast<int>(arkit.size() + AsymmetricBrowShapeNames().size()));
  int column = 0;
  for (const std::string& name : arkit) {
    const int i = linear.ShapeIndex(name);
    if (i < 0) throw InvalidInputError("template shapes: the rig has no ARKit shape " + name);
    out.deltas.col(column++) = linear.deltas.col(i);
    out.names.push_back(name);
  }
  const Eigen::VectorXf inner_up = linear.deltas.col(linear.ShapeIndex("browInnerUp"));
  const Eigen::VectorXf down_left = linear.deltas.col(linear.ShapeIndex("browDownLeft"));
  const float w = options.midline_blend_cm;
  for (int v = 0; v < V; ++v) {
    const float x = linear.neutral(v, 0);
    // Masks that leave a band around the midline: m_L(0) = m_R(0) = SmoothStep(0.25).
    const float left = SmoothStep(-0.5f * w, 1.5f * w, x);
    const float right = SmoothStep(-0.5f * w, 1.5f * w, -x);
    const float inner = 1.f - SmoothStep(0.5f * options.inner_brow_extent_cm,
                                         options.inner_brow_extent_cm, std::abs(x));
    out.deltas.block<3, 1>(3 * v, column) = left * inner_up.segment<3>(3 * v);
    out.deltas.block<3, 1>(3 * v, column + 1) = right * inner_up.segment<3>(3 * v);
    out.deltas.block<3, 1>(3 * v, column + 2) = inner * down_left.segment<3>(3 * v);
  }
  for (const auto& name : AsymmetricBrowShapeNames()) out.names.push_back(name);
  return out;
}

std::vector<int> MovingVertices(const LinearShapes& shapes, float threshold_cm) {
  std::vector<int> out;
  for (int v = 0; v < shapes.NumVertices(); ++v) {
    float most = 0.f;
    for (int i = 0; i < shapes.NumShapes(); ++i) {
      most = std::max(most, shapes.deltas.block<3, 1>(3 * v, i).norm());
    }
    if (most > threshold_cm) out.push_back(v);
  }
  return out;
}

std::vector<FacsExpression> ParseFacsTable(const std::vector<std::string>& entries) {
  std::vector<FacsExpression> table;
  for (const std::string& entry : entries) {
    const size_t eq = entry.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 >= entry.size()) {
      throw InvalidInputError("FACS table entry '" + entry +
                              "' is not of the form name=shapeA+shapeB");
    }
    FacsExpression e;
    e.name = entry.substr(0, eq);
    size_t begin = eq + 1;
    while (begin <= entry.size()) {
      size_t end = entry.find('+', begin);
      if (end == std::string::npos) end = entry.size();
      const std::string shape = entry.substr(begin, end - begin);
      if (shape.empty()) throw InvalidInputError("FACS table entry '" + entry + "' has an empty shape");
      e.shapes.push_back(shape);
      begin = end + 1;
    }
    table.push_back(std::move(e));
  }
  return table;
}

const std::vector<std::string>& DefaultFacsTable() {
  static const std::vector<std::string> table = {
      "blink=eyeBlinkLeft+eyeBlinkRight",
      "look_left=eyeLookOutLeft+eyeLookInRight+jawLeft+mouthLeft",
      "look_right=eyeLookInLeft+eyeLookOutRight+jawRight+mouthRight",
      "look_up=eyeLookUpLeft+eyeLookUpRight+browOuterUpLeft+browOuterUpRight",
      "look_down=eyeLookDownLeft+eyeLookDownRight+mouthShrugLower",
      "squint=eyeSquintLeft+eyeSquintRight+cheekSquintLeft+cheekSquintRight",
      "surprise=eyeWideLeft+eyeWideRight+browInnerUp+jawOpen",
      "jaw_forward=jawForward+mouthShrugUpper",
      "open_lips_closed=jawOpen+mouthClose",
      "funnel=mouthFunnel",
      "pucker=mouthPucker",
      "smile=mouthSmileLeft+mouthSmileRight",
      "frown=mouthFrownLeft+mouthFrownRight+browDownLeft+browDownRight",
      "dimple_press=mouthDimpleLeft+mouthDimpleRight+mouthPressLeft+mouthPressRight",
      "stretch=mouthStretchLeft+mouthStretchRight+mouthLowerDownLeft+mouthLowerDownRight",
      "lip_roll=mouthRollLower+mouthRollUpper",
      "sneer=noseSneerLeft+noseSneerRight+mouthUpperUpLeft+mouthUpperUpRight",
      "cheek_puff=cheekPuff",
      "tongue=tongueOut+jawOpen",
      "brow_inner_up_left=browInnerUpLeft",
      "brow_inner_up_right=browInnerUpRight",
      "brow_down_inner_left=browDownInnerLeft",
      "smile_left=mouthSmileLeft+cheekSquintLeft",
      "jaw_open=jawOpen",
  };
  return table;
}

Eigen::MatrixXf FacsWeights(const std::vector<FacsExpression>& table,
                            const std::vector<std::string>& shape_names, bool require_cover) {
  Eigen::MatrixXf alpha = Eigen::MatrixXf::Zero(static_cast<int>(table.size()),
                                                static_cast<int>(shape_names.size()));
  for (size_t k = 0; k < table.size(); ++k) {
    for (const std::string& s : table[k].shapes) {
      auto it = std::find(shape_names.begin(), shape_names.end(), s);
      if (it == shape_names.end()) {
        throw InvalidInputError("FACS expression '" + table[k].name + "' names unknown shape '" +
                                s + "'");
      }
      alpha(static_cast<int>(k), static_cast<int>(it - shape_names.begin())) = 1.f;
    }
  }
  if (require_cover) {
    for (int i = 0; i < alpha.cols(); ++i) {
      if (alpha.col(i).sum() == 0.f) {
        throw InvalidInputError("the FACS table covers no expression with shape '" +
                                shape_names[i] + "'; every template shape must be used");
      }
    }
  }
  return alpha;
}

}  // namespace facecap::assets
