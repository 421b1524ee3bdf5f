#include "rig/parts.h"

namespace facecap::rig {

Vertices SecondaryPart::Evaluate(const Eigen::VectorXf& weights) const {
  const Eigen::VectorXf d = deltas * weights;
  Vertices out = neutral;
  for (int k = 0; k < NumVertices(); ++k) out.row(k) += d.segment<3>(3 * k).transpose();
  return out;
}

int PartSet::PartIndex(const std::string& name) const {
  for (size_t k = 0; k < parts.size(); ++k) {
    if (parts[k].name == name) return static_cast<int>(k);
  }
  return -1;
}

}  // namespace facecap::rig
