// The bad-input sweep: every stage that `facecap run` knows, with each of its path options in
// turn pointed at one of its inputs, at a folder and at a file of the wrong kind. Each case
// must end with a clear error (exit 2 or 3, naming the file), every input file unchanged
// (the sha256 of each input the case names, and the size and modification time of every
// fixture file, before and after) and nothing under an output's final name. The
// stages and their path options come from the registry, so a new stage or path option is
// swept, or this test fails asking for valid inputs of it.
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <gtest/gtest.h>

#include "io/hdf5.h"
#include "io/rig_io.h"
#include "app/app.h"
#include "app/cli.h"
#include "app/registry.h"
#include "testing/testing.h"

namespace facecap::app {
namespace {

namespace fs = std::filesystem;
using stages::OutputKey;
using stages::OutputKind;

const char* const kDlibModel = "/usr/share/dlib/shape_predictor_68_face_landmarks.dat";
const char* const kPocketsphinxModel = "/usr/share/pocketsphinx/model/en-us";

std::string Quote(const std::string& s) { return "'" + s + "'"; }

// How one stage runs on valid inputs: its input options (file names relative to the fixture
// folder, or absolute; "" for an option left unset), options that keep a run small, and
// input options of which only one may be given.
struct StageInputs {
  std::map<std::string, std::string> inputs;
  std::string extra;
  std::set<std::string> exclusive;
};

const std::map<std::string, StageInputs>& ValidRuns() {
  static const std::map<std::string, StageInputs> runs = {
      {"rig.demo", {{}, "", {}}},
      {"rig.import", {{{"obj_dir", "objs"}, {"gltf", ""}}, "", {"obj_dir", "gltf"}}},
      {"rig.export", {{{"rig", "rig.h5"}}, "", {}}},
      {"rig.perturb", {{{"rig", "rig.h5"}}, "", {}}},
      {"rig.calibrate",
       {{{"rig", "rig.h5"}, {"landmark_model", kDlibModel}},
        "--people 1 --frames 1 --size 96 --threads 1", {}}},
      {"render", {{{"rig", "rig.h5"}}, "", {}}},
      {"synth.samples", {{{"rig", "rig.h5"}}, "--count 2 --size 32", {}}},
      {"synth.clip", {{{"rig", "rig.h5"}, {"background_folder", ""}}, "--frames 2 --size 64", {}}},
      {"synth.sheet", {{{"clip", "clip.h5"}}, "", {}}},
      {"synth.contract",
       {{{"samples", "samples.h5"}, {"sample_codes", "codes.h5"}, {"frame_codes", "codes.h5"},
         {"frames", ""}, {"bound", "contracted.h5"}}, "", {}}},
      {"synth.expand",
       {{{"rig", "rig.h5"}, {"samples", "contracted.h5"}, {"frame_codes", "codes.h5"},
         {"track", "track.h5"}}, "", {}}},
      {"synth.crops", {{{"clip", "clip.h5"}, {"frames", "frames.h5"}}, "", {}}},
      {"regress.train",
       {{{"samples", "samples.h5"}, {"sample_codes", "codes.h5"}, {"frame_codes", "frame_codes.h5"},
         {"frames", "frames.h5"}, {"more_frame_codes", "frame_codes.h5"}, {"more_frames", "frames.h5"},
         {"more_tracks", "footage_track.h5"}, {"track", "footage_track.h5"}, {"rig", "rig.h5"}},
        "--pose-steps 1 --landmark-steps 1 --finetune-steps 1 --batch 2 --hidden 8 --threads 1", {}}},
      {"regress.infer",
       {{{"model", "regressor.h5"}, {"codes", "frame_codes.h5"}, {"frames", "frames.h5"}, {"rig", "rig.h5"}},
        "", {}}},
      {"ingest",
       {{{"video", "clip.mp4"}, {"images", ""}, {"landmark_model", kDlibModel}}, "--threads 1",
        {"video", "images"}}},
      {"curate.build", {{{"frames", "frames.h5"}}, "--clusters 2,2", {}}},
      {"curate.query",
       {{{"curation", "curation.h5"}, {"frames", ""}, {"image", "face.png"}, {"renders", ""},
         {"query_frames", ""}, {"landmark_model", kDlibModel}},
        "", {"image", "renders", "query_frames"}}},
      {"deepfake.train",
       {{{"a", "samples.h5"}, {"b", "clip.h5"}, {"paired", ""}, {"init", "deepfake.h5"}},
        "--steps 1 --batch 2", {}}},
      {"deepfake.infer",
       {{{"model", "deepfake.h5"}, {"frames", "frames.h5"}, {"camera", ""}}, "", {}}},
      {"export.livelink", {{{"track", "track.h5"}}, "", {}}},
      {"export.gltf", {{{"track", "track.h5"}, {"rig", "rig.h5"}}, "", {}}},
      {"export.overlay",
       {{{"track", "track.h5"}, {"rig", "rig.h5"}, {"frames", "samples.h5"}},
        "--frames-dataset /samples/segmentation", {}}},
      {"export.landmarks",
       {{{"track", "track.h5"}, {"rig", "rig.h5"}, {"frames", "frames.h5"}}, "", {}}},
      {"scans.synth", {{}, "--people 4 --test-people 1 --threads 1", {}}},
      {"scans.import",
       {{{"labels", "labels.csv"}, {"template_rig", "rig.h5"}},
        "--facs smile=mouthSmileLeft+mouthSmileRight", {}}},
      {"blendshapes.train",
       {{{"scans", "scans.h5"}},
        "--estimation-epochs 1 --tuning-epochs 1 --batch 2 --threads 1 --channels 4", {}}},
      {"blendshapes.baselines", {{{"scans", "scans.h5"}}, "--threads 1", {}}},
      {"blendshapes.infer",
       {{{"model", "bsgen.h5"}, {"neutral", "objs/neutral.obj"}, {"scans", ""}}, "", {"neutral", "scans"}}},
      {"eval.blendshapes",
       {{{"scans", "scans.h5"}, {"baselines", "baselines.h5"}, {"model", "bsgen.h5"}}, "", {}}},
      {"eval.textures", {{{"scans", "scans.h5"}, {"model", ""}}, "", {}}},
      {"textures.library", {{{"scans", "scans.h5"}, {"rig", "scans_rig.h5"}}, "", {}}},
      {"export.textures", {{{"library", "library.h5"}, {"track", "track.h5"}}, "", {}}},
      {"textures.train", {{{"scans", "scans.h5"}}, "--epochs 1 --batch 24 --channels 2 --residual-blocks 0 --threads 1", {}}},
      {"textures.infer", {{{"model", "texnet.h5"}, {"rig", "scans_rig.h5"}, {"scans", "scans.h5"}}, "", {}}},
      {"assemble", {{{"rig", "scans_rig.h5"}}, "", {}}},
      {"eval.assembly", {{{"scans", "scans.h5"}, {"model", "bsgen.h5"}}, "--combinations 10", {}}},
      {"track",
       {{{"rig", "rig.h5"}, {"targets", "samples.h5"}, {"frames", ""}},
        "--targets-dataset /samples/segmentation", {}}},
      {"person.fit",
       {{{"rig", "rig.h5"}, {"frames", "frames.h5"}, {"translations", ""}},
        "--count 2 --landmark-rounds 1 --refine-rounds 0 --threads 1", {}}},
      {"eval.track",
       {{{"truth", "samples.h5"}, {"track", "track.h5"}, {"rig", "rig.h5"}, {"truth_rig", ""}},
        "", {}}},
      {"eval.person", {{{"truth", "clip.h5"}, {"person", "person.h5"}}, "", {}}},
      {"appearance.turntable",
       {{{"rig", "clip.h5"}, {"texture", ""}}, "--views 4 --size 32 --sheet none", {}}},
      {"appearance.frames",
       {{{"frames", "samples.h5"}, {"track", "track.h5"}, {"rig", "rig.h5"}},
        "--dataset /samples/segmentation --sheet none", {}}},
      {"appearance.gather", {{{"views", "turntable.h5"}, {"images", ""}}, "--texture-size 32", {}}},
      {"eval.appearance",
       {{{"truth", "clip.h5"}, {"texture", "texture.h5"}, {"naive", ""}}, "", {}}},
      {"eval.rerender",
       {{{"views", "turntable.h5"}, {"texture", "texture.h5"}, {"naive", ""}}, "--holdout-every 0",
        {}}},
      {"eval.landmarks",
       {{{"frames", "frames.h5"}, {"track", "track.h5"}, {"rig", "rig.h5"}}, "", {}}},
      {"lipsync.track",
       {{{"rig", "rig.h5"}, {"targets", "clip.h5"}, {"frames", ""}, {"sound", "clip.mp4"}},
        "--count 2 --levels 1", {}}},
      {"lipsync.blend",
       {{{"track", "clip_track.h5"}, {"mouth", "clip_track.h5"}, {"video", "clip.mp4"},
         {"mouth_video", "clip.mp4"}}, "", {}}},
      {"eval.lipsync", {{{"truth", "clip.h5"}, {"tracks", "clip_track.h5"}}, "", {}}},
      {"lipsync.audio",
       {{{"video", "clip.mp4"}, {"rig", "rig.h5"}, {"model_dir", kPocketsphinxModel}}, "", {}}},
  };
  return runs;
}

// Input options that name folders.
bool IsFolderInput(const std::string& key) {
  return key == "obj_dir" || key == "images" || key == "renders" || key == "background_folder" ||
         key == "model_dir";
}

std::string NameFor(OutputKind kind) {
  switch (kind) {
    case OutputKind::kHdf5: return "out.h5";
    case OutputKind::kImage: return "out.png";
    case OutputKind::kVideo: return "out.mp4";
    case OutputKind::kGltf: return "out.glb";
    case OutputKind::kMesh: return "out.obj";
    case OutputKind::kCsv: return "out.csv";
    case OutputKind::kAudio: return "out.wav";
    case OutputKind::kText: return "out.json";
    case OutputKind::kFolder: return "outdir";
  }
  return "out";
}

// What the sweep found, over all cases of one test.
struct Tally {
  int cases = 0, exit_zero = 0, other_codes = 0, inputs_modified = 0, final_outputs = 0;
};

class BadInputSweep : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = std::make_unique<testing::TempDir>();
    const std::vector<std::string> steps = {
        "rig demo --out rig.h5",
        "synth samples --rig rig.h5 --out samples.h5 --count 4 --size 64",
        "synth clip --rig rig.h5 --out clip.h5 --video --frames 6 --size 192 --identity-seed 7 "
        "--speech 'Hello there.' --speech-start-seconds 0",
        "ingest --video clip.mp4 --out frames.h5 --threads 1",
        "track --rig rig.h5 --targets samples.h5 --targets-dataset /samples/segmentation "
        "--out track.h5",
        "track --rig rig.h5 --targets clip.h5 --out clip_track.h5 --levels 1 --epochs 1",
        "deepfake train --a samples.h5 --b clip.h5 --out deepfake.h5 --steps 1 --batch 2",
        "deepfake infer --model deepfake.h5 --frames samples.h5 --dataset /samples/segmentation "
        "--out codes.h5 --no-flip-average --shift-average 0 --no-contours",
        "synth contract --samples samples.h5 --sample-codes codes.h5 --frame-codes codes.h5 "
        "--out contracted.h5 --sheet none",
        "deepfake infer --model deepfake.h5 --frames frames.h5 --out frame_codes.h5 --no-contours",
        "track --rig rig.h5 --targets frame_codes.h5 --targets-dataset /frames/translated --frames frames.h5 "
        "--out footage_track.h5 --levels 1 --epochs 1 --threads 1",
        "regress train --samples samples.h5 --sample-codes codes.h5 --frame-codes frame_codes.h5 "
        "--frames frames.h5 --track footage_track.h5 --rig rig.h5 --out regressor.h5 --pose-steps 1 --landmark-steps 1 "
        "--finetune-steps 1 --batch 2 --hidden 8 --threads 1",
        "scans synth --out scans.h5 --people 4 --test-people 1 --threads 1",
        "blendshapes train --scans scans.h5 --out bsgen.h5 --estimation-epochs 1 "
        "--tuning-epochs 1 --batch 2 --threads 1 --channels 4",
        "blendshapes baselines --scans scans.h5 --out baselines.h5 --threads 1",
        "person fit --rig rig.h5 --frames frames.h5 --out person.h5 --count 2 "
        "--landmark-rounds 1 --refine-rounds 0 --threads 1",
        "curate build --frames frames.h5 --out curation.h5 --clusters 2,2",
        "rig export --rig rig.h5 --obj-dir objs --gltf rig.glb",
        "render --rig rig.h5 --out face.png",
        "appearance turntable --rig clip.h5 --out turntable.h5 --views 4 --size 32 --sheet none",
        "appearance gather --views turntable.h5 --out texture.h5 --texture-size 32"};
    for (const std::string& step : steps) {
      const testing::CommandResult r = testing::RunCommand(
          "cd " + Quote(dir_->path()) + " && " + testing::BuildDir() + "/facecap " + step);
      ASSERT_EQ(r.code, 0) << step << "\n" << r.output;
    }
    std::ofstream(dir_->File("labels.csv"))
        << "person,expression,file,split\np0,neutral,objs/neutral.obj,train\n"
           "p0,smile,objs/neutral.obj,train\n";
    std::ofstream(dir_->File("garbage.h5")) << "not an HDF5 file\n";
    std::ofstream(dir_->File("garbage.mp4")) << "not a video\n";
    std::ofstream(dir_->File("garbage.obj")) << "not a mesh\n";
    std::ofstream(dir_->File("garbage.csv")) << "\x01\x02 not a table\n";
    std::ofstream(dir_->File("garbage.png")) << "not an image\n";
    std::ofstream(dir_->File("garbage.dat")) << "not a model\n";
    {
      // A rig of the scan database's topology, and a dynamic texture library made with it.
      io::H5File tmpl = io::H5File::CreateAtomic(dir_->File("scans_rig.h5"));
      io::WriteRig(io::ReadRig(io::H5File::OpenRead(dir_->File("scans.h5")), "/template"), &tmpl);
      tmpl.Commit();
      const testing::CommandResult r = testing::RunCommand(
          "cd " + Quote(dir_->path()) + " && " + testing::BuildDir() +
          "/facecap textures library --scans scans.h5 --rig scans_rig.h5 --out library.h5 && " +
          testing::BuildDir() + "/facecap textures train --scans scans.h5 --out texnet.h5 --epochs 1 --batch 24 "
          "--channels 2 --residual-blocks 0 --threads 1");
      ASSERT_EQ(r.code, 0) << r.output;
    }
    {
      io::H5File other = io::H5File::CreateAtomic(dir_->File("other.h5"));
      other.WriteVector<float>("/unrelated", {1.f, 2.f, 3.f});
      other.Commit();
    }
    fs::create_directories(dir_->File("empty_folder"));
  }
  static void TearDownTestSuite() { dir_.reset(); }

