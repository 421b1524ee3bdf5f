// The layout of a file's camera (synth clip, synth samples, deepfake infer, track):
// /camera/intrinsics, float64 [4]: fx, fy, cx, cy in pixels of the file's images (pixel
// centres at i + 0.5, as render::Camera projects), with attributes `columns` (the names
// above) and, where the writer knows them, `width` and `height` (pixels of the images it
// belongs to), `distance_cm` (the subject's framing distance), `fps` (the clip's rate),
// `fov_deg` and `meaning` (the source camera ingest assumes, in track files of footage).
#ifndef FACECAP_IO_CAMERA_FILE_H_
#define FACECAP_IO_CAMERA_FILE_H_

#include <optional>
#include <string>

#include "io/hdf5.h"
#include "render/camera.h"

namespace facecap::io {

inline constexpr char kCameraPath[] = "/camera/intrinsics";

struct CameraRecord {
  double fx = 0., fy = 0., cx = 0., cy = 0.;
  std::optional<double> width, height;  // pixels
  std::optional<double> distance_cm;
  std::optional<double> fps;

  // The record of a render camera with its image size.
  static CameraRecord Of(const render::Camera& camera);
  // The render camera: the recorded image size, else twice the principal point.
  render::Camera ToCamera() const;
};

bool HasCamera(const io::H5File& f);
// FileIOError naming the file when it has no camera.
CameraRecord ReadCamera(const io::H5File& f);
// The dataset and every attribute the record holds (a new output).
void WriteCamera(io::H5File* f, const CameraRecord& camera);

}  // namespace facecap::io

#endif  // FACECAP_IO_CAMERA_FILE_H_
