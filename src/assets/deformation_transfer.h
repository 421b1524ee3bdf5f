// Deformation transfer for meshes of one topology (Sumner and Popovic 2004), in its
// gradient-domain form: each source triangle's deformation gradient Q_t = V'_t V_t^-1 (edge
// frames completed by the scaled normal) is imposed on the target's triangle in the least-
// squares sense,
//
//   min_X  sum_t area_t || X_t G_t - Q_t ||_F^2  +  mu || X - (T_0 + D) ||^2
//
// where X_t = [x_b - x_a, x_c - x_a] are the target's deformed edges, G_t the pseudo-inverse
// of its rest edges, T_0 the target's rest vertices and D the source displacement: the small
// mu term fixes the translation and any disconnected part, and is exact when target and
// source coincide. Precompute (factorize, SimplicialLDLT) once per target, solve per shape.
#ifndef FACECAP_ASSETS_DEFORMATION_TRANSFER_H_
#define FACECAP_ASSETS_DEFORMATION_TRANSFER_H_

#include <memory>
#include <string>

#include <Eigen/Core>

#include "rig/rig.h"

namespace facecap::assets {

struct DeformationTransferOptions {
  // mu: weight of the pull towards target rest + source displacement (per vertex, cm^-0
  // relative to the area-weighted gradient term). Small: fixes the null space only.
  double anchor_weight = 1e-4;
  // Triangles whose rest area (cm^2) is below this are left out of the gradient term.
  double min_triangle_area = 1e-10;

  bool Check(std::string* why) const;
};

class DeformationTransfer {
 public:
  // Precomputes the target system (factorization) and the source rest frames.
  // source_rest, target_rest: #V by 3 of the same topology `triangles`.
  DeformationTransfer(const rig::Vertices& source_rest, const rig::Vertices& target_rest,
                      const rig::Triangles& triangles,
                      const DeformationTransferOptions& options = DeformationTransferOptions());
  ~DeformationTransfer();
  DeformationTransfer(const DeformationTransfer&) = delete;
  DeformationTransfer& operator=(const DeformationTransfer&) = delete;

  // The target deformed like source_rest -> source_deformed (#V by 3 each).
  rig::Vertices Transfer(const rig::Vertices& source_deformed) const;
  // Transfers every column of source deltas (3#V by N, S_i) and returns the target's deltas
  // (3#V by N): the template moved onto the target's neutral.
  Eigen::MatrixXf TransferDeltas(const Eigen::MatrixXf& source_deltas) const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace facecap::assets

#endif  // FACECAP_ASSETS_DEFORMATION_TRANSFER_H_
