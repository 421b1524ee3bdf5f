// facecap eval textures: dynamic textures (paper 001 Sec. 5, eq. 10-14) on the held-out
// people of a textured scan database, against the true expression textures.
#include "stages/textures_stage.h"

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <iostream>
#include <sstream>

#include "io/atomic_file.h"
#include "io/dynamic_texture_file.h"
#include "io/image_io.h"
#include "io/rig_io.h"
#include "rig/evaluate.h"
#include "stages/frame_loop.h"
#include "stages/resumable.h"
#include "stages/rig_texture.h"
#include "stages/texture_networks.h"
#include "stages/tracked_rig.h"
#include "synth/skin_dynamics.h"
#include "textures/compress_stretch.h"
#include "textures/influence.h"
#include "util/errors.h"
#include "util/json.h"
#include "util/log.h"
#include "util/parallel_for.h"
#include "util/progress.h"

namespace facecap::stages {
namespace {

// Squared errors per layer (albedo over its 3 channels, specular, displacement in mm) over
// the texels of a region.
struct LayerErrors {
  double albedo = 0, specular = 0, displacement = 0;
  int64_t texels = 0;
  void Add(const float* truth, const float* estimate) {
    double a = 0;
    for (int c = 0; c < 3; ++c) a += (truth[c] - estimate[c]) * static_cast<double>(truth[c] - estimate[c]);
    albedo += a / 3.0;
    specular += (truth[3] - estimate[3]) * static_cast<double>(truth[3] - estimate[3]);
    displacement += (truth[4] - estimate[4]) * static_cast<double>(truth[4] - estimate[4]);
    ++texels;
  }
  // PSNR with peak 1 (albedo, specular) and 1 mm (displacement).
  static double Psnr(double sum, int64_t n) { return n ? -10.0 * std::log10(std::max(sum / n, 1e-20)) : 0.0; }
  std::string Json() const {
    return "{\"albedo_db\": " + JsonNumber(Psnr(albedo, texels)) + ", \"specular_db\": " +
           JsonNumber(Psnr(specular, texels)) + ", \"displacement_db\": " + JsonNumber(Psnr(displacement, texels)) + "}";
  }
};

// One person of the database: meshes (V x 3, cm) and skin maps (n x 5).
struct TexturedPerson {
  rig::Vertices neutral;
  std::vector<rig::Vertices> scans;        // K captured expressions (with capture noise)
  std::vector<rig::Vertices> clean;        // K noise-free expressions (truth)
  std::vector<rig::Vertices> shapes;       // N true blendshapes at weight 1
  Eigen::MatrixXf weights;                 // K x N true weights
  std::vector<float> neutral_maps;         // n x 5
  std::vector<std::vector<float>> expression_maps, shape_offsets;  // K and N of n x 5
};

TexturedPerson ReadTexturedPerson(const io::H5File& f, int j, int V, int K, int N, size_t texture_floats) {
  TexturedPerson p;
  auto mesh = [&](const float* d) { return rig::Vertices(Eigen::Map<const rig::Vertices>(d, V, 3)); };
  std::vector<float> buf(3 * static_cast<size_t>(V));
  f.ReadFrames<float>("/scans/people/neutral", j, 1, buf.data());
  p.neutral = mesh(buf.data());
  std::vector<float> e(3 * static_cast<size_t>(V) * K), d(3 * static_cast<size_t>(V) * N);
  f.ReadFrames<float>("/scans/people/expressions", j, 1, e.data());
  f.ReadFrames<float>("/scans/truth/deltas", j, 1, d.data());
  std::vector<float> w(static_cast<size_t>(K) * N);
  f.ReadFrames<float>("/scans/truth/weights", j, 1, w.data());
  p.weights = Eigen::Map<Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(w.data(), K, N);
  for (int i = 0; i < N; ++i) p.shapes.push_back(p.neutral + mesh(&d[3 * static_cast<size_t>(V) * i]));
  for (int k = 0; k < K; ++k) {
    p.scans.push_back(mesh(&e[3 * static_cast<size_t>(V) * k]));
    rig::Vertices c = p.neutral;
    for (int i = 0; i < N; ++i) {
      if (p.weights(k, i) != 0.f) c += p.weights(k, i) * mesh(&d[3 * static_cast<size_t>(V) * i]);
    }
    p.clean.push_back(c);
  }
  p.neutral_maps.resize(texture_floats);
  f.ReadFrames<float>("/scans/textures/neutral", j, 1, p.neutral_maps.data());
  std::vector<float> offsets(texture_floats * K), shape_offsets(texture_floats * N);
  f.ReadFrames<float>("/scans/textures/offsets", j, 1, offsets.data());
  f.ReadFrames<float>("/scans/truth/shape_offsets", j, 1, shape_offsets.data());
  for (int k = 0; k < K; ++k) {
    std::vector<float> t(offsets.begin() + k * texture_floats, offsets.begin() + (k + 1) * texture_floats);
    for (size_t i = 0; i < texture_floats; ++i) t[i] += p.neutral_maps[i];
    p.expression_maps.push_back(std::move(t));
  }
  for (int i = 0; i < N; ++i) {
    p.shape_offsets.emplace_back(shape_offsets.begin() + i * texture_floats, shape_offsets.begin() + (i + 1) * texture_floats);
  }
  return p;
}

std::vector<const float*> Pointers(const std::vector<std::vector<float>>& v) {
  std::vector<const float*> out;
  for (const auto& x : v) out.push_back(x.data());
  return out;
}

// Per-vertex influences as [count, V, 2] (compress, stretch).
std::vector<float> VertexInfluenceArray(const std::vector<textures::VertexInfluence>& influence) {
  std::vector<float> out;
  for (const auto& v : influence) {
    for (int x = 0; x < v.compress.size(); ++x) {
      out.push_back(v.compress[x]);
      out.push_back(v.stretch[x]);
    }
  }
  return out;
}

// What eval textures keeps of one person's expressions (K x S x S x 5 each): the strain
// texture, eq. 14 as printed, the per-blendshape maps and, with a model, the networks' textures
// and the strain texture of their library.
struct KeptMaps {
  std::vector<float> dynamic, printed, linear, network, predicted;
};

void WritePersonMaps(const StageContext& ctx, const io::Config& resolved, const std::string& path, int person, int S,
                     const TexturedPerson& p, const textures::CompressStretchMaps& eq13,
                     const textures::CompressStretchMaps& fitted,
                     const std::vector<textures::VertexInfluence>& scan_vertex,
                     const std::vector<std::vector<float>>& scan_texel,
                     const std::vector<textures::VertexInfluence>& shape_vertex, const KeptMaps& kept,
                     float sharpness) {
  const int64_t K = static_cast<int64_t>(scan_vertex.size()), N = static_cast<int64_t>(shape_vertex.size());
  const int64_t V = p.neutral.rows(), C = synth::kSkinChannels;
  io::H5File f = io::H5File::CreateAtomic(path);
  f.WriteProvenance(MakeProvenance(ctx, "eval textures", resolved));
  f.Write<float>("/library/neutral", {S, S, C}, p.neutral_maps.data());
  f.Write<float>("/library/compress", {S, S, C}, eq13.compress.data());
  f.Write<float>("/library/stretch", {S, S, C}, eq13.stretch.data());
  f.Write<float>("/library/reference", {S, S, 2}, eq13.reference.data());
  f.Write<float>("/library/fitted_compress", {S, S, C}, fitted.compress.data());
  f.Write<float>("/library/fitted_stretch", {S, S, C}, fitted.stretch.data());
  f.Write<float>("/library/shape_influence", {N, V, 2}, VertexInfluenceArray(shape_vertex).data());
  f.SetAttribute("/library/compress", "sharpness_per_cm", static_cast<double>(sharpness));
  f.SetAttribute("/library/compress", "person", static_cast<int64_t>(person));
  f.Write<float>("/influence/vertex", {K, V, 2}, VertexInfluenceArray(scan_vertex).data());
  std::vector<float> texel;
  for (const auto& m : scan_texel) texel.insert(texel.end(), m.begin(), m.end());
  f.Write<float>("/influence/texel", {K, S, S, 2}, texel.data());
  std::vector<float> truth;
  for (const auto& m : p.expression_maps) truth.insert(truth.end(), m.begin(), m.end());
  f.Write<float>("/textures/truth", {K, S, S, C}, truth.data());
  f.Write<float>("/textures/dynamic", {K, S, S, C}, kept.dynamic.data());
  f.Write<float>("/textures/as_printed", {K, S, S, C}, kept.printed.data());
  f.Write<float>("/textures/per_blendshape", {K, S, S, C}, kept.linear.data());
  if (!kept.network.empty()) {
    f.Write<float>("/textures/network", {K, S, S, C}, kept.network.data());
    f.Write<float>("/textures/predicted", {K, S, S, C}, kept.predicted.data());
  }
  for (const char* name : {"/library/neutral", "/textures/truth", "/textures/dynamic"}) {
    f.SetAttribute(name, "channels", std::string(io::kSkinMapChannelNames));
  }
  f.Commit();
}

// eval textures' error sums over the held-out people, one per method.
struct TextureScores {
  LayerErrors stat, dynamic, as_printed, in_sample, per_shape, network, predicted;
  bool model = false;  // network and predicted were scored
};

// eval textures' JSON (stdout with --json, and --out) or table, with the storage comparison.
void ReportEvalTextures(const EvalTexturesOptions& o, const TextureScores& scores, int people, int K, int N, int S) {
  const LayerErrors &stat = scores.stat, &dynamic = scores.dynamic, &as_printed = scores.as_printed,
                    &in_sample = scores.in_sample, &per_shape = scores.per_shape, &network = scores.network,
                    &predicted = scores.predicted;
  const bool model = scores.model;
  const size_t n = static_cast<size_t>(S) * S;
  const float b = o.sharpness;
  // Storage of the dynamic part: T_C and T_S with their reference influences (the rig gives the
  // runtime mesh), against one map per blendshape; the neutral map is needed by both.
  auto library_bytes = [&](double texels_n) { return texels_n * (2.0 * synth::kSkinChannels + 2.0) * 4; };
  auto per_shape_bytes = [&](double texels_n) { return static_cast<double>(N) * texels_n * synth::kSkinChannels * 4; };
  const double n1k = 1024.0 * 1024.0;
  std::ostringstream js;
  js << "{\"static_neutral\": " << stat.Json() << ", \"dynamic\": " << dynamic.Json()
     << ", \"eq14_as_printed\": " << as_printed.Json()
     << ", \"dynamic_in_sample\": " << in_sample.Json() << ", \"per_blendshape_maps\": " << per_shape.Json();
  if (model) {
    js << ", \"network_expressions\": " << network.Json() << ", \"dynamic_predicted\": " << predicted.Json()
       << ", \"model\": " << JsonString(o.model);
  }
  js
     << ", \"library_size_ratio\": " << JsonNumber(per_shape_bytes(static_cast<double>(n)) / library_bytes(static_cast<double>(n)))
     << ", \"library_size_ratio_1024\": " << JsonNumber(per_shape_bytes(n1k) / library_bytes(n1k))
     << ", \"library_mb\": " << JsonNumber(library_bytes(static_cast<double>(n)) / 1e6)
     << ", \"per_blendshape_maps_mb\": " << JsonNumber(per_shape_bytes(static_cast<double>(n)) / 1e6)
     << ", \"sharpness\": " << JsonNumber(b) << ", \"people\": " << people << ", \"expressions\": " << K
     << ", \"blendshapes\": " << N << ", \"texture_size\": " << S << ", \"texels\": " << dynamic.texels
     << ", \"region\": \"texels where the scored expression's true influence (eq. 10-11 on its noise-free "
        "mesh) is non-zero\", \"peaks\": \"albedo and specular 1, displacement 1 mm\""
     << ", \"dynamic_library\": \"compress and stretch maps fitted to the other expressions' scans and true "
        "textures (leave one out), the strain texture of the true blendshapes' mesh at the true weights; eq. 14 "
        "as printed: eq. 12-13's maps of the same expressions, the true blendshapes' influences\"}";
  if (o.json) {
    std::cout << js.str() << std::endl;
  } else {
    auto row = [](const char* name, const LayerErrors& e) {
      std::printf("  %-34s %6.2f %6.2f %6.2f\n", name, LayerErrors::Psnr(e.albedo, e.texels),
                  LayerErrors::Psnr(e.specular, e.texels), LayerErrors::Psnr(e.displacement, e.texels));
    };
    std::printf("PSNR (dB) against the true expression textures, %d held-out people x %d expressions, "
                "where the expression moves the skin:\n  %-34s %6s %6s %6s\n",
                people, K, "", "albedo", "spec", "disp");
    row("static neutral", stat);
    row("dynamic (strain, leave one out)", dynamic);
    row("eq. 14 as printed (leave one out)", as_printed);
    row("dynamic (strain, all expressions)", in_sample);
    row("per-blendshape maps", per_shape);
    if (model) {
      row("network expression textures", network);
      row("dynamic (strain, predicted)", predicted);
    }
    std::printf("library %.2f MB against %.2f MB of per-blendshape maps (%.1fx; %.1fx at 1024^2)\n",
                library_bytes(static_cast<double>(n)) / 1e6, per_shape_bytes(static_cast<double>(n)) / 1e6,
                per_shape_bytes(static_cast<double>(n)) / library_bytes(static_cast<double>(n)),
                per_shape_bytes(n1k) / library_bytes(n1k));
  }
  if (!o.out.empty()) io::WriteFileAtomically(o.out, js.str() + "\n");
}

}  // namespace

StageSummary RunEvalTextures(const EvalTexturesOptions& o, const StageContext& ctx,
                             const io::Config& resolved) {
  StageSummary summary{o.out, "files", 0, 0};
  if (!ctx.comm.IsMainRank()) return summary;
  const io::H5File f = io::H5File::OpenRead(o.scans);
  if (!f.Exists("/scans/textures/neutral") || !f.Exists("/scans/truth/shape_offsets")) {
    throw FileIOError(o.scans + ": no skin maps (/scans/textures, /scans/truth/shape_offsets); make it with "
                      "scans synth and texture_size > 0");
  }
  const rig::Rig topology = io::ReadRigFile(o.scans, "/template");
  const auto tshape = f.DatasetShape("/scans/textures/neutral");
  const auto dshape = f.DatasetShape("/scans/truth/deltas");
  const auto eshape = f.DatasetShape("/scans/people/expressions");
  if (tshape.size() != 4 || tshape[3] != synth::kSkinChannels || tshape[1] != tshape[2] || dshape.size() != 4 ||
      eshape.size() != 4) {
    throw FileIOError(o.scans + ": skin maps or meshes of an unexpected shape");
  }
  const int P = static_cast<int>(tshape[0]), S = static_cast<int>(tshape[1]);
  const int N = static_cast<int>(dshape[1]), K = static_cast<int>(eshape[1]), V = topology.NumVertices();
  const size_t n = static_cast<size_t>(S) * S, texture_floats = n * synth::kSkinChannels;
  const std::vector<int32_t> split = f.ReadVector<int32_t>("/scans/people/split", P);
  const textures::TexelInterpolator texels(topology, S);
  const textures::OneRing ring = textures::BuildOneRing(topology.triangles, V);
  const float b = o.sharpness;
  // Methods: the static neutral; the strain texture with a library from the other K - 1
  // expressions (leave one out) and from all K; eq. 14 as printed with the leave-one-out
  // library; per-blendshape maps blended linearly by the weights.
  TextureScores scores;
  LayerErrors &stat = scores.stat, &dynamic = scores.dynamic, &as_printed = scores.as_printed,
              &in_sample = scores.in_sample, &per_shape = scores.per_shape, &network = scores.network,
              &predicted = scores.predicted;
  std::unique_ptr<TextureModel> model;
  if (!o.model.empty()) {
    model = std::make_unique<TextureModel>(o.model);
    if (model->size() != S || model->template_rig().NumVertices() != V) {
      throw InvalidInputError(o.model + ": a model for " + std::to_string(model->size()) + "^2 maps and " +
                              std::to_string(model->template_rig().NumVertices()) + " vertices; " + o.scans + " has " +
                              std::to_string(S) + "^2 and " + std::to_string(V));
    }
  }
  int people = 0;
  for (int j = 0; j < P; ++j) {
    if (split[j] != 1) continue;
    ++people;
    const TexturedPerson p = ReadTexturedPerson(f, j, V, K, N, texture_floats);
    const Eigen::VectorXf en = textures::MeanEdgeLength(ring, p.neutral);
    auto vertex_influence = [&](const rig::Vertices& mesh) {
      return textures::InfluenceValues(en, textures::MeanEdgeLength(ring, mesh));
    };
    auto influence = [&](const rig::Vertices& mesh) { return textures::InfluenceMap(texels, vertex_influence(mesh)); };
    std::vector<textures::VertexInfluence> scan_vertex, shape_vertex;
    std::vector<std::vector<float>> scan_influence, shape_influence;
    for (const auto& m : p.scans) {
      scan_vertex.push_back(vertex_influence(m));
      scan_influence.push_back(textures::InfluenceMap(texels, scan_vertex.back()));
    }
    for (const auto& m : p.shapes) {
      shape_vertex.push_back(vertex_influence(m));
      shape_influence.push_back(textures::InfluenceMap(texels, shape_vertex.back()));
    }
    const bool keep = !o.maps.empty() && people == 1;
    std::vector<float> kept_dynamic, kept_linear, kept_printed;
    const int C = synth::kSkinChannels;
    const auto eq13 = textures::ExtractCompressStretch(Pointers(scan_influence), Pointers(p.expression_maps), n, C, b);
    const auto all = textures::FitCompressStretch(Pointers(scan_influence), Pointers(p.expression_maps),
                                                  p.neutral_maps, n, C, b);
    const textures::StrainTexture strain_all(n, C, p.neutral_maps, all);
    // The networks' textures of the person's expression scans, and the library made of them.
    std::vector<std::vector<float>> net_maps(model ? K : 0);
    std::unique_ptr<textures::StrainTexture> strain_net;
    if (model) {
      ParallelFor(0, K, ThreadsPerRank(0), [&](int k) { net_maps[k] = model->ExpressionMaps(p.neutral, p.neutral_maps, p.scans[k]); });
      strain_net = std::make_unique<textures::StrainTexture>(
          n, C, p.neutral_maps,
          textures::FitCompressStretch(Pointers(scan_influence), Pointers(net_maps), p.neutral_maps, n, C, b));
    }
    std::vector<float> kept_network, kept_predicted;
    for (int k = 0; k < K; ++k) {
      std::vector<std::vector<float>> others_influence, others_maps;
      for (int i = 0; i < K; ++i) {
        if (i == k) continue;
        others_influence.push_back(scan_influence[i]);
        others_maps.push_back(p.expression_maps[i]);
      }
      // Leave one out: the library of the other expressions, as the strain texture and as eq. 14
      // as printed (eq. 12-13 maps, the blendshapes' influences).
      const textures::StrainTexture strain(
          n, C, p.neutral_maps,
          textures::FitCompressStretch(Pointers(others_influence), Pointers(others_maps), p.neutral_maps, n, C, b));
      const textures::DynamicTexture printed(
          n, C, p.neutral_maps,
          textures::ExtractCompressStretch(Pointers(others_influence), Pointers(others_maps), n, C, b),
          Pointers(shape_influence), b);
      std::vector<float> alpha(N);
      for (int i = 0; i < N; ++i) alpha[i] = p.weights(k, i);
      // The runtime mesh: the true blendshapes at the expression's weights.
      rig::Vertices mesh = p.neutral;
      for (int i = 0; i < N; ++i) {
        if (alpha[i] != 0.f) mesh += alpha[i] * (p.shapes[i] - p.neutral);
      }
      const std::vector<float> now = influence(mesh);
      const std::vector<float> est = strain.Evaluate(now), est_all = strain_all.Evaluate(now);
      const std::vector<float> est_printed = printed.Evaluate(alpha);
      std::vector<float> linear = p.neutral_maps;
      for (int i = 0; i < N; ++i) {
        if (alpha[i] == 0.f) continue;
        for (size_t t = 0; t < texture_floats; ++t) linear[t] += alpha[i] * p.shape_offsets[i][t];
      }
      const std::vector<float> est_net = strain_net ? strain_net->Evaluate(now) : std::vector<float>();
      if (keep) {
        kept_dynamic.insert(kept_dynamic.end(), est.begin(), est.end());
        kept_printed.insert(kept_printed.end(), est_printed.begin(), est_printed.end());
        kept_linear.insert(kept_linear.end(), linear.begin(), linear.end());
        if (model) {
          kept_network.insert(kept_network.end(), net_maps[k].begin(), net_maps[k].end());
          kept_predicted.insert(kept_predicted.end(), est_net.begin(), est_net.end());
        }
      }
      const std::vector<float> region = influence(p.clean[k]);
      const float* truth = p.expression_maps[k].data();
      for (size_t t = 0; t < n; ++t) {
        if (!texels.Covered(static_cast<int>(t)) || region[2 * t] + region[2 * t + 1] <= 0.f) continue;
        const size_t at = t * synth::kSkinChannels;
        stat.Add(truth + at, p.neutral_maps.data() + at);
        dynamic.Add(truth + at, est.data() + at);
        as_printed.Add(truth + at, est_printed.data() + at);
        in_sample.Add(truth + at, est_all.data() + at);
        per_shape.Add(truth + at, linear.data() + at);
        if (model) {
          network.Add(truth + at, net_maps[k].data() + at);
          predicted.Add(truth + at, est_net.data() + at);
        }
      }
    }
    if (keep) {
      WritePersonMaps(ctx, resolved, o.maps, j, S, p, eq13, all, scan_vertex, scan_influence, shape_vertex,
                      {kept_dynamic, kept_printed, kept_linear, kept_network, kept_predicted}, b);
    }
    FC_INFO("eval textures: person {} of {} held out", people, P);
  }
  if (people == 0) throw FileIOError(o.scans + ": no held-out people");
  scores.model = model != nullptr;
  ReportEvalTextures(o, scores, people, K, N, S);
  summary.items = 1;
  summary.computed = 1;
  return summary;
}

StageSummary RunTexturesLibrary(const TexturesLibraryOptions& o, const StageContext& ctx,
                                const io::Config& resolved) {
  StageSummary summary{o.out, "files", 0, 0};
  if (!ctx.comm.IsMainRank()) return summary;
  const io::H5File f = io::H5File::OpenRead(o.scans);
  if (!f.Exists("/scans/textures/neutral")) {
    throw FileIOError(o.scans + ": no skin maps (/scans/textures); make it with scans synth (texture_size > 0) or "
                      "scans import of meshes with maps beside them");
  }
  const rig::Rig rig = io::ReadRigFile(o.rig);
  const auto tshape = f.DatasetShape("/scans/textures/neutral");
  const auto eshape = f.DatasetShape("/scans/people/expressions");
  const int P = static_cast<int>(tshape[0]), S = static_cast<int>(tshape[1]), K = static_cast<int>(eshape[1]);
  const int V = rig.NumVertices(), N = rig.NumShapes();
  if (eshape[2] != V) {
    throw InvalidInputError(o.rig + ": " + std::to_string(V) + " vertices, the scans of " + o.scans + " have " +
                            std::to_string(eshape[2]));
  }
  const int j = ScanPersonIndex(f, o.scans, o.person, P);
  ResumableOutput output = OpenResumableOutput(o.out, resolved.ToToml(), MakeProvenance(ctx, "textures library", resolved));
  summary.items = 1;
  if (output.up_to_date) {
    FC_INFO("textures library: {} is up to date", o.out);
    return summary;
  }
  const size_t floats = static_cast<size_t>(S) * S * synth::kSkinChannels;
  auto mesh = [&](const float* d) { return rig::Vertices(Eigen::Map<const rig::Vertices>(d, V, 3)); };
  std::vector<float> buf(3 * static_cast<size_t>(V) * K);
  f.ReadFrames<float>("/scans/people/neutral", j, 1, buf.data());
  const rig::Vertices neutral = mesh(buf.data());
  f.ReadFrames<float>("/scans/people/expressions", j, 1, buf.data());
  std::vector<float> neutral_maps(floats), offsets(floats * K);
  f.ReadFrames<float>("/scans/textures/neutral", j, 1, neutral_maps.data());
  f.ReadFrames<float>("/scans/textures/offsets", j, 1, offsets.data());
  std::vector<rig::Vertices> expressions;
  std::vector<std::vector<float>> maps;
  for (int k = 0; k < K; ++k) {
    expressions.push_back(mesh(&buf[3 * static_cast<size_t>(V) * k]));
    std::vector<float> t(offsets.begin() + k * floats, offsets.begin() + (k + 1) * floats);
    for (size_t i = 0; i < floats; ++i) t[i] += neutral_maps[i];
    maps.push_back(std::move(t));
  }
  const io::DynamicTextureLibrary lib =
      MakeDynamicTextureLibrary(rig, neutral, expressions, std::move(neutral_maps), maps, S, o.sharpness);
  io::WriteRig(rig, &output.file);
  io::WriteDynamicTextureLibrary(&output.file, lib);
  output.file.Commit();
  FC_INFO("textures library: person {} of {}, {} expressions, {} shapes, {}x{} maps -> {}", j, o.scans, K, N, S, S,
          o.out);
  summary.computed = 1;
  return summary;
}

StageSummary RunExportTextures(const ExportTexturesOptions& o, const StageContext& ctx,
                               const io::Config& /*resolved*/) {
  const dist::Comm& comm = ctx.comm;
  rig::Rig rig;
  std::unique_ptr<textures::RigStrainTexture> dynamic;
  std::unique_ptr<TrackedRig> track;
  int S = 0;
  dist::CoordinateExceptions(comm, [&] {
    rig = io::ReadRigFile(o.library);
    dynamic = ReadRigDynamicTexture(o.library, rig, &S);
    if (!dynamic) throw FileIOError(o.library + ": no /dynamic_texture; make the library with textures library");
    track = std::make_unique<TrackedRig>(o.track, rig);
    std::filesystem::create_directories(o.out);
  });
  const int64_t F = track->NumFrames();
  const dist::Range mine = dist::BlockRange(F, comm.rank(), comm.size());
  auto frame_path = [&](const std::string& layer, int64_t frame) {
    char name[64];
    std::snprintf(name, sizeof(name), "%s.%05lld.exr", layer.c_str(), static_cast<long long>(frame));
    return (std::filesystem::path(o.out) / name).string();
  };
  int64_t done = 0, kept = 0;
  Progress progress("export textures", mine.end - mine.begin, 0, 5.0, comm.IsMainRank());
  dist::CoordinateExceptions(comm, [&] {
    for (int64_t frame = mine.begin; frame < mine.end; ++frame) {
      bool all_there = true;
      for (const std::string& l : o.layers) all_there = all_there && std::filesystem::exists(frame_path(l, frame));
      if (all_there) {
        ++kept;
      } else {
        const Eigen::VectorXf w = track->Weights(frame);
        const std::vector<float> maps = dynamic->Evaluate(std::vector<float>(w.data(), w.data() + w.size()));
        for (const std::string& l : o.layers) {
          const int first = l == "albedo" ? 0 : l == "specular" ? 3 : 4;
          io::WriteImage(frame_path(l, frame), io::SkinMapLayer(maps, S, first, l == "albedo" ? 3 : 1));
        }
      }
      progress.Update(++done);
    }
    progress.Finish();
  });
  double total_kept = static_cast<double>(kept);
  comm.SumReduce(&total_kept, 1);
  if (comm.IsMainRank()) {
    FC_INFO("export textures: {} frames x {} layers at {}x{} -> {} ({} kept from an earlier run)", F, o.layers.size(), S,
            S, o.out, total_kept);
  }
  return StageSummary{o.out, "frames", F, F - static_cast<int64_t>(total_kept)};
}

}  // namespace facecap::stages
