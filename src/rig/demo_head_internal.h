// Internal header of the demo head, not part of the public API (that is rig/demo_head.h): what
// demo_head.cpp and demo_head_{surface,topology,landmarks,shapes}.cpp share.
#ifndef FACECAP_RIG_DEMO_HEAD_INTERNAL_H_
#define FACECAP_RIG_DEMO_HEAD_INTERNAL_H_

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "rig/demo_head.h"
#include "rig/rig.h"

namespace facecap::rig::demo_head_internal {

inline constexpr float kPi = 3.14159265358979323846f;
inline constexpr float kEyeballRadius = 1.2f;  // cm

inline float Clamp01(float x) { return std::min(1.f, std::max(0.f, x)); }
inline float Smoothstep(float edge0, float edge1, float x) {
  const float t = Clamp01((x - edge0) / (edge1 - edge0));
  return t * t * (3.f - 2.f * t);
}
inline float Gauss(float x) { return std::exp(-x * x); }
inline float Lerp(float a, float b, float t) { return a + (b - a) * t; }
inline float Square(float x) { return x * x; }
// Polynomial smooth maximum with blend width k.
inline float SmoothMax(float a, float b, float k) {
  const float h = Clamp01(0.5f + 0.5f * (a - b) / k);
  return b + (a - b) * h + k * h * (1.f - h);
}
// Piecewise-linear table lookup, xs ascending.
inline float Table(const std::vector<std::pair<float, float>>& table, float x) {
  if (x <= table.front().first) return table.front().second;
  for (size_t k = 1; k < table.size(); ++k) {
    if (x <= table[k].first) {
      const float t = (x - table[k - 1].first) / (table[k].first - table[k - 1].first);
      return Lerp(table[k - 1].second, table[k].second, t);
    }
  }
  return table.back().second;
}

// ---- shape parameters (demo_head_surface.cpp) -----------------------------------------------

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

// The identity modes, in the order of rig.identity_modes.
const std::vector<IdentityModeDef>& IdentityModeDefs();

// ---- head surface (demo_head_surface.cpp) ---------------------------------------------------

struct ProfileKey {
  float y;            // height of the cross-section
  float half_width;   // W: half-width at the ear plane
  float front_depth;  // depth in front of the ear plane (z of the face at x = 0)
  float back_depth;   // depth behind the ear plane
};

// The skin as a function of (theta, t): theta is the column angle (0 at the face front,
// +pi/2 at the left ear), t the profile parameter (0 at the crown, NumKeys()-1 under the neck).
class HeadSurface {
 public:
  explicit HeadSurface(const HeadParams& p);

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
  Eigen::Vector3f EyeCenter(int side) const;
  const HeadParams& Params() const { return p_; }

  ProfileKey Profile(float t) const;

  // Profile parameter t with Profile(t).y == y, searched in [t_lo, t_hi] (y decreases with t).
  float ParameterAtHeight(float y, float t_lo, float t_hi) const;

  // Column angle whose front cross-section at key `key` passes through x (x >= 0).
  float ThetaAtX(float x, int key) const;

  // Height of the nose above the face (cm) at (x, y).
  float NoseHeight(float x, float y) const;

  // Height of the brow line at |x|.
  float BrowLineY(float ax) const;
  // Upper and lower vermilion borders (heights) at x.
  float UpperVermilionY(float x) const;
  float LowerVermilionY(float x) const;

  // Forward displacement of the face features at (x, y).
  float FeatureHeight(float x, float y) const;

  // Superellipse exponent of the front half at height y: rounded at the eyes and mouth, pointed
  // towards the chin, rounder again on the neck.
  float FrontExponent(float y) const;

  // Height of the jaw line (face above, neck below) at column angle theta.
  float JawLineY(float theta) const;

  // Shell over the eyeball that the closed lids lie on; -infinity outside it.
  float EyeCoverZ(float x, float y) const;

  Eigen::Vector3f Position(float theta, float t) const;

 private:
  static float& Channel(ProfileKey& k, int ch);
  static float Channel(const ProfileKey& k, int ch);

  HeadParams p_;
  std::vector<ProfileKey> keys_, tangents_;
  int dome_end_key_ = 0, eye_key_ = 0, mouth_key_ = 0, chin_key_ = 0, neck_key_ = 0;
  float y_eye_ = 0, y_mouth_ = 0, y_chin_ = 0, y_nasion_ = 0, y_nose_tip_ = 0, y_subnasale_ = 0;
  Eigen::Vector3f eye_center_;
};

// ---- mesh layout (demo_head_topology.cpp) ---------------------------------------------------

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
  int Vertex(int i, int j, bool below) const;
  // Closed loop around an opening: lo corner, upper margin, hi corner, lower margin back.
  std::vector<int> Loop(int lo, int hi, int row) const;
};

Layout MakeLayout(const DemoHeadOptions& options);

