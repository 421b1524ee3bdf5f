// Linear blendshape sets (paper 001 Sec. 4: P = S_0 + sum_i alpha_i S_i) and the generic
// template of N = 55 shapes: the 52 ARKit shapes of a rig plus asymmetric brow shapes
// (paper 001 Sec. 7.3), made from the rig's own deltas with smooth left/right masks.
//
// Shapes are dense: deltas is a 3#V by N matrix whose column i holds S_i with the vertices
// interleaved (x0, y0, z0, x1, ...). Units: centimetres, as the rig.
#ifndef FACECAP_ASSETS_TEMPLATE_SHAPES_H_
#define FACECAP_ASSETS_TEMPLATE_SHAPES_H_

#include <string>
#include <vector>

#include <Eigen/Core>

#include "rig/rig.h"

namespace facecap::assets {

struct LinearShapes {
  rig::Vertices neutral;              // S_0, #V by 3 (cm)
  std::vector<std::string> names;     // N shape names
  Eigen::MatrixXf deltas;             // 3#V by N, column i = S_i (cm)

  int NumVertices() const { return static_cast<int>(neutral.rows()); }
  int NumShapes() const { return static_cast<int>(deltas.cols()); }
  int ShapeIndex(const std::string& name) const;  // -1 when absent
};

// The rig's shapes as linear deltas: column i is S(e_i) - N, jaw skinning applied (the
// shape's full effect at weight 1, as ExportRigToObjFolder writes it).
LinearShapes LinearizeRig(const rig::Rig& rig);

// A jaw-free rig whose shapes are `shapes` (sparse, entries below 1e-6 cm dropped), with the
// topology, UVs, regions and landmarks of `topology`. This is the personalized rig.h5.
rig::Rig RigFromLinearShapes(const LinearShapes& shapes, const rig::Rig& topology);

struct TemplateShapeOptions {
  // Half width (cm) of the smooth transition of the left/right masks at the midline x = 0.
  float midline_blend_cm = 1.0f;
  // |x| (cm) beyond which browDownInner{Left,Right} fade out (inner part of browDown).
  float inner_brow_extent_cm = 2.5f;

  bool Check(std::string* why) const;
};

// The names of the three asymmetric brow shapes added to the 52 ARKit shapes.
const std::vector<std::string>& AsymmetricBrowShapeNames();

// The N = 55 template: LinearizeRig(rig) (which must hold the 52 ARKit shapes) followed by
// browInnerUpLeft / browInnerUpRight (browInnerUp masked to one side; the masks leave a band
// at the midline, so the halves do not sum to browInnerUp) and browDownInnerLeft (the medial
// part of browDownLeft). Throws InvalidInputError when an ARKit brow shape is missing.
LinearShapes MakeTemplateShapes(const rig::Rig& rig,
                                const TemplateShapeOptions& options = TemplateShapeOptions());

// Vertices that some shape moves by more than `threshold_cm`, ascending: the face region
// over which reconstruction errors are measured.
std::vector<int> MovingVertices(const LinearShapes& shapes, float threshold_cm = 1e-4f);

// One FACS expression: a name and the template shapes it combines with weight 1.
struct FacsExpression {
  std::string name;
  std::vector<std::string> shapes;
};

// Parses "name=shapeA+shapeB+..." entries. InvalidInputError names a malformed entry.
std::vector<FacsExpression> ParseFacsTable(const std::vector<std::string>& entries);
// The default table: 24 expressions that together cover all 55 template shapes.
const std::vector<std::string>& DefaultFacsTable();
// The K by N 0/1 weight matrix alpha of a table over `shape_names`; InvalidInputError names an
// unknown shape, and (when require_cover) the first shape no expression uses.
Eigen::MatrixXf FacsWeights(const std::vector<FacsExpression>& table,
                            const std::vector<std::string>& shape_names, bool require_cover);

}  // namespace facecap::assets

#endif  // FACECAP_ASSETS_TEMPLATE_SHAPES_H_
