#include "rig/rig.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

#include <Eigen/Geometry>

namespace facecap::rig {

int Rig::ShapeIndex(const std::string& name) const {
  for (int i = 0; i < NumShapes(); ++i) {
    if (shapes[i].name == name) return i;
  }
  return -1;
}

namespace {

// Collects problems; stops recording after a few so that a badly broken rig gives a
// readable message.
class ProblemList {
 public:
  template <typename... Args>
  void Add(const Args&... parts) {
    ++count_;
    if (count_ > kMaxListed) return;
    std::ostringstream line;
    (line << ... << parts);
    if (!text_.empty()) text_ += "; ";
    text_ += line.str();
  }
  bool empty() const { return count_ == 0; }
  std::string Text() const {
    if (count_ <= kMaxListed) return text_;
    return text_ + "; ... and " + std::to_string(count_ - kMaxListed) + " more problems";
  }

 private:
  static constexpr int kMaxListed = 8;
  int count_ = 0;
  std::string text_;
};

// First row of a float matrix with a non-finite entry, or -1.
template <typename Matrix>
int FirstNonFiniteRow(const Matrix& m) {
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    if (!m.row(r).allFinite()) return static_cast<int>(r);
  }
  return -1;
}

// Index triangles (e.g. uv_triangles) in [0, num_indexed); records the first violation.
void CheckIndexTriangles(const Triangles& tris, int num_indexed, const char* what,
                         ProblemList* problems) {
  for (Eigen::Index f = 0; f < tris.rows(); ++f) {
    for (int c = 0; c < 3; ++c) {
      const int i = tris(f, c);
      if (i < 0 || i >= num_indexed) {
        problems->Add(what, " ", f, " has index ", i, " outside [0, ", num_indexed, ")");
        return;
      }
    }
  }
}

}  // namespace

