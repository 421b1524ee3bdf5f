// The synthetic scan database (paper 001 Sec. 4, Sec. 7): people made from the demo head's
// identity modes, each with their own blendshapes and FACS expression scans.
//
// Person j's true shapes on the skin's moving vertices x (paper symbols: S_i template,
// S_i^j personal, S_0^j neutral, d(x) = S_0^j(x) - S_0(x) the identity displacement):
//
//   S_i^j(x) = (1 + e_ij) [ S_i(x) + s (g_ij f_ij(x) S_i(x) + h_ij(x) - S_i(x)) ]
//   g_ij     = 1 + 0.25 tanh(c_i . a_j)                 (global, a_j identity coefficients)
//   f_ij(x)  = 1 + 0.35 tanh(2 <d(x), S_i(x) / |S_i(x)|>)   (local geometry)
//   h_ij(x)  = 0.3 |S_i(x)| tanh(|d(x)| / 0.5 cm) d(x) / |d(x)|   (motion bent towards d)
//
// with s = personal_strength, c_i a fixed random direction per shape and e_ij ~ N(0,
// personal_noise^2) the personal part no neutral can predict. Other vertices (eyeballs,
// pockets) keep the template's motion. A captured expression k is
//
//   P_k^j = S_0^j + sum_i w_ik S_i^j + n,  n ~ N(0, vertex_noise_cm^2) per coordinate,
//
// where w_ik is drawn around the FACS table's alpha_ik: active shapes in [1 - jitter, 1],
// plus `unwanted_shapes` other shapes at up to unwanted_max ("unwanted motion").
#ifndef FACECAP_ASSETS_SCAN_DATABASE_H_
#define FACECAP_ASSETS_SCAN_DATABASE_H_

#include <string>
#include <vector>

#include <Eigen/Core>

#include "assets/template_shapes.h"
#include "rig/rig.h"

namespace facecap::assets {

struct ScanSynthOptions {
  int seed = 1;                        // database seed (people, personal shapes, noise)
  float identity_scale = 1.f;          // identity sample size in standard deviations
  float personal_strength = 1.f;       // s: how far personal shapes depart from the template
  float personal_noise = 0.05f;        // std of the per-shape personal factor e_ij
  float weight_jitter = 0.2f;          // active weights drawn in [1 - jitter, 1]
  int unwanted_shapes = 2;             // extra shapes activated per scan
  float unwanted_max = 0.25f;          // largest weight of an unwanted activation
  float vertex_noise_cm = 0.01f;       // per-coordinate scan noise (cm)

  template <class V>
  void Visit(V&& v) {
    v("seed", seed, "database seed (people, personal shapes, noise)");
    v("identity_scale", identity_scale, "identity sample size in standard deviations");
    v("personal_strength", personal_strength, "how far personal shapes depart from the template (0: not at all)");
    v("personal_noise", personal_noise, "std of the per-person, per-shape factor no neutral can predict");
    v("weight_jitter", weight_jitter, "active FACS weights are drawn in [1 - jitter, 1]");
    v("unwanted_shapes", unwanted_shapes, "extra shapes activated in every scan (unwanted motion)");
    v("unwanted_max", unwanted_max, "largest weight of an unwanted activation");
    v("vertex_noise_cm", vertex_noise_cm, "per-coordinate scan noise (cm)");
  }
  bool Check(std::string* why) const;
};

struct ScanPerson {
  int identity_seed = 0;
  Eigen::VectorXf neutral;        // S_0^j, 3#V
  Eigen::MatrixXf expressions;    // P_k^j as columns, 3#V by K
  Eigen::MatrixXf true_deltas;    // S_i^j, 3#V by N
  Eigen::MatrixXf true_weights;   // w_ik, K by N
  Eigen::VectorXf global_factors;    // g_ij, N (no effect on shapes that move no personal vertex)
  Eigen::VectorXf personal_factors;  // e_ij, N
};

// Person `person` of the database. rig: the demo head with identity modes (same topology as
// the template); personal_vertices: the vertices whose motion is personal (skin);
// facs: alpha, K by N. Deterministic in (options.seed, person).
ScanPerson SynthesizeScanPerson(const rig::Rig& rig, const LinearShapes& template_shapes,
                                const std::vector<int>& personal_vertices,
                                const Eigen::MatrixXf& facs, int person,
                                const ScanSynthOptions& options);

}  // namespace facecap::assets

#endif  // FACECAP_ASSETS_SCAN_DATABASE_H_
