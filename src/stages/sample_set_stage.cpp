// facecap synth contract: the random samples that no real frame resembles, judged in a first
// deepfake's latent space, removed (paper 000 Sec. 7.1, Fig. 16). The samples' codes E(I_S)
// are compared with the real frames' E(D_A(E(I_R))) (stages/sample_file.h).
#include <algorithm>
#include <cmath>
#include <numeric>

#include "stages/sample_set_stage.h"

#include "io/image_io.h"
#include "nn/augment.h"
#include "render/contact_sheet.h"
#include "io/frames_file.h"
#include "stages/sample_file.h"
#include "stages/stage_paths.h"
#include "synth/sample_set.h"
#include "util/errors.h"
#include "util/log.h"

namespace facecap::stages {
namespace {

// Square image `index` of `dataset` at `size` x `size` (bilinear).
Image8 ReadTile(const io::H5File& f, const std::string& dataset, int64_t index, int size) {
  const io::Shape shape = f.CheckShape(dataset, {-1, -1, -1, 3});
  if (shape[1] != shape[2]) throw FileIOError(f.path() + ": " + dataset + " is not square");
  const int source = static_cast<int>(shape[1]);
  std::vector<uint8_t> pixels(3LL * source * source);
  f.ReadFrames<uint8_t>(dataset, index, 1, pixels.data());
  Image8 tile(size, size, 3);
  std::vector<float> resized(3LL * size * size);
  nn::ResizeToFloat(pixels.data(), source, size, resized.data());
  for (size_t k = 0; k < resized.size(); ++k) {
    tile.data[k] = static_cast<uint8_t>(std::lround(std::clamp(resized[k], 0.f, 1.f) * 255.f));
  }
  return tile;
}

// A 2-pixel frame of `rgb` around a tile.
void FrameTile(Image8* tile, const uint8_t rgb[3]) {
  for (int y = 0; y < tile->height; ++y) {
    for (int x = 0; x < tile->width; ++x) {
      if (x >= 2 && y >= 2 && x < tile->width - 2 && y < tile->height - 2) continue;
      std::copy(rgb, rgb + 3, tile->pixel(x, y));
    }
  }
}

}  // namespace

StageSummary RunSynthContract(const SynthContractOptions& o, const StageContext& ctx,
                              const io::Config& resolved) {
  // Seconds of work for thousands of samples: rank 0 alone.
  if (!ctx.comm.IsMainRank()) return StageSummary{o.out, "samples", 0, 0};
  const io::H5File samples = io::H5File::OpenRead(o.samples);
  const std::string sampling_config = SamplingConfig(samples);
  const io::Shape seg = samples.CheckShape("/samples/segmentation", {-1, -1, -1, 3});
  const int64_t n = seg[0];
  const io::H5File sample_codes_file = io::H5File::OpenRead(o.sample_codes);
  const io::H5File frame_codes_file = io::H5File::OpenRead(o.frame_codes);
  std::vector<int64_t> sample_rows, real_rows;
  const synth::CodeMatrix sample_codes = ReadCodes(sample_codes_file, kSampleCodes, &sample_rows);
  if (static_cast<int64_t>(sample_rows.size()) != n) {
    throw FileIOError(o.sample_codes + ": codes of " + std::to_string(sample_rows.size()) +
                      " images, " + o.samples + " has " + std::to_string(n) +
                      " samples (run deepfake infer on the samples)");
  }
  const synth::CodeMatrix real_codes = ReadCodes(frame_codes_file, kFrameCodes, &real_rows);
  if (real_rows.empty()) throw FileIOError(o.frame_codes + ": no frame with a face");
  if (real_codes.cols() != sample_codes.cols()) {
    throw FileIOError(o.frame_codes + ": codes of " + std::to_string(real_codes.cols()) +
                      " values, " + o.sample_codes + " has codes of " +
                      std::to_string(sample_codes.cols()) + " (two different deepfakes)");
  }

  double bound_threshold = 0;
  if (!o.bound.empty()) {
    const io::H5File bound = io::H5File::OpenRead(o.bound);
    if (!bound.HasAttribute("/contraction", "threshold")) {
      throw FileIOError(o.bound + ": not a synth contract output (no /contraction@threshold)");
    }
    bound_threshold = bound.GetDoubleAttribute("/contraction", "threshold");
  }
  const bool sheet = o.sheet != "none";
  io::H5File frames_file;
  std::string real_dataset = io::frames::kTranslated;
  if (sheet && !o.frames.empty()) {
    frames_file = io::H5File::OpenRead(o.frames);
    real_dataset = frames_file.Exists(io::frames::kCrop) ? io::frames::kCrop : io::frames::kImage;
  }
  const io::H5File& real_images = o.frames.empty() ? frame_codes_file : frames_file;
  if (sheet) {
    const io::Shape shape = real_images.CheckShape(real_dataset, {-1, -1, -1, 3});
    if (shape[0] <= *std::max_element(real_rows.begin(), real_rows.end())) {
      throw FileIOError(real_images.path() + ": " + real_dataset + " has " +
                        std::to_string(shape[0]) + " images, " + o.frame_codes + " codes of " +
                        std::to_string(real_rows.back() + 1) + " frames");
    }
  }

  std::vector<int64_t> nearest;
  const std::vector<double> score =
      synth::MeanNearestDistance(sample_codes, real_codes, o.neighbors, false, &nearest);
  const double threshold = o.bound.empty() ? synth::FractionThreshold(score, o.remove_fraction)
                                           : bound_threshold;
  std::vector<uint8_t> kept(n, 1);
  for (int64_t i : synth::ScoresAbove(score, threshold)) kept[i] = 0;
  std::vector<int64_t> source;
  for (int64_t i = 0; i < n; ++i) {
    if (kept[i]) source.push_back(i);
  }
  if (source.empty()) {
    throw InvalidInputError("synth contract: threshold " + std::to_string(threshold) +
                            " removes every sample of " + o.samples);
  }
  const int64_t m = static_cast<int64_t>(source.size());
  const int size = static_cast<int>(seg[1]);
  const int S = static_cast<int>(samples.CheckShape("/samples/weights", {n, -1})[1]);

  io::H5File f = io::H5File::CreateAtomic(o.out);
  f.WriteProvenance(MakeProvenance(ctx, "synth contract", resolved));
  const std::string framing = samples.HasAttribute("/samples/camera", "framing")
                                  ? samples.GetStringAttribute("/samples/camera", "framing")
                                  : std::string("the source set's");
  CreateSampleDatasets(&f, size, S, m, framing);
  CopySampleRecords(samples, &f);
  f.SetAttribute("/samples", "sampling_config", sampling_config);
  constexpr int64_t kBlock = 256;
  for (int64_t begin = 0; begin < m; begin += kBlock) {
    const int64_t end = std::min(m, begin + kBlock);
    std::vector<int64_t> at(end - begin);
    std::iota(at.begin(), at.end(), begin);
    std::vector<std::vector<uint8_t>> rows;
    for (int64_t j = begin; j < end; ++j) rows.push_back(ReadSampleRow(samples, source[j]));
    WriteSampleRows(&f, at, rows);
  }
  synth::CodeMatrix kept_codes(m, sample_codes.cols());
  for (int64_t j = 0; j < m; ++j) kept_codes.row(j) = sample_codes.row(source[j]);
  f.WriteMatrix("/samples/latent", kept_codes);
  f.SetAttribute("/samples/latent", "meaning",
                 std::string("E(I) of each kept sample, from " + o.sample_codes));
  f.WriteVector("/contraction/source_index", source);
  f.SetAttribute("/contraction/source_index", "meaning",
                 std::string("index of each kept sample in " + o.samples));
  f.WriteVector("/contraction/score", score);
  f.SetAttribute("/contraction/score", "meaning",
                 std::string("every sample's mean code distance to its " +
                             std::to_string(o.neighbors) + " nearest real frames"));
  f.WriteVector("/contraction/kept", kept);
  std::vector<int64_t> nearest_frame(n);
  for (int64_t i = 0; i < n; ++i) nearest_frame[i] = real_rows[nearest[i]];
  f.WriteVector("/contraction/nearest_frame", nearest_frame);
  f.SetAttribute("/contraction/nearest_frame", "meaning",
                 std::string("frame of " + o.frame_codes + " nearest each sample"));
  f.SetAttribute("/contraction", "threshold", threshold);
  f.SetAttribute("/contraction", "neighbors", static_cast<int64_t>(o.neighbors));
  f.SetAttribute("/contraction", "removed", n - m);
  f.Commit();
  FC_INFO("synth contract: {} of {} samples removed (score above {:.4g}: mean code distance to the "
          "{} nearest of {} real frames), {} kept -> {}",
          n - m, n, threshold, o.neighbors, real_rows.size(), m, o.out);

  const StageSummary summary{o.out, "samples", m, m};  // the kept samples, written by every run
  if (!sheet) return summary;
  // The sheet: per row, the i-th most in-distribution sample and its nearest real frame, then
  // the i-th least in-distribution one and its nearest real frame.
  std::vector<int64_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int64_t a, int64_t b) { return score[a] < score[b]; });
  const int rows = static_cast<int>(std::min<int64_t>(o.sheet_rows, (n + 1) / 2));
  const int tile = std::max(64, size);
  const uint8_t green[3] = {40, 200, 60}, red[3] = {220, 40, 40};
  std::vector<Image8> tiles;
  for (int r = 0; r < rows; ++r) {
    for (const int64_t i : {order[r], order[n - 1 - r]}) {
      Image8 sample = ReadTile(samples, "/samples/segmentation", i, tile);
      FrameTile(&sample, kept[i] ? green : red);
      tiles.push_back(std::move(sample));
      tiles.push_back(ReadTile(real_images, real_dataset, nearest_frame[i], tile));
    }
  }
  render::ContactSheetOptions sheet_options;
  sheet_options.columns = 4;
  sheet_options.border = 2;
  const std::string sheet_path = o.sheet.empty() ? WithSuffix(o.out, "_contraction.png") : o.sheet;
  io::WriteImage(sheet_path, render::ContactSheet(tiles, sheet_options));
  FC_INFO("synth contract: sheet -> {} (left: the most in-distribution samples, right: the least; "
          "each beside its nearest real frame; green kept, red removed)",
          sheet_path);
  return summary;
}

}  // namespace facecap::stages
