// Demo head landmarks: the 68 iBUG points as vertices of the neutral mesh.
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Core>

#include "rig/demo_head_internal.h"

namespace facecap::rig::demo_head_internal {

Eigen::VectorXi MakeLandmarks(const HeadBuilder& b, const Vertices& n) {
  const Layout& l = b.GetLayout();
  const HeadSurface& hs = b.Surface();
  const HeadParams& p = hs.Params();
  Eigen::VectorXi lm(68);
  // Nearest original grid vertex on the front of the face to (x, y), rows in [r0, r1].
  auto nearest = [&](float x, float y, int r0, int r1) {
    int best = -1;
    float best_d = std::numeric_limits<float>::infinity();
    for (int i = std::max(0, r0); i <= std::min(l.rows - 1, r1); ++i) {
      for (int j = 0; j < l.cols; ++j) {
        if (std::cos(b.ColumnTheta(i, j)) < 0.3f) continue;
        const int v = l.Grid(i, j);
        const float d = Square(n(v, 0) - x) + Square(n(v, 1) - y);
        if (d < best_d) { best_d = d; best = v; }
      }
    }
    return best;
  };
  // Jaw contour 0-16: even arc-length samples of the jaw line from the right ear to the left.
  {
    std::vector<Eigen::Vector3f> curve;
    std::vector<float> length = {0.f};
    for (int k = 0; k <= 352; ++k) {
      const float theta = (-88.f + 0.5f * k) * kPi / 180.f;
      const float t = hs.ParameterAtHeight(hs.JawLineY(theta) + 0.15f, 0.f, hs.NumKeys() - 1.f);
      curve.push_back(hs.Position(theta, t));
      if (k > 0) length.push_back(length.back() + (curve[k] - curve[k - 1]).norm());
    }
    int s = 0;
    for (int m = 0; m < 17; ++m) {
      const float target = length.back() * m / 16.f;
      while (s + 1 < static_cast<int>(length.size()) && length[s] < target) ++s;
      int best = -1;
      float best_d = std::numeric_limits<float>::infinity();
      for (int i = 0; i < l.rows; ++i) {
        for (int j = 0; j < l.cols; ++j) {
          const int v = l.Grid(i, j);
          const float d = (n.row(v).transpose() - curve[s]).squaredNorm();
          if (d < best_d) { best_d = d; best = v; }
        }
      }
      lm(m) = best;
    }
  }
  // Brows 17-21 (right, outer to inner) and 22-26 (left, inner to outer).
  const float ex = p.eye_half_spacing;
  for (int k = 0; k < 5; ++k) {
    const float ax_right = ex + 1.9f - 0.925f * k;
    lm(17 + k) = nearest(-ax_right, hs.BrowLineY(ax_right), 0, l.row_eye);
    const float ax_left = ex - 1.8f + 0.925f * k;
    lm(22 + k) = nearest(ax_left, hs.BrowLineY(ax_left), 0, l.row_eye);
  }
  // Nose bridge 27-29 down the centre column, tip 30 the most forward centre vertex.
  int tip = l.Grid(0, l.half_cols);
  for (int i = 0; i < l.rows; ++i) {
    if (n(l.Grid(i, l.half_cols), 2) > n(tip, 2)) tip = l.Grid(i, l.half_cols);
  }
  for (int k = 0; k < 3; ++k) {
    const float y = Lerp(hs.NasionY() - 0.15f, hs.NoseTipY(), k / 3.f);
    lm(27 + k) = nearest(0.f, y, 0, l.row_mouth);
  }
  lm(30) = tip;
  // Nose base 31-35, right to left.
  for (int k = 0; k < 5; ++k) {
    lm(31 + k) = nearest(-1.0f + 0.5f * k, hs.SubnasaleY() + 0.1f + 0.15f * std::abs(k - 2),
                         l.row_eye, l.row_mouth - 1);
  }
  // Eyes: corners are the slit ends, lid points are margin vertices at 1/3 and 2/3 across.
  auto eye_column = [&](int side, float u) {
    int best = l.EyeLo(side) + 1;
    for (int j = l.EyeLo(side) + 1; j < l.EyeHi(side); ++j) {
      if (std::abs(b.EyeFraction(j) - u) < std::abs(b.EyeFraction(best) - u)) best = j;
    }
    return best;
  };
  const int re = l.row_eye;
  lm(36) = l.Grid(re, l.Column(1, l.k_eye_outer));
  lm(37) = l.Grid(re, eye_column(1, 2.f / 3.f));
  lm(38) = l.Grid(re, eye_column(1, 1.f / 3.f));
  lm(39) = l.Grid(re, l.Column(1, l.k_eye_inner));
  lm(40) = l.Vertex(re, eye_column(1, 1.f / 3.f), true);
  lm(41) = l.Vertex(re, eye_column(1, 2.f / 3.f), true);
  lm(42) = l.Grid(re, l.Column(0, l.k_eye_inner));
  lm(43) = l.Grid(re, eye_column(0, 1.f / 3.f));
  lm(44) = l.Grid(re, eye_column(0, 2.f / 3.f));
  lm(45) = l.Grid(re, l.Column(0, l.k_eye_outer));
  lm(46) = l.Vertex(re, eye_column(0, 2.f / 3.f), true);
  lm(47) = l.Vertex(re, eye_column(0, 1.f / 3.f), true);
  // Lips.
  const int rm = l.row_mouth;
  const float mhw = p.mouth_half_width;
  auto mouth_column = [&](float x) {
    int best = l.MouthLo() + 1;
    for (int j = l.MouthLo() + 1; j < l.MouthHi(); ++j) {
      if (std::abs(n(l.Grid(rm, j), 0) - x) < std::abs(n(l.Grid(rm, best), 0) - x)) best = j;
    }
    return best;
  };
  lm(48) = l.Grid(rm, l.MouthLo() - 1);
  lm(54) = l.Grid(rm, l.MouthHi() + 1);
  const float outer_x[5] = {-0.62f, -0.28f, 0.f, 0.28f, 0.62f};
  for (int k = 0; k < 5; ++k) {
    const float xu = outer_x[k] * mhw;
    lm(49 + k) = nearest(xu, hs.UpperVermilionY(xu), rm - 6, rm - 1);
    const float xl = -outer_x[k] * mhw;
    lm(55 + k) = nearest(xl, hs.LowerVermilionY(xl), rm + 1, rm + 6);
  }
  lm(60) = l.Grid(rm, l.MouthLo());
  lm(64) = l.Grid(rm, l.MouthHi());
  const float inner_x[3] = {-0.45f, 0.f, 0.45f};
  for (int k = 0; k < 3; ++k) {
    lm(61 + k) = l.Grid(rm, mouth_column(inner_x[k] * mhw));
    lm(65 + k) = l.Vertex(rm, mouth_column(-inner_x[k] * mhw), true);
  }
  return lm;
}

}  // namespace facecap::rig::demo_head_internal