  static std::string Fixture(const std::string& name) {
    if (name.empty() || name.front() == '/') return name;
    return dir_->File(name);
  }

  // What a case could change: the size and modification time of every fixture file (but
  // cases/, where the cases write) and the sha256 of each fixture file or folder in `inputs`.
  static std::string Snapshot(const std::map<std::string, std::string>& inputs) {
    std::string named;
    for (const auto& [key, path] : inputs) {
      if (!path.empty() && path.rfind(dir_->path(), 0) == 0) named += " " + Quote(path);
    }
    std::string command = "cd " + Quote(dir_->path()) +
                          " && find . -path ./cases -prune -o -type f -printf '%p %s %T@\\n' | "
                          "LC_ALL=C sort";
    if (!named.empty()) {
      command += " && find" + named + " -type f -print0 | LC_ALL=C sort -z | xargs -0 -r sha256sum";
    }
    return testing::RunCommand(command).output;
  }

  // The stages, with their path options as the registry declares them.
  static const std::vector<StageSpec>& Stages() {
    static CLI::App app;
    static AppState state;
    static bool registered = false;
    if (!registered) {
      RegisterAll(&app, &state);
      registered = true;
    }
    return state.stages;
  }

  // One case: the stage with `inputs` (key -> path) and `outputs` (key -> path). Expects an
  // error naming `named`, with the exit code in `codes`, the message holding `says`.
  void RunCase(const StageSpec& spec, const std::map<std::string, std::string>& inputs,
               const std::map<std::string, std::string>& outputs, const std::string& extra,
               const std::string& named, const std::set<int>& codes, const std::string& says,
               const std::string& what, Tally* tally) {
    std::string args = spec.command;
    std::vector<std::string> fresh;  // outputs that did not exist before the case
    for (const auto& [key, path] : inputs) {
      if (!path.empty()) args += " " + FlagName(key) + " " + Quote(path);
    }
    for (const auto& [key, path] : outputs) {
      args += " " + FlagName(key) + " " + Quote(path);
      if (!fs::exists(path)) fresh.push_back(path);
    }
    args += " " + extra;
    const std::string before = Snapshot(inputs);
    const testing::CommandResult r = testing::RunFacecap(args);
    ++tally->cases;
    const std::string label = "[" + spec.table + "] " + what + "\n  facecap " + args + "\n" +
                              r.output;
    if (r.code == 0) ++tally->exit_zero;
    if (r.code != 0 && codes.count(r.code) == 0) ++tally->other_codes;
    EXPECT_TRUE(codes.count(r.code)) << "exit " << r.code << ": " << label;
    EXPECT_NE(r.output.find(named), std::string::npos) << "does not name " << named << ": "
                                                       << label;
    if (!says.empty()) {
      EXPECT_NE(r.output.find(says), std::string::npos) << "does not say '" << says << "': "
                                                        << label;
    }
    const bool modified = Snapshot(inputs) != before;
    tally->inputs_modified += modified;
    EXPECT_FALSE(modified) << "an input changed: " << label;
    for (const std::string& path : fresh) {
      std::error_code ec;
      const bool left = fs::exists(path, ec) && !fs::is_directory(path, ec);
      tally->final_outputs += left;
      EXPECT_FALSE(left) << "a failed run left " << path << ": " << label;
    }
  }

