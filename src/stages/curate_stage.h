// facecap curate build | query: the hierarchical clustering of paper 000 Sec. 3 over the
// frames of an ingest output, and queries against it (by frame, by image, by a folder of
// synthetic renders: the turntable matching of Sec. 5.2, or by every face of another ingest
// output), with a contact sheet of each query beside its picks.
//   curate build: features f_pose, f_lighting, f_expression of every face in an ingest output
//     and the tree of k-means levels over them (default: 9 pose clusters, 3 lighting clusters
//     each, flat expression);
//   curate query: the frames that match a query (a frame, an image, a folder of renders, or
//     another ingest output) with q_1..q_n picks per level; writes their indices and a contact
//     sheet.
#ifndef FACECAP_STAGES_CURATE_STAGE_H_
#define FACECAP_STAGES_CURATE_STAGE_H_

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "curate/cluster_tree.h"
#include "curate/features.h"
#include "face/face_analyzer.h"
#include "io/config.h"
#include "stages/stage.h"
#include "util/errors.h"

namespace facecap::stages {

// [curate.build]
struct CurateBuildOptions {
  std::string frames = "frames.h5";      // ingest output
  std::string out = "curation.h5";       // output file
  std::vector<std::string> levels = {"pose", "lighting", "expression"};  // f_1 ... f_n
  std::vector<int> clusters = {9, 3};    // k_1 ... k_{n-1}
  int seed = 1;                          // k-means++ seed
  int max_iterations = 50;               // Lloyd iterations at most
  int threads = 0;                       // OpenMP threads for the features (0: all)

  template <class V>
  void Visit(V&& v) {
    v("frames", frames, "ingest output (frames.h5) whose faces are clustered");
    v("out", out, "output file (HDF5) with the features and the cluster tree");
    v("levels", levels, "features of the tree's levels, top first: pose, lighting, expression "
                        "(the last level is flat)");
    v("clusters", clusters, "k-means clusters per node for every level but the last");
    v("seed", seed, "seed of the k-means++ initialisation");
    v("max_iterations", max_iterations, "k-means (Lloyd) iterations at most");
    v("threads", threads, "OpenMP threads for the features (0: all available)");
  }
  bool Check(std::string* why) const {
    if (frames.empty() || out.empty()) { *why = "frames and out must name files"; return false; }
    try {
      for (const auto& l : levels) curate::ParseFeatureKind(l);
    } catch (const InvalidInputError& e) {
      *why = std::string("levels: ") + e.what();
      return false;
    }
    if (seed < 0) { *why = "seed must be >= 0"; return false; }
    if (threads < 0) { *why = "threads must be >= 0"; return false; }
    curate::ClusterTreeOptions t{clusters, static_cast<uint64_t>(seed), max_iterations};
    return t.Check(static_cast<int>(levels.size()), why);
  }
};

// [curate.query]
struct CurateQueryOptions {
  std::string curation = "curation.h5";  // output of curate build
  std::string frames;                    // its ingest output ("": the one it was built from)
  int64_t frame = -1;                    // query by this frame of the ingest output
  std::string image;                     // or by a face in this image
  std::string renders;                   // or by every image in this folder (turntable)
  std::string query_frames;              // or by every face of another ingest output
  std::vector<int> picks = {2, 3, 1};    // q_1 ... q_n
  int64_t unique_frames = 0;             // widen the picks until this many unique frames (0: off)
  std::string out = "picks.h5";          // output: the picked frames
  bool contact_sheet = true;             // write the contact sheet
  std::string sheet;                     // its PNG ("": beside out, out's name with .png)
  std::string landmark_model = face::kDefaultLandmarkModel;  // for image and renders queries
  int sheet_rows = 48;                   // queries shown on the sheet at most
  int sheet_columns = 12;                // picks shown per query at most

  template <class V>
  void Visit(V&& v) {
    v("curation", curation, "curation file from `facecap curate build`");
    v("frames", frames, "its ingest output (default: the file the tree was built from)");
    v("frame", frame, "query with this frame (row) of the ingest output");
    v("image", image, "query with the face in this image");
    v("renders", renders, "query with every image of this folder, e.g. synthetic turntable "
                          "renders; returns the unique frames");
    v("query_frames", query_frames, "query with every face of another ingest output");
    v("picks", picks, "q_1 ... q_n: nodes kept per level and frames per leaf (paper: 2, 3, 1)");
    v("unique_frames", unique_frames,
      "target count of unique frames over all queries (e.g. 250 for a turntable, paper 000 "
      "Sec. 5.2): the picks are widened from the bottom level up (frames per leaf, then "
      "lighting, then pose) until exactly this many are unique, or every frame is taken "
      "(0: the picks as given)");
    v("out", out, "output file (HDF5) with the picked frames");
    v("contact_sheet", contact_sheet, "write the contact sheet (--no-contact-sheet: none)");
    v("sheet", sheet, "contact sheet PNG, each query's crop beside its picks (default: beside "
                      "out, with out's name and .png)");
    v("landmark_model", landmark_model, "dlib 68-point model for image and renders queries");
    v("sheet_rows", sheet_rows, "queries shown on the contact sheet at most");
    v("sheet_columns", sheet_columns, "picks shown beside each query on the contact sheet at most");
  }
  bool Check(std::string* why) const {
    const int given = (frame >= 0) + !image.empty() + !renders.empty() + !query_frames.empty();
    if (given != 1) {
      *why = "give exactly one query: frame, image, renders or query_frames";
      return false;
    }
    for (int q : picks) if (q < 1) { *why = "each pick count must be >= 1"; return false; }
    if (out.empty()) { *why = "out must name a file"; return false; }
    if (sheet_rows < 1) { *why = "sheet_rows must be >= 1"; return false; }
    if (sheet_columns < 1) { *why = "sheet_columns must be >= 1"; return false; }
    if (unique_frames < 0) { *why = "unique_frames must be >= 0"; return false; }
    if (contact_sheet && SheetPath() == out) { *why = "sheet must differ from out"; return false; }
    return true;
  }
  // The contact sheet's path: `sheet`, or out with .png.
  std::string SheetPath() const {
    if (!sheet.empty()) return sheet;
    return std::filesystem::path(out).replace_extension(".png").string();
  }
};

// Runs curate build on rank 0 (the other ranks return at once, with 0 frames): the
// summary counts the frames with a face that the tree holds, all computed by this run.
StageSummary RunCurateBuild(const CurateBuildOptions& options, const StageContext& ctx,
                            const io::Config& resolved);

// Runs curate query on rank 0 (the other ranks return at once, with 0 frames): the
// summary counts the unique frames picked, all computed by this run.
StageSummary RunCurateQuery(const CurateQueryOptions& options, const StageContext& ctx,
                            const io::Config& resolved);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_CURATE_STAGE_H_
