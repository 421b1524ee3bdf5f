// The albedo texture a textured rig file carries (io/texture_file.h), as the exports embed it.
#ifndef FACECAP_STAGES_RIG_TEXTURE_H_
#define FACECAP_STAGES_RIG_TEXTURE_H_

#include <string>

#include "util/image.h"

namespace facecap::stages {

// The rig file's /texture/albedo encoded as 8-bit sRGB (what glTF's base colour holds), or an
// empty image when the file carries no texture. FileIOError for a malformed texture.
Image8 ReadRigTextureSrgb(const std::string& rig_path);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_RIG_TEXTURE_H_