  // Runs `each(spec, valid inputs, fresh outputs, extra)` for every stage.
  void ForEachStage(const std::function<void(const StageSpec&, const StageInputs&,
                                             const std::vector<OutputKey>&)>& each) {
    for (const StageSpec& spec : Stages()) {
      const auto run = ValidRuns().find(spec.table);
      ASSERT_NE(run, ValidRuns().end())
          << "[" << spec.table << "] has no valid inputs in ValidRuns(): add them";
      const std::set<std::string> keys(spec.path_keys.inputs.begin(),
                                       spec.path_keys.inputs.end());
      std::set<std::string> listed;
      for (const auto& [key, value] : run->second.inputs) listed.insert(key);
      ASSERT_EQ(keys, listed) << "[" << spec.table << "] ValidRuns() must list every input "
                                 "option the registry declares";
      each(spec, run->second, spec.path_keys.outputs);
    }
  }

  // Valid inputs of a run, with exclusive options other than `keep` left unset.
  static std::map<std::string, std::string> ValidInputs(const StageInputs& run,
                                                        const std::string& keep = "") {
    std::map<std::string, std::string> inputs;
    for (const auto& [key, name] : run.inputs) {
      const bool dropped = !keep.empty() && key != keep && run.exclusive.count(keep) &&
                           run.exclusive.count(key);
      inputs[key] = dropped ? "" : Fixture(name);
    }
    return inputs;
  }

