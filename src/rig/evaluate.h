// Rig evaluation (paper 000 Sec. 6) and its exact Jacobian with respect to the rigid pose and
// the shape weights.
//
//   S(w) = (M R(w) + (1 - M) I)(N + sum_i w_i D_i) + M T(w)               (rig equation)
//   x_camera = scale * Rot(pitch, yaw, roll) * S(w) + translation          (P_rigid, pose.h)
//
// The jaw rotation acts about rig.jaw_pivot: R(w) x means R(w) (x - pivot) + pivot.
// R(w) = EulerToMatrix(sum_i w_i theta_i) with theta_i = shapes[i].jaw_euler (Euler-angle
// interpolation), T(w) = sum_i w_i T_i with T_i = shapes[i].jaw_translation.
//
// Solver parameter vector (EvaluatePosedWithJacobian's columns, NumRigParams entries):
//   [ pitch, yaw, roll (rad), tx, ty, tz (cm), scale, w_0, ..., w_{S-1} ]
// Scale is the linear factor of RigidPose::scale (not its logarithm).
#ifndef FACECAP_RIG_EVALUATE_H_
#define FACECAP_RIG_EVALUATE_H_

#include <array>
#include <vector>

#include <Eigen/Core>

#include "rig/pose.h"
#include "rig/rig.h"

namespace facecap::rig {

// Column of each pose parameter in the solver parameter vector; shape weight i sits at
// column kNumPoseParams + i.
enum PoseParam : int {
  kPitch = 0,
  kYaw = 1,
  kRoll = 2,
  kTx = 3,
  kTy = 4,
  kTz = 5,
  kScale = 6,
  kNumPoseParams = 7,
};

// kNumPoseParams + rig.NumShapes().
int NumRigParams(const Rig& rig);

// Packs / unpacks the solver parameter vector laid out as above.
Eigen::VectorXf PackRigParams(const RigidPose& pose, const Eigen::VectorXf& weights);
void UnpackRigParams(const Eigen::VectorXf& params, RigidPose* pose, Eigen::VectorXf* weights);

// EulerToMatrix and its partial derivatives d R / d euler_xyz[k], k = 0, 1, 2.
void EulerToMatrixWithDerivatives(const Eigen::Vector3f& euler_xyz, Eigen::Matrix3f* rotation,
                                  std::array<Eigen::Matrix3f, 3>* derivatives);

// Indices of the shapes that drive the jaw (Shape::UsesJaw), ascending.
std::vector<int> JawShapeIndices(const Rig& rig);

// sum_i w_i theta_i and T(w) = sum_i w_i T_i.
Eigen::Vector3f InterpolatedJawEuler(const Rig& rig, const Eigen::VectorXf& weights);
Eigen::Vector3f InterpolatedJawTranslation(const Rig& rig, const Eigen::VectorXf& weights);

// Precomputed evaluation of one rig (precompute / solve split): per-vertex lists of the
// shapes that move each vertex, the jaw-skinned vertices and per-thread vertex blocks.
// The evaluator references the rig, which must outlive it and not change while it is used.
// All methods are const and thread-safe; call them from many threads at once.
class RigEvaluator {
 public:
  struct Options {
    // Threads for full evaluations (EvaluateShape / EvaluatePosed); 1 runs inline, <= 0 uses
    // DefaultNumThreads(). Threads pay only for large rigs (tens of thousands of vertices);
    // nested inside an OpenMP parallel region the evaluation always runs inline.
    int num_threads = 1;
  };

  explicit RigEvaluator(const Rig& rig) : RigEvaluator(rig, Options()) {}
  RigEvaluator(const Rig& rig, const Options& options);

  const Rig& rig() const { return rig_; }
  int NumParams() const { return kNumPoseParams + rig_.NumShapes(); }
  const std::vector<int>& jaw_shapes() const { return jaw_shapes_; }

  // S(w) in head space, #V x 3; no allocation when *out already has #V rows.
  void EvaluateShape(const Eigen::VectorXf& weights, Vertices* out) const;
  // P_rigid S(w) in camera space, #V x 3.
  void EvaluatePosed(const RigidPose& pose, const Eigen::VectorXf& weights, Vertices* out) const;
  // Posed positions of vertex_ids (|ids| x 3) and, when jacobian is not null, the exact
  // Jacobian d positions / d params: (3 |ids|) x NumParams(), rows 3k, 3k+1, 3k+2 are x, y, z
  // of vertex_ids[k], columns in the solver parameter layout above. Either output may be null.
  void EvaluatePosedWithJacobian(const RigidPose& pose, const Eigen::VectorXf& weights,
                                 const std::vector<int>& vertex_ids, Vertices* positions,
                                 Eigen::MatrixXf* jacobian) const;

 private:
  struct DeltaEntry {
    int shape;
    Eigen::Vector3f offset;
  };
  // A run of consecutive vertices [first_vertex, first_vertex + count) of one shape whose
  // offsets are stored densely (3 * count floats from dense_offsets_[offset_begin]), so that
  // adding w_i D_i over it is one vectorizable axpy.
  struct DenseRun {
    int first_vertex;
    int count;
    int offset_begin;
  };
  // The part of shape s inside vertex block b: dense runs plus isolated (scattered) entries.
  struct ShapeBlock {
    int run_begin, run_end;
    int scattered_begin, scattered_end;
  };
  void CheckWeights(const Eigen::VectorXf& weights) const;
  void BuildShapeBlocks();

  const Rig& rig_;
  Options options_;
  int num_blocks_ = 1;
  std::vector<int> block_begin_;            // num_blocks_ + 1 vertex boundaries
  std::vector<ShapeBlock> shape_blocks_;     // [s * num_blocks_ + b]
  std::vector<DenseRun> dense_runs_;
  std::vector<float> dense_offsets_;
  std::vector<int> scattered_vertex_;
  std::vector<Eigen::Vector3f> scattered_offset_;
  std::vector<int> jaw_vertices_;            // vertices with M > 0, ascending
  std::vector<int> jaw_block_begin_;         // num_blocks_ + 1 boundaries into jaw_vertices_
  std::vector<int> vertex_delta_begin_;      // #V + 1 row offsets into vertex_deltas_
  std::vector<DeltaEntry> vertex_deltas_;    // per-vertex (shape, D_i offset) lists
  std::vector<int> jaw_shapes_;
};

// One-call wrappers. EvaluateShape and EvaluatePosed need no precomputation;
// EvaluatePosedWithJacobian builds a RigEvaluator on each call (keep one for repeated calls).
void EvaluateShape(const Rig& rig, const Eigen::VectorXf& weights, Vertices* out);
void EvaluatePosed(const Rig& rig, const RigidPose& pose, const Eigen::VectorXf& weights,
                   Vertices* out);
void EvaluatePosedWithJacobian(const Rig& rig, const RigidPose& pose,
                               const Eigen::VectorXf& weights, const std::vector<int>& vertex_ids,
                               Vertices* positions, Eigen::MatrixXf* jacobian);

}  // namespace facecap::rig

#endif  // FACECAP_RIG_EVALUATE_H_
