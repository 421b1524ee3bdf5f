// Rasterizer throughput on one core: segmentation renders per second at 128 x 128 (the
// target is >= 500), plus the other G-buffer outputs for reference.
//
//   facecap_bench_render [--size N] [--subdivisions S] [--seconds T] [--rig rig.h5]
//
// Without --rig the mesh is an icosphere rig (S = 5: 10,242 vertices, 20,480 triangles, the
// size of a head mesh); with --rig the rig's neutral mesh is rendered. Posing happens
// before the clock starts: the figures are for projection, rasterization and the output
// pass, which is what a synthetic-sample or inverse-rendering loop pays per image.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "io/rig_io.h"
#include "render/camera.h"
#include "render/gbuffer_images.h"
#include "render/primitives.h"
#include "render/rasterizer.h"
#include "render/shading.h"
#include "rig/rig.h"

namespace facecap::render {
namespace {

using Clock = std::chrono::steady_clock;

struct BenchmarkOptions {
  int image_size = 128;        // square image side in pixels
  double min_seconds = 2.0;    // time spent on each measured output
  int num_poses = 16;          // distinct head poses cycled through
  float fov_y_deg = 25.f;      // vertical field of view of the camera
};

// Rigid poses of the rig's neutral mesh in camera space: yaw in [-35, 35] degrees, pitch
// in [-15, 15] degrees, the bounding sphere filling about 90% of the image height.
std::vector<rig::Vertices> PosedMeshes(const rig::Rig& rig, const BenchmarkOptions& options) {
  const Eigen::RowVector3f centre = rig.neutral.colwise().mean();
  const rig::Vertices centred = rig.neutral.rowwise() - centre;
  const float bounding_radius = centred.rowwise().norm().maxCoeff();
  const float half_fov = 0.5f * options.fov_y_deg * static_cast<float>(M_PI) / 180.f;
  const float distance = bounding_radius / std::sin(0.9f * half_fov);
  std::vector<rig::Vertices> posed;
  for (int i = 0; i < options.num_poses; ++i) {
    const float phase = options.num_poses > 1 ? static_cast<float>(i) / (options.num_poses - 1)
                                               : 0.5f;
    const float yaw = (-35.f + 70.f * phase) * static_cast<float>(M_PI) / 180.f;
    const float pitch = 15.f * std::sin(6.f * phase) * static_cast<float>(M_PI) / 180.f;
    const Eigen::Matrix3f rotation = (Eigen::AngleAxisf(yaw, Eigen::Vector3f::UnitY()) *
                                      Eigen::AngleAxisf(pitch, Eigen::Vector3f::UnitX()))
                                         .toRotationMatrix();
    rig::Vertices vertices = centred * rotation.transpose();
    vertices.col(2).array() -= distance;
    posed.push_back(std::move(vertices));
  }
  return posed;
}

// Runs render(pose_index) repeatedly for at least min_seconds; returns renders per second.
template <typename RenderFn>
double MeasureRendersPerSecond(int num_poses, double min_seconds, RenderFn&& render) {
  for (int i = 0; i < num_poses; ++i) render(i);  // warm-up: buffers allocated here
  int renders = 0;
  const Clock::time_point start = Clock::now();
  double elapsed = 0.0;
  while (elapsed < min_seconds) {
    for (int i = 0; i < num_poses; ++i, ++renders) render(i);
    elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  }
  return renders / elapsed;
}

// Benchmarks the render outputs of a rig's neutral mesh and prints one line per figure.
// Returns the segmentation renders per second.
double BenchmarkRig(const rig::Rig& rig, const std::string& mesh_name,
                    const BenchmarkOptions& options) {
  const Camera camera =
      Camera::FromFov(options.image_size, options.image_size, options.fov_y_deg);
  const std::vector<rig::Vertices> posed = PosedMeshes(rig, options);
  GBuffer gbuffer;
  Image8 segmentation;
  ImageF uv_image, shaded;
  rig::Vertices normals;
  const Eigen::Vector3f background(0.f, 0.f, 0.f);
  long long covered_pixels = 0;
  for (const rig::Vertices& vertices : posed) {
    Rasterize(vertices, rig.triangles, camera, &gbuffer);
    covered_pixels += gbuffer.NumCovered();
  }

  const double rasterize_only = MeasureRendersPerSecond(
      options.num_poses, options.min_seconds,
      [&](int i) { Rasterize(posed[i], rig.triangles, camera, &gbuffer); });
  const double segmentation_rate =
      MeasureRendersPerSecond(options.num_poses, options.min_seconds, [&](int i) {
        Rasterize(posed[i], rig.triangles, camera, &gbuffer);
        RenderSegmentation(gbuffer, rig.triangle_region, rig.regions, background,
                           &segmentation);
      });
  const double uv_rate =
      MeasureRendersPerSecond(options.num_poses, options.min_seconds, [&](int i) {
        Rasterize(posed[i], rig.triangles, camera, &gbuffer);
        RenderUVImage(gbuffer, rig.uvs, rig.uv_triangles, &uv_image);
      });
  const Lighting lighting;
  ShadingOptions shading;
  shading.albedo_source = AlbedoSource::kPerRegion;
  const double shaded_rate =
      MeasureRendersPerSecond(options.num_poses, options.min_seconds, [&](int i) {
        Rasterize(posed[i], rig.triangles, camera, &gbuffer);
        VertexNormals(posed[i], rig.triangles, &normals);
        RenderShaded(gbuffer, posed[i], normals, rig, lighting, shading, nullptr, nullptr,
                     &shaded);
      });

  constexpr double kTargetRendersPerSecond = 500.0;  // target, per core
  std::printf("mesh: %s, %d vertices, %d triangles\n", mesh_name.c_str(),
              rig.NumVertices(), static_cast<int>(rig.triangles.rows()));
  std::printf("image: %dx%d, mean covered pixels %.0f\n", options.image_size,
              options.image_size, static_cast<double>(covered_pixels) / posed.size());
  std::printf("rasterize_only_per_second: %.0f (%.3f ms)\n", rasterize_only,
              1e3 / rasterize_only);
  std::printf("segmentation_renders_per_second: %.0f (%.3f ms per render)\n",
              segmentation_rate, 1e3 / segmentation_rate);
  std::printf("segmentation_ratio_to_target_500: %.2f\n",
              segmentation_rate / kTargetRendersPerSecond);
  std::printf("uv_image_renders_per_second: %.0f\n", uv_rate);
  std::printf("shaded_renders_per_second (normals included): %.0f\n", shaded_rate);
  return segmentation_rate;
}

int Main(int argc, char** argv) {
  BenchmarkOptions options;
  int subdivisions = 5;
  std::string rig_path;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const bool has_value = i + 1 < argc;
    if (arg == "--size" && has_value) {
      options.image_size = std::atoi(argv[++i]);
    } else if (arg == "--subdivisions" && has_value) {
      subdivisions = std::atoi(argv[++i]);
    } else if (arg == "--seconds" && has_value) {
      options.min_seconds = std::atof(argv[++i]);
    } else if (arg == "--rig" && has_value) {
      rig_path = argv[++i];
    } else {
      std::fprintf(stderr,
                   "usage: %s [--size N] [--subdivisions S] [--seconds T] [--rig rig.h5]\n",
                   argv[0]);
      return 2;
    }
  }
  if (options.image_size < 1 || subdivisions < 0 || subdivisions > 7 ||
      !(options.min_seconds > 0.0)) {
    std::fprintf(stderr, "bad option value\n");
    return 2;
  }
  if (!rig_path.empty()) {
    BenchmarkRig(io::ReadRigFile(rig_path), rig_path, options);
  } else {
    BenchmarkRig(IcosphereRig(subdivisions, 10.f, 12),
                 "icosphere (subdivisions " + std::to_string(subdivisions) + ")", options);
  }
  return 0;
}

}  // namespace
}  // namespace facecap::render

int main(int argc, char** argv) {
  try {
    return facecap::render::Main(argc, argv);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "error: %s\n", error.what());
    return 1;
  }
}
