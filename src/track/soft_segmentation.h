// Differentiable segmentation render F_seg(p, y, w) (paper 000 Sec. 8): the hard z-buffer
// render with its region borders and silhouettes antialiased, so that pixel colours are
// smooth in the vertex positions, with analytic Jacobians.
//
// Model. The hard rasterizer decides visibility. Every mesh edge that separates two visible
// front faces of different regions, or a front face from a back face (a silhouette), is a
// border edge. A pixel whose centre q lies within `edge_width_px` of a visible border edge
// (the nearest one when several are) takes the colour
//
//   I(q) = c_B + (c_A - c_B) s(d_A(q)),    s(d) = smoothstep((d + w) / (2 w))        (soft edge)
//
// where d_A(q) is the signed screen distance from q to the edge's line, positive on the side
// of face A, c_A the region colour of face A, and c_B the colour of the other side: the region
// colour of face B for a region border, or for a silhouette the hard colour of what lies
// behind (background or another surface, read off the hard render one pixel across the edge).
// s is C1 and reaches 0 and 1 at |d| = w, so pixels farther than w from every border keep
// their hard colour and have zero derivative: the Jacobian is sparse, rows only for the
// pixels along borders (a box-filter-like antialiasing of the edges).
//
// Derivative of a soft pixel with respect to the camera-space positions X_a, X_b of the edge's
// end points: dI/dX = (c_A - c_B) s'(d) (dd/du_a du_a/dX_a + dd/du_b du_b/dX_b), with u the
// pinhole projection of camera.h. The region colours and behind colours are held constant.
#ifndef FACECAP_TRACK_SOFT_SEGMENTATION_H_
#define FACECAP_TRACK_SOFT_SEGMENTATION_H_

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "render/camera.h"
#include "render/rasterizer.h"
#include "rig/evaluate.h"
#include "rig/pose.h"
#include "rig/rig.h"

namespace facecap::track {

struct SoftSegmentationOptions {
  // Half-width w (pixels) of the soft band around each border edge: the colour ramps from
  // c_B to c_A over d in [-w, w]. Wider bands see targets farther away, narrower ones fit
  // more precisely. Range (0, 8].
  float edge_width_px = 1.f;
  // A border edge counts as visible when its midpoint is not farther than the nearest
  // visible surface around its pixel (the farthest of the 3x3 pixels around it) by more
  // than this fraction of its depth.
  float visibility_depth_tolerance = 0.01f;
  // Colour of pixels where nothing is visible, RGB in [0, 1].
  Eigen::Vector3f background_color = Eigen::Vector3f::Zero();

  // False, with the reason in *why, when a field is out of range.
  bool Check(std::string* why) const;
};

// A pixel whose soft colour depends on one border edge.
struct EdgePixel {
  int pixel = 0;                    // y * width + x
  int vertex_a = 0, vertex_b = 0;   // the edge's end points (mesh vertex indices)
  float distance = 0.f;             // d_A, pixels
  Eigen::Vector3f color_slope = Eigen::Vector3f::Zero();  // dI / d d_A = (c_A - c_B) s'(d)
  Eigen::Vector3f dd_dxa = Eigen::Vector3f::Zero();  // d d_A / d X_a (camera space, 1/cm)
  Eigen::Vector3f dd_dxb = Eigen::Vector3f::Zero();  // d d_A / d X_b
};

// The result of one soft render; reused between renders (no allocation at a fixed size).
struct SoftRender {
  render::GBuffer gbuffer;
  std::vector<float> color;            // 3 * #pixels, soft RGB in [0, 1], row-major, y down
  std::vector<float> hard_color;       // 3 * #pixels, the hard render's RGB
  std::vector<EdgePixel> edge_pixels;  // the pixels with a non-zero derivative, ascending
  // Workspace.
  std::vector<Eigen::Vector3f> screen;  // #V (u, v, depth)
  std::vector<uint8_t> front;           // #F, 1 where the face is in front and faces the camera
  std::vector<float> best_distance;     // #pixels
  std::vector<int> best_edge;           // #pixels
  std::vector<int> border_edges;        // visible border edges of this render
  std::vector<int> edge_side_a;         // per border edge of this render: face A
  std::vector<Eigen::Vector3f> edge_colors;  // per border edge: c_A, c_B, 2 entries each
};

// Precomputed mesh edges and region colours of one rig (precompute / render split). The
// renderer references the rig, which must outlive it. Render is const and thread-safe.
class SoftSegmentationRenderer {
 public:
  // region_colors: one RGB colour in [0, 1] per rig region (the texture T_seg, or another
  // palette such as a skin albedo for the realistic-texture baseline).
  SoftSegmentationRenderer(const rig::Rig& rig, std::vector<Eigen::Vector3f> region_colors,
                           const SoftSegmentationOptions& options = SoftSegmentationOptions());

  // Renders the posed mesh (camera space, #V by 3) with `camera` into *out.
  void Render(const rig::Vertices& camera_vertices, const render::Camera& camera,
              SoftRender* out) const;

  const rig::Rig& rig() const { return rig_; }
  const std::vector<Eigen::Vector3f>& region_colors() const { return region_colors_; }
  const SoftSegmentationOptions& options() const { return options_; }

 private:
  struct MeshEdge {
    int v0, v1;       // v0 < v1
    int face0, face1; // adjacent faces; face1 = -1 on an open border of the mesh
  };
  // The steps of Render: the hard colours, the vertices on the screen and the front faces,
  // the visible border edges with their colours, each pixel's nearest border edge, and the
  // soft colours with their derivatives.
  void HardColors(SoftRender* out) const;
  void ScreenAndFacing(const rig::Vertices& camera_vertices, const render::Camera& camera,
                       SoftRender* out) const;
  void BorderEdges(SoftRender* out) const;
  void NearestBorderEdges(SoftRender* out) const;
  void SoftColors(const rig::Vertices& camera_vertices, const render::Camera& camera,
                  SoftRender* out) const;

  const rig::Rig& rig_;
  std::vector<Eigen::Vector3f> region_colors_;
  SoftSegmentationOptions options_;
  std::vector<MeshEdge> edges_;
};

// Jacobian of the soft colours with respect to rig parameters (rig/evaluate.h layout),
// chained through RigEvaluator::EvaluatePosedWithJacobian for the edge end points only.
// Every edge pixel i has dI_i / dparams[columns] = edge_pixels[i].color_slope * rows.row(i):
// rows (#edge pixels x |columns|) holds d d_A / dparams[columns]. `render` must come from
// rendering evaluator.EvaluatePosed(pose, weights).
struct SoftJacobianWorkspace {
  std::vector<int> vertex_ids;
  std::vector<int> vertex_slot;          // #V, slot in vertex_ids or -1
  Eigen::MatrixXf vertex_jacobian;       // 3 |ids| x NumParams
  Eigen::MatrixXf block_jacobian;        // 3 |ids| x |columns|
};
void SoftEdgeJacobian(const SoftRender& render, const rig::RigEvaluator& evaluator,
                      const rig::RigidPose& pose, const Eigen::VectorXf& weights,
                      const std::vector<int>& columns, Eigen::MatrixXf* rows,
                      SoftJacobianWorkspace* workspace);

// The region colours of a rig (its segmentation texture T_seg).
std::vector<Eigen::Vector3f> RigRegionColors(const rig::Rig& rig);

}  // namespace facecap::track

#endif  // FACECAP_TRACK_SOFT_SEGMENTATION_H_