bool Rig::Check(std::string* why) const {
  ProblemList problems;
  const int num_vertices = NumVertices();
  const int num_triangles = static_cast<int>(triangles.rows());

  if (num_vertices == 0) problems.Add("the neutral has no vertices");
  if (num_triangles == 0) problems.Add("the rig has no triangles");
  if (int row = FirstNonFiniteRow(neutral); row >= 0) {
    problems.Add("neutral vertex ", row, " is not finite");
  }

  // Triangles: indices in range, then degenerate ones (repeated corner or zero area).
  bool triangles_in_range = true;
  for (int f = 0; f < num_triangles && triangles_in_range; ++f) {
    for (int c = 0; c < 3; ++c) {
      const int v = triangles(f, c);
      if (v < 0 || v >= num_vertices) {
        problems.Add("triangle ", f, " has vertex index ", v, " outside [0, ", num_vertices, ")");
        triangles_in_range = false;
        break;
      }
    }
  }
  if (triangles_in_range) {
    for (int f = 0; f < num_triangles; ++f) {
      const int a = triangles(f, 0), b = triangles(f, 1), c = triangles(f, 2);
      if (a == b || b == c || a == c) {
        problems.Add("triangle ", f, " is degenerate: repeated vertex (", a, ", ", b, ", ", c, ")");
        continue;
      }
      const Eigen::Vector3f ab = neutral.row(b) - neutral.row(a);
      const Eigen::Vector3f ac = neutral.row(c) - neutral.row(a);
      const Eigen::Vector3f bc = neutral.row(c) - neutral.row(b);
      const float longest_squared =
          std::max({ab.squaredNorm(), ac.squaredNorm(), bc.squaredNorm()});
      // Zero area up to float rounding: the sine of the largest angle's complement below 1e-6.
      if (!(ab.cross(ac).norm() > 1e-6f * longest_squared)) {
        problems.Add("triangle ", f, " is degenerate: zero area (vertices ", a, ", ", b, ", ", c,
                     ")");
      }
    }
  }

  // Texture coordinates.
  if (uvs.rows() > 0) {
    if (uv_triangles.rows() != num_triangles) {
      problems.Add("uv_triangles has ", uv_triangles.rows(), " rows, expected ", num_triangles,
                   " (one per triangle)");
    } else {
      CheckIndexTriangles(uv_triangles, static_cast<int>(uvs.rows()), "uv triangle", &problems);
    }
    if (int row = FirstNonFiniteRow(uvs); row >= 0) problems.Add("uv ", row, " is not finite");
  } else if (uv_triangles.rows() > 0) {
    problems.Add("uv_triangles has ", uv_triangles.rows(), " rows but there are no uvs");
  }

  // Regions.
  if (triangle_region.size() != num_triangles) {
    problems.Add("triangle_region has ", triangle_region.size(), " entries, expected ",
                 num_triangles, " (one per triangle)");
  } else {
    for (int f = 0; f < num_triangles; ++f) {
      const int r = triangle_region[f];
      if (r < 0 || r >= static_cast<int>(regions.size())) {
        problems.Add("triangle ", f, " has region ", r, " outside [0, ", regions.size(), ")");
        break;
      }
    }
  }
  for (size_t r = 0; r < regions.size(); ++r) {
    if (!regions[r].color.allFinite()) problems.Add("region '", regions[r].name, "' colour is not finite");
  }

  // Jaw skinning M and pivot.
  if (jaw_weights.size() != num_vertices) {
    problems.Add("jaw_weights has ", jaw_weights.size(), " entries, expected ", num_vertices,
                 " (one per vertex)");
  } else {
    for (int v = 0; v < num_vertices; ++v) {
      const float m = jaw_weights[v];
      if (!(m >= 0.f && m <= 1.f)) {
        problems.Add("jaw weight of vertex ", v, " is ", m, ", outside [0, 1]");
        break;
      }
    }
  }
  if (!jaw_pivot.allFinite()) problems.Add("jaw_pivot is not finite");

  // Shapes: unique names, sparse deltas sorted, in range and finite, finite jaw parameters.
  std::set<std::string> names;
  for (int s = 0; s < NumShapes(); ++s) {
    const Shape& shape = shapes[s];
    const std::string label = "shape " + std::to_string(s) + " '" + shape.name + "'";
    if (shape.name.empty()) problems.Add(label, " has an empty name");
    if (!names.insert(shape.name).second) problems.Add(label, " repeats an earlier shape name");
    if (shape.delta.vertex.size() != shape.delta.offset.size()) {
      problems.Add(label, " has ", shape.delta.vertex.size(), " delta vertices but ",
                   shape.delta.offset.size(), " offsets");
      continue;
    }
    for (size_t k = 0; k < shape.delta.vertex.size(); ++k) {
      const int v = shape.delta.vertex[k];
      if (v < 0 || v >= num_vertices) {
        problems.Add(label, " delta ", k, " has vertex index ", v, " outside [0, ", num_vertices,
                     ")");
        break;
      }
      if (k > 0 && v <= shape.delta.vertex[k - 1]) {
        problems.Add(label, " delta vertex indices are not strictly ascending at entry ", k,
                     " (", shape.delta.vertex[k - 1], " then ", v, ")");
        break;
      }
      if (!shape.delta.offset[k].allFinite()) {
        problems.Add(label, " delta of vertex ", v, " is not finite");
        break;
      }
    }
    if (!shape.jaw_euler.allFinite()) problems.Add(label, " jaw_euler is not finite");
    if (!shape.jaw_translation.allFinite()) problems.Add(label, " jaw_translation is not finite");
  }

  // Landmarks: 68 (iBUG order) or none.
  if (landmarks.size() != 0 && landmarks.size() != 68) {
    problems.Add("landmarks has ", landmarks.size(), " entries, expected 68 or none");
  }
  for (Eigen::Index k = 0; k < landmarks.size(); ++k) {
    if (landmarks[k] < 0 || landmarks[k] >= num_vertices) {
      problems.Add("landmark ", k, " has vertex index ", landmarks[k], " outside [0, ",
                   num_vertices, ")");
      break;
    }
  }

  // Identity modes: dense #V x 3, finite.
  for (size_t k = 0; k < identity_modes.size(); ++k) {
    if (identity_modes[k].rows() != num_vertices) {
      problems.Add("identity mode ", k, " has ", identity_modes[k].rows(), " rows, expected ",
                   num_vertices);
    } else if (int row = FirstNonFiniteRow(identity_modes[k]); row >= 0) {
      problems.Add("identity mode ", k, " is not finite at vertex ", row);
    }
  }

  if (problems.empty()) return true;
  if (why) *why = problems.Text();
  return false;
}

}  // namespace facecap::rig
