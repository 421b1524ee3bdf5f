// The command-line table, video: ingest, curate, deepfake, track, person, appearance, lipsync,
// regress, export.
#include <string>

#include <CLI/CLI.hpp>

#include "app/commands.h"
#include "app/registry.h"
#include "stages/appearance_stage.h"
#include "stages/curate_stage.h"
#include "stages/deepfake_stage.h"
#include "stages/export_stage.h"
#include "stages/ingest_stage.h"
#include "stages/lipsync_stage.h"
#include "stages/person_stage.h"
#include "stages/regress_stage.h"
#include "stages/track_stage.h"

namespace facecap::app {

using stages::OutputKind;
using stages::PathKeys;
using stages::AppearanceFramesOptions;
using stages::AppearanceGatherOptions;
using stages::AppearanceTurntableOptions;
using stages::CurateBuildOptions;
using stages::CurateQueryOptions;
using stages::DeepfakeInferOptions;
using stages::DeepfakeTrainOptions;
using stages::ExportGltfOptions;
using stages::ExportLandmarksOptions;
using stages::ExportLiveLinkOptions;
using stages::ExportOverlayOptions;
using stages::IngestOptions;
using stages::LipsyncAudioOptions;
using stages::LipsyncBlendOptions;
using stages::LipsyncTrackOptions;
using stages::PersonFitStageOptions;
using stages::RegressInferOptions;
using stages::RegressTrainOptions;
using stages::RunAppearanceFrames;
using stages::RunAppearanceGather;
using stages::RunAppearanceTurntable;
using stages::RunCurateBuild;
using stages::RunCurateQuery;
using stages::RunDeepfakeInfer;
using stages::RunDeepfakeTrain;
using stages::RunExportGltf;
using stages::RunExportLandmarks;
using stages::RunExportLiveLink;
using stages::RunExportOverlay;
using stages::RunIngest;
using stages::RunLipsyncAudio;
using stages::RunLipsyncBlend;
using stages::RunLipsyncTrack;
using stages::RunPersonFit;
using stages::RunRegressInfer;
using stages::RunRegressTrain;
using stages::RunTrack;
using stages::TrackOptions;

CLI::App* ExportSubcommand(CLI::App* app) {
  return GroupSubcommand(app, "export", "Tracked animation to other tools' formats");
}

CLI::App* LipsyncSubcommand(CLI::App* app) {
  return GroupSubcommand(app, "lipsync",
                         "Lip-sync (paper 000 Sec. 8.1): the mouth from a second source, blended "
                         "into the video's solve");
}

void RegisterIngest(CLI::App* app, AppState* state) {
  AddStage<IngestOptions>(
      app, state, "ingest", "ingest", "ingest",
      "Real footage to frames.h5: a video (--video) or image folder (--images), faces detected "
      "with dlib, one subject followed, 68 landmarks, similarity-aligned crops, source file, "
      "frame index and timecode per frame; spread across ranks, identical for any rank count, "
      "resumable",
      PathKeys{{"video", "images", "landmark_model"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunIngest));
}

void RegisterCurate(CLI::App* app, AppState* state) {
  CLI::App* curate = app->add_subcommand("curate", "Curate frames: features and the hierarchical "
                                                   "cluster tree (paper 000 Sec. 3), and queries");
  curate->require_subcommand(1);
  AddStage<CurateBuildOptions>(
      curate, state, "build", "curate.build", "curate build",
      "Features f_pose, f_lighting, f_expression of every face in an ingest output and the tree "
      "of k-means levels over them (default: 9 pose clusters, 3 lighting clusters each, flat "
      "expression)",
      PathKeys{{"frames"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunCurateBuild));
  AddStage<CurateQueryOptions>(
      curate, state, "query", "curate.query", "curate query",
      "Frames that match a query (a frame, an image, a folder of renders, or another ingest "
      "output) with q_1..q_n picks per level; writes their indices and a contact sheet",
      PathKeys{{"curation", "frames", "image", "renders", "query_frames", "landmark_model"}, {{"out", OutputKind::kHdf5}, {"sheet", OutputKind::kImage}}},
      StageCommand(RunCurateQuery));
}

void RegisterDeepfake(CLI::App* app, AppState* state) {
  CLI::App* deepfake = app->add_subcommand(
      "deepfake", "The deepfake of paper 000 Sec. 4: train with gradient allreduce, translate frames");
  deepfake->require_subcommand(1);
  AddStage<DeepfakeTrainOptions>(
      deepfake, state, "train", "deepfake.train", "deepfake train",
      "Train E, D_A, D_B with the discriminators G_image and G_latent on A (synthetic renders) and "
      "B (real frames), data-parallel across ranks with gradient allreduce; checkpoints, resumes, "
      "progress lines with each loss, preview grid",
      PathKeys{{"a", "b", "paired", "init"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunDeepfakeTrain));
  AddStage<DeepfakeInferOptions>(
      deepfake, state, "infer", "deepfake.infer", "deepfake infer",
      "Translate frames with D(E(I)), store the codes E(I) and E(D(E(I))), and the region borders "
      "of each translation as polylines with an overlay PNG; spread across ranks, resumable",
      PathKeys{{"model", "frames", "camera"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunDeepfakeInfer));
}

void RegisterExport(CLI::App* app, AppState* state) {
  CLI::App* exp = ExportSubcommand(app);
  exp->require_subcommand(1);
  AddStage<ExportLiveLinkOptions>(
      exp, state, "livelink", "export.livelink", "export livelink",
      "Live Link Face CSV: Timecode, BlendShapeCount, then 61 values per frame (the 52 ARKit "
      "shapes matched by name, head yaw/pitch/roll, eye yaw/pitch/roll)",
      PathKeys{{"track"}, {{"out", OutputKind::kCsv}}},
      StageCommand(RunExportLiveLink));
  AddStage<ExportGltfOptions>(
      exp, state, "gltf", "export.gltf", "export gltf",
      "glTF (.glb/.gltf) of the rig with one morph target per shape and the tracked weights as "
      "a morph-target animation",
      PathKeys{{"track", "rig"}, {{"out", OutputKind::kGltf}}},
      StageCommand(RunExportGltf));
  AddStage<ExportOverlayOptions>(
      exp, state, "overlay", "export.overlay", "export overlay",
      "mp4 of the tracked rig drawn over the frames it was tracked on (the source video's own "
      "frames for a track of footage): segmentation colours blended in, region borders and "
      "silhouette in white; optionally a contact sheet PNG",
      PathKeys{{"track", "rig", "frames"}, {{"out", OutputKind::kVideo}, {"sheet", OutputKind::kImage}}},
      StageCommand(RunExportOverlay));
  AddStage<ExportLandmarksOptions>(
      exp, state, "landmarks", "export.landmarks", "export landmarks",
      "CSV of the tracked rig's 68 landmarks (iBUG order) in the source video's pixels, one row "
      "per ingested frame (frames without a face: empty coordinates), so that other tools can "
      "score the tracking",
      PathKeys{{"track", "rig", "frames"}, {{"out", OutputKind::kCsv}}},
      StageCommand(RunExportLandmarks));
}

void RegisterTrack(CLI::App* app, AppState* state) {
  AddStage<TrackOptions>(
      app, state, "track", "track", "track",
      "Inverse-rendering tracking (paper 000 Sec. 8): per frame, the rig's rigid pose and "
      "controls that make its soft segmentation render match the target, by block coordinate "
      "descent (pose, jaw, rest) with Ceres; frames spread across ranks by a dynamic work "
      "queue, identical for any rank count, resumable",
      PathKeys{{"rig", "targets", "frames"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunTrack));
  AddStage<LipsyncTrackOptions>(
      LipsyncSubcommand(app), state, "track", "lipsync.track", "lipsync track",
      "The mouth of a frontal lip video (a lip-sync network's output, a second camera): "
      "ingested and translated as any footage (its frames and translations), then solved as "
      "track does with the head held frontal (its position solved) and every control outside "
      "the mouth group (solve_controls) at the neutral; then zeroed on the frames where its "
      "sound is silent (the mouth at rest), one-frame flicker removed, and the lips parted "
      "where they meet in a phone of its sound that forbids it; writes a track file for "
      "lipsync blend",
      PathKeys{{"rig", "targets", "frames", "sound"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunLipsyncTrack));
}

void RegisterPerson(CLI::App* app, AppState* state) {
  CLI::App* person = app->add_subcommand("person", "The person's own rig from their footage");
  person->require_subcommand(1);
  AddStage<PersonFitStageOptions>(
      person, state, "fit", "person.fit", "person fit",
      "The person's neutral geometry from many frames (paper 000 Sec. 5.1): the generic rig's "
      "identity modes fitted by inverse rendering of the segmentation translations, jointly "
      "with the pose and expression of frames chosen for pose variety (a fit to ingest's 68 "
      "landmarks kept beside as a baseline, and the person's own landmark vertices); the "
      "rig's shapes moved onto the person by deformation transfer. Frames spread across "
      "ranks, the same result for any rank count, resumable",
      PathKeys{{"rig", "frames", "translations"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunPersonFit));
}

void RegisterAppearance(CLI::App* app, AppState* state) {
  CLI::App* appearance = app->add_subcommand(
      "appearance", "The person's texture from their footage (paper 000 Sec. 5): turntables of "
                    "their rig, and the colours of images of those views gathered into a texture");
  appearance->require_subcommand(1);
  AddStage<AppearanceTurntableOptions>(
      appearance, state, "turntable", "appearance.turntable", "appearance turntable",
      "Renders of the rig at neutral over a pitch x yaw grid (Sec. 5.2), framed as ingest crops "
      "footage, each with U(I), triangle ids and depth; a contact sheet; spread across ranks, "
      "identical for any rank count, resumable",
      PathKeys{{"rig", "texture"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunAppearanceTurntable));
  AddStage<AppearanceFramesOptions>(
      appearance, state, "frames", "appearance.frames", "appearance frames",
      "Tracked footage as views for gathering: each frame's image (ingest's crop) with the "
      "tracked rig's U(I), triangle ids and depth in its camera, laid out as the turntable's; "
      "splatting these is the naive capture the deepfake's translations are measured against; "
      "spread across ranks, resumable",
      PathKeys{{"frames", "track", "rig"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunAppearanceFrames));
  AddStage<AppearanceGatherOptions>(
      appearance, state, "gather", "appearance.gather", "appearance gather",
      "Photon gathering (Sec. 5.4): every pixel of the views' images is a particle at its U(I) "
      "position; each texel averages its k nearest particles of its UV chart by inverse "
      "distance, with a confidence from the radius they needed; HDF5, linear EXR and sRGB PNG",
      PathKeys{{"views", "images"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunAppearanceGather));
}

void RegisterLipsync(CLI::App* app, AppState* state) {
  CLI::App* lipsync = LipsyncSubcommand(app);
  AddStage<LipsyncBlendOptions>(
      lipsync, state, "blend", "lipsync.blend", "lipsync blend",
      "The video's solve with its mouth controls cross-faded towards a mouth source's (lipsync "
      "track of a frontal lip video), the source aligned in time by the sound of both videos "
      "(or offset_seconds); pose and every other control stay the video's; a track file",
      PathKeys{{"track", "mouth", "video", "mouth_video"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunLipsyncBlend));
  AddStage<LipsyncAudioOptions>(
      lipsync, state, "audio", "lipsync.audio", "lipsync audio",
      "A mouth source from the video's own sound: phones recognized offline by pocketsphinx "
      "(freely, or aligned to a transcript), mapped to visemes and to the rig's ARKit mouth "
      "controls through dominance-function coarticulation; a track file for lipsync blend",
      PathKeys{{"video", "rig", "model_dir"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunLipsyncAudio));
}

void RegisterRegress(CLI::App* app, AppState* state) {
  CLI::App* regress = app->add_subcommand(
      "regress", "The personalized regressor of paper 000 Sec. 9: pose and controls from a frame's deepfake code");
  regress->require_subcommand(1);
  AddStage<RegressTrainOptions>(
      regress, state, "train", "regress.train", "regress train",
      "Train P (pose), J (jaw controls) and W (the other controls) on the codes E(D_S(E(I))) of the synthetic "
      "samples against their truth; optionally the paper's phases 2 and 3: L (landmarks) on the samples' landmarks, "
      "then P, J, W again with L frozen, the footage crops' detected landmarks as weak supervision. Data-parallel "
      "over ranks (gradient allreduce), checkpoints, resume",
      PathKeys{{"samples", "sample_codes", "frame_codes", "frames", "more_frame_codes", "more_frames", "more_tracks", "track", "rig"},
               {{"out", OutputKind::kHdf5}}},
      StageCommand(RunRegressTrain));
  AddStage<RegressInferOptions>(
      regress, state, "infer", "regress.infer", "regress infer",
      "Each frame's pose and controls from its code by the trained regressor, the head placed on the detected "
      "landmarks; a track file in the source camera that exports and eval track read. Frames spread across ranks, "
      "resumable",
      PathKeys{{"model", "codes", "frames", "rig"}, {{"out", OutputKind::kHdf5}}},
      StageCommand(RunRegressInfer));
}

}  // namespace facecap::app
