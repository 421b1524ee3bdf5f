// Demo head mesh layout, the builder that places its vertices, the topology with UVs and
// segmentation regions, and the per-vertex facts and jaw skinning weights.
#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Core>

#include "rig/demo_head_internal.h"

namespace facecap::rig::demo_head_internal {

// ---- mesh layout -------------------------------------------------------------------------------

int Layout::Vertex(int i, int j, bool below) const {
  j = ((j % cols) + cols) % cols;
  if (below && i == row_eye) {
    for (int side = 0; side < 2; ++side) {
      if (j > EyeLo(side) && j < EyeHi(side)) return eye_dup_begin[side] + (j - EyeLo(side) - 1);
    }
  }
  if (below && i == row_mouth && j > MouthLo() && j < MouthHi()) {
    return mouth_dup_begin + (j - MouthLo() - 1);
  }
  return Grid(i, j);
}

std::vector<int> Layout::Loop(int lo, int hi, int row) const {
  std::vector<int> loop;
  for (int j = lo; j <= hi; ++j) loop.push_back(Grid(row, j));
  for (int j = hi - 1; j > lo; --j) loop.push_back(Vertex(row, j, true));
  return loop;
}

namespace {

int Scaled(int base, int resolution) {
  return std::max(2, static_cast<int>(std::lround(base * resolution / 100.0)));
}

}  // namespace

Layout MakeLayout(const DemoHeadOptions& options) {
  Layout l;
  const int r = options.resolution;
  l.col_segments = {Scaled(8, r), Scaled(4, r), Scaled(10, r), Scaled(12, r), Scaled(12, r)};
  l.row_segments = {Scaled(14, r), Scaled(12, r), Scaled(32, r), Scaled(16, r), Scaled(7, r),
                    Scaled(8, r)};
  l.half_cols = 0;
  for (int n : l.col_segments) l.half_cols += n;
  l.cols = 2 * l.half_cols;
  l.k_eye_inner = l.col_segments[0];
  l.k_mouth_corner = l.k_eye_inner + l.col_segments[1];
  l.k_eye_outer = l.k_mouth_corner + l.col_segments[2];
  l.rows = 0;
  for (int n : l.row_segments) l.rows += n;
  l.rows -= 1;  // the last segment ends at the bottom pole
  l.row_eye = l.row_segments[0] + l.row_segments[1] - 1;
  l.row_mouth = l.row_eye + l.row_segments[2];
  l.row_chin = l.row_mouth + l.row_segments[3];
  int v = l.rows * l.cols;
  l.top_pole = v++;
  l.bottom_pole = v++;
  l.eye_dup_count = l.k_eye_outer - l.k_eye_inner - 1;
  for (int side = 0; side < 2; ++side) {
    l.eye_dup_begin[side] = v;
    v += l.eye_dup_count;
  }
  l.mouth_dup_count = 2 * l.k_mouth_corner - 1;
  l.mouth_dup_begin = v;
  v += l.mouth_dup_count;
  l.eye_loop = 2 * l.eye_dup_count + 2;
  for (int side = 0; side < 2; ++side) {
    l.eye_pocket_begin[side] = v;
    v += l.eye_loop + 1;  // one inner ring and a centre
  }
  l.mouth_loop = 2 * l.mouth_dup_count + 2;
  l.mouth_pocket_begin = v;
  v += l.mouth_rings * l.mouth_loop + 1;
  l.eyeball_segments = options.eyeball_segments;
  l.eyeball_bands = std::max(4, options.eyeball_segments / 2);
  l.eyeball_count = (l.eyeball_bands - 1) * l.eyeball_segments + 2;
  for (int side = 0; side < 2; ++side) {
    l.eyeball_begin[side] = v;
    v += l.eyeball_count;
  }
  l.num_vertices = v;
  return l;
}

namespace {

// Polar angles of the eyeball rings from the front pole: pupil edge, iris edge, then even.
std::vector<float> EyeballRingAngles(int bands) {
  std::vector<float> angles = {0.2f, 0.46f};
  const int rest = bands - 1 - 2;
  for (int k = 1; k <= rest; ++k) angles.push_back(0.46f + (kPi - 0.46f) * k / (rest + 1));
  return angles;
}

}  // namespace

// ---- builder ---------------------------------------------------------------------------------

HeadBuilder::HeadBuilder(const HeadParams& params, const Layout& layout)
    : surface_(params), layout_(layout) {
  PlaceRows();
  PlaceColumns();
}

float HeadBuilder::ColumnTheta(int i, int j) const {
  j = ((j % layout_.cols) + layout_.cols) % layout_.cols;
  if (j == 0) return kPi;
  return Lerp(eye_column_theta_[j], mouth_column_theta_[j], row_blend_[i]);
}

float HeadBuilder::EyeFraction(int j) const {
  j = ((j % layout_.cols) + layout_.cols) % layout_.cols;
  const float th = j == 0 ? kPi : std::abs(eye_column_theta_[j]);
  return (th - theta_eye_inner_) / (theta_eye_outer_ - theta_eye_inner_);
}

float HeadBuilder::UpperOpening(float u) const {
  if (u <= 0.f || u >= 1.f) return 0.f;
  return surface_.Params().upper_lid_open * std::pow(std::sin(kPi * std::pow(u, 0.85f)), 0.7f);
}

float HeadBuilder::LowerOpening(float u) const {
  if (u <= 0.f || u >= 1.f) return 0.f;
  return surface_.Params().lower_lid_open * std::pow(std::sin(kPi * std::pow(u, 1.15f)), 0.8f);
}

Eigen::Vector3f HeadBuilder::SkinVertex(int i, int j, bool below, const LidState lids[2]) const {
  const float theta = ColumnTheta(i, j);
  float t = row_t_[i];
  // Eyelid warp: rows move away from the eye slit.
  const int side = theta >= 0.f ? 0 : 1;
  const float u = EyeFraction(j);
  if (u > 0.f && u < 1.f) {
    const LidState& lid = lids[side];
    const float y = surface_.Profile(t).y;
    const float d = y - surface_.EyeY();
    const bool lower = i > layout_.row_eye || (i == layout_.row_eye && below);
    float shift;
    if (lower) {
      shift = -lid.lower_scale * LowerOpening(u) * Gauss(d / 0.6f);
    } else {
      const float open = lid.upper_scale * UpperOpening(u);
      const float closed = -lid.lower_scale * LowerOpening(u);
      shift = Lerp(open, closed, lid.closure) * Gauss(d / 0.75f);
    }
    if (std::abs(shift) > 1e-6f) {
      t = surface_.ParameterAtHeight(y + shift, surface_.DomeEndKey() - 1.f,
                                     static_cast<float>(surface_.MouthKey()));
    }
  }
  return surface_.Position(theta, t);
}

Vertices HeadBuilder::Build(const LidState lids[2], const EyeballRotation eyes[2]) const {
  const Layout& l = layout_;
  Vertices v(l.num_vertices, 3);
#pragma omp parallel for schedule(static)
  for (int i = 0; i < l.rows; ++i) {
    for (int j = 0; j < l.cols; ++j) v.row(l.Grid(i, j)) = SkinVertex(i, j, false, lids);
  }
  v.row(l.top_pole) = surface_.Position(0.f, 0.f);
  v.row(l.bottom_pole) = surface_.Position(0.f, surface_.NumKeys() - 1.f);
  for (int side = 0; side < 2; ++side) {
    for (int j = l.EyeLo(side) + 1; j < l.EyeHi(side); ++j) {
      v.row(l.Vertex(l.row_eye, j, true)) = SkinVertex(l.row_eye, j, true, lids);
    }
  }
  for (int j = l.MouthLo() + 1; j < l.MouthHi(); ++j) {
    v.row(l.Vertex(l.row_mouth, j, true)) = SkinVertex(l.row_mouth, j, true, lids);
  }
  // Eye pockets: a ring pulled towards the eyeball centre, then a centre vertex.
  for (int side = 0; side < 2; ++side) {
    const Eigen::Vector3f c = surface_.EyeCenter(side);
    const std::vector<int> loop = l.Loop(l.EyeLo(side), l.EyeHi(side), l.row_eye);
    for (int k = 0; k < l.eye_loop; ++k) {
      const Eigen::Vector3f p = v.row(loop[k]).transpose();
      v.row(l.eye_pocket_begin[side] + k) = (c + 0.72f * (p - c)).transpose();
    }
    v.row(l.eye_pocket_begin[side] + l.eye_loop) = (c - Eigen::Vector3f(0, 0, 0.35f)).transpose();
  }
  // Mouth cavity: rings that widen vertically and recede, then a centre vertex.
  {
    const std::vector<int> loop = l.Loop(l.MouthLo(), l.MouthHi(), l.row_mouth);
    const float mhw = surface_.Params().mouth_half_width;
    const float y_m = surface_.MouthY();
    const float z_front = v(l.Grid(l.row_mouth, l.half_cols), 2);
    const float spread[3] = {0.35f, 1.1f, 0.9f};
    const float depth[3] = {0.45f, 1.6f, 3.2f};
    const float narrow[3] = {0.93f, 0.85f, 0.6f};
    for (int k = 0; k < l.mouth_loop; ++k) {
      const Eigen::Vector3f p = v.row(loop[k]).transpose();
      const bool upper = k <= l.mouth_dup_count + 1;
      const bool corner = k == 0 || k == l.mouth_dup_count + 1;
      const float s = std::min(1.f, std::abs(p.x()) / mhw);
      const float vertical = corner ? 0.f : (upper ? 1.f : -1.f) * std::sqrt(1.f - s * s);
      for (int r = 0; r < l.mouth_rings; ++r) {
        const float z = r < 2 ? p.z() - depth[r] : z_front - depth[r];
        v.row(l.mouth_pocket_begin + r * l.mouth_loop + k) =
            Eigen::Vector3f(narrow[r] * p.x(), y_m - 0.1f * r + spread[r] * vertical, z).transpose();
      }
    }
    v.row(l.mouth_pocket_begin + l.mouth_rings * l.mouth_loop) =
        Eigen::Vector3f(0.f, y_m - 0.3f, z_front - 3.7f).transpose();
  }
  // Eyeballs: spheres with the pupil at the front pole.
  const std::vector<float> rings = EyeballRingAngles(l.eyeball_bands);
  for (int side = 0; side < 2; ++side) {
    const Eigen::Vector3f c = surface_.EyeCenter(side);
    const Eigen::Matrix3f& rot = eyes[side].rotation;
    int idx = l.eyeball_begin[side];
    v.row(idx++) = (c + rot * Eigen::Vector3f(0, 0, kEyeballRadius)).transpose();
    for (float a : rings) {
      for (int b = 0; b < l.eyeball_segments; ++b) {
        const float phi = 2.f * kPi * b / l.eyeball_segments;
        const Eigen::Vector3f d(std::sin(a) * std::cos(phi), std::sin(a) * std::sin(phi), std::cos(a));
        v.row(idx++) = (c + rot * (kEyeballRadius * d)).transpose();
      }
    }
    v.row(idx++) = (c + rot * Eigen::Vector3f(0, 0, -kEyeballRadius)).transpose();
  }
  return v;
}

Vertices HeadBuilder::BuildNeutral() const {
  const LidState lids[2];
  const EyeballRotation eyes[2];
  return Build(lids, eyes);
}

template <typename Measure>
std::vector<float> HeadBuilder::ArcLengthPlace(float a, float b, int n, bool open_end,
                                               Measure measure) {
  const int samples = 256;
  std::vector<float> ts(samples + 1), lengths(samples + 1, 0.f);
  for (int s = 0; s <= samples; ++s) ts[s] = Lerp(a, b, static_cast<float>(s) / samples);
  for (int s = 1; s <= samples; ++s) lengths[s] = lengths[s - 1] + measure(ts[s - 1], ts[s]);
  std::vector<float> out;
  const int count = open_end ? n - 1 : n;
  int s = 1;
  for (int k = 1; k <= count; ++k) {
    if (!open_end && k == n) { out.push_back(b); break; }
    const float target = lengths[samples] * k / n;
    while (s < samples && lengths[s] < target) ++s;
    const float seg = lengths[s] - lengths[s - 1];
    const float f = seg > 0.f ? (target - lengths[s - 1]) / seg : 0.f;
    out.push_back(Lerp(ts[s - 1], ts[s], f));
  }
  return out;
}

void HeadBuilder::PlaceRows() {
  const HeadSurface& hs = surface_;
  const float theta_eye = hs.ThetaAtX(hs.Params().eye_half_spacing, hs.EyeKey());
  auto measure = [&](float t0, float t1) {
    return (hs.Position(0.f, t1) - hs.Position(0.f, t0)).norm() +
           (hs.Position(theta_eye, t1) - hs.Position(theta_eye, t0)).norm();
  };
  const float knots[7] = {0.f,
                          static_cast<float>(hs.DomeEndKey()),
                          static_cast<float>(hs.EyeKey()),
                          static_cast<float>(hs.MouthKey()),
                          static_cast<float>(hs.ChinKey()),
                          static_cast<float>(hs.NeckKey()),
                          hs.NumKeys() - 1.f};
  row_t_.clear();
  for (int seg = 0; seg < 6; ++seg) {
    const std::vector<float> ts =
        ArcLengthPlace(knots[seg], knots[seg + 1], layout_.row_segments[seg], seg == 5, measure);
    row_t_.insert(row_t_.end(), ts.begin(), ts.end());
  }
}

void HeadBuilder::PlaceColumns() {
  const HeadSurface& hs = surface_;
  const HeadParams& p = hs.Params();
  theta_eye_inner_ = hs.ThetaAtX(p.eye_half_spacing - p.eye_half_width, hs.EyeKey());
  theta_eye_outer_ = hs.ThetaAtX(p.eye_half_spacing + p.eye_half_width, hs.EyeKey());
  const float theta_mouth = std::min(hs.ThetaAtX(p.mouth_half_width, hs.MouthKey()),
                                     theta_eye_outer_ - 0.05f);
  const std::vector<int>& n = layout_.col_segments;
  // Eye rows: knots at the eye corners, arc length along the eye row.
  eye_column_theta_ = Side(hs.EyeKey(), {0.f, theta_eye_inner_, theta_eye_outer_, 0.5f * kPi, kPi},
                           {n[0], n[1] + n[2], n[3], n[4]});
  // Mouth rows: knots at the mouth corners, arc length along the mouth row.
  mouth_column_theta_ = Side(hs.MouthKey(), {0.f, theta_mouth, theta_eye_outer_, 0.5f * kPi, kPi},
                             {n[0] + n[1], n[2], n[3], n[4]});
  row_blend_.resize(layout_.rows);
  for (int i = 0; i < layout_.rows; ++i) {
    const float y = hs.Profile(row_t_[i]).y;
    row_blend_[i] = Smoothstep(hs.EyeY() - 1.7f, hs.MouthY() + 1.3f, y);
  }
}

std::vector<float> HeadBuilder::Side(int key, const std::vector<float>& knots,
                                     const std::vector<int>& counts) const {
  const HeadSurface& hs = surface_;
  const float t = static_cast<float>(key);
  auto measure = [&](float a0, float a1) {
    return (hs.Position(a1, t) - hs.Position(a0, t)).norm();
  };
  std::vector<float> side = {0.f};
  for (size_t seg = 0; seg + 1 < knots.size(); ++seg) {
    const std::vector<float> ts = ArcLengthPlace(knots[seg], knots[seg + 1], counts[seg], false, measure);
    side.insert(side.end(), ts.begin(), ts.end());
  }
  std::vector<float> ring(layout_.cols, 0.f);
  for (int k = 0; k <= layout_.half_cols; ++k) {
    ring[layout_.Column(0, k) % layout_.cols] = side[k];
    if (k > 0 && k < layout_.half_cols) ring[layout_.Column(1, k)] = -side[k];
  }
  ring[0] = kPi;
  return ring;
}

// ---- topology, UVs, regions -----------------------------------------------------------------

namespace {

enum RegionId {
  kSkin, kHair, kNeck, kNose, kLeftBrow, kRightBrow, kLeftUpperLid, kLeftLowerLid,
  kRightUpperLid, kRightLowerLid, kSclera, kIris, kPupil, kUpperLip, kLowerLip,
  kMouthInterior, kNumRegions
};

}  // namespace

std::vector<Region> MakeRegions() {
  return {
      {"skin", {0.85f, 0.62f, 0.48f}},
      {"hair", {0.22f, 0.12f, 0.04f}},
      {"neck", {0.55f, 0.35f, 0.80f}},
      {"nose", {0.98f, 0.88f, 0.15f}},
      {"left_brow", {0.05f, 0.45f, 0.05f}},
      {"right_brow", {0.50f, 0.95f, 0.35f}},
      {"left_upper_eyelid", {1.00f, 0.35f, 0.75f}},
      {"left_lower_eyelid", {0.62f, 0.05f, 0.42f}},
      {"right_upper_eyelid", {0.35f, 0.85f, 1.00f}},
      {"right_lower_eyelid", {0.05f, 0.35f, 0.70f}},
      {"sclera", {1.00f, 1.00f, 1.00f}},
      {"iris", {0.00f, 0.70f, 0.55f}},
      {"pupil", {0.00f, 0.00f, 0.00f}},
      {"upper_lip", {0.95f, 0.08f, 0.08f}},
      {"lower_lip", {0.60f, 0.00f, 0.00f}},
      {"mouth_interior", {0.15f, 0.00f, 0.38f}},
  };
}

namespace {

// Height of the hairline at column angle theta.
float HairLineY(const HeadSurface& hs, float theta) {
  const float deg = std::abs(theta) * 180.f / kPi;
  const float ye = hs.EyeY();
  return Table({{0.f, ye + 7.2f}, {25.f, ye + 7.0f}, {45.f, ye + 5.6f}, {62.f, ye + 4.2f},
                {78.f, ye + 3.0f}, {92.f, ye + 1.6f}, {104.f, ye - 1.0f}, {118.f, ye - 5.0f},
                {180.f, ye - 6.0f}},
               deg);
}

// Builds the triangles (with their UV triangles and regions) and the UVs of one head, part by
// part, in the order MakeTopology calls the parts.
class TopologyMaker {
 public:
  TopologyMaker(const HeadBuilder& builder, const Vertices& neutral);

