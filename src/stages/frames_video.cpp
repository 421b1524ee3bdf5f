#include "stages/frames_video.h"

#include <vector>

#include "io/hdf5.h"
#include "io/frames_file.h"
#include "synth/appearance.h"
#include "util/image.h"
#include "util/log.h"

namespace facecap::stages {

void WriteFramesVideo(const std::string& h5_path, const std::string& video_path, double fps,
                      const std::string& stage) {
  io::H5File f = io::H5File::OpenRead(h5_path);
  const io::Shape shape = f.CheckShape(io::frames::kImage, {-1, -1, -1, 3});
  std::vector<Image8> frames(shape[0], Image8(static_cast<int>(shape[2]), static_cast<int>(shape[1]), 3));
  for (int64_t i = 0; i < shape[0]; ++i) f.ReadFrames<uint8_t>(io::frames::kImage, i, 1, frames[i].data.data());
  const std::string codec = synth::WriteVideo(video_path, frames, fps);
  FC_INFO("{}: {} frames -> {} ({})", stage, frames.size(), video_path, codec);
}

}  // namespace facecap::stages
