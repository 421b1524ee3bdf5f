// `facecap assemble` (paper 001 Sec. 6): a personalized rig with secondary parts, and
// `eval assembly`, their checks on the held-out people of a scan database.
#include "stages/assemble_stage.h"

#include <cstdio>
#include <iostream>
#include <set>
#include <sstream>

#include "assets/secondary_parts.h"
#include "assets/template_shapes.h"
#include "io/atomic_file.h"
#include "io/parts_io.h"
#include "io/rig_io.h"
#include "io/texture_file.h"
#include "rig/demo_head.h"
#include "stages/blendshape_predictor.h"
#include "synth/skin_dynamics.h"
#include "util/errors.h"
#include "util/json.h"
#include "util/log.h"

namespace facecap::stages {
namespace {

// The demo head whose topology a rig has, with its jaw and shapes: the generic parts' face.
rig::Rig DemoHeadOfTopology(const rig::Rig& face, int resolution, const std::string& path) {
  rig::DemoHeadOptions o;
  o.resolution = resolution;
  o.num_identity_modes = 0;
  rig::Rig head = rig::MakeDemoHead(o);
  if (head.NumVertices() != face.NumVertices() || head.triangles.rows() != face.triangles.rows() ||
      head.triangles != face.triangles) {
    throw FileIOError(path + ": " + std::to_string(face.NumVertices()) + " vertices and " +
                            std::to_string(face.triangles.rows()) + " triangles, not the demo head's topology at "
                            "head_resolution " + std::to_string(resolution) + " (" +
                            std::to_string(head.NumVertices()) + " vertices): set head_resolution to the scan "
                            "database's");
  }
  return head;
}

struct GenericParts {
  rig::Rig head;
  assets::LinearShapes shapes;
  assets::PartSet parts;
  assets::FaceParts where;
};

GenericParts MakeGeneric(const rig::Rig& face, int resolution, const std::string& path) {
  GenericParts g;
  g.head = DemoHeadOfTopology(face, resolution, path);
  g.shapes = assets::MakeTemplateShapes(g.head);
  g.parts = assets::MakeGenericParts(g.head, g.shapes);
  g.where = assets::FindFaceParts(g.head);
  return g;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
StageSummary RunAssemble(const AssembleOptions& o, const StageContext& ctx,
                         const io::Config& resolved) {
  StageSummary summary{o.out, "files", 0, 0};
  if (!ctx.comm.IsMainRank()) return summary;
  std::string why;
  if (!o.Check(&why)) throw InvalidInputError("assemble: " + why);
  const rig::Rig face = io::ReadRigFile(o.rig);
  const GenericParts g = MakeGeneric(face, o.head_resolution, o.rig);
  const assets::LinearShapes person = assets::LinearizeRig(face);
  assets::AssemblyOptions ao;
  ao.clearance_shapes = o.clearance_shapes;
  assets::AssemblyReport report;
  assets::PartSet parts = assets::AssembleParts(g.parts, g.shapes, person, ao, &report);
  const ImageF albedo = io::ReadRigTexture(o.rig);
  parts.iris = o.iris >= 0 ? o.iris : assets::MatchIris(face, albedo);
  const io::H5File in = io::H5File::OpenRead(o.rig);
  io::H5File f = io::H5File::CreateAtomic(o.out);
  for (const char* name : {"/rig", "/texture", "/dynamic_texture"}) {
    if (in.Exists(name)) f.CopyFrom(in, name);
  }
  f.WriteProvenance(MakeProvenance(ctx, "assemble", resolved));
  io::WriteParts(&f, parts, assets::IrisTexture(parts.iris, o.iris_size));
  f.Commit();
  float worst = 0.f, mean = 0.f;
  for (float r : report.fit_rms_cm) worst = std::max(worst, r), mean += r / std::max<size_t>(1, report.fit_rms_cm.size());
  int vertices = 0;
  for (const auto& p : parts.parts) vertices += p.NumVertices();
  FC_INFO("assemble: {} parts ({} vertices) on {} shapes; placement rms {:.3f} mm, shape fit rms {:.3f} mm mean, "
          "{:.3f} mm worst; eyeballs set back {:.2f} / {:.2f} mm; iris {}{} -> {}",
          parts.parts.size(), vertices, parts.NumShapes(), 10.f * report.placement_rms_cm, 10.f * mean, 10.f * worst,
          10.f * report.eyeball_setback_cm[0], 10.f * report.eyeball_setback_cm[1],
          parts.iris, o.iris >= 0 ? "" : albedo.empty() ? " (no albedo to match)" : " (matched to the albedo)", o.out);
  summary.items = 1;
  summary.computed = 1;
  return summary;
}

namespace {

// ---------------------------------------------------------------------------------------------
struct CheckSums {
  double root_mean = 0, root_max = 0, penetration_max = 0, teeth_mean = 0, teeth_max = 0;
  double true_teeth_mean = 0, true_teeth_max = 0, setback_mean = 0, setback_max = 0;
  int people = 0;
  // The lower teeth against the true jaw (the face's own jaw in Add) and step 4's setbacks.
  void AddTruth(const assets::AssemblyChecks& c, const assets::AssemblyReport& r) {
    true_teeth_mean += c.teeth_jaw_mean_deg;
    true_teeth_max = std::max<double>(true_teeth_max, c.teeth_jaw_max_deg);
    for (float s : r.eyeball_setback_cm) {
      setback_mean += 5.0 * s;  // mm, mean of two eyes
      setback_max = std::max<double>(setback_max, 10.0 * s);
    }
  }
  void Add(const assets::AssemblyChecks& c) {
    root_mean += c.lash_root_mean_mm;
    root_max = std::max<double>(root_max, c.lash_root_max_mm);
    penetration_max = std::max<double>(penetration_max, c.penetration_max_mm);
    teeth_mean += c.teeth_jaw_mean_deg;
    teeth_max = std::max<double>(teeth_max, c.teeth_jaw_max_deg);
    ++people;
  }
  std::string Json() const {
    const double n = std::max(1, people);
    std::ostringstream js;
    js << "{\"lash_root_mean_mm\": " << JsonNumber(root_mean / n) << ", \"lash_root_max_mm\": " << JsonNumber(root_max)
       << ", \"penetration_max_mm\": " << JsonNumber(penetration_max)
       << ", \"teeth_jaw_mean_deg\": " << JsonNumber(teeth_mean / n)
       << ", \"teeth_jaw_max_deg\": " << JsonNumber(teeth_max)
       << ", \"teeth_true_jaw_mean_deg\": " << JsonNumber(true_teeth_mean / n)
       << ", \"teeth_true_jaw_max_deg\": " << JsonNumber(true_teeth_max)
       << ", \"eyeball_setback_mean_mm\": " << JsonNumber(setback_mean / n)
       << ", \"eyeball_setback_max_mm\": " << JsonNumber(setback_max) << "}";
    return js.str();
  }
};

}  // namespace

StageSummary RunEvalAssembly(const EvalAssemblyOptions& o, const StageContext& ctx,
                             const io::Config& /*resolved*/) {
  StageSummary summary{o.out, "files", 0, 0};
  if (!ctx.comm.IsMainRank()) return summary;
  std::string why;
  if (!o.Check(&why)) throw InvalidInputError("eval assembly: " + why);
  const io::H5File f = io::H5File::OpenRead(o.scans);
  if (!f.Exists("/scans/truth/deltas")) throw FileIOError(o.scans + ": no /scans/truth/deltas (a synthetic database is needed)");
  const rig::Rig topology = io::ReadRigFile(o.scans, "/template");
  const GenericParts g = MakeGeneric(topology, o.head_resolution, o.scans);
  const int V = topology.NumVertices();
  const io::Shape ds = f.DatasetShape("/scans/truth/deltas");
  if (ds.size() != 4 || ds[2] != V || ds[3] != 3) throw FileIOError(o.scans + ": /scans/truth/deltas is not [P, N, " + std::to_string(V) + ", 3]");
  const int P = static_cast<int>(ds[0]), N = static_cast<int>(ds[1]);
  const std::vector<std::string> names = f.ReadStrings("/scans/shape_names", N);
  if (names != g.shapes.names) throw FileIOError(o.scans + ": /scans/shape_names differ from the demo head's template shapes");
  const std::vector<int32_t> split = f.ReadVector<int32_t>("/scans/people/split", P);
  std::unique_ptr<BlendshapePredictor> model;
  if (!o.model.empty()) {
    model = std::make_unique<BlendshapePredictor>(o.model);
    if (model->topology().NumVertices() != V) throw InvalidInputError(o.model + ": a model of another topology than " + o.scans);
  }
  const std::vector<int> jaw_shapes = assets::JawShapes(g.head, g.shapes);
  assets::AssemblyOptions ours;
  ours.clearance_shapes = o.clearance_shapes;
  assets::AssemblyOptions no_follow = ours;
  no_follow.follow_residual = false;
  CheckSums generic_true, paper_true, ours_true, paper_pred, ours_pred;
  // Irises: the matched one's colour against the albedo's iris, beside a fixed first iris.
  const bool textured = f.Exists("/scans/textures/neutral");
  int texture_size = 0;
  if (textured) {
    const io::Shape ts = f.DatasetShape("/scans/textures/neutral");
    if (ts.size() != 4 || ts[1] != ts[2] || ts[3] != synth::kSkinChannels) {
      throw FileIOError(o.scans + ": /scans/textures/neutral is not [P, S, S, " + std::to_string(synth::kSkinChannels) + "]");
    }
    texture_size = static_cast<int>(ts[1]);
  }
  double iris_matched = 0, iris_fixed = 0;
  std::set<int> irises;
  for (int j = 0; j < P; ++j) {
    if (split[j] != 1) continue;
    assets::LinearShapes truth;
    truth.names = g.shapes.names;
    truth.neutral.resize(V, 3);
    f.ReadFrames<float>("/scans/people/neutral", j, 1, truth.neutral.data());
    std::vector<float> d(static_cast<size_t>(N) * V * 3);
    f.ReadFrames<float>("/scans/truth/deltas", j, 1, d.data());
    truth.deltas = Eigen::Map<const Eigen::MatrixXf>(d.data(), 3 * V, N);
    // Each row: the parts on `face` (its own jaw for the teeth), and the teeth against the true jaw.
    auto add = [&](CheckSums* row, const assets::PartSet& parts, const assets::LinearShapes& face,
                   const assets::AssemblyReport& report) {
      const unsigned seed = static_cast<unsigned>(o.seed) * 7919u + static_cast<unsigned>(j);
      row->Add(assets::CheckAssembly(parts, face, g.where, topology.triangles, o.combinations, seed, jaw_shapes));
      row->AddTruth(assets::CheckAssembly(parts, face, g.where, topology.triangles, 0, seed, jaw_shapes, &truth), report);
    };
    auto assemble = [&](const assets::LinearShapes& face, const assets::AssemblyOptions& options, assets::AssemblyReport* r) {
      return assets::AssembleParts(g.parts, g.shapes, face, options, r);
    };
    assets::AssemblyReport none, report;
    add(&generic_true, g.parts, truth, none);
    add(&paper_true, assemble(truth, no_follow, &report), truth, report);
    add(&ours_true, assemble(truth, ours, &report), truth, report);
    if (model) {
      const assets::LinearShapes predicted = model->Personalize(truth.neutral);
      add(&paper_pred, assemble(predicted, no_follow, &report), predicted, report);
      add(&ours_pred, assemble(predicted, ours, &report), predicted, report);
    }
    if (textured) {
      std::vector<float> maps(static_cast<size_t>(texture_size) * texture_size * synth::kSkinChannels);
      f.ReadFrames<float>("/scans/textures/neutral", j, 1, maps.data());
      ImageF albedo(texture_size, texture_size, 3);
      for (size_t t = 0; t < static_cast<size_t>(texture_size) * texture_size; ++t) {
        for (int c = 0; c < 3; ++c) albedo.data[3 * t + c] = maps[synth::kSkinChannels * t + c];
      }
      Eigen::Vector3f colour;
      if (assets::AlbedoIrisColor(topology, albedo, &colour)) {
        const int k = assets::MatchIris(topology, albedo);
        irises.insert(k);
        iris_matched += (assets::IrisColors()[k] - colour).norm();
        iris_fixed += (assets::IrisColors()[0] - colour).norm();
      }
    }
    FC_INFO("eval assembly: person {} done", j);
  }
  if (generic_true.people == 0) throw FileIOError(o.scans + ": no held-out people (/scans/people/split has no 1)");
  std::ostringstream js;
  js << "{\"people\": " << generic_true.people << ", \"poses_per_person\": " << N + o.combinations
     << ", \"true_shapes\": {\"generic_parts\": " << generic_true.Json() << ", \"coefficient_fit\": " << paper_true.Json()
     << ", \"assembled\": " << ours_true.Json() << "}";
  if (model) js << ", \"predicted_shapes\": {\"coefficient_fit\": " << paper_pred.Json() << ", \"assembled\": " << ours_pred.Json() << "}";
  const double people = generic_true.people;
  if (textured) {
    js << ", \"iris\": {\"matched_color_error\": " << JsonNumber(iris_matched / people)
       << ", \"fixed_color_error\": " << JsonNumber(iris_fixed / people) << ", \"distinct_irises\": " << irises.size() << "}";
  }
  js << "}";
  if (o.json) {
    std::cout << js.str() << std::endl;
  } else {
    std::printf("%d held-out people, %d poses each (every shape, %d random combinations); teeth: mean and worst "
                "angle between the lower teeth and the face's jaw (the true jaw) over the jaw shapes; eye setback: mean "
                "and largest\n", generic_true.people, N + o.combinations, o.combinations);
    std::printf("%-42s %9s %9s %11s %9s %9s %13s %14s\n", "parts on the face", "root mean", "root max", "penetration",
                "teeth", "teeth max", "teeth (truth)", "eye setback");
    auto row = [&](const char* name, const CheckSums& c) {
      const double n = std::max(1, c.people);
      std::printf("%-42s %6.3f mm %6.3f mm %8.3f mm %5.2f deg %5.2f deg %5.2f/%5.2f deg %5.2f/%5.2f mm\n", name,
                  c.root_mean / n, c.root_max, c.penetration_max, c.teeth_mean / n, c.teeth_max, c.true_teeth_mean / n,
                  c.true_teeth_max, c.setback_mean / n, c.setback_max);
    };
    row("true shapes, generic parts (not fitted)", generic_true);
    row("true shapes, coefficient fit alone", paper_true);
    row("true shapes, assembled", ours_true);
    if (model) {
      row("predicted shapes, coefficient fit alone", paper_pred);
      row("predicted shapes, assembled", ours_pred);
    }
    if (textured) {
      std::printf("iris: matched to the albedo, colour error %.4f (a fixed iris: %.4f; linear RGB), %zu distinct irises\n",
                  iris_matched / people, iris_fixed / people, irises.size());
    }
  }
  if (!o.out.empty()) io::WriteFileAtomically(o.out, js.str() + "\n");
  summary.items = 1;
  summary.computed = 1;
  return summary;
}

}  // namespace facecap::stages
