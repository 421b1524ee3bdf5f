// The layout of a samples file (synth samples, synth contract, synth expand): per sample
// /samples/{segmentation [H, W, 3] uint8, weights [S], pose [3] (pitch, yaw, roll rad),
// landmarks [68, 2], landmark_visible [68] uint8, camera [4] (fx, fy, cx, cy)}, and once
// /samples/shape_names, /regions/{names, colors} and /camera/intrinsics. A sample travels
// between ranks and files as one packed row (PackSampleRow's byte layout).
#ifndef FACECAP_STAGES_SAMPLE_FILE_H_
#define FACECAP_STAGES_SAMPLE_FILE_H_

#include <cstdint>
#include <string>
#include <vector>

#include "io/hdf5.h"
#include "render/camera.h"
#include "rig/rig.h"
#include "synth/sample_set.h"

namespace facecap::stages {

constexpr int kSampleLandmarks = 68;

// The per-sample datasets of a new or continued output; `framing` names the framing in the
// camera dataset's description.
void CreateSampleDatasets(io::H5File* f, int size, int num_shapes, int64_t count,
                          const std::string& framing);

// The rig's shape and region names, region colours and the camera (a new output).
void WriteSampleRecords(io::H5File* f, const rig::Rig& rig, const render::Camera& camera,
                        float distance);
// The same records copied from another samples file.
void CopySampleRecords(const io::H5File& from, io::H5File* to);

// One sample as a packed row.
std::vector<uint8_t> PackSampleRow(const std::vector<uint8_t>& segmentation,
                                   const float* weights, int num_shapes, const float pose[3],
                                   const std::vector<float>& landmarks_xy,
                                   const std::vector<uint8_t>& visible, const float camera[4]);
// Sample `index` of a samples file as a packed row.
std::vector<uint8_t> ReadSampleRow(const io::H5File& f, int64_t index);
// Writes packed rows at `indices` (ascending; contiguous runs written at once).
void WriteSampleRows(io::H5File* f, const std::vector<int64_t>& indices,
                     const std::vector<std::vector<uint8_t>>& rows);

// The codes of deepfake infer's outputs that a sample set is shaped with (synth contract,
// synth expand): each sample's E(I_S), and each real frame's E(D_A(E(I_R))), its translation
// encoded, in the samples' own domain. Ranking the samples by their distance to the real
// frames' E(I_R) instead agreed half as well with their distance to the footage's true
// parameters (analysis/contraction_codes.py).
inline constexpr char kSampleCodes[] = "/frames/latent";
inline constexpr char kFrameCodes[] = "/frames/latent_of_translation";

// The codes in `dataset` of a deepfake infer output, of the frames with a face (all, without
// /frames/found); their frame indices in *rows. FileIOError naming the file when missing.
synth::CodeMatrix ReadCodes(const io::H5File& f, const std::string& dataset,
                            std::vector<int64_t>* rows);

// The resolved [synth.samples] configuration the samples of `f` were drawn and rendered
// with: /samples@sampling_config when present (a contracted or expanded set), else the root
// config of a synth samples output. FileIOError naming the file otherwise.
std::string SamplingConfig(const io::H5File& f);

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_SAMPLE_FILE_H_
