// facecap scans synth | import: the scan database (paper 001 Sec. 4, Sec. 7) in one HDF5
// layout, synthetic with known personal shapes or imported from registered OBJ meshes.
//
// scans.h5:
//   /template (rig.h5 layout)           the N template shapes S_i on the template neutral S_0
//   /scans/shape_names [N]              /scans/facs/names [K], /scans/facs/weights [K, N] (0/1)
//   /scans/people/neutral [P, V, 3]     /scans/people/expressions [P, K, V, 3] (cm)
//   /scans/people/split [P] (0 train, 1 held out)
//   /scans/truth/deltas [P, N, V, 3], /scans/truth/weights [P, K, N]   (synthetic only)
//   /scans/truth/global_factors [P, N] (g_ij), /scans/truth/personal_factors [P, N] (e_ij),
//   /scans/truth/personal_vertices [X] (the x where the personal form applies; attribute
//   personal_strength s): the terms of scan_database.h's S_i^j, for analyses of what a
//   neutral can predict (analysis/blendshapes_ceiling.py)   (synthetic only)
//   /scans/textures/neutral [P, S, S, 5]      the neutral skin maps in the template's UV layout
//   /scans/textures/offsets [P, K, S, S, 5]   each expression's maps minus the neutral's
//     channels albedo R, G, B (linear), specular intensity, displacement (mm along the
//     normal); synth/skin_dynamics.h makes them from the noise-free expression's strain
//   /scans/truth/skin [P, 5]                   age, wrinkle depth (mm), wrinkle frequency
//     (1/cm), flush, blanch: the person's skin dynamics   (synthetic with textures only)
//   /scans/truth/shape_offsets [P, N, S, S, 5] each true blendshape's maps at weight 1 minus
//     the neutral's   (synthetic with textures only)
// scans import writes /scans/textures from the maps beside each mesh (attribute
// imported_layers: the layers found beside the first neutral; the others are 0).
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>

#include "stages/scans_stage.h"

#include "assets/geometry_image.h"
#include "assets/scan_database.h"
#include "assets/template_shapes.h"
#include "io/dynamic_texture_file.h"
#include "io/image_io.h"
#include "io/mesh_io.h"
#include "io/rig_io.h"
#include "render/shading.h"
#include "rig/demo_head.h"
#include "stages/frame_loop.h"
#include "stages/resumable.h"
#include "synth/skin_dynamics.h"
#include "util/errors.h"
#include "util/log.h"
#include "util/parallel_for.h"

