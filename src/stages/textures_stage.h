// facecap eval textures, textures library and export textures: dynamic textures (paper 001
// Sec. 5, eq. 10-14).
//   eval textures: the strain texture on the held-out people of a textured scan database, PSNR
//     of albedo, specular and displacement against the true expression textures where the
//     expression moves the skin, beside the static neutral texture and per-blendshape maps, and
//     the library's size against theirs; one JSON object;
//   textures library: a person's dynamic texture library from their expression scans and skin
//     maps (compress and stretch maps fitted for the strain texture and the rig shapes'
//     influences), written as a textured rig that render draws and export textures plays;
//   export textures: a tracked take's dynamic textures (the strain texture at each frame's
//     weights) as EXR sequences of albedo, specular and displacement, frames spread across
//     ranks.
#ifndef FACECAP_STAGES_TEXTURES_STAGE_H_
#define FACECAP_STAGES_TEXTURES_STAGE_H_

#include <string>
#include <vector>

#include "io/config.h"
#include "stages/stage.h"

namespace facecap::stages {

// [eval.textures]
struct EvalTexturesOptions {
  std::string scans = "scans.h5";  // textured scan database (scans synth)
  float sharpness = 300.f;         // b of eq. 12, per cm
  bool json = true;                // print one JSON object (else a table)
  std::string out = "";            // also write the JSON to this file
  std::string maps = "";           // the first held-out person's maps (HDF5)
  std::string model = "";          // texture network model (textures train): the predicted rows

  template <class V>
  void Visit(V&& v) {
    v("scans", scans, "textured scan database (scans synth with texture_size > 0)");
    v("sharpness", sharpness, "b of eq. 12's softmax exp(b I) over the influence maps, per cm of edge length "
                              "change (the paper's equation: 1)");
    v("json", json, "print one JSON object (false: a readable table)");
    v("out", out, "also write the JSON object to this file (empty: none)");
    v("maps", maps, "HDF5 file for the first held-out person's maps: the library (/library/neutral, "
                    "compress, stretch [S, S, 5] of eq. 12-13, reference [S, S, 2], fitted_compress, "
                    "fitted_stretch; /library/shape_influence [N, V, 2]), the expressions' "
                    "influences (/influence/vertex [K, V, 2], /influence/texel [K, S, S, 2]; R compress, "
                    "G stretch) and textures (/textures/truth; /textures/dynamic, the strain texture of the library of "
                    "the other expressions; /textures/as_printed, eq. 14 as printed; /textures/per_blendshape "
                    "[K, S, S, 5]; with a model /textures/network, the networks' expression textures, and "
                    "/textures/predicted, the strain texture of the library made from them) (empty: none)");
    v("model", model, "texture network model (textures train): adds the rows of the networks' expression textures "
                      "and of the strain texture of the library made from them (empty: none)");
  }
  bool Check(std::string* why) const {
    if (scans.empty()) { *why = "scans must name a file"; return false; }
    if (!(sharpness > 0.f && sharpness <= 1000.f)) { *why = "sharpness must be in (0, 1000]"; return false; }
    return true;
  }
};

// [textures.library]
struct TexturesLibraryOptions {
  std::string scans = "scans.h5";  // scan database with skin maps
  std::string person = "0";        // the person: a name of /scans/people/names or an index
  std::string rig = "rig.h5";      // the person's rig
  float sharpness = 300.f;         // b of eq. 12, per cm
  std::string out = "library.h5";  // the library (a textured rig)

  template <class V>
  void Visit(V&& v) {
    v("scans", scans, "scan database with skin maps (scans synth, or scans import of meshes with their maps)");
    v("person", person, "the person whose expressions make the library: a name of /scans/people/names or an index");
    v("rig", rig, "the person's rig (blendshapes infer, or any rig of the database's topology); its mesh at a "
                  "frame's weights drives the strain texture");
    v("sharpness", sharpness, "b of eq. 12's softmax exp(b I) over the influence maps, per cm of edge length change "
                              "(the paper's equation: 1)");
    v("out", out, "the library: a textured rig (HDF5) with /dynamic_texture (T_N, T_C, T_S and the shapes' influences)");
  }
  bool Check(std::string* why) const {
    if (scans.empty() || rig.empty() || out.empty()) { *why = "scans, rig and out must name files"; return false; }
    if (person.empty()) { *why = "person must name a person or give an index"; return false; }
    if (!(sharpness > 0.f && sharpness <= 1000.f)) { *why = "sharpness must be in (0, 1000]"; return false; }
    return true;
  }
};

// [export.textures]
struct ExportTexturesOptions {
  std::string library = "library.h5";  // textures library output
  std::string track = "track.h5";      // tracked take
  std::string out = "textures";        // folder of the EXR sequences
  std::vector<std::string> layers = {"albedo", "specular", "displacement"};

  template <class V>
  void Visit(V&& v) {
    v("library", library, "dynamic texture library (textures library): the person's rig with its maps");
    v("track", track, "tracked take (track, or any file in its layout) whose weights drive the strain texture");
    v("out", out, "folder for the sequences OUT/<layer>.<frame, 5 digits>.exr (linear albedo RGB, specular, "
                  "displacement in mm); frames already there are kept");
    v("layers", layers, "layers to write: albedo, specular, displacement");
  }
  bool Check(std::string* why) const {
    if (library.empty() || track.empty() || out.empty()) { *why = "library, track and out must name files"; return false; }
    if (layers.empty()) { *why = "layers is empty"; return false; }
    for (const std::string& l : layers) {
      if (l != "albedo" && l != "specular" && l != "displacement") {
        *why = "layers must be albedo, specular or displacement, got '" + l + "'";
        return false;
      }
    }
    return true;
  }
};

// Runs eval textures on rank 0 (the other ranks return at once, with an empty summary): the
// summary counts one file, the JSON object (stdout, and out when given), computed by this run.
StageSummary RunEvalTextures(const EvalTexturesOptions& options, const StageContext& ctx,
                             const io::Config& resolved);

// Runs textures library on rank 0 (the other ranks return at once, with an empty summary):
// the summary counts one file, the library, computed unless it was already up to date.
StageSummary RunTexturesLibrary(const TexturesLibraryOptions& options, const StageContext& ctx,
                                const io::Config& resolved);

// Runs export textures on every rank of ctx.comm (collective): the summary counts the take's
// frames and those written by this run (frames whose every layer exists are kept), on every rank.
StageSummary RunExportTextures(const ExportTexturesOptions& options, const StageContext& ctx,
                               const io::Config& resolved);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_TEXTURES_STAGE_H_
