#include "assets/person_rig.h"

#include <algorithm>
#include <vector>

#include "assets/deformation_transfer.h"
#include "util/errors.h"

namespace facecap::assets {

namespace {
// Offsets below this (cm) are dropped from a transferred delta: the solve leaves round-off
// on vertices the shape does not move.
constexpr float kDeltaFloor = 1e-5f;
// The jaw pivot follows the mean displacement of this many vertices nearest to it.
constexpr int kPivotNeighbours = 64;
}  // namespace

rig::Rig PersonRig(const rig::Rig& generic, const rig::Vertices& neutral) {
  const int V = generic.NumVertices();
  if (neutral.rows() != V) {
    throw InvalidInputError("person rig: the neutral has " + std::to_string(neutral.rows()) +
                            " vertices, the rig " + std::to_string(V));
  }
  rig::Rig person = generic;
  person.neutral = neutral;
  const int S = generic.NumShapes();
  if (S > 0) {
    Eigen::MatrixXf deltas = Eigen::MatrixXf::Zero(3 * V, S);
    for (int s = 0; s < S; ++s) {
      const rig::SparseDelta& d = generic.shapes[s].delta;
      for (size_t k = 0; k < d.vertex.size(); ++k) {
        deltas.block<3, 1>(3 * d.vertex[k], s) = d.offset[k];
      }
    }
    const DeformationTransfer transfer(generic.neutral, neutral, generic.triangles);
    const Eigen::MatrixXf moved = transfer.TransferDeltas(deltas);
    for (int s = 0; s < S; ++s) {
      rig::SparseDelta d;
      for (int v = 0; v < V; ++v) {
        const Eigen::Vector3f o = moved.block<3, 1>(3 * v, s);
        if (o.norm() > kDeltaFloor) {
          d.vertex.push_back(v);
          d.offset.push_back(o);
        }
      }
      person.shapes[s].delta = std::move(d);
    }
  }
  // The pivot moves with the vertices around it.
  std::vector<std::pair<float, int>> nearest(V);
  for (int v = 0; v < V; ++v) {
    nearest[v] = {(generic.neutral.row(v).transpose() - generic.jaw_pivot).squaredNorm(), v};
  }
  const int n = std::min(kPivotNeighbours, V);
  std::partial_sort(nearest.begin(), nearest.begin() + n, nearest.end());
  Eigen::Vector3f shift = Eigen::Vector3f::Zero();
  for (int k = 0; k < n; ++k) {
    const int v = nearest[k].second;
    shift += (neutral.row(v) - generic.neutral.row(v)).transpose();
  }
  if (n > 0) person.jaw_pivot = generic.jaw_pivot + shift / static_cast<float>(n);
  return person;
}

}  // namespace facecap::assets
