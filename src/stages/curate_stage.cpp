// facecap curate build | query: the hierarchical clustering of paper 000 Sec. 3 over the
// frames of an ingest output, and queries against it (by frame, by image, by a folder of
// synthetic renders: the turntable matching of Sec. 5.2, or by every face of another ingest
// output), with a contact sheet of each query beside its picks.
#include <chrono>
#include <filesystem>
#include <fstream>
#include <unordered_set>

#include "stages/curate_stage.h"

#include "curate/cluster_tree.h"
#include "curate/features.h"
#include "curate/frame_query.h"
#include "face/align.h"
#include "face/face_analyzer.h"
#include "face/frame_source.h"
#include "io/hdf5.h"
#include "io/image_io.h"
#include "render/contact_sheet.h"
#include "io/frames_file.h"
#include "util/errors.h"
#include "util/log.h"

namespace facecap::stages {
namespace {

using curate::FeatureKind;
using curate::FeatureMatrix;

// Found frames of an ingest output: their rows, crops and crop landmarks, read in blocks.
struct FoundFrames {
  std::vector<int64_t> rows;
  std::vector<Image8> crops;
  std::vector<face::Landmarks> landmarks;
};

std::vector<int64_t> FoundRows(const io::H5File& f) {
  const std::vector<uint8_t> found = f.ReadVector<uint8_t>(io::frames::kFound, f.NumFrames(io::frames::kCrop));
  std::vector<int64_t> rows;
  for (int64_t i = 0; i < static_cast<int64_t>(found.size()); ++i) if (found[i]) rows.push_back(i);
  return rows;
}

void ReadFrame(const io::H5File& f, int64_t row, int size, Image8* crop, face::Landmarks* l) {
  *crop = Image8(size, size, 3);
  f.ReadFrames<uint8_t>(io::frames::kCrop, row, 1, crop->data.data());
  f.ReadFrames<float>(io::frames::kLandmarksCrop, row, 1, l->data());
}

int CropSize(const io::H5File& f) {
  const io::Shape s = f.CheckShape(io::frames::kCrop, {-1, -1, -1, 3});
  if (s[1] != s[2]) throw FileIOError(f.path() + ": /frames/crop is not square");
  return static_cast<int>(s[1]);
}

// A curation file: its tree over the frames, and the ingest output they are rows of.
struct Curation : curate::FrameTree {
  std::string frames_file;
};

Curation ReadCuration(const std::string& path) {
  const io::H5File f = io::H5File::OpenRead(path);
  Curation c;
  for (const std::string& name : f.ReadStrings("/tree/levels")) c.kinds.push_back(curate::ParseFeatureKind(name));
  if (c.kinds.empty()) throw FileIOError(path + ": /tree/levels is empty");
  c.frame_of_item = f.ReadVector<int64_t>("/features/frame");
  c.frames_file = f.GetStringAttribute("/", "frames_file");
  std::vector<curate::ClusterLevel> levels(c.kinds.size() - 1);
  for (size_t l = 0; l < levels.size(); ++l) {
    const std::string g = "/tree/level_" + std::to_string(l);
    levels[l].centers = f.ReadMatrix<float>(g + "/centers", -1, curate::FeatureDims(c.kinds[l]));
    const int64_t nodes = levels[l].centers.rows();
    levels[l].parent = f.ReadVector<int32_t>(g + "/parent", nodes);
    levels[l].first_child = f.ReadVector<int32_t>(g + "/first_child", nodes + 1);
  }
  const std::string flat = std::string("/features/") + curate::FeatureName(c.kinds.back());
  FeatureMatrix flat_features = f.ReadMatrix<float>(flat, static_cast<int64_t>(c.frame_of_item.size()),
                                                    curate::FeatureDims(c.kinds.back()));
  c.tree = curate::ClusterTree::FromParts(std::move(levels), f.ReadVector<int64_t>("/tree/leaf_items"),
                                          std::move(flat_features));
  return c;
}

// One query: its crop (for the sheet), features and a label.
struct QueryItem {
  std::string label;
  Image8 crop;
  face::Landmarks landmarks;
};

// The query by one frame of the ingest output the tree was built from.
QueryItem QueryOfFrame(const io::H5File& frames, const std::string& frames_path, int64_t frame, int size) {
  const std::vector<uint8_t> found =
      frames.ReadVector<uint8_t>(io::frames::kFound, frames.NumFrames(io::frames::kCrop));
  if (frame >= static_cast<int64_t>(found.size())) {
    throw InvalidInputError("[curate.query] frame " + std::to_string(frame) + " is outside " +
                            frames_path + " (" + std::to_string(found.size()) + " frames)");
  }
  if (!found[frame]) {
    throw InvalidInputError("[curate.query] frame " + std::to_string(frame) + " of " + frames_path +
                            " has no face (see /frames/status)");
  }
  QueryItem q;
  q.label = "frame " + std::to_string(frame);
  ReadFrame(frames, frame, size, &q.crop, &q.landmarks);
  return q;
}

// The queries by every face of another ingest output.
std::vector<QueryItem> QueriesOfFrames(const std::string& path) {
  std::vector<QueryItem> queries;
  const io::H5File other = io::H5File::OpenRead(path);
  const int other_size = CropSize(other);
  for (int64_t row : FoundRows(other)) {
    QueryItem q;
    q.label = path + " frame " + std::to_string(row);
    ReadFrame(other, row, other_size, &q.crop, &q.landmarks);
    queries.push_back(std::move(q));
  }
  return queries;
}

// The queries by the face of an image, or by the first face of every image of a folder
// (images without a face skipped); cropped as the ingest output's crops.
std::vector<QueryItem> QueriesOfImages(const CurateQueryOptions& o, const face::CropOptions& crop_options) {
  std::vector<std::string> files;
  if (!o.image.empty()) {
    files.push_back(o.image);
  } else {
    auto source = face::FrameSource::OpenImages(o.renders, 40000000);
    files = source->Files();
  }
  face::FaceAnalyzerOptions ao;
  ao.landmark_model = o.landmark_model;
  face::FaceAnalyzer analyzer(ao);
  std::vector<QueryItem> queries;
  int64_t skipped = 0;
  for (const std::string& file : files) {
    const face::DecodedFrame d = face::ReadImageFile(file, 40000000);
    if (!d.ok) {
      if (!o.image.empty()) throw FileIOError(d.error);
      FC_WARN("curate query: skipping {}", d.error);
      ++skipped;
      continue;
    }
    const std::vector<face::FaceBox> faces = analyzer.Detect(d.image);
    if (faces.empty()) {
      if (!o.image.empty()) throw FileIOError(file + ": no face found in the query image");
      ++skipped;
      continue;
    }
    const face::AlignedCrop crop =
        face::AlignFace(d.image, analyzer.FitLandmarks(d.image, faces[0]), crop_options);
    queries.push_back(QueryItem{file, crop.image, crop.landmarks});
  }
  if (skipped) FC_WARN("curate query: {} of {} images gave no face and were skipped", skipped, files.size());
  return queries;
}

// The queries' picks, as rows of the ingest output's /frames (curate::PickFrames), and what
// the widening to unique_frames did.
curate::FramePicks PickFrames(const Curation& c, const std::vector<QueryItem>& queries,
                              const CurateQueryOptions& o) {
  std::vector<const Image8*> crops;
  std::vector<face::Landmarks> landmarks;
  for (const QueryItem& q : queries) {
    crops.push_back(&q.crop);
    landmarks.push_back(q.landmarks);
  }
  curate::FramePicks p = curate::PickFrames(c, crops, landmarks, o.picks, o.unique_frames);
  if (o.unique_frames > 0) {
    std::string used;
    for (int q : p.picks_per_level) used += (used.empty() ? "" : ", ") + std::to_string(q);
    if (static_cast<int64_t>(p.unique.size()) < o.unique_frames) {
      FC_WARN("curate query: {} unique frames asked for, the tree holds {}: all taken", o.unique_frames,
              p.unique.size());
    }
    FC_INFO("curate query: picks widened to ({}) for {} unique frames", used, p.unique.size());
  }
  return p;
}

// The picks file: the unique frames, each query's picks, labels and poses.
void WritePicks(const CurateQueryOptions& o, const StageContext& ctx, const io::Config& resolved,
                const std::string& frames_path, const io::H5File& frames,
                const std::vector<QueryItem>& queries, const curate::FramePicks& p) {
  const std::vector<int64_t> source_index =
      frames.ReadVector<int64_t>(io::frames::kSourceIndex, frames.NumFrames(io::frames::kCrop));
  std::vector<int64_t> unique_source;
  for (int64_t row : p.unique) unique_source.push_back(source_index[row]);

  io::H5File out = io::H5File::CreateAtomic(o.out);
  out.WriteProvenance(MakeProvenance(ctx, "curate query", resolved));
  out.SetAttribute("/", "frames_file", std::filesystem::absolute(frames_path).string());
  out.WriteVector("/picks/frames", p.unique);
  out.SetAttribute("/picks/frames", "meaning", std::string("rows of the ingest output's /frames, unique, in query order"));
  out.WriteVector("/picks/source_index", unique_source);
  out.WriteVector("/queries/picks", p.all);
  out.WriteVector("/queries/offsets", p.offsets);
  out.SetAttribute("/queries/picks", "meaning", std::string("query i picked /queries/picks[offsets[i] : offsets[i+1]]"));
  std::vector<std::string> labels;
  for (const QueryItem& q : queries) labels.push_back(q.label);
  out.WriteStrings("/queries/labels", labels);
  out.WriteMatrix("/queries/pose", p.features.pose);
  out.SetAttribute("/queries/pose", "columns", std::string("pitch, yaw (degrees; pitch > 0 face down, yaw > 0 face to its left)"));
  out.WriteVector("/queries/picks_per_level", p.picks_per_level);
  out.SetAttribute("/queries/picks_per_level", "meaning", std::string("q_1 ... q_n used (widened for unique_frames)"));
  out.SetAttribute("/picks/frames", "unique_frames_asked", o.unique_frames);
  out.Commit();
}

// The contact sheet: one row per query, its crop beside the crops of its picks.
void WriteQuerySheet(const CurateQueryOptions& o, const io::H5File& frames, int size,
                     const std::vector<QueryItem>& queries, const std::vector<std::vector<int64_t>>& per_query) {
  size_t columns = 1;
  for (const auto& p : per_query) columns = std::max(columns, std::min(p.size(), static_cast<size_t>(o.sheet_columns)) + 1);
  std::vector<Image8> tiles;
  const size_t rows = std::min<size_t>(queries.size(), static_cast<size_t>(o.sheet_rows));
  for (size_t i = 0; i < rows; ++i) {
    tiles.push_back(queries[i].crop);
    for (size_t j = 0; j + 1 < columns; ++j) {
      Image8 tile(size, size, 3, 0);
      face::Landmarks unused;
      if (j < per_query[i].size()) ReadFrame(frames, per_query[i][j], size, &tile, &unused);
      tiles.push_back(std::move(tile));
    }
  }
  render::ContactSheetOptions sheet_options;
  sheet_options.columns = static_cast<int>(columns);
  sheet_options.border = 2;
  sheet_options.border_value = {40, 40, 40};
  io::WriteImage(o.SheetPath(), render::ContactSheet(tiles, sheet_options));
  FC_INFO("curate query: contact sheet (query | picks, one row per query) -> {}", o.SheetPath());
}

}  // namespace

StageSummary RunCurateBuild(const CurateBuildOptions& o, const StageContext& ctx,
                            const io::Config& resolved) {
  StageSummary summary{o.out, "frames", 0, 0};
  // About a second of work for 10,000 frames: rank 0 alone.
  if (!ctx.comm.IsMainRank()) return summary;
  const auto t0 = std::chrono::steady_clock::now();
  const io::H5File in = io::H5File::OpenRead(o.frames);
  const int size = CropSize(in);
  const std::vector<int64_t> rows = FoundRows(in);
  if (rows.empty()) {
    throw FileIOError(o.frames + ": no frame with a face to curate (see /frames/status)");
  }
  // Features in blocks, so that crops of long clips never sit in memory at once.
  const int64_t n = static_cast<int64_t>(rows.size());
  curate::FeatureTable table;
  table.pose.resize(n, curate::kPoseDims);
  table.lighting.resize(n, curate::kLightingDims);
  table.expression.resize(n, curate::kExpressionDims);
  constexpr int64_t kBlock = 512;
  for (int64_t begin = 0; begin < n; begin += kBlock) {
    const int64_t count = std::min(kBlock, n - begin);
    std::vector<Image8> crops(count);
    std::vector<face::Landmarks> landmarks(count);
    std::vector<const Image8*> crop_ptrs(count);
    // One read of the rows' span (chunks decompress once), then the found rows from it.
    const int64_t first = rows[begin], span = rows[begin + count - 1] - first + 1;
    const int64_t crop_bytes = static_cast<int64_t>(size) * size * 3;
    std::vector<uint8_t> span_crops(span * crop_bytes);
    std::vector<float> span_landmarks(span * face::kNumLandmarks * 2);
    in.ReadFrames<uint8_t>(io::frames::kCrop, first, span, span_crops.data());
    in.ReadFrames<float>(io::frames::kLandmarksCrop, first, span, span_landmarks.data());
    for (int64_t j = 0; j < count; ++j) {
      const int64_t k = rows[begin + j] - first;
      crops[j] = Image8(size, size, 3);
      std::copy_n(span_crops.begin() + k * crop_bytes, crop_bytes, crops[j].data.begin());
      std::copy_n(span_landmarks.begin() + k * face::kNumLandmarks * 2, face::kNumLandmarks * 2,
                  landmarks[j].data());
      crop_ptrs[j] = &crops[j];
    }
    const curate::FeatureTable block = curate::ComputeFeatures(crop_ptrs, landmarks, o.threads);
    table.pose.middleRows(begin, count) = block.pose;
    table.lighting.middleRows(begin, count) = block.lighting;
    table.expression.middleRows(begin, count) = block.expression;
  }
  const auto t1 = std::chrono::steady_clock::now();
  std::vector<FeatureMatrix> levels;
  for (const std::string& name : o.levels) levels.push_back(table.Of(curate::ParseFeatureKind(name)));
  const curate::ClusterTreeOptions tree_options{o.clusters, static_cast<uint64_t>(o.seed), o.max_iterations};
  const curate::ClusterTree tree = curate::ClusterTree::Build(levels, tree_options);
  const auto t2 = std::chrono::steady_clock::now();

  io::H5File f = io::H5File::CreateAtomic(o.out);
  f.WriteProvenance(MakeProvenance(ctx, "curate build", resolved));
  f.SetAttribute("/", "frames_file", std::filesystem::absolute(o.frames).string());
  f.WriteVector("/features/frame", rows);
  f.SetAttribute("/features/frame", "meaning", std::string("row of the ingest output's /frames"));
  f.WriteMatrix("/features/pose", table.pose);
  f.SetAttribute("/features/pose", "columns", std::string("pitch, yaw (degrees; pitch > 0 face down, yaw > 0 face to its left, as rig::RigidPose)"));
  f.WriteMatrix("/features/lighting", table.lighting);
  f.SetAttribute("/features/lighting", "layout", std::string("4 rows x 3 columns x RGB of the nose crop, [0, 1]"));
  f.WriteMatrix("/features/expression", table.expression);
  f.SetAttribute("/features/expression", "layout", std::string("aligned minus template (x, y) of 17-21+36-41, 22-26+42-47, 48-67"));
  f.WriteStrings("/tree/levels", o.levels);
  for (size_t l = 0; l < tree.levels().size(); ++l) {
    const curate::ClusterLevel& L = tree.levels()[l];
    const std::string g = "/tree/level_" + std::to_string(l);
    f.WriteMatrix(g + "/centers", L.centers);
    f.WriteVector(g + "/parent", L.parent);
    f.WriteVector(g + "/first_child", L.first_child);
  }
  f.WriteVector("/tree/leaf_items", tree.leaf_items());
  f.SetAttribute("/tree/leaf_items", "meaning", std::string("rows of /features grouped by node of the last clustered level"));
  f.Commit();
  FC_INFO("curate build: {} frames with a face of {}: features {:.3f} s, tree {:.3f} s ({} levels, "
          "{} leaf nodes) -> {}", n, o.frames, std::chrono::duration<double>(t1 - t0).count(),
          std::chrono::duration<double>(t2 - t1).count(), tree.NumLevels(),
          tree.levels().empty() ? 1 : tree.levels().back().centers.rows(), o.out);
  summary.items = n;
  summary.computed = n;
  return summary;
}

StageSummary RunCurateQuery(const CurateQueryOptions& o, const StageContext& ctx,
                            const io::Config& resolved) {
  StageSummary summary{o.out, "frames", 0, 0};
  if (!ctx.comm.IsMainRank()) return summary;
  const Curation c = ReadCuration(o.curation);
  if (static_cast<int>(o.picks.size()) != c.tree.NumLevels()) {
    throw InvalidInputError("[curate.query] picks needs " + std::to_string(c.tree.NumLevels()) +
                            " counts for the tree's levels, got " + std::to_string(o.picks.size()));
  }
  const std::string frames_path = o.frames.empty() ? c.frames_file : o.frames;
  const io::H5File frames = io::H5File::OpenRead(frames_path);
  const int size = CropSize(frames);
  const face::CropOptions crop_options{
      size, frames.HasAttribute("/", "crop_padding") ? frames.GetDoubleAttribute("/", "crop_padding") : 0.25,
      frames.HasAttribute("/", "crop_raise") ? frames.GetDoubleAttribute("/", "crop_raise") : 0.0};

  std::vector<QueryItem> queries;
  if (o.frame >= 0) {
    queries.push_back(QueryOfFrame(frames, frames_path, o.frame, size));
  } else if (!o.query_frames.empty()) {
    queries = QueriesOfFrames(o.query_frames);
  } else {
    queries = QueriesOfImages(o, crop_options);
  }
  if (queries.empty()) throw FileIOError("curate query: no query face (no image gave a face)");

  const curate::FramePicks picks = PickFrames(c, queries, o);
  WritePicks(o, ctx, resolved, frames_path, frames, queries, picks);
  if (o.contact_sheet) WriteQuerySheet(o, frames, size, queries, picks.per_query);
  FC_INFO("curate query: {} quer{} -> {} unique frames ({:.3f} ms per query in the tree) -> {}",
          queries.size(), queries.size() == 1 ? "y" : "ies", picks.unique.size(),
          1000.0 * picks.query_s / queries.size(), o.out);
  summary.items = static_cast<int64_t>(picks.unique.size());
  summary.computed = summary.items;
  return summary;
}

}  // namespace facecap::stages
