// facecap synth crops: a synthetic clip's frames as ingest cropped its video, beside the clip's
// segmentation renders warped by the same crop transforms (nearest neighbour, so that every
// pixel keeps a region colour), with the clip's regions. Two uses: paired examples for the
// deepfake (wild frames of other people with their true segmentation) in the framing of real
// crops, and the true segmentation of a clip's crops, for the oracle solves of the demo.
// Rank 0 alone: a copy and a warp per frame.
#include <algorithm>
#include <cmath>

#include <Eigen/LU>

#include "stages/synth_crops_stage.h"

#include "io/hdf5.h"
#include "io/frames_file.h"
#include "stages/ingested_frames.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/progress.h"

namespace facecap::stages {
namespace {

// The segmentation seen through a crop transform (source -> crop pixels, pixel centres at
// integers), nearest neighbour, black outside the source.
void WarpNearest(const uint8_t* source, int width, int height, const float* transform, int size,
                 uint8_t* out) {
  const Eigen::Map<const Eigen::Matrix<float, 2, 3, Eigen::RowMajor>> m(transform);
  const Eigen::Matrix2f inverse = m.leftCols<2>().inverse();
  const Eigen::Vector2f t = m.col(2);
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      const Eigen::Vector2f p = inverse * (Eigen::Vector2f(static_cast<float>(x), static_cast<float>(y)) - t);
      const int sx = static_cast<int>(std::lround(p.x())), sy = static_cast<int>(std::lround(p.y()));
      uint8_t* o = out + 3 * (static_cast<size_t>(y) * size + x);
      if (sx < 0 || sy < 0 || sx >= width || sy >= height) {
        o[0] = o[1] = o[2] = 0;
        continue;
      }
      const uint8_t* s = source + 3 * (static_cast<size_t>(sy) * width + sx);
      o[0] = s[0];
      o[1] = s[1];
      o[2] = s[2];
    }
  }
}

}  // namespace

StageSummary RunSynthCrops(const SynthCropsOptions& o, const StageContext& ctx,
                           const io::Config& resolved) {
  if (!ctx.comm.IsMainRank()) return StageSummary{o.out, "frames", 0, 0};
  std::string why;
  if (!o.Check(&why)) throw InvalidInputError("synth crops: " + why);
  io::H5File clip = io::H5File::OpenRead(o.clip);
  io::H5File frames = io::H5File::OpenRead(o.frames);
  const io::Shape seg = clip.CheckShape(io::frames::kSegmentation, {-1, -1, -1, 3});
  if (!clip.Exists("/regions/colors") || !clip.Exists("/regions/names")) {
    throw FileIOError(o.clip + ": no /regions (not a synth clip output)");
  }
  const io::Shape crop = frames.CheckShape(io::frames::kCrop, {-1, -1, -1, 3});
  const int64_t n = crop[0];
  const int size = static_cast<int>(crop[1]);
  frames.CheckShape(io::frames::kCropTransform, {n, 2, 3});
  frames.CheckShape(io::frames::kFound, {n});
  frames.CheckShape(io::frames::kSourceIndex, {n});
  const std::vector<int64_t> source = frames.ReadVector<int64_t>(io::frames::kSourceIndex, n);
  const std::vector<uint8_t> found = frames.ReadVector<uint8_t>(io::frames::kFound, n);
  const std::vector<float> transform = frames.Read<float>(io::frames::kCropTransform, {n, 2, 3});
  for (int64_t k = 0; k < n; ++k) {
    if (source[k] < 0 || source[k] >= seg[0]) {
      throw FileIOError(o.frames + ": frame " + std::to_string(k) + " comes from source frame " +
                        std::to_string(source[k]) + ", but " + o.clip + " has " +
                        std::to_string(seg[0]) + " frames: not the ingest of this clip");
    }
  }
  const int W = static_cast<int>(seg[2]), H = static_cast<int>(seg[1]);
  io::H5File f = io::H5File::CreateAtomic(o.out);
  f.WriteProvenance(MakeProvenance(ctx, "synth crops", resolved));
  f.CreateFrames<uint8_t>(io::frames::kImage, {size, size, 3}, n, 8);
  f.SetAttribute(io::frames::kImage, "layout", std::string("frame, y, x, RGB: ingest's crops"));
  f.CreateFrames<uint8_t>(io::frames::kSegmentation, {size, size, 3}, n, 8);
  f.SetAttribute(io::frames::kSegmentation, "layout",
                 std::string("frame, y, x, RGB: the clip's segmentation through each crop "
                             "transform (nearest); region colours of /regions/colors"));
  f.WriteVector(io::frames::kFound, found);
  f.SetAttribute(io::frames::kFound, "meaning", std::string("1: ingest found the face (frames with 0 are not used)"));
  f.Write<float>(io::frames::kCropTransform, {n, 2, 3}, transform.data());
  f.WriteVector(io::frames::kSourceIndex, source);
  const std::vector<std::string> region_names = clip.ReadStrings("/regions/names");
  f.WriteStrings("/regions/names", region_names);
  const auto colors =
      clip.ReadMatrix<float>("/regions/colors", static_cast<int64_t>(region_names.size()), 3);
  f.WriteMatrix("/regions/colors", colors);
  // Blocks of frames: a read and a write per dataset and block.
  constexpr int64_t kBlock = 64;
  const int64_t crop_bytes = 3LL * size * size, frame_bytes = 3LL * W * H;
  std::vector<uint8_t> crops, warped, segmentation;
  Progress progress("synth crops", n);
  for (int64_t first = 0; first < n; first += kBlock) {
    const int64_t count = std::min(kBlock, n - first);
    crops.resize(count * crop_bytes);
    warped.assign(count * crop_bytes, 0);
    frames.ReadFrames<uint8_t>(io::frames::kCrop, first, count, crops.data());
    // The source frames of the block, in one read when they are consecutive.
    const int64_t lo = source[first], hi = source[first + count - 1];
    const bool consecutive = hi - lo == count - 1;
    if (consecutive) {
      segmentation.resize(count * frame_bytes);
      clip.ReadFrames<uint8_t>(io::frames::kSegmentation, lo, count, segmentation.data());
    } else {
      segmentation.resize(frame_bytes);
    }
    for (int64_t j = 0; j < count; ++j) {
      const int64_t k = first + j;
      if (!found[k]) continue;
      const uint8_t* seg = segmentation.data() + (consecutive ? j * frame_bytes : 0);
      if (!consecutive) clip.ReadFrames<uint8_t>(io::frames::kSegmentation, source[k], 1, segmentation.data());
      WarpNearest(seg, W, H, &transform[6 * k], size, warped.data() + j * crop_bytes);
    }
    f.WriteFrames<uint8_t>(io::frames::kImage, first, count, crops.data());
    f.WriteFrames<uint8_t>(io::frames::kSegmentation, first, count, warped.data());
    progress.Update(first + count);
  }
  progress.Finish();
  f.Commit();
  FC_INFO("synth crops: {} frames ({} with a face) -> {}", n,
          std::count(found.begin(), found.end(), uint8_t{1}), o.out);
  return StageSummary{o.out, "frames", n, n};
}

}  // namespace facecap::stages
