// An mp4 of a file's /frames/image, for viewing (a clip, a turntable).
#ifndef FACECAP_STAGES_FRAMES_VIDEO_H_
#define FACECAP_STAGES_FRAMES_VIDEO_H_

#include <string>

namespace facecap::stages {

// Writes /frames/image of `h5_path` (sRGB [frames, H, W, 3]) to `video_path` at `fps` with
// synth::WriteVideo's codec, and logs it under `stage`.
void WriteFramesVideo(const std::string& h5_path, const std::string& video_path, double fps,
                      const std::string& stage);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_FRAMES_VIDEO_H_
