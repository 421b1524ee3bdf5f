// Secondary parts of a face rig (paper 001 Sec. 6: eyeballs, lashes, teeth, ...): separate
// meshes with one blendshape delta per shape of the face, as data. How they are made and
// fitted to a person is assets/secondary_parts.h; their HDF5 layout is io/parts_io.h.
//
// Deltas are dense, 3#P by N with the vertices interleaved (x0, y0, z0, x1, ...), in the shape
// order of the face's blendshape set. Units: centimetres.
#ifndef FACECAP_RIG_PARTS_H_
#define FACECAP_RIG_PARTS_H_

#include <string>
#include <vector>

#include <Eigen/Core>

#include "rig/rig.h"

namespace facecap::rig {

struct SecondaryPart {
  std::string name;        // "left_eyeball", "upper_teeth", ...
  std::string material;    // eye, cornea, lacrimal, lashes, teeth, gums, tongue
  int group = 0;           // index into PartSet::groups
  Vertices neutral;   // #P x 3 (cm)
  Triangles triangles;
  UVs uvs;            // one per vertex, in [0, 1]^2
  Eigen::MatrixXf deltas;  // 3#P x N
  std::vector<int> follow; // per vertex: the face vertex whose fit residual it adds, or -1

  int NumVertices() const { return static_cast<int>(neutral.rows()); }
  // neutral + deltas * weights (weights has N entries).
  Vertices Evaluate(const Eigen::VectorXf& weights) const;
};

struct PartGroup {
  std::string name;            // left_eye, right_eye, mouth, jaw, left_eyeball, right_eyeball
  std::vector<int> placement;  // face vertices whose similarity transform places the group
  std::vector<int> fit;        // face vertices the shape coefficients are fitted on
  // A rigid group (the jaw) follows the rigid motion of its fit vertices in each shape instead
  // of a coefficient fit; shape-specific motion beyond it (tongueOut) comes from the generic
  // shape of the same name.
  bool rigid = false;
  // Face vertices the group's eyeball must stay behind (the lids; empty for other groups).
  std::vector<int> clear;
};

struct PartSet {
  std::vector<std::string> shape_names;  // N, the face's blendshape set
  std::vector<PartGroup> groups;
  std::vector<SecondaryPart> parts;
  int iris = 0;                          // index of the procedural iris (assets::IrisColors())

  int NumShapes() const { return static_cast<int>(shape_names.size()); }
  int PartIndex(const std::string& name) const;  // -1 when absent
};

}  // namespace facecap::rig

#endif  // FACECAP_RIG_PARTS_H_