namespace facecap::stages {
namespace {

void WriteDatabaseHeader(io::H5File* f, const assets::LinearShapes& tmpl, const rig::Rig& topology,
                         const std::vector<assets::FacsExpression>& table, const Eigen::MatrixXf& alpha,
                         int people) {
  io::WriteRig(assets::RigFromLinearShapes(tmpl, topology), f, "/template");
  f->WriteStrings("/scans/shape_names", tmpl.names);
  std::vector<std::string> names;
  for (const auto& e : table) names.push_back(e.name);
  f->WriteStrings("/scans/facs/names", names);
  f->WriteMatrix("/scans/facs/weights", alpha);
  const int64_t V = tmpl.NumVertices(), K = alpha.rows();
  f->CreateFrames<float>("/scans/people/neutral", {V, 3}, people, 1);
  f->CreateFrames<float>("/scans/people/expressions", {K, V, 3}, people, 1);
  f->SetAttribute("/scans/people/neutral", "units", std::string("cm"));
  f->SetAttribute("/scans/people/expressions", "units", std::string("cm"));
}

// Person j's skin maps: the neutral (S^2 x 5) followed by each expression's offset from it
// (K x S^2 x 5), the expressions' strain taken on their noise-free meshes, then each true
// blendshape's offset at weight 1 (N x S^2 x 5); and the person's skin parameters.
struct PersonTextures {
  std::vector<float> maps;
  std::vector<float> skin;
};
PersonTextures SynthesizePersonTextures(const rig::Rig& head, const textures::OneRing& ring,
                                        const textures::TexelInterpolator& texels, const assets::ScanPerson& person,
                                        uint64_t seed) {
  const int V = head.NumVertices(), K = static_cast<int>(person.true_weights.rows());
  const synth::PersonColors colors = synth::DrawPersonColors(seed);
  const synth::SkinDynamics skin = synth::DrawSkinDynamics(seed + 1);
  const std::vector<float> neutral = synth::NeutralSkinMaps(head, texels, colors, skin, seed + 2);
  auto mesh = [&](const Eigen::VectorXf& column) {
    return rig::Vertices(Eigen::Map<const rig::Vertices>(column.data(), V, 3));
  };
  const Eigen::VectorXf en = textures::MeanEdgeLength(ring, mesh(person.neutral));
  PersonTextures out;
  out.maps = neutral;
  std::vector<float> compress, stretch;
  for (int k = 0; k < K; ++k) {
    const Eigen::VectorXf clean = person.neutral + person.true_deltas * person.true_weights.row(k).transpose();
    synth::RelativeStrain(ring, texels, en, mesh(clean), &compress, &stretch);
    const std::vector<float> e = synth::ExpressionSkinMaps(neutral, texels, skin, compress, stretch);
    for (size_t i = 0; i < e.size(); ++i) out.maps.push_back(e[i] - neutral[i]);
  }
  for (int s = 0; s < person.true_deltas.cols(); ++s) {
    synth::RelativeStrain(ring, texels, en, mesh(person.neutral + person.true_deltas.col(s)), &compress, &stretch);
    const std::vector<float> e = synth::ExpressionSkinMaps(neutral, texels, skin, compress, stretch);
    for (size_t i = 0; i < e.size(); ++i) out.maps.push_back(e[i] - neutral[i]);
  }
  out.skin = {skin.age, skin.wrinkle_depth_mm, skin.wrinkle_frequency, skin.flush, skin.blanch};
  return out;
}

static_assert(synth::kSkinChannels == io::kSkinMapChannels, "skin maps have the file layout's channels");

// /scans/textures/neutral [P, S, S, 5] and /scans/textures/offsets [P, K, S, S, 5] with their
// attributes; `imported_layers` (scans import) is recorded when not empty.
void CreateSkinMapDatasets(io::H5File* f, int P, int K, int S, const std::string& imported_layers) {
  f->CreateFrames<float>("/scans/textures/neutral", {S, S, synth::kSkinChannels}, P, 1);
  f->CreateFrames<float>("/scans/textures/offsets", {K, S, S, synth::kSkinChannels}, P, 1);
  for (const char* name : {"/scans/textures/neutral", "/scans/textures/offsets"}) {
    f->SetAttribute(name, "channels", std::string(io::kSkinMapChannelNames));
    f->SetAttribute(name, "layout", std::string("the template's UV layout, row 0 at v = 1 (OBJ convention)"));
    if (!imported_layers.empty()) f->SetAttribute(name, "imported_layers", imported_layers);
  }
}

}  // namespace

StageSummary RunScansSynth(const ScansSynthOptions& o, const StageContext& ctx,
                           const io::Config& resolved) {
  const dist::Comm& comm = ctx.comm;
  std::vector<assets::FacsExpression> table;
  Eigen::MatrixXf alpha;
  rig::Rig head;
  assets::LinearShapes tmpl;
  dist::CoordinateExceptions(comm, [&] {
    rig::DemoHeadOptions ho;
    ho.resolution = o.head_resolution;
    head = rig::MakeDemoHead(ho);
    tmpl = assets::MakeTemplateShapes(head);
    table = assets::ParseFacsTable(o.facs);
    alpha = assets::FacsWeights(table, tmpl.names, true);
  });
  const std::vector<int> personal = assets::ChartVertices(head, assets::MovingVertices(tmpl));
  // Rank 0 writes; every rank synthesizes its block of people (cheap, deterministic per person).
  ResumableOutput output;
  int up_to_date = 0;
  dist::CoordinateExceptions(comm, [&] {
    if (!comm.IsMainRank()) return;
    output = OpenResumableOutput(o.out, resolved.ToToml(), MakeProvenance(ctx, "scans synth", resolved));
    up_to_date = output.up_to_date ? 1 : 0;
  });
  comm.Broadcast(&up_to_date, sizeof(up_to_date));
  if (up_to_date) {
    if (comm.IsMainRank()) FC_INFO("scans synth: {} is up to date", o.out);
    return StageSummary{o.out, "people", o.people, 0};
  }
  const int P = o.people, V = tmpl.NumVertices(), N = tmpl.NumShapes(), K = static_cast<int>(alpha.rows());
  const dist::Range mine = dist::BlockRange(P, comm.rank(), comm.size());
  std::vector<assets::ScanPerson> people(mine.end - mine.begin);
  std::vector<PersonTextures> person_textures(people.size());
  const int S = o.texture_size;
  std::unique_ptr<textures::TexelInterpolator> texels;
  const textures::OneRing ring = textures::BuildOneRing(head.triangles, head.NumVertices());
  if (S > 0) texels = std::make_unique<textures::TexelInterpolator>(head, S);
  ParallelFor(0, static_cast<int>(people.size()), ThreadsPerRank(o.threads), [&](int k) {
    const int j = static_cast<int>(mine.begin) + k;
    people[k] = assets::SynthesizeScanPerson(head, tmpl, personal, alpha, j, o.synth);
    if (texels) {
      const uint64_t seed = static_cast<uint64_t>(o.synth.seed) * 1000003u + static_cast<uint64_t>(j) * 7919u + 17u;
      person_textures[k] = SynthesizePersonTextures(head, ring, *texels, people[k], seed);
    }
  });
  // Gather to rank 0 as bytes.
  std::vector<uint8_t> bytes;
  for (size_t k = 0; k < people.size(); ++k) {
    const assets::ScanPerson& p = people[k];
    auto put = [&](const float* data, size_t n) {
      const uint8_t* b = reinterpret_cast<const uint8_t*>(data);
      bytes.insert(bytes.end(), b, b + n * sizeof(float));
    };
    put(p.neutral.data(), p.neutral.size());
    put(p.expressions.data(), p.expressions.size());
    put(p.true_deltas.data(), p.true_deltas.size());
    put(p.true_weights.data(), p.true_weights.size());  // column-major K x N
    put(p.global_factors.data(), p.global_factors.size());
    put(p.personal_factors.data(), p.personal_factors.size());
    put(person_textures[k].maps.data(), person_textures[k].maps.size());
    put(person_textures[k].skin.data(), person_textures[k].skin.size());
  }
  const auto gathered = comm.Gather(bytes);
  dist::CoordinateExceptions(comm, [&] {
    if (!comm.IsMainRank()) return;
    io::H5File& f = output.file;
    WriteDatabaseHeader(&f, tmpl, head, table, alpha, P);
    f.CreateFrames<float>("/scans/truth/deltas", {N, V, 3}, P, 1);
    f.CreateFrames<float>("/scans/truth/weights", {K, N}, P, 16);
    f.CreateFrames<float>("/scans/truth/global_factors", {N}, P, 64);
    f.CreateFrames<float>("/scans/truth/personal_factors", {N}, P, 64);
    f.WriteVector<int32_t>("/scans/truth/personal_vertices", personal);
    f.SetAttribute("/scans/truth/personal_vertices", "personal_strength", static_cast<double>(o.synth.personal_strength));
    std::vector<int32_t> split(P, 0);
    for (int j = P - o.test_people; j < P; ++j) split[j] = 1;
    f.WriteVector<int32_t>("/scans/people/split", split);
    f.SetAttribute("/scans/people/split", "values", std::string("0 training, 1 held out"));
    const size_t texture_floats = static_cast<size_t>(S) * S * synth::kSkinChannels;
    const int skin_parameters = S > 0 ? synth::SkinDynamics::kNumParameters : 0;
    if (S > 0) {
      CreateSkinMapDatasets(&f, P, K, S, "");
      f.CreateFrames<float>("/scans/truth/shape_offsets", {N, S, S, synth::kSkinChannels}, P, 1);
      f.SetAttribute("/scans/truth/shape_offsets", "channels", std::string(io::kSkinMapChannelNames));
      f.CreateFrames<float>("/scans/truth/skin", {skin_parameters}, P, 64);
      f.SetAttribute("/scans/truth/skin", "columns", std::string("age wrinkle_depth_mm wrinkle_frequency_per_cm flush blanch"));
    }
    int person = 0;
    for (const auto& chunk : gathered) {
      size_t at = 0;
      const size_t per_person = sizeof(float) * (3 * V + 3 * V * K + 3 * V * N + K * N + 2 * N +
                                                 (K + N + 1) * texture_floats + skin_parameters);
      for (; at + per_person <= chunk.size(); at += per_person, ++person) {
        const float* d = reinterpret_cast<const float*>(chunk.data() + at);
        f.WriteFrames<float>("/scans/people/neutral", person, 1, d);
        f.WriteFrames<float>("/scans/people/expressions", person, 1, d + 3 * V);  // [K][V*3]
        // true deltas: 3V x N column-major = [N][V*3]
        f.WriteFrames<float>("/scans/truth/deltas", person, 1, d + 3 * V + 3 * V * K);
        Eigen::Map<const Eigen::MatrixXf> w(d + 3 * V + 3 * V * K + 3 * V * N, K, N);
        Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> wr = w;
        f.WriteFrames<float>("/scans/truth/weights", person, 1, wr.data());
        const float* factors = d + 3 * V + 3 * V * K + 3 * V * N + K * N;
        f.WriteFrames<float>("/scans/truth/global_factors", person, 1, factors);
        f.WriteFrames<float>("/scans/truth/personal_factors", person, 1, factors + N);
        if (S > 0) {
          const float* maps = factors + 2 * N;
          f.WriteFrames<float>("/scans/textures/neutral", person, 1, maps);
          f.WriteFrames<float>("/scans/textures/offsets", person, 1, maps + texture_floats);
          f.WriteFrames<float>("/scans/truth/shape_offsets", person, 1, maps + (K + 1) * texture_floats);
          f.WriteFrames<float>("/scans/truth/skin", person, 1, maps + (K + N + 1) * texture_floats);
        }
      }
    }
    if (person != P) throw ParallelConsistencyError("scans synth: gathered " + std::to_string(person) + " people");
    f.Commit();
    FC_INFO("scans synth: {} people ({} held out) x {} expressions, {} shapes, {} vertices -> {}", P,
            o.test_people, K, N, V, o.out);
  });
  return StageSummary{o.out, "people", P, P};
}

namespace {

// The map of `layer` beside mesh file `mesh` (MESH_layer.ext), or "" when there is none.
std::string MapBeside(const std::string& mesh, const std::string& layer) {
  const std::filesystem::path p(mesh);
  for (const char* ext : {".exr", ".tif", ".tiff", ".png", ".jpg"}) {
    const std::filesystem::path candidate = p.parent_path() / (p.stem().string() + "_" + layer + ext);
    if (std::filesystem::is_regular_file(candidate)) return candidate.string();
  }
  return "";
}

// Which skin map layers a database imports: those beside the first neutral.
struct MapLayers {
  bool albedo = false, specular = false, displacement = false;
  bool any() const { return albedo || specular || displacement; }
  std::string Names() const {
    std::string out;
    for (auto [on, name] : {std::pair{albedo, "albedo"}, {specular, "specular"}, {displacement, "displacement"}}) {
      if (on) out += (out.empty() ? "" : " ") + std::string(name);
    }
    return out;
  }
};

// The skin maps beside `mesh` as S x S x 5 (albedo linear RGB, specular, displacement mm),
// each resampled bilinearly; a layer the database does not import is 0.
std::vector<float> ReadSkinMaps(const std::string& mesh, const MapLayers& layers, int S, float displacement_scale) {
  std::vector<float> maps(static_cast<size_t>(S) * S * synth::kSkinChannels, 0.f);
  // Read as 3 channels (a grey map replicated; specular and displacement use the first).
  auto read = [&](const std::string& layer, bool* is_float) {
    const std::string path = MapBeside(mesh, layer);
    if (path.empty()) {
      throw FileIOError(mesh + ": no " + layer + " map beside it (" + std::filesystem::path(mesh).stem().string() +
                        "_" + layer + ".exr, .tif, .png or .jpg), which the first neutral has");
    }
    const ImageF image = io::ReadImageF(path, 3, is_float);
    if (image.width != image.height) {
      throw FileIOError(path + ": skin maps must be square, this one is " + std::to_string(image.width) + "x" +
                        std::to_string(image.height));
    }
    return render::ResampleBilinear(image, S, S);
  };
  const size_t n = static_cast<size_t>(S) * S;
  bool is_float = false;
  if (layers.albedo) {
    const ImageF a = read("albedo", &is_float);
    for (size_t t = 0; t < n; ++t) {
      for (int c = 0; c < 3; ++c) {
        const float v = a.data[3 * t + c];
        maps[t * synth::kSkinChannels + c] = is_float ? v : render::DecodeSrgb(v);
      }
    }
  }
  if (layers.specular) {
    const ImageF sp = read("specular", &is_float);
    for (size_t t = 0; t < n; ++t) maps[t * synth::kSkinChannels + 3] = sp.data[3 * t];
  }
  if (layers.displacement) {
    const std::string path = MapBeside(mesh, "displacement");
    const ImageF d = read("displacement", &is_float);
    if (!is_float) throw FileIOError(path + ": displacement maps must hold floats (EXR or float TIFF)");
    for (size_t t = 0; t < n; ++t) maps[t * synth::kSkinChannels + 4] = displacement_scale * d.data[3 * t];
  }
  return maps;
}

}  // namespace

StageSummary RunScansImport(const ScansImportOptions& o, const StageContext& ctx,
                            const io::Config& resolved) {
  StageSummary summary{o.out, "people", 0, 0};  // rank 0 fills it in
  dist::CoordinateExceptions(ctx.comm, [&] {
    if (!ctx.comm.IsMainRank()) return;
    const rig::Rig topology = io::ReadRigFile(o.template_rig);
    const assets::LinearShapes tmpl = assets::LinearizeRig(topology);
    const auto table = assets::ParseFacsTable(o.facs);
    const Eigen::MatrixXf alpha = assets::FacsWeights(table, tmpl.names, false);
    std::map<std::string, int> expression_index;
    for (size_t k = 0; k < table.size(); ++k) expression_index[table[k].name] = static_cast<int>(k);
    std::ifstream in(o.labels);
    if (!in) throw FileIOError(o.labels + ": cannot open the labels CSV");
    const std::filesystem::path base = std::filesystem::path(o.labels).parent_path();
    struct Person { std::map<int, std::string> files; std::string neutral; int split = 0; };
    std::map<std::string, Person> people;
    std::vector<std::string> order;
    std::string line;
    int line_number = 0;
    while (std::getline(in, line)) {
      ++line_number;
      if (line.empty() || line[0] == '#') continue;
      std::vector<std::string> cells;
      std::stringstream ss(line);
      std::string cell;
      while (std::getline(ss, cell, ',')) cells.push_back(cell);
      if (line_number == 1 && !cells.empty() && cells[0] == "person") continue;
      if (cells.size() != 4) throw FileIOError(o.labels + ":" + std::to_string(line_number) + ": expected person,expression,file,split");
      if (!people.count(cells[0])) order.push_back(cells[0]);
      Person& p = people[cells[0]];
      p.split = cells[3] == "test" ? 1 : 0;
      const std::string file = (base / cells[2]).string();
      if (cells[1] == "neutral") {
        p.neutral = file;
      } else {
        auto it = expression_index.find(cells[1]);
        if (it == expression_index.end()) throw FileIOError(o.labels + ":" + std::to_string(line_number) + ": expression '" + cells[1] + "' is not in the FACS table");
        p.files[it->second] = file;
      }
    }
    const int V = tmpl.NumVertices(), K = static_cast<int>(table.size()), P = static_cast<int>(order.size());
    if (P == 0) throw FileIOError(o.labels + ": no people");
    MapLayers layers;
    if (o.texture_size > 0 && !people[order[0]].neutral.empty()) {
      const std::string first = people[order[0]].neutral;
      layers = {!MapBeside(first, "albedo").empty(), !MapBeside(first, "specular").empty(),
                !MapBeside(first, "displacement").empty()};
    }
    const int S = layers.any() ? o.texture_size : 0;
    ResumableOutput output = OpenResumableOutput(o.out, resolved.ToToml(), MakeProvenance(ctx, "scans import", resolved));
    summary.items = P;
    if (output.up_to_date) return;
    io::H5File& f = output.file;
    WriteDatabaseHeader(&f, tmpl, topology, table, alpha, P);
    if (S > 0) CreateSkinMapDatasets(&f, P, K, S, layers.Names());
    std::vector<int32_t> split;
    auto read = [&](const std::string& path) {
      const io::Mesh mesh = io::ReadMeshObj(path);
      if (mesh.vertices.rows() != V) throw FileIOError(path + ": " + std::to_string(mesh.vertices.rows()) + " vertices, the template has " + std::to_string(V));
      return mesh.vertices;
    };
    for (int j = 0; j < P; ++j) {
      const Person& p = people[order[j]];
      if (p.neutral.empty()) throw FileIOError(o.labels + ": person " + order[j] + " has no neutral");
      const rig::Vertices neutral = read(p.neutral);
      f.WriteFrames<float>("/scans/people/neutral", j, 1, neutral.data());
      std::vector<float> expressions;
      for (int k = 0; k < K; ++k) {
        auto it = p.files.find(k);
        if (it == p.files.end()) throw FileIOError(o.labels + ": person " + order[j] + " lacks expression " + table[k].name);
        const rig::Vertices e = read(it->second);
        expressions.insert(expressions.end(), e.data(), e.data() + e.size());
      }
      f.WriteFrames<float>("/scans/people/expressions", j, 1, expressions.data());
      if (S > 0) {
        const std::vector<float> neutral_maps = ReadSkinMaps(p.neutral, layers, S, o.displacement_scale_mm);
        f.WriteFrames<float>("/scans/textures/neutral", j, 1, neutral_maps.data());
        std::vector<float> offsets;
        for (int k = 0; k < K; ++k) {
          const std::vector<float> e = ReadSkinMaps(p.files.at(k), layers, S, o.displacement_scale_mm);
          for (size_t i = 0; i < e.size(); ++i) offsets.push_back(e[i] - neutral_maps[i]);
        }
        f.WriteFrames<float>("/scans/textures/offsets", j, 1, offsets.data());
      }
      split.push_back(p.split);
    }
    f.WriteVector<int32_t>("/scans/people/split", split);
    f.WriteStrings("/scans/people/names", order);
    f.Commit();
    summary.computed = P;
    if (S > 0) {
      FC_INFO("scans import: {} people x {} expressions, skin maps ({}) at {}x{} -> {}", P, K, layers.Names(), S, S, o.out);
    } else {
      FC_INFO("scans import: {} people x {} expressions -> {}", P, K, o.out);
    }
  });
  return summary;
}

}  // namespace facecap::stages
