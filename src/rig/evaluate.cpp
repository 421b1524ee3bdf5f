#include "rig/evaluate.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <omp.h>

#include "util/errors.h"
#include "util/parallel_for.h"

namespace facecap::rig {

namespace {

// The jaw's rigid motion at weights w: x -> R(w)(x - pivot) + pivot + T(w).
struct JawMotion {
  bool moves = false;              // false when R(w) = I and T(w) = 0
  Eigen::Matrix3f rotation = Eigen::Matrix3f::Identity();  // R(w)
  Eigen::Vector3f pivot = Eigen::Vector3f::Zero();
  Eigen::Vector3f translation = Eigen::Vector3f::Zero();   // T(w)
};

JawMotion ComputeJawMotion(const Rig& rig, const Eigen::VectorXf& weights) {
  JawMotion jaw;
  const Eigen::Vector3f euler = InterpolatedJawEuler(rig, weights);
  jaw.translation = InterpolatedJawTranslation(rig, weights);
  jaw.pivot = rig.jaw_pivot;
  jaw.moves = !euler.isZero(0) || !jaw.translation.isZero(0);
  if (jaw.moves) jaw.rotation = EulerToMatrix(euler);
  return jaw;
}

void CheckWeightCount(const Rig& rig, const Eigen::VectorXf& weights) {
  if (weights.size() != rig.NumShapes()) {
    throw InvalidInputError("rig evaluation: " + std::to_string(weights.size()) +
                            " weights given for a rig with " + std::to_string(rig.NumShapes()) +
                            " shapes");
  }
}

// out[v] += w * D_i[v] for the delta entries [begin, end) of one shape.
inline void AddDeltaEntries(const SparseDelta& delta, float weight, int begin, int end,
                            float* out) {
  const int* vertex = delta.vertex.data();
  const Eigen::Vector3f* offset = delta.offset.data();
  for (int k = begin; k < end; ++k) {
    float* o = out + 3 * static_cast<std::ptrdiff_t>(vertex[k]);
    o[0] += weight * offset[k].x();
    o[1] += weight * offset[k].y();
    o[2] += weight * offset[k].z();
  }
}

// x <- (m R + (1 - m) I) x + m T with R about the pivot, i.e. x + m (R (x - p) + p + T - x).
inline void ApplyJawSkinning(const JawMotion& jaw, float jaw_weight, float* o) {
  const Eigen::Vector3f x(o[0], o[1], o[2]);
  const Eigen::Vector3f moved = jaw.rotation * (x - jaw.pivot) + jaw.pivot + jaw.translation;
  const Eigen::Vector3f skinned = x + jaw_weight * (moved - x);
  o[0] = skinned.x();
  o[1] = skinned.y();
  o[2] = skinned.z();
}

// x <- scale * Rot * x + translation for rows [begin, end).
void ApplyPoseRows(const RigidPose& pose, int begin, int end, Vertices* out) {
  const Eigen::Matrix3f scaled_rotation = pose.scale * pose.Rotation();
  for (int v = begin; v < end; ++v) {
    const Eigen::Vector3f x = out->row(v).transpose();
    out->row(v) = (scaled_rotation * x + pose.translation).transpose();
  }
}

// Single-threaded S(w) without precomputed data: scatter each shape with a non-zero weight.
void EvaluateShapeDirect(const Rig& rig, const Eigen::VectorXf& weights, Vertices* out) {
  CheckWeightCount(rig, weights);
  const int num_vertices = rig.NumVertices();
  out->resize(num_vertices, 3);
  std::copy(rig.neutral.data(), rig.neutral.data() + 3 * num_vertices, out->data());
  for (int s = 0; s < rig.NumShapes(); ++s) {
    const float w = weights[s];
    if (w == 0.f) continue;
    const SparseDelta& delta = rig.shapes[s].delta;
    AddDeltaEntries(delta, w, 0, static_cast<int>(delta.vertex.size()), out->data());
  }
  const JawMotion jaw = ComputeJawMotion(rig, weights);
  if (!jaw.moves) return;
  if (rig.jaw_weights.size() != num_vertices) {
    throw InvalidInputError("rig evaluation: jaw_weights has " +
                            std::to_string(rig.jaw_weights.size()) + " entries for " +
                            std::to_string(num_vertices) + " vertices");
  }
  for (int v = 0; v < num_vertices; ++v) {
    const float m = rig.jaw_weights[v];
    if (m > 0.f) ApplyJawSkinning(jaw, m, out->data() + 3 * static_cast<std::ptrdiff_t>(v));
  }
}

}  // namespace

int NumRigParams(const Rig& rig) { return kNumPoseParams + rig.NumShapes(); }

Eigen::VectorXf PackRigParams(const RigidPose& pose, const Eigen::VectorXf& weights) {
  Eigen::VectorXf params(kNumPoseParams + weights.size());
  params[kPitch] = pose.pitch;
  params[kYaw] = pose.yaw;
  params[kRoll] = pose.roll;
  params[kTx] = pose.translation.x();
  params[kTy] = pose.translation.y();
  params[kTz] = pose.translation.z();
  params[kScale] = pose.scale;
  params.tail(weights.size()) = weights;
  return params;
}

void UnpackRigParams(const Eigen::VectorXf& params, RigidPose* pose, Eigen::VectorXf* weights) {
  if (params.size() < kNumPoseParams) {
    throw InvalidInputError("rig parameter vector has " + std::to_string(params.size()) +
                            " entries, fewer than the 7 pose parameters");
  }
  if (pose) {
    pose->pitch = params[kPitch];
    pose->yaw = params[kYaw];
    pose->roll = params[kRoll];
    pose->translation = Eigen::Vector3f(params[kTx], params[kTy], params[kTz]);
    pose->scale = params[kScale];
  }
  if (weights) *weights = params.tail(params.size() - kNumPoseParams);
}

void EulerToMatrixWithDerivatives(const Eigen::Vector3f& euler_xyz, Eigen::Matrix3f* rotation,
                                  std::array<Eigen::Matrix3f, 3>* derivatives) {
  const float cx = std::cos(euler_xyz.x()), sx = std::sin(euler_xyz.x());
  const float cy = std::cos(euler_xyz.y()), sy = std::sin(euler_xyz.y());
  const float cz = std::cos(euler_xyz.z()), sz = std::sin(euler_xyz.z());
  Eigen::Matrix3f rx, ry, rz, drx, dry, drz;
  rx << 1, 0, 0, 0, cx, -sx, 0, sx, cx;
  ry << cy, 0, sy, 0, 1, 0, -sy, 0, cy;
  rz << cz, -sz, 0, sz, cz, 0, 0, 0, 1;
  drx << 0, 0, 0, 0, -sx, -cx, 0, cx, -sx;
  dry << -sy, 0, cy, 0, 0, 0, -cy, 0, -sy;
  drz << -sz, -cz, 0, cz, -sz, 0, 0, 0, 0;
  const Eigen::Matrix3f rz_ry = rz * ry;
  if (rotation) *rotation = rz_ry * rx;
  if (derivatives) {
    (*derivatives)[0] = rz_ry * drx;
    (*derivatives)[1] = rz * dry * rx;
    (*derivatives)[2] = drz * ry * rx;
  }
}

std::vector<int> JawShapeIndices(const Rig& rig) {
  std::vector<int> indices;
  for (int s = 0; s < rig.NumShapes(); ++s) {
    if (rig.shapes[s].UsesJaw()) indices.push_back(s);
  }
  return indices;
}

Eigen::Vector3f InterpolatedJawEuler(const Rig& rig, const Eigen::VectorXf& weights) {
  CheckWeightCount(rig, weights);
  Eigen::Vector3f euler = Eigen::Vector3f::Zero();  // sum_i w_i theta_i
  for (int s = 0; s < rig.NumShapes(); ++s) euler += weights[s] * rig.shapes[s].jaw_euler;
  return euler;
}

Eigen::Vector3f InterpolatedJawTranslation(const Rig& rig, const Eigen::VectorXf& weights) {
  CheckWeightCount(rig, weights);
  Eigen::Vector3f translation = Eigen::Vector3f::Zero();  // T(w) = sum_i w_i T_i
  for (int s = 0; s < rig.NumShapes(); ++s) {
    translation += weights[s] * rig.shapes[s].jaw_translation;
  }
  return translation;
}

// ---- RigEvaluator ----------------------------------------------------------------------------

RigEvaluator::RigEvaluator(const Rig& rig, const Options& options)
    : rig_(rig), options_(options) {
  const int num_vertices = rig.NumVertices();
  const int num_shapes = rig.NumShapes();
  if (rig.jaw_weights.size() != num_vertices) {
    throw InvalidInputError("RigEvaluator: jaw_weights has " +
                            std::to_string(rig.jaw_weights.size()) + " entries for " +
                            std::to_string(num_vertices) + " vertices");
  }
  for (int s = 0; s < num_shapes; ++s) {
    const SparseDelta& delta = rig.shapes[s].delta;
    bool ok = delta.vertex.size() == delta.offset.size();
    for (size_t k = 0; ok && k < delta.vertex.size(); ++k) {
      ok = delta.vertex[k] >= 0 && delta.vertex[k] < num_vertices &&
           (k == 0 || delta.vertex[k] > delta.vertex[k - 1]);
    }
    if (!ok) {
      throw InvalidInputError("RigEvaluator: shape '" + rig.shapes[s].name +
                              "' has delta vertex indices that are out of range, not ascending "
                              "or not matched by offsets (see Rig::Check)");
    }
  }

  // Vertex blocks for threaded full evaluations.
  int threads = options_.num_threads <= 0 ? DefaultNumThreads() : options_.num_threads;
  num_blocks_ = threads <= 1 ? 1 : std::min(4 * threads, std::max(1, num_vertices / 256));
  block_begin_.resize(num_blocks_ + 1);
  for (int b = 0; b <= num_blocks_; ++b) {
    block_begin_[b] = static_cast<int>(static_cast<long long>(num_vertices) * b / num_blocks_);
  }
  BuildShapeBlocks();
  for (int v = 0; v < num_vertices; ++v) {
    if (rig.jaw_weights[v] > 0.f) jaw_vertices_.push_back(v);
  }
  jaw_block_begin_.resize(num_blocks_ + 1);
  for (int b = 0; b <= num_blocks_; ++b) {
    jaw_block_begin_[b] = static_cast<int>(
        std::lower_bound(jaw_vertices_.begin(), jaw_vertices_.end(), block_begin_[b]) -
        jaw_vertices_.begin());
  }

  // Per-vertex (shape, offset) lists in CSR form, shapes ascending within a vertex.
  vertex_delta_begin_.assign(num_vertices + 1, 0);
  for (const Shape& shape : rig.shapes) {
    for (int v : shape.delta.vertex) ++vertex_delta_begin_[v + 1];
  }
  for (int v = 0; v < num_vertices; ++v) vertex_delta_begin_[v + 1] += vertex_delta_begin_[v];
  vertex_deltas_.resize(vertex_delta_begin_[num_vertices]);
  std::vector<int> fill(vertex_delta_begin_.begin(), vertex_delta_begin_.end() - 1);
  for (int s = 0; s < num_shapes; ++s) {
    const SparseDelta& delta = rig.shapes[s].delta;
    for (size_t k = 0; k < delta.vertex.size(); ++k) {
      vertex_deltas_[fill[delta.vertex[k]]++] = DeltaEntry{s, delta.offset[k]};
    }
  }
  jaw_shapes_ = JawShapeIndices(rig);
}

void RigEvaluator::BuildShapeBlocks() {
  // Entries at most kMaxGap vertices apart join one run (the gap is stored as zero offsets);
  // runs shorter than kMinRunLength stay scattered entries.
  constexpr int kMaxGap = 2;
  constexpr int kMinRunLength = 16;
  const int num_shapes = rig_.NumShapes();
  shape_blocks_.resize(static_cast<size_t>(num_shapes) * num_blocks_);
  for (int s = 0; s < num_shapes; ++s) {
    const SparseDelta& delta = rig_.shapes[s].delta;
    const int num_entries = static_cast<int>(delta.vertex.size());
    for (int b = 0; b < num_blocks_; ++b) {
      ShapeBlock& block = shape_blocks_[static_cast<size_t>(s) * num_blocks_ + b];
      block.run_begin = static_cast<int>(dense_runs_.size());
      block.scattered_begin = static_cast<int>(scattered_vertex_.size());
      int k = static_cast<int>(std::lower_bound(delta.vertex.begin(), delta.vertex.end(),
                                                block_begin_[b]) - delta.vertex.begin());
      while (k < num_entries && delta.vertex[k] < block_begin_[b + 1]) {
        int last = k;  // last entry of the run starting at k
        while (last + 1 < num_entries && delta.vertex[last + 1] < block_begin_[b + 1] &&
               delta.vertex[last + 1] - delta.vertex[last] <= kMaxGap) {
          ++last;
        }
        const int first_vertex = delta.vertex[k];
        const int count = delta.vertex[last] - first_vertex + 1;
        if (count >= kMinRunLength) {
          DenseRun run{first_vertex, count, static_cast<int>(dense_offsets_.size())};
          dense_offsets_.resize(dense_offsets_.size() + 3 * static_cast<size_t>(count), 0.f);
          for (int e = k; e <= last; ++e) {
            float* o = &dense_offsets_[run.offset_begin + 3 * (delta.vertex[e] - first_vertex)];
            o[0] = delta.offset[e].x();
            o[1] = delta.offset[e].y();
            o[2] = delta.offset[e].z();
          }
          dense_runs_.push_back(run);
        } else {
          for (int e = k; e <= last; ++e) {
            scattered_vertex_.push_back(delta.vertex[e]);
            scattered_offset_.push_back(delta.offset[e]);
          }
        }
        k = last + 1;
      }
      block.run_end = static_cast<int>(dense_runs_.size());
      block.scattered_end = static_cast<int>(scattered_vertex_.size());
    }
  }
}

void RigEvaluator::CheckWeights(const Eigen::VectorXf& weights) const {
  CheckWeightCount(rig_, weights);
}

namespace {

// Runs fn(block) for every block, threaded unless there is one block or we are already
// inside a parallel region.
template <typename Fn>
void ForEachBlock(int num_blocks, int num_threads, Fn&& fn) {
  if (num_blocks == 1 || omp_in_parallel()) {
    for (int b = 0; b < num_blocks; ++b) fn(b);
  } else {
    ParallelFor(0, num_blocks, num_threads, fn);
  }
}

}  // namespace

void RigEvaluator::EvaluateShape(const Eigen::VectorXf& weights, Vertices* out) const {
  CheckWeights(weights);
  const int num_vertices = rig_.NumVertices();
  out->resize(num_vertices, 3);
  const JawMotion jaw = ComputeJawMotion(rig_, weights);
  ForEachBlock(num_blocks_, options_.num_threads, [&](int b) {
    const int begin = block_begin_[b], end = block_begin_[b + 1];
    std::copy(rig_.neutral.data() + 3 * static_cast<std::ptrdiff_t>(begin),
              rig_.neutral.data() + 3 * static_cast<std::ptrdiff_t>(end),
              out->data() + 3 * static_cast<std::ptrdiff_t>(begin));
    // N + sum_i w_i D_i
    for (int s = 0; s < rig_.NumShapes(); ++s) {
      const float w = weights[s];
      if (w == 0.f) continue;
      const ShapeBlock& block = shape_blocks_[static_cast<size_t>(s) * num_blocks_ + b];
      for (int r = block.run_begin; r < block.run_end; ++r) {
        const DenseRun& run = dense_runs_[r];
        float* __restrict o = out->data() + 3 * static_cast<std::ptrdiff_t>(run.first_vertex);
        const float* __restrict d = dense_offsets_.data() + run.offset_begin;
        const int n = 3 * run.count;
        for (int i = 0; i < n; ++i) o[i] += w * d[i];
      }
      float* o = out->data();
      for (int e = block.scattered_begin; e < block.scattered_end; ++e) {
        float* p = o + 3 * static_cast<std::ptrdiff_t>(scattered_vertex_[e]);
        const Eigen::Vector3f& d = scattered_offset_[e];
        p[0] += w * d.x();
        p[1] += w * d.y();
        p[2] += w * d.z();
      }
    }
    // (M R(w) + (1 - M) I)(...) + M T(w)
    if (jaw.moves) {
      for (int j = jaw_block_begin_[b]; j < jaw_block_begin_[b + 1]; ++j) {
        const int v = jaw_vertices_[j];
        ApplyJawSkinning(jaw, rig_.jaw_weights[v],
                         out->data() + 3 * static_cast<std::ptrdiff_t>(v));
      }
    }
  });
}

void RigEvaluator::EvaluatePosed(const RigidPose& pose, const Eigen::VectorXf& weights,
                                 Vertices* out) const {
  EvaluateShape(weights, out);
  ApplyPoseRows(pose, 0, rig_.NumVertices(), out);
}

void RigEvaluator::EvaluatePosedWithJacobian(const RigidPose& pose,
                                             const Eigen::VectorXf& weights,
                                             const std::vector<int>& vertex_ids,
                                             Vertices* positions,
                                             Eigen::MatrixXf* jacobian) const {
  CheckWeights(weights);
  const int num_vertices = rig_.NumVertices();
  const int num_ids = static_cast<int>(vertex_ids.size());
  for (int k = 0; k < num_ids; ++k) {
    if (vertex_ids[k] < 0 || vertex_ids[k] >= num_vertices) {
      throw InvalidInputError("EvaluatePosedWithJacobian: vertex id " +
                              std::to_string(vertex_ids[k]) + " (entry " + std::to_string(k) +
                              ") outside [0, " + std::to_string(num_vertices) + ")");
    }
  }

  // Pose rotation Rot(pitch, yaw, roll) and its derivatives.
  Eigen::Matrix3f pose_rotation;
  std::array<Eigen::Matrix3f, 3> pose_rotation_derivative;
  EulerToMatrixWithDerivatives(Eigen::Vector3f(pose.pitch, pose.yaw, pose.roll), &pose_rotation,
                               &pose_rotation_derivative);
  const float scale = pose.scale;
  // Jaw rotation R(w) = EulerToMatrix(sum_i w_i theta_i) and its derivatives.
  Eigen::Matrix3f jaw_rotation;
  std::array<Eigen::Matrix3f, 3> jaw_rotation_derivative;
  EulerToMatrixWithDerivatives(InterpolatedJawEuler(rig_, weights), &jaw_rotation,
                               &jaw_rotation_derivative);
  const Eigen::Vector3f jaw_translation = InterpolatedJawTranslation(rig_, weights);  // T(w)
  const Eigen::Vector3f& pivot = rig_.jaw_pivot;

  if (positions) positions->resize(num_ids, 3);
  if (jacobian) jacobian->setZero(3 * num_ids, NumParams());
  const Eigen::Matrix3f scaled_pose_rotation = scale * pose_rotation;

  for (int k = 0; k < num_ids; ++k) {
    const int v = vertex_ids[k];
    // x = N + sum_i w_i D_i at v.
    Eigen::Vector3f blended = rig_.neutral.row(v).transpose();
    for (int e = vertex_delta_begin_[v]; e < vertex_delta_begin_[v + 1]; ++e) {
      blended += weights[vertex_deltas_[e].shape] * vertex_deltas_[e].offset;
    }
    const float jaw_weight = rig_.jaw_weights[v];  // M at v
    Eigen::Vector3f skinned = blended;             // S(w) at v
    Eigen::Matrix3f blend_to_skinned = Eigen::Matrix3f::Identity();  // d S / d x
    Eigen::Matrix3f jaw_angle_to_skinned = Eigen::Matrix3f::Zero();   // d S / d (sum w theta)
    if (jaw_weight > 0.f) {
      const Eigen::Vector3f relative = blended - pivot;
      skinned = blended + jaw_weight * (jaw_rotation * relative + pivot + jaw_translation - blended);
      blend_to_skinned = (1.f - jaw_weight) * Eigen::Matrix3f::Identity() + jaw_weight * jaw_rotation;
      for (int a = 0; a < 3; ++a) {
        jaw_angle_to_skinned.col(a) = jaw_weight * (jaw_rotation_derivative[a] * relative);
      }
    }
    const Eigen::Vector3f rotated = pose_rotation * skinned;  // Rot S
    if (positions) positions->row(k) = (scale * rotated + pose.translation).transpose();
    if (!jacobian) continue;

    Eigen::MatrixXf& jac = *jacobian;
    const int row = 3 * k;
    for (int a = 0; a < 3; ++a) {
      jac.block<3, 1>(row, kPitch + a) = scale * (pose_rotation_derivative[a] * skinned);
    }
    jac(row + 0, kTx) = 1.f;
    jac(row + 1, kTy) = 1.f;
    jac(row + 2, kTz) = 1.f;
    jac.block<3, 1>(row, kScale) = rotated;

    // d / d w_i of the delta part: s Rot ((1 - M) I + M R) D_i.
    const Eigen::Matrix3f delta_to_posed = scaled_pose_rotation * blend_to_skinned;
    for (int e = vertex_delta_begin_[v]; e < vertex_delta_begin_[v + 1]; ++e) {
      jac.block<3, 1>(row, kNumPoseParams + vertex_deltas_[e].shape) +=
          delta_to_posed * vertex_deltas_[e].offset;
    }
    // d / d w_i of the jaw part: s Rot M (dR/dtheta theta_i (x - p) + T_i).
    if (jaw_weight > 0.f) {
      for (int s : jaw_shapes_) {
        const Shape& shape = rig_.shapes[s];
        jac.block<3, 1>(row, kNumPoseParams + s) +=
            scaled_pose_rotation *
            (jaw_angle_to_skinned * shape.jaw_euler + jaw_weight * shape.jaw_translation);
      }
    }
  }
}

// ---- one-call wrappers -----------------------------------------------------------------------

void EvaluateShape(const Rig& rig, const Eigen::VectorXf& weights, Vertices* out) {
  EvaluateShapeDirect(rig, weights, out);
}

void EvaluatePosed(const Rig& rig, const RigidPose& pose, const Eigen::VectorXf& weights,
                   Vertices* out) {
  EvaluateShapeDirect(rig, weights, out);
  ApplyPoseRows(pose, 0, rig.NumVertices(), out);
}

void EvaluatePosedWithJacobian(const Rig& rig, const RigidPose& pose,
                               const Eigen::VectorXf& weights, const std::vector<int>& vertex_ids,
                               Vertices* positions, Eigen::MatrixXf* jacobian) {
  RigEvaluator(rig).EvaluatePosedWithJacobian(pose, weights, vertex_ids, positions, jacobian);
}

}  // namespace facecap::rig
