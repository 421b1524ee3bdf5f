// facecap appearance: the person's texture from images of their head (paper 000 Sec. 5).
//   turntable  renders of a rig over a pitch x yaw grid (Sec. 5.2), framed as ingest crops
//              footage, each with its U(I) image, triangle ids and depth; spread across ranks,
//              identical for any rank count, resumable
//   gather     the colours of images of those views (the turntable's own renders, or their
//              translations by a deepfake) gathered into a texture (Sec. 5.4)
#include "stages/appearance_stage.h"

#include <algorithm>
#include <cmath>
#include <memory>

#include "appearance/photon_gather.h"
#include "face/align.h"
#include "io/hdf5.h"
#include "io/image_io.h"
#include "io/rig_io.h"
#include "io/texture_file.h"
#include "render/camera.h"
#include "render/contact_sheet.h"
#include "render/framing.h"
#include "render/gbuffer_images.h"
#include "render/rasterizer.h"
#include "render/shading.h"
#include "render/texel_map.h"
#include "render/turntable.h"
#include "rig/evaluate.h"
#include "stages/crop_framing.h"
#include "stages/frame_loop.h"
#include "io/frames_file.h"
#include "stages/frames_video.h"
#include "stages/holdout.h"
#include "stages/ingested_frames.h"
#include "stages/resumable.h"
#include "stages/tracked_rig.h"
#include "util/bytes.h"
#include "util/errors.h"
#include "util/log.h"

namespace facecap::stages {
namespace {

constexpr double kDegree = 3.14159265358979323846 / 180.;

// The per-view datasets of a turntable file.
void CreateViewDatasets(io::H5File* f, int size, int64_t views) {
  f->CreateFrames<uint8_t>(io::frames::kImage, {size, size, 3}, views, 16, 1);
  f->SetAttribute(io::frames::kImage, "layout", std::string("view, y, x, RGB (sRGB)"));
  f->CreateFrames<float>(io::frames::kUv, {size, size, 3}, views, 4);
  f->SetAttribute(io::frames::kUv, "layout",
                  std::string("view, y, x, (u, v, coverage): U(I), the texture coordinates of "
                              "the visible surface (OBJ convention), coverage 1 on the head"));
  f->CreateFrames<int32_t>(io::frames::kTriangle, {size, size}, views, 4);
  f->SetAttribute(io::frames::kTriangle, "layout", std::string("view, y, x: visible triangle, -1 none"));
  f->CreateFrames<float>(io::frames::kDepth, {size, size}, views, 4);
  f->SetAttribute(io::frames::kDepth, "units", std::string("cm from the camera; 0 where no head"));
  f->CreateFrames<float>(io::frames::kPose, {3}, views, 1024);
  f->SetAttribute(io::frames::kPose, "columns", std::string("pitch, yaw, roll (rad), in the view's camera"));
  f->CreateFrames<float>(io::frames::kCamera, {4}, views, 1024);
  f->SetAttribute(io::frames::kCamera, "columns", std::string("fx, fy, cx, cy (pixels) of the view"));
}

// Per-thread rendering state.
struct ViewRenderer {
  render::GBuffer gbuffer;
  rig::Vertices posed, normals;
  ImageF shaded, uv, depth;
  render::ImageI triangles;
  Image8 image;
};

// Where the views come from: the camera of each and the rig's pose and weights in it, and its
// image (rendered, or read from footage on rank 0).
class ViewSource {
 public:
  virtual ~ViewSource() = default;
  virtual int64_t NumViews() const = 0;
  virtual int Size() const = 0;
  // View `view`: its camera, and the rig's pose in it and weights; false when the view shows no
  // head (a frame without a tracked face). `posed` is scratch.
  virtual bool Setup(int64_t view, rig::Vertices* posed, render::Camera* camera,
                     rig::RigidPose* pose, Eigen::VectorXf* weights) const = 0;
  // True: the view's image is the rig's shaded render (ShadedImage); false: rank 0 reads it
  // (ReadImage) when it writes the view.
  virtual bool Rendered() const = 0;
  virtual void ReadImage(int64_t /*view*/, Image8* /*image*/) const {}
};

// Renders every view of a source (U(I), triangle ids, depth, and the shaded image when the
// source renders it) across ranks into a resumable output with the datasets of
// CreateViewDatasets and the rig under /rig, then a contact sheet.
class ViewsRun {
 public:
  struct Settings {
    std::string stage, out;
    ViewRunOptions run;
    bool video = false;  // an mp4 of the views beside out
  };
  ViewsRun(const Settings& settings, const StageContext& ctx, const io::Config& resolved,
           const rig::Rig& rig, const ViewSource& source, const render::Lighting& lighting,
           const render::ShadingOptions& shading, const ImageF* texture)
      : s_(settings), ctx_(ctx), resolved_(resolved), comm_(ctx.comm), rig_(rig),
        source_(source), lighting_(lighting), shading_(shading), texture_(texture),
        evaluator_(rig) {}

