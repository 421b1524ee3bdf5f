// The one rule by which stages keep items out for evaluation: with hold-out period n, item i is
// held out when i % n == n - 1 (every n-th, the last of each n); n = 0 holds nothing out.
// deepfake train's b_holdout_every, appearance gather's and eval's holdout_every, and the
// blendshape trainer's unseen expressions all follow it, so that they agree on the items.
#ifndef FACECAP_STAGES_HOLDOUT_H_
#define FACECAP_STAGES_HOLDOUT_H_

#include <cstdint>

namespace facecap::stages {

inline bool IsHeldOut(int64_t index, int64_t every) {
  return every > 0 && index % every == every - 1;
}

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_HOLDOUT_H_