  std::string CaseFolder() {
    const std::string folder = dir_->File("cases/" + std::to_string(next_case_++));
    fs::create_directories(folder);
    return folder;
  }

  std::map<std::string, std::string> FreshOutputs(const std::vector<OutputKey>& outputs,
                                                  const std::string& folder) {
    std::map<std::string, std::string> paths;
    for (const OutputKey& out : outputs) {
      paths[out.key] = folder + "/" + out.key + "_" + NameFor(out.kind);
    }
    return paths;
  }

  static void Report(const char* what, const Tally& t) {
    std::printf("bad-input sweep, %s: %d cases, %d exits of 0, %d other exit codes, %d inputs "
                "modified, %d final-named outputs of failed runs\n",
                what, t.cases, t.exit_zero, t.other_codes, t.inputs_modified, t.final_outputs);
  }

  static std::unique_ptr<testing::TempDir> dir_;
  int next_case_ = 0;
};

std::unique_ptr<testing::TempDir> BadInputSweep::dir_;

// Every output option aimed at every input of the stage: exit 2 naming both, before any work.
TEST_F(BadInputSweep, OutputsNamingInputsAreRefused) {
  Tally tally;
  ForEachStage([&](const StageSpec& spec, const StageInputs& run,
                   const std::vector<OutputKey>& outputs) {
    for (const OutputKey& out : outputs) {
      bool first = true;
      for (const auto& [key, name] : run.inputs) {
        if (name.empty()) continue;
        const std::string input = Fixture(name);
        std::vector<std::string> spellings = {input};
        // Once per output, the same file spelled through "." and a symbolic link.
        if (first) {
          spellings.push_back(fs::path(input).parent_path().string() + "/./" +
                              fs::path(input).filename().string());
          const std::string link = CaseFolder() + "/link" + fs::path(input).extension().string();
          fs::create_symlink(input, link);
          spellings.push_back(link);
        }
        first = false;
        for (const std::string& spelling : spellings) {
          std::map<std::string, std::string> outs = FreshOutputs(outputs, CaseFolder());
          outs[out.key] = spelling;
          RunCase(spec, ValidInputs(run, key), outs, run.extra, spelling, {2}, "is the input",
                  out.key + " = input " + key, &tally);
        }
      }
    }
  });
  Report("outputs naming inputs", tally);
}