  StageSummary Run() {
    const int64_t n = source_.NumViews();
    FrameOutput opened = OpenFrameOutput(
        ctx_, resolved_, s_.stage, s_.out, n,
        [&](io::H5File* f, bool resumed) {
          CreateViewDatasets(f, source_.Size(), n);
          if (!resumed) io::WriteRig(rig_, f, "/rig");
        },
        "views");
    output_ = std::move(opened.output);
    StageSummary summary{s_.out, "views", n, 0};
    if (!opened.up_to_date) {
      const int threads = ThreadsPerRank(s_.run.threads);
      renderers_ = std::vector<ViewRenderer>(threads);
      FrameLoopOptions loop;
      loop.what = s_.stage;
      loop.batch = s_.run.batch;
      loop.threads = threads;
      summary.computed = RunFrameLoopAndCommit(
          comm_, opened.pending, n, loop,
          [&](int64_t view, int thread) { return RenderView(view, thread); },
          [&](const std::vector<int64_t>& views, const std::vector<std::vector<uint8_t>>& results) {
            CommitViews(views, results);
          },
          &output_);
    }
    if (comm_.IsMainRank()) {
      if (s_.run.sheet != "none") WriteSheet();
      if (s_.video) WriteFramesVideo(s_.out, WithSuffix(s_.out, ".mp4"), 25., s_.stage);
      FC_INFO("{}: {} views -> {}", s_.stage, n, s_.out);
    }
    return summary;
  }

 private:
  std::vector<uint8_t> RenderView(int64_t view, int thread) {
    ViewRenderer& r = renderers_[thread];
    render::Camera camera;
    rig::RigidPose pose;
    Eigen::VectorXf weights;
    const int size = source_.Size();
    if (source_.Setup(view, &r.posed, &camera, &pose, &weights)) {
      evaluator_.EvaluatePosed(pose, weights, &r.posed);
      render::Rasterize(r.posed, rig_.triangles, camera, &r.gbuffer);
      render::RenderUVImage(r.gbuffer, rig_.uvs, rig_.uv_triangles, &r.uv);
      render::RenderTriangleIdImage(r.gbuffer, &r.triangles);
      render::RenderDepthImage(r.gbuffer, 0.f, &r.depth);
      if (source_.Rendered()) {
        render::VertexNormals(r.posed, rig_.triangles, &r.normals);
        render::RenderShaded(r.gbuffer, r.posed, r.normals, rig_, lighting_, shading_, texture_,
                             nullptr, &r.shaded);
        render::LinearToImage8(r.shaded, true, &r.image);
      }
    } else {
      r.uv = ImageF(size, size, 3);
      r.depth = ImageF(size, size, 1);
      r.triangles = render::ImageI(size, size, 1, -1);
      camera = render::Camera();
    }
    ByteWriter w;
    w.PutVector(source_.Rendered() ? r.image.data : std::vector<uint8_t>());
    w.PutVector(r.uv.data);
    w.PutVector(r.triangles.data);
    w.PutVector(r.depth.data);
    const float angles[3] = {pose.pitch, pose.yaw, pose.roll};
    w.PutArray(angles, 3);
    const float intrinsics[4] = {camera.fx, camera.fy, camera.cx, camera.cy};
    w.PutArray(intrinsics, 4);
    return std::move(w.bytes());
  }

  // Rank 0: one view at a time (a view is about 0.3 MB), then marks them done.
  void CommitViews(const std::vector<int64_t>& views, const std::vector<std::vector<uint8_t>>& results) {
    io::H5File& f = output_.file;
    Image8 image(source_.Size(), source_.Size(), 3);
    for (size_t k = 0; k < views.size(); ++k) {
      ByteReader r(results[k]);
      std::vector<uint8_t> rendered = r.GetVector<uint8_t>();
      if (!source_.Rendered()) {
        source_.ReadImage(views[k], &image);
        rendered = image.data;
      }
      f.WriteFrames<uint8_t>(io::frames::kImage, views[k], 1, rendered.data());
      f.WriteFrames<float>(io::frames::kUv, views[k], 1, r.GetVector<float>().data());
      f.WriteFrames<int32_t>(io::frames::kTriangle, views[k], 1, r.GetVector<int32_t>().data());
      f.WriteFrames<float>(io::frames::kDepth, views[k], 1, r.GetVector<float>().data());
      f.WriteFrames<float>(io::frames::kPose, views[k], 1, r.GetVector<float>().data());
      f.WriteFrames<float>(io::frames::kCamera, views[k], 1, r.GetVector<float>().data());
    }
    io::DoneMask mask(&f, source_.NumViews());
    mask.MarkDone(views);
  }

