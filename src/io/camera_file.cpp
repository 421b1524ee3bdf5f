#include "io/camera_file.h"

#include <cmath>
#include <vector>

#include "util/errors.h"

namespace facecap::io {

CameraRecord CameraRecord::Of(const render::Camera& camera) {
  CameraRecord r;
  r.fx = camera.fx;
  r.fy = camera.fy;
  r.cx = camera.cx;
  r.cy = camera.cy;
  r.width = camera.width;
  r.height = camera.height;
  return r;
}

render::Camera CameraRecord::ToCamera() const {
  render::Camera camera;
  camera.fx = static_cast<float>(fx);
  camera.fy = static_cast<float>(fy);
  camera.cx = static_cast<float>(cx);
  camera.cy = static_cast<float>(cy);
  camera.width = width ? static_cast<int>(*width) : static_cast<int>(std::lround(2. * cx));
  camera.height = height ? static_cast<int>(*height) : static_cast<int>(std::lround(2. * cy));
  return camera;
}

bool HasCamera(const io::H5File& f) { return f.Exists(kCameraPath); }

CameraRecord ReadCamera(const io::H5File& f) {
  if (!HasCamera(f)) throw FileIOError(f.path() + ": no " + std::string(kCameraPath));
  const std::vector<double> k = f.ReadVector<double>(kCameraPath, 4);
  CameraRecord r;
  r.fx = k[0];
  r.fy = k[1];
  r.cx = k[2];
  r.cy = k[3];
  const auto attribute = [&f](const char* name) -> std::optional<double> {
    if (!f.HasAttribute(kCameraPath, name)) return std::nullopt;
    return f.GetDoubleAttribute(kCameraPath, name);
  };
  r.width = attribute("width");
  r.height = attribute("height");
  r.distance_cm = attribute("distance_cm");
  r.fps = attribute("fps");
  return r;
}

void WriteCamera(io::H5File* f, const CameraRecord& c) {
  f->WriteVector<double>(kCameraPath, {c.fx, c.fy, c.cx, c.cy});
  f->SetAttribute(kCameraPath, "columns", std::string("fx, fy, cx, cy (pixels)"));
  const auto attribute = [f](const char* name, const std::optional<double>& value) {
    if (value) f->SetAttribute(kCameraPath, name, *value);
  };
  attribute("width", c.width);
  attribute("height", c.height);
  attribute("distance_cm", c.distance_cm);
  attribute("fps", c.fps);
}

}  // namespace facecap::io