// Every output option at a folder (or, for a folder output, at a file) and with a name its
// format does not have: exit 2, before any work.
TEST_F(BadInputSweep, OutputsAtFoldersAndWrongExtensionsAreRefused) {
  {
    // The snapshot sees a named input rewritten in place with its size and time kept, and a
    // file it does not name appearing.
    const std::string probe = dir_->File("probe.bin");
    std::ofstream(probe) << "before";
    const std::string before = Snapshot({{"probe", probe}});
    const fs::file_time_type time = fs::last_write_time(probe);
    std::ofstream(probe) << "after!";
    fs::last_write_time(probe, time);
    EXPECT_NE(Snapshot({{"probe", probe}}), before);
    const std::string unnamed = Snapshot({});
    std::ofstream(dir_->File("stray.bin")) << "x";
    EXPECT_NE(Snapshot({}), unnamed);
    fs::remove(probe);
    fs::remove(dir_->File("stray.bin"));
  }
  Tally tally;
  ForEachStage([&](const StageSpec& spec, const StageInputs& run,
                   const std::vector<OutputKey>& outputs) {
    for (const OutputKey& out : outputs) {
      const std::string folder = CaseFolder();
      std::map<std::string, std::string> outs = FreshOutputs(outputs, folder);
      const bool folder_output = out.kind == OutputKind::kFolder;
      const std::string wrong = folder + "/" + (folder_output ? "a_file.h5" : "a_folder.h5");
      if (folder_output) {
        std::ofstream(wrong) << "a file\n";
      } else {
        fs::create_directories(wrong);
      }
      outs[out.key] = wrong;
      RunCase(spec, ValidInputs(run), outs, run.extra, wrong, {2},
              folder_output ? "is a file" : "is a folder", out.key + " at a folder", &tally);
      if (folder_output || out.kind == OutputKind::kText) continue;
      outs = FreshOutputs(outputs, CaseFolder());
      outs[out.key] = fs::path(outs[out.key]).replace_extension(".unknown").string();
      RunCase(spec, ValidInputs(run), outs, run.extra, outs[out.key], {2}, "must end in",
              out.key + " with an unknown extension", &tally);
    }
  });
  Report("outputs at folders and wrong names", tally);
}

