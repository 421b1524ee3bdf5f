// facecap blendshapes train | baselines | infer, and facecap eval blendshapes: personalized
// blendshapes from one neutral scan (paper 001 Sec. 4) and their comparison with the template
// and example-based rigging (paper 001 Table 2).
//   blendshapes train: the blendshape generator (Estimation Stage, then Tuning Stage with the
//     blending weight predictor) on a scan database; data-parallel with gradient allreduce,
//     resumable;
//   blendshapes baselines: baseline shapes for every person of a scan database, the template
//     moved by deformation transfer and example-based facial rigging on the person's scans;
//   blendshapes infer: one neutral mesh (an OBJ, or a person of a scan database) to a
//     personalized rig.h5;
//   eval blendshapes: reconstruction errors of template, example-based and generated
//     blendshapes on training and held-out people (paper 001 Table 2), and their distance to
//     the true personal shapes.
#ifndef FACECAP_STAGES_BLENDSHAPES_STAGE_H_
#define FACECAP_STAGES_BLENDSHAPES_STAGE_H_

#include <string>
#include <utility>
#include <vector>

#include "assets/example_based_rigging.h"
#include "io/config.h"
#include "nn/blendshape_generator.h"
#include "stages/stage.h"

namespace facecap::stages {

// [blendshapes.train]
struct BlendshapesTrainOptions {
  std::string scans = "scans.h5";     // scan database
  std::string out = "bsgen.h5";       // trained model
  int image_size = 64;                // geometry image size (pixels, multiple of 4)
  int estimation_epochs = 60;         // passes over the training people, Estimation Stage
  int tuning_epochs = 30;             // passes over the training people, Tuning Stage
  int batch = 8;                      // people per step, all ranks together
  int checkpoint_every = 50;          // steps between checkpoints
  double progress_seconds = 10;       // interval of the progress lines
  int threads = 0;                    // tensor threads per rank (0: the cores divided among ranks)
  int seed = 1;                       // batch order seed
  float nominal_weight = 1.f;         // the weight of a FACS table's 1 in training
  float average_fraction = 0.f;       // each stage ends with the mean of its last steps' parameters
  nn::BlendshapeNetOptions net;       // networks and losses

  // --help's sections, by the first key of each.
  static std::vector<std::pair<std::string, std::string>> HelpSections() {
    return {{"scans", "Data and schedule"}, {"model.channels", "Networks"}, {"model.learning_rate", "Losses and optimizer"}};
  }
  template <class V>
  void Visit(V&& v) {
    v("scans", scans, "scan database (HDF5, from scans synth or scans import)");
    v("out", out, "trained model (HDF5)");
    v("image_size", image_size, "geometry image size in pixels (a multiple of 4)");
    v("estimation_epochs", estimation_epochs, "passes over the training people in the Estimation Stage");
    v("tuning_epochs", tuning_epochs, "passes over the training people in the Tuning Stage");
    v("batch", batch, "people per optimizer step, all ranks together");
    v("checkpoint_every", checkpoint_every, "optimizer steps between checkpoints");
    v("progress_seconds", progress_seconds, "seconds between progress lines");
    v("threads", threads, "tensor threads per rank (0: the cores divided among the node's ranks)");
    v("seed", seed, "batch order seed");
    v("nominal_weight", nominal_weight,
      "the weight a FACS table's 1 stands for in training: the Estimation Stage's weights and the "
      "weight predictor's start (captured expressions are rarely at full intensity; the shapes "
      "are then learnt at the intensity they have at weight 1, not at the scans' mean)");
    v("average_fraction", average_fraction,
      "each stage ends with the parameters averaged over this last fraction of its steps "
      "(iterate averaging: what the step size's noise adds to the parameters averages out; 0: the last step's)");
    io::VisitGroup("model", net, v);
  }
  bool Check(std::string* why) const {
    if (scans.empty() || out.empty()) { *why = "scans and out must name files"; return false; }
    if (image_size < 16 || image_size > 256 || image_size % 4 != 0) { *why = "image_size must be a multiple of 4 in [16, 256]"; return false; }
    if (estimation_epochs < 0 || tuning_epochs < 0) { *why = "epochs must be >= 0"; return false; }
    if (batch < 1) { *why = "batch must be >= 1"; return false; }
    if (checkpoint_every < 1) { *why = "checkpoint_every must be >= 1"; return false; }
    if (!(progress_seconds > 0)) { *why = "progress_seconds must be positive"; return false; }
    if (threads < 0) { *why = "threads must be >= 0"; return false; }
    if (!(nominal_weight > 0.f && nominal_weight <= 1.f)) { *why = "nominal_weight must be in (0, 1]"; return false; }
    if (!(average_fraction >= 0.f && average_fraction < 1.f)) { *why = "average_fraction must be in [0, 1)"; return false; }
    return net.Check(why);
  }
};

// [blendshapes.baselines]
struct BlendshapesBaselinesOptions {
  std::string scans = "scans.h5";       // scan database
  std::string out = "baselines.h5";     // template (deformation transfer) and example-based shapes
  int threads = 0;                      // threads per rank (0: the cores divided among ranks)
  // A second example-based fit that does not see every holdout_every-th expression of each
  // person (expressions k with k % holdout_every == holdout_every - 1), so that all methods
  // can also be scored on expressions no method has seen (0: no such fit).
  int holdout_every = 3;
  assets::ExampleBasedOptions example;  // example-based rigging