  // Rank 0: sheet_count views spread evenly, read back from the output.
  void WriteSheet() const {
    io::H5File f = io::H5File::OpenRead(s_.out);
    const int64_t n = source_.NumViews();
    const int64_t count = std::min<int64_t>(s_.run.sheet_count, n);
    std::vector<Image8> tiles;
    for (int64_t k = 0; k < count; ++k) {
      const int64_t view = count == 1 ? 0 : k * (n - 1) / (count - 1);
      Image8 tile(source_.Size(), source_.Size(), 3);
      f.ReadFrames<uint8_t>(io::frames::kImage, view, 1, tile.data.data());
      tiles.push_back(std::move(tile));
    }
    render::ContactSheetOptions sheet;
    sheet.columns = static_cast<int>(std::min<int64_t>(count, 10));
    io::WriteImage(s_.run.SheetPath(s_.out), render::ContactSheet(tiles, sheet));
  }

  const Settings s_;
  const StageContext& ctx_;
  const io::Config& resolved_;
  const dist::Comm& comm_;
  const rig::Rig& rig_;
  const ViewSource& source_;
  const render::Lighting lighting_;
  const render::ShadingOptions shading_;
  const ImageF* texture_;
  const rig::RigEvaluator evaluator_;
  ResumableOutput output_;  // rank 0
  std::vector<ViewRenderer> renderers_;
};

// The turntable's views: the rig at neutral over the pitch x yaw grid, framed as ingest crops.
class TurntableSource : public ViewSource {
 public:
  TurntableSource(const AppearanceTurntableOptions& o, const rig::Rig& rig)
      : o_(o), rig_(rig), evaluator_(rig),
        camera_(render::Camera::FromFov(o.size, o.size, static_cast<float>(o.fov_deg))),
        distance_(render::FramingDistance(rig, camera_, static_cast<float>(o.fill))),
        angles_(render::TurntableAngles(o.views, static_cast<float>(o.pitch_min_deg * kDegree),
                                        static_cast<float>(o.pitch_max_deg * kDegree),
                                        static_cast<float>(o.yaw_min_deg * kDegree),
                                        static_cast<float>(o.yaw_max_deg * kDegree))),
        crop_template_(face::CropTemplate({o.size, o.crop_padding, o.crop_raise})) {}
  int64_t NumViews() const override { return o_.views; }
  int Size() const override { return o_.size; }
  bool Rendered() const override { return true; }
  bool Setup(int64_t view, rig::Vertices* posed, render::Camera* camera, rig::RigidPose* pose,
             Eigen::VectorXf* weights) const override {
    const auto [pitch, yaw] = angles_[view];
    *pose = render::FramedPose(rig_, distance_, pitch, yaw);
    *weights = Eigen::VectorXf::Zero(rig_.NumShapes());
    *camera = IngestCropCamera(rig_, evaluator_, camera_, crop_template_, o_.size, *weights,
                               pose, posed);
    return true;
  }

