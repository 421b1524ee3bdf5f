// facecap textures train / infer: the expression texture networks (paper 001 Sec. 5.2, Fig.
// 7) trained on a textured scan database with the training controller, and a person's dynamic
// texture library made from their predicted expression textures (eq. 12-13).
//   textures train: the networks on a textured scan database's training people (the first
//     predicts an expression's albedo offset from the neutral maps, the neutral geometry image
//     and the expression's offset geometry image and influences; the second the specular and
//     displacement offsets from those and the first's prediction); data-parallel over ranks
//     (gradient allreduce), checkpoints, resume;
//   textures infer: a person's dynamic texture library from their neutral skin maps and rig
//     alone (the networks predict the textures of the model's FACS expressions of the rig, and
//     compress and stretch maps are fitted to them for the strain texture).
#ifndef FACECAP_STAGES_TEXTURES_NET_STAGE_H_
#define FACECAP_STAGES_TEXTURES_NET_STAGE_H_

#include <string>
#include <utility>
#include <vector>

#include "io/config.h"
#include "nn/texture_net.h"
#include "stages/stage.h"

namespace facecap::stages {

// [textures.train]
struct TexturesTrainOptions {
  std::string scans = "scans.h5";      // textured scan database
  std::string out = "texnet.h5";       // trained model
  int epochs = 24;                     // passes over the training people's expressions
  int batch = 8;                       // expressions per optimizer step, all ranks together
  float low_frequency_sigma = 2.f;     // blur of the displacement's low-frequency part, texels
  int checkpoint_every = 100;          // steps between checkpoints
  double progress_seconds = 10;        // interval of the progress lines
  int threads = 0;                     // tensor threads per rank (0: the cores divided among ranks)
  int seed = 1;                        // batch order seed
  nn::TextureNetOptions net;

  static std::vector<std::pair<std::string, std::string>> HelpSections() {
    return {{"scans", "Data and schedule"}, {"model.channels", "Networks and optimizer"}};
  }
  template <class V>
  void Visit(V&& v) {
    v("scans", scans, "textured scan database (scans synth with texture_size > 0, or scans import of meshes with "
                      "their skin maps); its training people (split 0) are learnt, at its maps' resolution");
    v("out", out, "trained model (HDF5)");
    v("epochs", epochs, "passes over every training person's expressions");
    v("batch", batch, "expressions per optimizer step, all ranks together");
    v("low_frequency_sigma", low_frequency_sigma,
      "standard deviation in texels of the Gaussian blur that splits the displacement offset into the low-frequency "
      "part and the high-frequency rest, which the second network predicts as two channels");
    v("checkpoint_every", checkpoint_every, "optimizer steps between checkpoints");
    v("progress_seconds", progress_seconds, "seconds between progress lines");
    v("threads", threads, "tensor threads per rank (0: the cores divided among the node's ranks)");
    v("seed", seed, "batch order seed");
    io::VisitGroup("model", net, v);
  }
  bool Check(std::string* why) const {
    if (scans.empty() || out.empty()) { *why = "scans and out must name files"; return false; }
    if (epochs < 1) { *why = "epochs must be >= 1"; return false; }
    if (batch < 1) { *why = "batch must be >= 1"; return false; }
    if (!(low_frequency_sigma > 0.f && low_frequency_sigma <= 64.f)) { *why = "low_frequency_sigma must be in (0, 64]"; return false; }
    if (checkpoint_every < 1) { *why = "checkpoint_every must be >= 1"; return false; }
    if (!(progress_seconds > 0)) { *why = "progress_seconds must be positive"; return false; }
    if (threads < 0) { *why = "threads must be >= 0"; return false; }
    return net.Check(why);
  }
};

// [textures.infer]
struct TexturesInferOptions {
  std::string model = "texnet.h5";  // textures train output
  std::string rig = "rig.h5";       // the person's rig
  std::string scans = "scans.h5";   // where the person's neutral skin maps are
  std::string person = "0";         // the person in it
  float sharpness = 300.f;          // b of eq. 12, per cm
  std::string out = "library.h5";   // the library (a textured rig)

  template <class V>
  void Visit(V&& v) {
    v("model", model, "texture network model (textures train)");
    v("rig", rig, "the person's rig (blendshapes infer, or any rig of the model's topology): its neutral and its "
                  "shapes at the model's FACS weights are the expressions whose textures the networks predict");
    v("scans", scans, "scan database holding the person's neutral skin maps (scans import of the neutral scan with its "
                      "maps, or scans synth)");
    v("person", person, "the person in scans: a name of /scans/people/names or an index");
    v("sharpness", sharpness, "b of eq. 12's softmax exp(b I) over the influence maps, per cm of edge length change "
                              "(the paper's equation: 1)");
    v("out", out, "the library: a textured rig (HDF5) with /dynamic_texture (T_N, T_C, T_S and the shapes' "
                  "influences) made from the predicted expression textures, and /predicted [K, S, S, 5] with them");
  }
  bool Check(std::string* why) const {
    if (model.empty() || rig.empty() || scans.empty() || out.empty()) { *why = "model, rig, scans and out must name files"; return false; }
    if (person.empty()) { *why = "person must name a person or give an index"; return false; }
    if (!(sharpness > 0.f && sharpness <= 1000.f)) { *why = "sharpness must be in (0, 1000]"; return false; }
    return true;
  }
};

// Trains the networks on every rank of ctx.comm (collective): the summary counts the
// training's optimizer steps and those this run made (0 when the model was up to date).
StageSummary RunTexturesTrain(const TexturesTrainOptions& options, const StageContext& ctx,
                              const io::Config& resolved);

// Runs textures infer on rank 0 (the other ranks return at once, with an empty summary): the
// summary counts one file, the library, computed unless it was already up to date.
StageSummary RunTexturesInfer(const TexturesInferOptions& options, const StageContext& ctx,
                              const io::Config& resolved);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_TEXTURES_NET_STAGE_H_
