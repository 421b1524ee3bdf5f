// The 52 ARKit blendshape names (ARFaceAnchor.BlendShapeLocation) in Apple's documented order:
// left eye, right eye, mouth and jaw, eyebrows, cheeks, nose, tongue. "Left" and "Right" are
// the subject's left (+x) and right (-x).
#ifndef FACECAP_RIG_ARKIT_H_
#define FACECAP_RIG_ARKIT_H_

#include <string>
#include <vector>

namespace facecap::rig {

// Number of ARKit blendshapes.
inline constexpr int kNumArkitShapes = 52;

// The 52 names, eyeBlinkLeft first and tongueOut last.
const std::vector<std::string>& ArkitShapeNames();

// Position of `name` in ArkitShapeNames(), or -1 when it is not an ARKit name (case-sensitive).
int ArkitIndex(const std::string& name);

}  // namespace facecap::rig

#endif  // FACECAP_RIG_ARKIT_H_