  template <class V>
  void Visit(V&& v) {
    v("scans", scans, "scan database (HDF5)");
    v("out", out, "output (HDF5): every person's template and example-based shapes");
    v("threads", threads, "threads per rank (0: the cores divided among the node's ranks)");
    v("holdout_every", holdout_every,
      "also fit example-based rigging without every n-th expression, for scoring on unseen "
      "expressions (0: no such fit)");
    v("iterations", example.iterations, "example-based rigging: shape / weight alternations");
    v("shape_regularization", example.shape_regularization, "example-based rigging: beta, pull towards the transferred template");
    v("kappa", example.kappa, "example-based rigging: kappa of the per-vertex regularization weights");
    v("theta", example.theta, "example-based rigging: theta of the per-vertex regularization weights");
    v("weight_regularization", example.weight_regularization, "example-based rigging: gamma (cm^2), pull of the weights towards the FACS table");
  }
  bool Check(std::string* why) const {
    if (scans.empty() || out.empty()) { *why = "scans and out must name files"; return false; }
    if (threads < 0) { *why = "threads must be >= 0"; return false; }
    if (holdout_every < 0 || holdout_every == 1) { *why = "holdout_every must be 0 or >= 2"; return false; }
    return example.Check(why);
  }
};

// [blendshapes.infer]
struct BlendshapesInferOptions {
  std::string model = "bsgen.h5";     // trained model
  std::string neutral = "";           // the person's neutral mesh (template topology, cm)
  std::string scans = "";             // or a scan database holding it
  std::string person = "0";           // the person in scans
  std::string out = "rig.h5";         // personalized rig
  int threads = 1;                    // tensor threads

  template <class V>
  void Visit(V&& v) {
    v("model", model, "trained model (HDF5, from blendshapes train)");
    v("neutral", neutral, "the person's neutral mesh: OBJ with the template's topology (cm); or give scans and person");
    v("scans", scans, "a scan database whose person's neutral is the input (instead of neutral)");
    v("person", person, "the person in scans: a name of /scans/people/names or an index");
    v("out", out, "personalized rig (HDF5, rig.h5 layout)");
    v("threads", threads, "tensor threads");
  }
  bool Check(std::string* why) const {
    if (model.empty() || out.empty()) { *why = "model and out must name files"; return false; }
    if (neutral.empty() == scans.empty()) { *why = "give either neutral (an OBJ) or scans (and person)"; return false; }
    if (threads < 1) { *why = "threads must be >= 1"; return false; }
    return true;
  }
};

// [eval.blendshapes]
struct EvalBlendshapesOptions {
  std::string scans = "scans.h5";          // scan database
  std::string baselines = "baselines.h5";  // from blendshapes baselines
  std::string model = "bsgen.h5";          // from blendshapes train
  std::string markdown;                    // also write the markdown table here ("" : log only)
  std::string shapes;                      // also write ours' shapes and per-scan errors here
  bool json = false;                       // print the metrics as one JSON object on stdout

  template <class V>
  void Visit(V&& v) {
    v("scans", scans, "scan database (HDF5)");
    v("baselines", baselines, "template and example-based shapes (HDF5, from blendshapes baselines)");
    v("model", model, "trained model (HDF5, from blendshapes train)");
    v("markdown", markdown, "file for the markdown table (empty: the log only)");
    v("shapes", shapes, "HDF5 file for the generated shapes of every person (/shapes/ours/deltas, "
      "/shapes/ours_estimation/deltas [P, N, V, 3], cm) and every method's per-scan errors "
      "(/errors/<method> [P, K], mm) (empty: none)");
    v("json", json, "print the metrics as one JSON object on stdout");
  }
  bool Check(std::string* why) const {
    if (scans.empty() || baselines.empty() || model.empty()) { *why = "scans, baselines and model must name files"; return false; }
    return true;
  }
};

// Trains the blendshape generator on every rank of ctx.comm (collective): the summary counts
// the training's optimizer steps and those this run made (0 when the model was up to date).
StageSummary RunBlendshapesTrain(const BlendshapesTrainOptions& options, const StageContext& ctx,
                                 const io::Config& resolved);

// Fits the baselines on every rank of ctx.comm (collective, people spread across ranks): the
// summary counts one file, the baselines, computed unless it was already up to date.
StageSummary RunBlendshapesBaselines(const BlendshapesBaselinesOptions& options,
                                     const StageContext& ctx, const io::Config& resolved);

// Runs blendshapes infer on rank 0 (the other ranks return an empty summary): the summary
// counts one file, the personalized rig, computed by this run.
StageSummary RunBlendshapesInfer(const BlendshapesInferOptions& options, const StageContext& ctx,
                                 const io::Config& resolved);

// Runs eval blendshapes on rank 0 (the other ranks return an empty summary): the summary,
// under the markdown option's path, counts one file, the metrics (the log's table, the
// markdown and shapes files when given, the JSON with json), computed by this run.
StageSummary RunEvalBlendshapes(const EvalBlendshapesOptions& options, const StageContext& ctx,
                                const io::Config& resolved);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_BLENDSHAPES_STAGE_H_
