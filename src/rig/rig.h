// Blendshape rig with jaw skinning (paper 000 Sec. 6).
//
//   S(w) = (M R(w) + (1 - M) I)(N + sum_i w_i D_i) + M T(w)
//
// N: neutral vertex positions; D_i: de-skinned shape deltas (sparse); M: per-vertex jaw
// skinning weights in [0, 1]; R(w): jaw rotation about the jaw pivot, built by Euler-angle
// interpolation sum_i w_i theta_i of the per-shape jaw angles theta_i; T(w) = sum_i w_i T_i.
// A rigid head pose P_rigid (pitch, yaw, roll, translation, scale) is applied on top.
//
// Units: centimetres; +x is the head's left (viewer's right when frontal), +y up, +z out of
// the face towards a frontal camera. Angles in radians unless a name says degrees.
#ifndef FACECAP_RIG_RIG_H_
#define FACECAP_RIG_RIG_H_

#include <string>
#include <vector>

#include <Eigen/Core>

namespace facecap::rig {

using Vertices = Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>;    // #V x 3
using Triangles = Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>;     // #F x 3
using UVs = Eigen::Matrix<float, Eigen::Dynamic, 2, Eigen::RowMajor>;         // #UV x 2

// One blendshape D_i stored sparsely: only vertices that move.
struct SparseDelta {
  std::vector<int> vertex;                 // vertex indices, ascending
  std::vector<Eigen::Vector3f> offset;     // offset of each listed vertex (cm)
};

// A rig shape: a name (ARKit where it applies), its de-skinned delta D_i, and its jaw part.
struct Shape {
  std::string name;
  SparseDelta delta;                        // D_i
  Eigen::Vector3f jaw_euler = Eigen::Vector3f::Zero();        // theta_i: jaw X,Y,Z Euler angles (rad)
  Eigen::Vector3f jaw_translation = Eigen::Vector3f::Zero();  // T_i (cm)
  bool UsesJaw() const { return !jaw_euler.isZero(0) || !jaw_translation.isZero(0); }
};

struct Region {
  std::string name;                         // "upper_lip", "left_upper_eyelid", ...
  Eigen::Vector3f color;                    // flat segmentation colour, RGB in [0, 1]
};

struct Rig {
  Vertices neutral;                         // N
  Triangles triangles;                      // counter-clockwise seen from outside
  UVs uvs;                                  // texture coordinates in [0, 1]^2
  Triangles uv_triangles;                   // per-corner indices into uvs (as in OBJ)
  Eigen::VectorXi triangle_region;          // #F region index into regions
  std::vector<Region> regions;
  Eigen::VectorXf jaw_weights;              // M, #V, in [0, 1]
  Eigen::Vector3f jaw_pivot = Eigen::Vector3f::Zero();  // centre of jaw rotation (cm)
  std::vector<Shape> shapes;
  Eigen::VectorXi landmarks;                // 68 vertex indices, iBUG 300-W order
  std::vector<Vertices> identity_modes;     // dense #V x 3 offsets; N(alpha) = N + sum a_k mode_k

  int NumVertices() const { return static_cast<int>(neutral.rows()); }
  int NumShapes() const { return static_cast<int>(shapes.size()); }
  int ShapeIndex(const std::string& name) const;  // -1 when absent
  // Consistency check: sizes, index ranges, finite values. Returns false and says why.
  bool Check(std::string* why) const;
};

}  // namespace facecap::rig

#endif  // FACECAP_RIG_RIG_H_
