#include "stages/sample_file.h"

#include <Eigen/Core>

#include "io/camera_file.h"
#include "io/frames_file.h"
#include "util/bytes.h"
#include "util/errors.h"

namespace facecap::stages {

void CreateSampleDatasets(io::H5File* f, int size, int num_shapes, int64_t count,
                          const std::string& framing) {
  f->CreateFrames<uint8_t>("/samples/segmentation", {size, size, 3}, count, 16, 1);
  f->SetAttribute("/samples/segmentation", "layout", std::string("frame, y, x, RGB"));
  f->CreateFrames<float>("/samples/weights", {num_shapes}, count, 256, 4);
  f->CreateFrames<float>("/samples/pose", {3}, count, 1024, 4);
  f->SetAttribute("/samples/pose", "columns", std::string("pitch, yaw, roll"));
  f->SetAttribute("/samples/pose", "units", std::string("rad"));
  f->CreateFrames<float>("/samples/landmarks", {kSampleLandmarks, 2}, count, 256, 4);
  f->SetAttribute("/samples/landmarks", "units", std::string("pixels (x right, y down)"));
  f->CreateFrames<uint8_t>("/samples/landmark_visible", {kSampleLandmarks}, count, 1024, 4);
  f->CreateFrames<float>("/samples/camera", {4}, count, 1024, 4);
  f->SetAttribute("/samples/camera", "columns",
                  std::string("fx, fy, cx, cy (pixels) of the camera each sample is rendered "
                              "with (" + framing + " framing)"));
  f->SetAttribute("/samples/camera", "framing", framing);
}

void WriteSampleRecords(io::H5File* f, const rig::Rig& rig, const render::Camera& camera,
                        float distance) {
  std::vector<std::string> names;
  for (const auto& s : rig.shapes) names.push_back(s.name);
  f->WriteStrings("/samples/shape_names", names);
  std::vector<std::string> region_names;
  Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> colors(rig.regions.size(), 3);
  for (size_t r = 0; r < rig.regions.size(); ++r) {
    region_names.push_back(rig.regions[r].name);
    colors.row(r) = rig.regions[r].color.transpose();
  }
  f->WriteStrings("/regions/names", region_names);
  f->WriteMatrix("/regions/colors", colors);
  io::CameraRecord record = io::CameraRecord::Of(camera);
  record.width = record.height = std::nullopt;
  record.distance_cm = distance;
  io::WriteCamera(f, record);
}

void CopySampleRecords(const io::H5File& from, io::H5File* to) {
  to->WriteStrings("/samples/shape_names", from.ReadStrings("/samples/shape_names"));
  to->WriteStrings("/regions/names", from.ReadStrings("/regions/names"));
  to->WriteMatrix("/regions/colors", from.ReadMatrix<float>("/regions/colors", -1, 3));
  io::WriteCamera(to, io::ReadCamera(from));
}

std::vector<uint8_t> PackSampleRow(const std::vector<uint8_t>& segmentation,
                                   const float* weights, int num_shapes, const float pose[3],
                                   const std::vector<float>& landmarks_xy,
                                   const std::vector<uint8_t>& visible, const float camera[4]) {
  ByteWriter w;
  w.PutVector(segmentation);
  w.PutArray(weights, num_shapes);
  w.PutArray(pose, 3);
  w.PutVector(landmarks_xy);
  w.PutVector(visible);
  w.PutArray(camera, 4);
  return std::move(w.bytes());
}

std::vector<uint8_t> ReadSampleRow(const io::H5File& f, int64_t index) {
  const io::Shape seg = f.CheckShape("/samples/segmentation", {-1, -1, -1, 3});
  const io::Shape weights = f.CheckShape("/samples/weights", {seg[0], -1});
  std::vector<uint8_t> segmentation(static_cast<size_t>(seg[1] * seg[2] * 3));
  std::vector<float> w(static_cast<size_t>(weights[1])), xy(2 * kSampleLandmarks);
  std::vector<uint8_t> visible(kSampleLandmarks);
  float pose[3], camera[4];
  f.ReadFrames<uint8_t>("/samples/segmentation", index, 1, segmentation.data());
  f.ReadFrames<float>("/samples/weights", index, 1, w.data());
  f.ReadFrames<float>("/samples/pose", index, 1, pose);
  f.ReadFrames<float>("/samples/landmarks", index, 1, xy.data());
  f.ReadFrames<uint8_t>("/samples/landmark_visible", index, 1, visible.data());
  f.ReadFrames<float>("/samples/camera", index, 1, camera);
  return PackSampleRow(segmentation, w.data(), static_cast<int>(w.size()), pose, xy, visible,
                       camera);
}

void WriteSampleRows(io::H5File* f, const std::vector<int64_t>& indices,
                     const std::vector<std::vector<uint8_t>>& rows) {
  size_t k = 0;
  while (k < indices.size()) {
    size_t end = k + 1;
    while (end < indices.size() && indices[end] == indices[end - 1] + 1) ++end;
    const int64_t n = static_cast<int64_t>(end - k);
    std::vector<uint8_t> seg, vis;
    std::vector<float> weights, angles, xy, cameras;
    for (size_t j = k; j < end; ++j) {
      ByteReader r(rows[j]);
      auto append = [](auto* to, const auto& from) { to->insert(to->end(), from.begin(), from.end()); };
      append(&seg, r.GetVector<uint8_t>());
      append(&weights, r.GetVector<float>());
      append(&angles, r.GetVector<float>());
      append(&xy, r.GetVector<float>());
      append(&vis, r.GetVector<uint8_t>());
      append(&cameras, r.GetVector<float>());
    }
    f->WriteFrames<uint8_t>("/samples/segmentation", indices[k], n, seg.data());
    f->WriteFrames<float>("/samples/weights", indices[k], n, weights.data());
    f->WriteFrames<float>("/samples/pose", indices[k], n, angles.data());
    f->WriteFrames<float>("/samples/landmarks", indices[k], n, xy.data());
    f->WriteFrames<uint8_t>("/samples/landmark_visible", indices[k], n, vis.data());
    f->WriteFrames<float>("/samples/camera", indices[k], n, cameras.data());
    k = end;
  }
}

synth::CodeMatrix ReadCodes(const io::H5File& f, const std::string& dataset,
                            std::vector<int64_t>* rows) {
  const io::Shape shape = f.CheckShape(dataset, {-1, -1});
  std::vector<uint8_t> found(shape[0], 1);
  if (f.Exists(io::frames::kFound)) found = f.ReadVector<uint8_t>(io::frames::kFound, shape[0]);
  const synth::CodeMatrix all = f.ReadMatrix<float>(dataset);
  rows->clear();
  for (int64_t i = 0; i < shape[0]; ++i) {
    if (found[i]) rows->push_back(i);
  }
  if (static_cast<int64_t>(rows->size()) == all.rows()) return all;
  synth::CodeMatrix codes(rows->size(), all.cols());
  for (size_t j = 0; j < rows->size(); ++j) codes.row(j) = all.row((*rows)[j]);
  return codes;
}

std::string SamplingConfig(const io::H5File& f) {
  if (f.HasAttribute("/samples", "sampling_config")) {
    return f.GetStringAttribute("/samples", "sampling_config");
  }
  if (f.HasAttribute("/", "stage") && f.GetStringAttribute("/", "stage") == "synth samples" &&
      f.HasAttribute("/", "config")) {
    return f.GetStringAttribute("/", "config");
  }
  throw FileIOError(f.path() + ": not made by synth samples, contract or expand (no sampling "
                    "configuration in /samples@sampling_config or the root config)");
}

}  // namespace facecap::stages
