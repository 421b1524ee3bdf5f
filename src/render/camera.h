// Pinhole camera at the origin looking down -z, +y up in camera space, image y down.
//   u = cx + fx * x / (-z),  v = cy - fy * y / (-z),  depth = -z
#ifndef FACECAP_RENDER_CAMERA_H_
#define FACECAP_RENDER_CAMERA_H_

#include <Eigen/Core>

namespace facecap::render {

struct Camera {
  int width = 128;
  int height = 128;
  float fx = 0.f, fy = 0.f;  // focal lengths in pixels
  float cx = 0.f, cy = 0.f;  // principal point in pixels (pixel centres at i + 0.5)

  // A camera whose vertical field of view is fov_y_deg, principal point at the centre.
  static Camera FromFov(int width, int height, float fov_y_deg);
  // (u, v, depth) of a camera-space point; depth > 0 in front of the camera.
  Eigen::Vector3f Project(const Eigen::Vector3f& p) const;
  // Camera-space direction of the ray through image point (u, v), scaled to depth 1
  // (its z is -1), so that the point at depth d on that ray is d * RayDirection(u, v).
  Eigen::Vector3f RayDirection(float u, float v) const;
};

// The view of a similarity-aligned crop of an image taken with a pinhole camera. A crop
// q = s R(theta) p + t of the source image (pixel centres at integer coordinates, the OpenCV
// and dlib convention of ingest's /frames/crop_transform) is itself a pinhole image: that of
// a camera with focal length s f and a moved principal point, turned about its optical axis.
// A point X in source camera space is at Rz(roll) X in the crop camera's space, so a head
// pose solved in the crop has the source pose's pitch and yaw and its roll plus `roll`.
struct CropView {
  Camera camera;      // the crop camera, scaled to the image size asked for
  float roll = 0.f;   // rad, the turn of the crop camera about the optical axis (-theta)
};

// `crop_transform` is the 2 x 3 matrix [s R | t] from source to crop pixels of a crop
// crop_size pixels wide; the returned camera is for an image of out_size x out_size pixels
// showing the same crop. `source` must have square pixels (fx == fy).
CropView CameraOfCrop(const Camera& source, const Eigen::Matrix<float, 2, 3>& crop_transform,
                      int crop_size, int out_size);

}  // namespace facecap::render

#endif  // FACECAP_RENDER_CAMERA_H_