// ---- builder (demo_head_topology.cpp) -------------------------------------------------------

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
  HeadBuilder(const HeadParams& params, const Layout& layout);

  const HeadSurface& Surface() const { return surface_; }
  const Layout& GetLayout() const { return layout_; }
  // Column angle of grid vertex (i, j): the eye-row layout above the nose, the mouth-row layout
  // below it, blended in between, so that eye and mouth features never share columns.
  float ColumnTheta(int i, int j) const;
  float RowT(int i) const { return row_t_[i]; }
  float ThetaEyeInner() const { return theta_eye_inner_; }
  float ThetaEyeOuter() const { return theta_eye_outer_; }

  // Fraction across eye `side` of column j: 0 at the inner corner, 1 at the outer corner.
  float EyeFraction(int j) const;
  // Upper and lower lid openings (cm above / below the slit) at fraction u.
  float UpperOpening(float u) const;
  float LowerOpening(float u) const;

  // Skin vertex at grid (i, j); `below` marks the lower margin copy on a slit row.
  Eigen::Vector3f SkinVertex(int i, int j, bool below, const LidState lids[2]) const;

  // All vertices with the given lid states and eyeball rotations.
  Vertices Build(const LidState lids[2], const EyeballRotation eyes[2]) const;

  Vertices BuildNeutral() const;

 private:
  // Arc-length placement of n points in (a, b] (or (a, b) when open_end) along the measure.
  template <typename Measure>
  static std::vector<float> ArcLengthPlace(float a, float b, int n, bool open_end,
                                           Measure measure);

  void PlaceRows();
  void PlaceColumns();

  // Full ring of column angles (index j) from one side's knots and segment counts.
  std::vector<float> Side(int key, const std::vector<float>& knots,
                          const std::vector<int>& counts) const;

  HeadSurface surface_;
  Layout layout_;
  std::vector<float> row_t_;
  std::vector<float> eye_column_theta_, mouth_column_theta_;  // per column j
  std::vector<float> row_blend_;                              // 0: eye layout, 1: mouth layout
  float theta_eye_inner_ = 0.f, theta_eye_outer_ = 0.f;
};

// ---- topology, UVs, regions (demo_head_topology.cpp) ----------------------------------------

// The segmentation regions, in the order of the triangle region ids MakeTopology assigns.
std::vector<Region> MakeRegions();

struct MeshTopology {
  Triangles triangles;
  Triangles uv_triangles;
  UVs uvs;
  Eigen::VectorXi triangle_region;
};

MeshTopology MakeTopology(const HeadBuilder& builder, const Vertices& neutral);

// ---- per-vertex facts (demo_head_topology.cpp) ----------------------------------------------

enum class Part { kSkin, kEyePocket, kMouthPocket, kEyeball };

struct VertexFacts {
  Part part = Part::kSkin;
  int eye = -1;             // 0: left eye (+x), 1: right eye (-x), for eye parts
  bool below_mouth = false; // skin below the lip slit (lower margin included), lower cavity half
  float pocket_depth = 0.f; // 0 at the opening, 1 at the back of the mouth cavity
  int loop_index = -1;      // for mouth cavity vertices: index into the mouth loop
};

std::vector<VertexFacts> MakeFacts(const Layout& l);

Eigen::Vector3f JawPivot(const HeadSurface& hs);

Eigen::VectorXf MakeJawWeights(const HeadSurface& hs, const Layout& l, const Vertices& neutral,
                               const std::vector<VertexFacts>& facts);

// ---- landmarks (demo_head_landmarks.cpp) ----------------------------------------------------

// The 68 iBUG landmarks as vertex indices of the neutral `n` that `b` built.
Eigen::VectorXi MakeLandmarks(const HeadBuilder& b, const Vertices& n);

// ---- shapes (demo_head_shapes.cpp) ----------------------------------------------------------

// Makes the 52 ARKit shapes of one head (rig.shapes, in ArkitShapeNames() order).
class ShapeMaker {
 public:
  ShapeMaker(const HeadBuilder& builder, const Vertices& neutral,
             const std::vector<VertexFacts>& facts, const Eigen::VectorXf& jaw_weights,
             const DemoHeadOptions& options);

  std::vector<Shape> MakeAll() const;

 private:
  using Field = std::function<Eigen::Vector3f(const Eigen::Vector3f&, const VertexFacts&)>;

  // Dense delta of a displacement field over the skin and the mouth cavity (attenuated with
  // depth). `mirror` evaluates the field for the subject's right side.
  Vertices FieldDelta(const Field& f, bool mirror) const;

  Vertices LidDelta(int side, const LidState& lid, const Eigen::Matrix3f& eye_rotation) const;

  float Front(const Eigen::Vector3f& p) const { return Smoothstep(0.f, 3.f, p.z()); }
  float Mhw() const { return hs_.Params().mouth_half_width; }
  // Weight around the left mouth corner with radius r.
  float CornerWeight(const Eigen::Vector3f& p, float r) const;
  float LipWeight(const Eigen::Vector3f& p, float vertical = 1.1f) const;
  static float LeftSide(const Eigen::Vector3f& p) { return Smoothstep(-0.8f, 0.8f, p.x()); }
  float BrowWeight(const Eigen::Vector3f& p, float centre_offset, float width) const;

  Shape Make(const std::string& name) const;
  // The groups of shapes that Make calls in turn: each fills s when `name` is one of its shapes
  // and leaves it as it is otherwise. `base` is the name without its Left / Right suffix and
  // `right` is true for a Right shape.
  void MakeEyeShape(const std::string& name, const std::string& base, bool right, Shape& s) const;
  void MakeJawShape(const std::string& name, const std::string& base, bool right, Shape& s) const;
  void MakeMouthShape(const std::string& name, const std::string& base, bool right, Shape& s) const;
  void MakeOneLipShape(const std::string& name, const std::string& base, bool right,
                       Shape& s) const;
  void MakeBrowShape(const std::string& name, const std::string& base, bool right, Shape& s) const;
  void MakeCheekNoseTongueShape(const std::string& name, const std::string& base, bool right,
                                Shape& s) const;

  const HeadBuilder& b_;
  const HeadSurface& hs_;
  const Layout& l_;
  const Vertices& n_;
  const std::vector<VertexFacts>& facts_;
  const Eigen::VectorXf& jaw_weights_;
  const DemoHeadOptions& options_;
  Eigen::Vector3f left_corner_;
};

}  // namespace facecap::rig::demo_head_internal

#endif  // FACECAP_RIG_DEMO_HEAD_INTERNAL_H_