 private:
  const AppearanceTurntableOptions& o_;
  const rig::Rig& rig_;
  const rig::RigEvaluator evaluator_;
  const render::Camera camera_;
  const float distance_;
  const std::vector<std::pair<float, float>> angles_;
  const Eigen::Matrix<double, 68, 2, Eigen::RowMajor> crop_template_;
};

// Reads the rig of a view-making stage on every rank; FileIOError unless it has the 68
// landmarks and texture coordinates.
rig::Rig ReadViewRig(const dist::Comm& comm, const std::string& path) {
  rig::Rig rig;
  dist::CoordinateExceptions(comm, [&] {
    rig = io::ReadRigFile(path);
    if (rig.landmarks.size() != 68) {
      throw FileIOError(path + ": the rig has " + std::to_string(rig.landmarks.size()) +
                        " landmarks; views are framed by the 68 iBUG landmarks");
    }
    if (rig.uvs.rows() == 0) throw FileIOError(path + ": the rig has no texture coordinates");
  });
  return rig;
}

}  // namespace

StageSummary RunAppearanceTurntable(const AppearanceTurntableOptions& o, const StageContext& ctx,
                                    const io::Config& resolved) {
  const rig::Rig rig = ReadViewRig(ctx.comm, o.rig);
  ImageF texture;
  dist::CoordinateExceptions(ctx.comm, [&] {
    if (!o.texture.empty()) texture = io::ReadColorTexture(o.texture, o.texture_dataset);
  });
  render::Lighting lighting;
  render::ShadingOptions shading;
  shading.albedo_source = texture.empty() ? render::AlbedoSource::kConstant : render::AlbedoSource::kTexture;
  if (o.lighting == "none") {
    lighting.ambient = Eigen::Vector3f::Ones();
    lighting.directional_lights.clear();
    shading.specular_strength = 0.f;
  }
  const TurntableSource source(o, rig);
  const ViewsRun::Settings settings{"appearance turntable", o.out, o.run, o.video};
  return ViewsRun(settings, ctx, resolved, rig, source, lighting, shading,
                  texture.empty() ? nullptr : &texture).Run();
}

namespace {

// Tracked footage as views: each frame's image with the tracked rig in its camera (the crop's,
// for a track of ingested crops). Frames without a tracked face show no head.
class TrackedFramesSource : public ViewSource {
 public:
  TrackedFramesSource(const AppearanceFramesOptions& o, const rig::Rig& rig)
      : track_(o.track, rig), path_(o.frames) {
    io::H5File f = io::H5File::OpenRead(o.frames);
    dataset_ = o.dataset;
    if (dataset_.empty()) dataset_ = f.Exists(io::frames::kCrop) ? io::frames::kCrop : io::frames::kImage;
    const io::Shape shape = f.CheckShape(dataset_, {-1, -1, -1, 3});
    if (shape[1] != shape[2]) throw FileIOError(o.frames + ": " + dataset_ + " is not square");
    if (shape[0] != track_.NumFrames()) {
      throw FileIOError(o.frames + ": " + dataset_ + " has " + std::to_string(shape[0]) +
                        " frames, " + o.track + " tracks " + std::to_string(track_.NumFrames()));
    }
    size_ = static_cast<int>(shape[1]);
    if (track_.InSourceCamera()) {
      ingested_ = std::make_unique<IngestedFrames>(IngestedFrames::Read(o.frames));
    }
  }
  int64_t NumViews() const override { return track_.NumFrames(); }
  int Size() const override { return size_; }
  bool Rendered() const override { return false; }
  bool Setup(int64_t view, rig::Vertices* /*posed*/, render::Camera* camera,
             rig::RigidPose* pose, Eigen::VectorXf* weights) const override {
    if (!track_.Solved(view) || (ingested_ && !ingested_->Found(view))) return false;
    *pose = track_.Pose(view);
    *weights = track_.Weights(view);
    if (ingested_) {
      const render::CropView crop = ingested_->CropCamera(view, size_);
      *pose = PoseInCrop(*pose, crop);
      *camera = crop.camera;
    } else {
      *camera = track_.CameraForWidth(size_, size_);
    }
    return true;
  }
  void ReadImage(int64_t view, Image8* image) const override {
    if (!file_.is_open()) file_ = io::H5File::OpenRead(path_);
    file_.ReadFrames<uint8_t>(dataset_, view, 1, image->data.data());
  }