  void PlaceHeadUvs();
  void AddSkinGrid();
  void AddPoles();
  void AddPockets();
  void AddEyeballs();
  void PlacePartUvs();
  MeshTopology Finish() const;

 private:
  int UvOf(int i, int j, int vertex) const { return j == l_.cols ? seam_uv_begin_ + i : vertex; }
  void Add(int a, int b, int c, int ua, int ub, int uc, int reg);
  RegionId SkinRegion(int i, int j, const Eigen::Vector3f& centre) const;
  void AddPocket(const std::vector<int>& loop, int ring_begin, int rings, int reg);
  void PlaceBoxUvs(int begin, int count, float u0);

  const HeadBuilder& builder_;
  const Layout& l_;
  const HeadSurface& hs_;
  const Vertices& neutral_;
  std::vector<Eigen::Vector3i> tris_, uvtris_;
  std::vector<int> region_;
  std::vector<Eigen::Vector2f> uvs_;
  const int seam_uv_begin_;  // u = 1 copies of column 0, per row
  const int pole_uv_begin_;  // per column: top then bottom
};

TopologyMaker::TopologyMaker(const HeadBuilder& builder, const Vertices& neutral)
    : builder_(builder), l_(builder.GetLayout()), hs_(builder.Surface()), neutral_(neutral),
      uvs_(l_.num_vertices, Eigen::Vector2f::Zero()), seam_uv_begin_(l_.num_vertices),
      pole_uv_begin_(seam_uv_begin_ + l_.rows) {}

// Head UVs: u by column (seam at the back), v by the front arc length of the (warped) row.
// Per-vertex v from the neutral height keeps the eye openings open in UV space too.
void TopologyMaker::PlaceHeadUvs() {
  uvs_.resize(pole_uv_begin_ + 2 * l_.cols, Eigen::Vector2f::Zero());
  const float y_top = neutral_(l_.top_pole, 1), y_bottom = neutral_(l_.bottom_pole, 1);
  auto head_v = [&](int vertex) {
    const float y = neutral_(vertex, 1);
    return 0.22f + 0.76f * (y - y_bottom) / (y_top - y_bottom);
  };
  for (int i = 0; i < l_.rows; ++i) {
    for (int j = 0; j < l_.cols; ++j) {
      for (bool below : {false, true}) {
        const int vtx = l_.Vertex(i, j, below);
        uvs_[vtx] = Eigen::Vector2f(static_cast<float>(j) / l_.cols, head_v(vtx));
      }
    }
    uvs_[seam_uv_begin_ + i] = Eigen::Vector2f(1.f, head_v(l_.Grid(i, 0)));
  }
  for (int j = 0; j < l_.cols; ++j) {
    uvs_[pole_uv_begin_ + 2 * j] = Eigen::Vector2f((j + 0.5f) / l_.cols, 0.98f);
    uvs_[pole_uv_begin_ + 2 * j + 1] = Eigen::Vector2f((j + 0.5f) / l_.cols, 0.22f);
  }
}

void TopologyMaker::Add(int a, int b, int c, int ua, int ub, int uc, int reg) {
  tris_.emplace_back(a, b, c);
  uvtris_.emplace_back(ua, ub, uc);
  region_.push_back(reg);
}

// Region of a skin quad (rows i, i+1; columns j, j+1) from its neutral centre.
RegionId TopologyMaker::SkinRegion(int i, int j, const Eigen::Vector3f& centre) const {
  const float x = centre.x(), y = centre.y();
  const float theta_a = builder_.ColumnTheta(i, j);
  const float theta_b = j + 1 == l_.cols ? kPi : builder_.ColumnTheta(i, j + 1);
  const float theta = 0.5f * (theta_a + theta_b);
  for (int side = 0; side < 2; ++side) {
    if (j >= l_.EyeLo(side) && j < l_.EyeHi(side)) {
      const float u = 0.5f * (builder_.EyeFraction(j) + builder_.EyeFraction(j + 1));
      const float margin_up = hs_.EyeY() + builder_.UpperOpening(u);
      const float margin_low = hs_.EyeY() - builder_.LowerOpening(u);
      if (i < l_.row_eye &&
          (i == l_.row_eye - 1 || y < margin_up + 0.55f + 0.15f * std::sin(kPi * u))) {
        if (i >= l_.row_eye - 6) return side == 0 ? kLeftUpperLid : kRightUpperLid;
      }
      if (i >= l_.row_eye && (i == l_.row_eye || y > margin_low - 0.45f)) {
        if (i <= l_.row_eye + 4) return side == 0 ? kLeftLowerLid : kRightLowerLid;
      }
    }
  }
  const float ax = std::abs(x);
  const float ex = hs_.Params().eye_half_spacing;
  if (centre.z() > 0.f && ax > ex - 2.0f && ax < ex + 2.1f) {
    const float u = (ax - (ex - 2.0f)) / 4.1f;
    const float half = Lerp(0.42f, 0.2f, u);
    if (std::abs(y - hs_.BrowLineY(ax)) < half) return x > 0.f ? kLeftBrow : kRightBrow;
  }
  if (j >= l_.MouthLo() && j < l_.MouthHi()) {
    if (i < l_.row_mouth && (i == l_.row_mouth - 1 || y < hs_.UpperVermilionY(x))) {
      if (i >= l_.row_mouth - 5) return kUpperLip;
    }
    if (i >= l_.row_mouth && (i == l_.row_mouth || y > hs_.LowerVermilionY(x))) {
      if (i <= l_.row_mouth + 5) return kLowerLip;
    }
  }
  if (centre.z() > 0.f && y < hs_.NasionY() + 0.3f && y > hs_.SubnasaleY() - 0.25f &&
      hs_.NoseHeight(x, y) > 0.32f) {
    return kNose;
  }
  if (y < hs_.JawLineY(theta)) return kNeck;
  if (y > HairLineY(hs_, theta)) return kHair;
  return kSkin;
}

// Skin grid.
void TopologyMaker::AddSkinGrid() {
  for (int i = 0; i + 1 < l_.rows; ++i) {
    for (int j = 0; j < l_.cols; ++j) {
      const int jn = j + 1;
      const int a = l_.Vertex(i, j, true), b = l_.Vertex(i + 1, j, false);
      const int c = l_.Vertex(i + 1, jn, false), d = l_.Vertex(i, jn, true);
      const int ua = UvOf(i, j, a), ub = UvOf(i + 1, j, b);
      const int uc = UvOf(i + 1, jn, c), ud = UvOf(i, jn, d);
      const Eigen::Vector3f centre = 0.25f * (neutral_.row(a) + neutral_.row(b) +
                                              neutral_.row(c) + neutral_.row(d)).transpose();
      const int reg = SkinRegion(i, j, centre);
      // Mirror-symmetric diagonals: a-c on the +x half, b-d on the -x half.
      if (j >= l_.half_cols) {
        Add(a, b, c, ua, ub, uc, reg);
        Add(a, c, d, ua, uc, ud, reg);
      } else {
        Add(a, b, d, ua, ub, ud, reg);
        Add(b, c, d, ub, uc, ud, reg);
      }
    }
  }
}

// Poles.
void TopologyMaker::AddPoles() {
  for (int j = 0; j < l_.cols; ++j) {
    const int jn = j + 1;
    Add(l_.top_pole, l_.Grid(0, j), l_.Grid(0, jn), pole_uv_begin_ + 2 * j,
        UvOf(0, j, l_.Grid(0, j)), UvOf(0, jn, l_.Grid(0, jn)), kHair);
    const int last = l_.rows - 1;
    Add(l_.Grid(last, j), l_.bottom_pole, l_.Grid(last, jn), UvOf(last, j, l_.Grid(last, j)),
        pole_uv_begin_ + 2 * j + 1, UvOf(last, jn, l_.Grid(last, jn)), kNeck);
  }
}

// Pockets: rings behind a loop, then a fan; the loop is used reversed so that every edge of
// the opening is shared with opposite direction.
void TopologyMaker::AddPocket(const std::vector<int>& loop, int ring_begin, int rings, int reg) {
  const int n = static_cast<int>(loop.size());
  std::vector<int> prev = loop;
  for (int r = 0; r < rings; ++r) {
    std::vector<int> next(n);
    for (int k = 0; k < n; ++k) next[k] = ring_begin + r * n + k;
    for (int k = 0; k < n; ++k) {
      const int kn = (k + 1) % n;
      Add(prev[kn], prev[k], next[k], prev[kn], prev[k], next[k], reg);
      Add(prev[kn], next[k], next[kn], prev[kn], next[k], next[kn], reg);
    }
    prev = next;
  }
  const int centre = ring_begin + rings * n;
  for (int k = 0; k < n; ++k) {
    const int kn = (k + 1) % n;
    Add(prev[kn], prev[k], centre, prev[kn], prev[k], centre, reg);
  }
}

void TopologyMaker::AddPockets() {
  for (int side = 0; side < 2; ++side) {
    AddPocket(l_.Loop(l_.EyeLo(side), l_.EyeHi(side), l_.row_eye), l_.eye_pocket_begin[side], 1,
              kSclera);
  }
  AddPocket(l_.Loop(l_.MouthLo(), l_.MouthHi(), l_.row_mouth), l_.mouth_pocket_begin,
            l_.mouth_rings, kMouthInterior);
}

// Eyeballs.
void TopologyMaker::AddEyeballs() {
  for (int side = 0; side < 2; ++side) {
    const int base = l_.eyeball_begin[side], n = l_.eyeball_segments;
    const int ring_count = l_.eyeball_bands - 1;
    auto ring = [&](int r, int b) { return base + 1 + r * n + (b % n); };
    for (int b = 0; b < n; ++b) {
      Add(base, ring(0, b), ring(0, b + 1), base, ring(0, b), ring(0, b + 1), kPupil);
    }
    for (int r = 0; r + 1 < ring_count; ++r) {
      const int reg = r == 0 ? kIris : kSclera;
      for (int b = 0; b < n; ++b) {
        Add(ring(r, b), ring(r + 1, b), ring(r + 1, b + 1), ring(r, b), ring(r + 1, b),
            ring(r + 1, b + 1), reg);
        Add(ring(r, b), ring(r + 1, b + 1), ring(r, b + 1), ring(r, b), ring(r + 1, b + 1),
            ring(r, b + 1), reg);
      }
    }
    const int back = base + l_.eyeball_count - 1;
    for (int b = 0; b < n; ++b) {
      Add(ring(ring_count - 1, b), back, ring(ring_count - 1, b + 1), ring(ring_count - 1, b), back,
          ring(ring_count - 1, b + 1), kSclera);
    }
  }
}

// Front projection of the vertices begin .. begin + count - 1 into a box at u0.
void TopologyMaker::PlaceBoxUvs(int begin, int count, float u0) {
  Eigen::Vector2f lo(1e9f, 1e9f), hi(-1e9f, -1e9f);
  for (int k = begin; k < begin + count; ++k) {
    lo = lo.cwiseMin(neutral_.row(k).head<2>().transpose());
    hi = hi.cwiseMax(neutral_.row(k).head<2>().transpose());
  }
  const Eigen::Vector2f size = (hi - lo).cwiseMax(Eigen::Vector2f(1e-3f, 1e-3f));
  for (int k = begin; k < begin + count; ++k) {
    const Eigen::Vector2f q = (neutral_.row(k).head<2>().transpose() - lo).cwiseQuotient(size);
    uvs_[k] = Eigen::Vector2f(u0 + 0.01f + 0.18f * q.x(), 0.01f + 0.18f * q.y());
  }
}

// UVs of the parts that are not skin: front projections into boxes below the head chart.
void TopologyMaker::PlacePartUvs() {
  PlaceBoxUvs(l_.eyeball_begin[0], l_.eyeball_count, 0.0f);
  PlaceBoxUvs(l_.eyeball_begin[1], l_.eyeball_count, 0.2f);
  PlaceBoxUvs(l_.eye_pocket_begin[0], l_.eye_loop + 1, 0.4f);
  PlaceBoxUvs(l_.eye_pocket_begin[1], l_.eye_loop + 1, 0.6f);
  PlaceBoxUvs(l_.mouth_pocket_begin, l_.mouth_rings * l_.mouth_loop + 1, 0.8f);
  uvs_[l_.top_pole] = Eigen::Vector2f(0.5f, 0.99f);
  uvs_[l_.bottom_pole] = Eigen::Vector2f(0.5f, 0.21f);
}

MeshTopology TopologyMaker::Finish() const {
  MeshTopology out;
  out.triangles.resize(static_cast<int>(tris_.size()), 3);
  out.uv_triangles.resize(static_cast<int>(tris_.size()), 3);
  out.triangle_region.resize(static_cast<int>(tris_.size()));
  for (int f = 0; f < static_cast<int>(tris_.size()); ++f) {
    out.triangles.row(f) = tris_[f].transpose();
    out.uv_triangles.row(f) = uvtris_[f].transpose();
    out.triangle_region(f) = region_[f];
  }
  out.uvs.resize(static_cast<int>(uvs_.size()), 2);
  for (int k = 0; k < static_cast<int>(uvs_.size()); ++k) out.uvs.row(k) = uvs_[k].transpose();
  return out;
}

}  // namespace

MeshTopology MakeTopology(const HeadBuilder& builder, const Vertices& neutral) {
  TopologyMaker maker(builder, neutral);
  maker.PlaceHeadUvs();
  maker.AddSkinGrid();
  maker.AddPoles();
  maker.AddPockets();
  maker.AddEyeballs();
  maker.PlacePartUvs();
  return maker.Finish();
}

// ---- per-vertex facts ------------------------------------------------------------------------

std::vector<VertexFacts> MakeFacts(const Layout& l) {
  std::vector<VertexFacts> facts(l.num_vertices);
  for (int i = 0; i < l.rows; ++i) {
    for (int j = 0; j < l.cols; ++j) facts[l.Grid(i, j)].below_mouth = i > l.row_mouth;
  }
  facts[l.bottom_pole].below_mouth = true;
  for (int k = 0; k < l.mouth_dup_count; ++k) facts[l.mouth_dup_begin + k].below_mouth = true;
  for (int side = 0; side < 2; ++side) {
    for (int k = 0; k < l.eye_dup_count; ++k) facts[l.eye_dup_begin[side] + k].below_mouth = false;
    for (int k = 0; k <= l.eye_loop; ++k) {
      facts[l.eye_pocket_begin[side] + k].part = Part::kEyePocket;
      facts[l.eye_pocket_begin[side] + k].eye = side;
    }
    for (int k = 0; k < l.eyeball_count; ++k) {
      facts[l.eyeball_begin[side] + k].part = Part::kEyeball;
      facts[l.eyeball_begin[side] + k].eye = side;
    }
  }
  for (int r = 0; r < l.mouth_rings; ++r) {
    for (int k = 0; k < l.mouth_loop; ++k) {
      VertexFacts& f = facts[l.mouth_pocket_begin + r * l.mouth_loop + k];
      f.part = Part::kMouthPocket;
      f.below_mouth = k > l.mouth_dup_count + 1;
      f.pocket_depth = static_cast<float>(r + 1) / (l.mouth_rings + 1);
      f.loop_index = k;
    }
  }
  VertexFacts& centre = facts[l.mouth_pocket_begin + l.mouth_rings * l.mouth_loop];
  centre.part = Part::kMouthPocket;
  centre.pocket_depth = 1.f;
  return facts;
}

namespace {

// Jaw skinning weight M of a skin vertex (paper 000 Sec. 6): 1 on the chin, lower lip and lower
// jaw, 0 on the skull, upper lip and nose, a smooth ramp between that rises towards the jaw
// joint beside the mouth, and a jump across the lip slit.
float SkinJawWeight(const HeadSurface& hs, const Eigen::Vector3f& p, bool below_mouth,
                    const Eigen::Vector3f& pivot) {
  const float mhw = hs.Params().mouth_half_width;
  const float ax = std::abs(p.x());
  const float y_ref = hs.MouthY() + (pivot.y() - hs.MouthY()) * Smoothstep(mhw, 7.5f, ax);
  const float d = p.y() - y_ref;
  const float c2 = Square(std::min(1.f, ax / mhw));
  const float width = Lerp(1.3f, 2.5f, Smoothstep(mhw, 6.f, ax));
  float m;
  if (below_mouth || d < 0.f) {
    m = 1.f - 0.5f * c2 * (1.f - Smoothstep(0.f, width, -d));
  } else {
    m = 0.5f * c2 * (1.f - Smoothstep(0.f, width, d));
  }
  m *= Smoothstep(hs.ChinY() - 3.5f, hs.ChinY() - 0.3f, p.y());  // the neck stays
  m *= Smoothstep(pivot.z() - 0.5f, pivot.z() + 3.5f, p.z());     // behind the joint stays
  return Clamp01(m);
}

}  // namespace

Eigen::Vector3f JawPivot(const HeadSurface& hs) {
  return Eigen::Vector3f(0.f, hs.EyeY() - 2.8f, 1.0f);
}

Eigen::VectorXf MakeJawWeights(const HeadSurface& hs, const Layout& l, const Vertices& neutral,
                               const std::vector<VertexFacts>& facts) {
  const Eigen::Vector3f pivot = JawPivot(hs);
  Eigen::VectorXf m = Eigen::VectorXf::Zero(l.num_vertices);
  for (int v = 0; v < l.num_vertices; ++v) {
    if (facts[v].part == Part::kSkin) {
      m(v) = SkinJawWeight(hs, neutral.row(v).transpose(), facts[v].below_mouth, pivot);
    }
  }
  const std::vector<int> loop = l.Loop(l.MouthLo(), l.MouthHi(), l.row_mouth);
  for (int r = 0; r < l.mouth_rings; ++r) {
    for (int k = 0; k < l.mouth_loop; ++k) m(l.mouth_pocket_begin + r * l.mouth_loop + k) = m(loop[k]);
  }
  m(l.mouth_pocket_begin + l.mouth_rings * l.mouth_loop) = 0.5f;
  return m;
}

}  // namespace facecap::rig::demo_head_internal
