#include "rig/identity_shapes.h"

#include <string>
#include <utility>

namespace facecap::rig {

Rig WithIdentityShapes(const Rig& rig) {
  Rig out = rig;
  for (size_t k = 0; k < rig.identity_modes.size(); ++k) {
    Shape s;
    s.name = "identity_" + std::to_string(k);
    const Vertices& mode = rig.identity_modes[k];
    for (int v = 0; v < mode.rows(); ++v) {
      s.delta.vertex.push_back(v);
      s.delta.offset.push_back(mode.row(v).transpose());
    }
    out.shapes.push_back(std::move(s));
  }
  return out;
}

}  // namespace facecap::rig