 private:
  TrackedRig track_;
  std::string path_, dataset_;
  int size_ = 0;
  std::unique_ptr<IngestedFrames> ingested_;
  mutable io::H5File file_;  // rank 0, opened at the first read
};

}  // namespace

StageSummary RunAppearanceFrames(const AppearanceFramesOptions& o, const StageContext& ctx,
                                 const io::Config& resolved) {
  const rig::Rig rig = ReadViewRig(ctx.comm, o.rig);
  std::unique_ptr<TrackedFramesSource> source;
  dist::CoordinateExceptions(ctx.comm, [&] { source = std::make_unique<TrackedFramesSource>(o, rig); });
  const ViewsRun::Settings settings{"appearance frames", o.out, o.run};
  return ViewsRun(settings, ctx, resolved, rig, *source, render::Lighting(),
                  render::ShadingOptions(), nullptr).Run();
}

namespace {

// The particles of every view: its image's pixels at their U(I) positions.
std::vector<appearance::Particle> ReadParticles(const AppearanceGatherOptions& o,
                                                const std::vector<int32_t>& charts) {
  io::H5File views = io::H5File::OpenRead(o.views);
  const io::Shape uv_shape = views.CheckShape(io::frames::kUv, {-1, -1, -1, 3});
  const int64_t count = uv_shape[0];
  const int size = static_cast<int>(uv_shape[1]);
  views.CheckShape(io::frames::kTriangle, {count, size, size});
  const std::string images_path = o.images.empty() ? o.views : o.images;
  io::H5File images = o.images.empty() ? io::H5File::OpenRead(o.views) : io::H5File::OpenRead(o.images);
  std::string dataset = o.dataset;
  if (dataset.empty()) dataset = images.Exists(io::frames::kTranslated) ? io::frames::kTranslated : io::frames::kImage;
  const io::Shape image_shape = images.CheckShape(dataset, {-1, -1, -1, 3});
  if (image_shape[0] != count) {
    throw FileIOError(images_path + ": " + dataset + " has " + std::to_string(image_shape[0]) +
                      " images, " + o.views + " has " + std::to_string(count) + " views");
  }
  Image8 image(static_cast<int>(image_shape[2]), static_cast<int>(image_shape[1]), 3);
  ImageF linear, uv(size, size, 3), interior;
  Image<int32_t> triangles(size, size, 1);
  std::vector<appearance::Particle> particles;
  for (int64_t v = 0; v < count; ++v) {
    if (IsHeldOut(v, o.holdout_every)) continue;
    images.ReadFrames<uint8_t>(dataset, v, 1, image.data.data());
    views.ReadFrames<float>(io::frames::kUv, v, 1, uv.data.data());
    views.ReadFrames<int32_t>(io::frames::kTriangle, v, 1, triangles.data.data());
    render::Image8ToLinear(image, true, &linear);
    appearance::SilhouetteInterior(uv, o.edge_margin_px, &interior);
    appearance::AppendImageParticles(render::ResampleBilinear(linear, size, size), uv, triangles, charts, &interior,
                                     &particles);
  }
  return particles;
}

}  // namespace

StageSummary RunAppearanceGather(const AppearanceGatherOptions& o, const StageContext& ctx,
                                 const io::Config& resolved) {
  StageSummary summary{o.out, "files", 0, 0};
  // One process gathers: the particles of a few hundred views fit one node, and the result is
  // the same for any rank count.
  if (!ctx.comm.IsMainRank()) return summary;
  const rig::Rig rig = io::ReadRigFile(o.views);
  const std::vector<int32_t> charts = appearance::UVCharts(rig);
  const std::vector<appearance::Particle> particles = ReadParticles(o, charts);
  const render::TexelMap texels = render::BakeTexelMap(rig, o.texture_size);
  appearance::GatheredTexture gathered =
      appearance::GatherParticles(particles, texels, charts, o.gather);
  appearance::FillHoles(gathered.confidence, &gathered.color);
  int64_t covered = 0, layout = 0;
  for (size_t i = 0; i < texels.triangle.size(); ++i) {
    layout += texels.Covered(i);
    covered += gathered.confidence.data[i] > 0.f;
  }
  io::H5File f = io::H5File::CreateAtomic(o.out);
  f.WriteProvenance(MakeProvenance(ctx, "appearance gather", resolved));
  io::WriteRig(rig, &f);
  io::WriteColorTexture(&f, io::kTextureAlbedoPath, gathered.color);
  const int64_t N = o.texture_size;
  f.Write<float>(io::kTextureConfidencePath, {N, N}, gathered.confidence.data.data());
  f.SetAttribute(io::kTextureConfidencePath, "meaning",
                 std::string("min(1, r_1 / r): r the radius holding the k gathered particles, r_1 "
                             "that at one particle per texel; 0 where nothing was gathered"));
  f.Write<int32_t>(io::kTextureParticlesPath, {N, N}, gathered.count.data.data());
  f.SetAttribute(io::kTextureParticlesPath, "meaning",
                 std::string("particles whose nearest texel centre is this texel"));
  f.SetAttribute("/texture", "particles", static_cast<int64_t>(particles.size()));
  f.SetAttribute("/texture", "coverage", static_cast<double>(covered) / std::max<int64_t>(layout, 1));
  f.Commit();
  if (o.exr != "none") io::WriteImage(o.ExrPath(), gathered.color);
  if (o.png != "none") {
    Image8 png;
    render::LinearToImage8(gathered.color, true, &png);
    io::WriteImage(o.PngPath(), png);
  }
  FC_INFO("appearance gather: {} particles, {:.1f}% of the UV layout covered -> {}",
          particles.size(), 100. * covered / std::max<int64_t>(layout, 1), o.out);
  summary.items = 1;
  summary.computed = 1;
  return summary;
}

}  // namespace facecap::stages
