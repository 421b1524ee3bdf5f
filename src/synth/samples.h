// Random rig samples for training the deepfake (paper 000 Sec. 7): every control uniform in
// [0, 1] under per-region sparsity limits (e.g. no more than five lip shapes active at once),
// the rigid pose from a truncated Gaussian (pitch in [-10, 10] deg, yaw in [-80, 80] deg by
// default), rendered as segmentation images with 2D landmarks. With identity_sigma > 0 each
// sample is also another person: identity coefficients alpha_k ~ N(0, sigma^2) over the
// rig's identity modes.
//
// Sample i draws only from Rng(seed, i): a dataset is the same for any number of ranks or
// threads, and any sample can be recomputed alone.
#ifndef FACECAP_SYNTH_SAMPLES_H_
#define FACECAP_SYNTH_SAMPLES_H_

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "render/camera.h"
#include "rig/rig.h"

namespace facecap::synth {

struct SampleOptions {
  int count = 4000;                 // number of samples
  int size = 128;                   // image width and height in pixels
  int seed = 1;                     // dataset seed; sample i draws from (seed, i)
  float fov_deg = 20.f;             // vertical field of view of the camera
  float fill = 0.7f;                // fraction of the image height the face (landmarks) spans
  float pitch_sigma_deg = 5.f;      // sigma of the truncated Gaussian on pitch
  float pitch_limit_deg = 10.f;     // pitch in [-limit, limit]
  float yaw_sigma_deg = 40.f;       // sigma of the truncated Gaussian on yaw
  float yaw_limit_deg = 80.f;       // yaw in [-limit, limit]
  float identity_sigma = 0.f;       // sigma of each sample's identity coefficients (0: the rig's head)
  // Sparsity per face region: a shape belongs to the first group whose prefix starts its
  // name; at most sparsity_max_active[g] shapes of group g are active in a sample (their
  // number drawn uniformly from 0..max). Shapes of no group stay at 0.
  std::vector<std::string> sparsity_groups = {"eye", "brow", "cheek", "nose",
                                              "jaw", "mouth", "tongue"};
  std::vector<int> sparsity_max_active = {4, 2, 2, 2, 2, 5, 1};

  template <class V>
  void Visit(V&& v) {
    v("count", count, "number of samples");
    v("size", size, "image width and height in pixels");
    v("seed", seed, "dataset seed; sample i is drawn from (seed, i)");
    v("fov_deg", fov_deg, "vertical field of view of the camera in degrees");
    v("fill", fill, "fraction of the image height that the face (its 68 landmarks) spans");
    v("pitch_sigma_deg", pitch_sigma_deg, "sigma of the truncated Gaussian on pitch, degrees");
    v("pitch_limit_deg", pitch_limit_deg, "pitch is truncated to [-limit, limit] degrees");
    v("yaw_sigma_deg", yaw_sigma_deg, "sigma of the truncated Gaussian on yaw, degrees");
    v("yaw_limit_deg", yaw_limit_deg, "yaw is truncated to [-limit, limit] degrees");
    v("identity_sigma", identity_sigma,
      "each sample's head: identity coefficients alpha_k ~ N(0, sigma^2), truncated to "
      "+-2.5 sigma, over the rig's identity modes (0: every sample is the rig's own head)");
    v("sparsity_groups", sparsity_groups, "shape-name prefixes of the face regions");
    v("sparsity_max_active", sparsity_max_active, "most active shapes per region, one per group");
  }
  bool Check(std::string* why) const;
};

// The sparsity groups resolved against a rig's shape names.
struct Sparsity {
  std::vector<std::vector<int>> group_shapes;  // shape indices per group, ascending
  std::vector<int> max_active;                 // per group
  std::vector<int> ungrouped;                  // shapes that stay at 0
};
// Throws InvalidInputError when a group matches no shape of the rig.
Sparsity ResolveSparsity(const rig::Rig& rig, const SampleOptions& options);

struct SampleParams {
  float pitch = 0.f;  // rad
  float yaw = 0.f;    // rad
  Eigen::VectorXf weights;
  Eigen::VectorXf identity;  // coefficients of the identity modes (empty: the rig's head)
};

// The parameters of sample `index`; identity coefficients for num_identity_modes modes when
// options.identity_sigma > 0, drawn after the rest so that the other parameters do not depend
// on them.
SampleParams DrawSample(const Sparsity& sparsity, const SampleOptions& options, int num_shapes,
                        int64_t index, int num_identity_modes = 0);

// The camera every sample is rendered with.
render::Camera SampleCamera(const SampleOptions& options);

}  // namespace facecap::synth

#endif  // FACECAP_SYNTH_SAMPLES_H_
