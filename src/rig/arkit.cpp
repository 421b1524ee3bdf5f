#include "rig/arkit.h"

namespace facecap::rig {

const std::vector<std::string>& ArkitShapeNames() {
  static const std::vector<std::string> kNames = {
      // Left eye.
      "eyeBlinkLeft", "eyeLookDownLeft", "eyeLookInLeft", "eyeLookOutLeft", "eyeLookUpLeft",
      "eyeSquintLeft", "eyeWideLeft",
      // Right eye.
      "eyeBlinkRight", "eyeLookDownRight", "eyeLookInRight", "eyeLookOutRight", "eyeLookUpRight",
      "eyeSquintRight", "eyeWideRight",
      // Mouth and jaw.
      "jawForward", "jawLeft", "jawRight", "jawOpen", "mouthClose", "mouthFunnel", "mouthPucker",
      "mouthLeft", "mouthRight", "mouthSmileLeft", "mouthSmileRight", "mouthFrownLeft",
      "mouthFrownRight", "mouthDimpleLeft", "mouthDimpleRight", "mouthStretchLeft",
      "mouthStretchRight", "mouthRollLower", "mouthRollUpper", "mouthShrugLower",
      "mouthShrugUpper", "mouthPressLeft", "mouthPressRight", "mouthLowerDownLeft",
      "mouthLowerDownRight", "mouthUpperUpLeft", "mouthUpperUpRight",
      // Eyebrows.
      "browDownLeft", "browDownRight", "browInnerUp", "browOuterUpLeft", "browOuterUpRight",
      // Cheeks.
      "cheekPuff", "cheekSquintLeft", "cheekSquintRight",
      // Nose.
      "noseSneerLeft", "noseSneerRight",
      // Tongue.
      "tongueOut"};
  return kNames;
}

int ArkitIndex(const std::string& name) {
  const std::vector<std::string>& names = ArkitShapeNames();
  for (int i = 0; i < static_cast<int>(names.size()); ++i) {
    if (names[i] == name) return i;
  }
  return -1;
}

}  // namespace facecap::rig