// Every input option at a folder, at a file that is not what it reads, and at an HDF5 file
// of another kind: exit 2 or 3 naming it, nothing written.
TEST_F(BadInputSweep, InputsOfTheWrongKindAreClearErrors) {
  Tally tally;
  ForEachStage([&](const StageSpec& spec, const StageInputs& run,
                   const std::vector<OutputKey>& outputs) {
    for (const auto& [key, name] : run.inputs) {
      std::vector<std::string> wrong;
      if (IsFolderInput(key)) {
        wrong = {Fixture("empty_folder"), Fixture("garbage.h5")};
      } else {
        std::string extension = fs::path(name).extension().string();
        if (extension.empty() || name.empty()) extension = ".h5";
        wrong = {Fixture("empty_folder"), Fixture("garbage" + extension), Fixture("other.h5")};
      }
      for (const std::string& bad : wrong) {
        std::map<std::string, std::string> ins = ValidInputs(run, key);
        ins[key] = bad;
        RunCase(spec, ins, FreshOutputs(outputs, CaseFolder()), run.extra, bad, {2, 3}, "",
                key + " = " + fs::path(bad).filename().string(), &tally);
      }
    }
  });
  Report("inputs of the wrong kind", tally);
}

}  // namespace
}  // namespace facecap::app
