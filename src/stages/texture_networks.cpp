#include "stages/texture_networks.h"

#include <cstdlib>

#include "io/dynamic_texture_file.h"
#include "io/rig_io.h"
#include "nn/texture_net.h"
#include "util/errors.h"

namespace facecap::stages {

ScanTexturedPerson ReadScanTexturedPerson(const io::H5File& f, const std::string& path, int j) {
  if (!f.Exists("/scans/textures/neutral") || !f.Exists("/scans/textures/offsets")) {
    throw FileIOError(path + ": no skin maps (/scans/textures); make it with scans synth (texture_size > 0) or "
                      "scans import of meshes with maps beside them");
  }
  const auto tshape = f.DatasetShape("/scans/textures/neutral");
  const auto eshape = f.DatasetShape("/scans/people/expressions");
  if (tshape.size() != 4 || tshape[3] != io::kSkinMapChannels || tshape[1] != tshape[2] || eshape.size() != 4 ||
      eshape[3] != 3 || j < 0 || j >= tshape[0] || j >= eshape[0]) {
    throw FileIOError(path + ": skin maps or meshes of an unexpected shape, or no person " + std::to_string(j));
  }
  const int K = static_cast<int>(eshape[1]), V = static_cast<int>(eshape[2]);
  const size_t floats = static_cast<size_t>(tshape[1]) * tshape[2] * io::kSkinMapChannels;
  ScanTexturedPerson p;
  std::vector<float> buf(3 * static_cast<size_t>(V) * K);
  auto mesh = [&](const float* d) { return rig::Vertices(Eigen::Map<const rig::Vertices>(d, V, 3)); };
  f.ReadFrames<float>("/scans/people/neutral", j, 1, buf.data());
  p.neutral = mesh(buf.data());
  f.ReadFrames<float>("/scans/people/expressions", j, 1, buf.data());
  p.neutral_maps.resize(floats);
  f.ReadFrames<float>("/scans/textures/neutral", j, 1, p.neutral_maps.data());
  std::vector<float> offsets(floats * K);
  f.ReadFrames<float>("/scans/textures/offsets", j, 1, offsets.data());
  for (int k = 0; k < K; ++k) {
    p.expressions.push_back(mesh(&buf[3 * static_cast<size_t>(V) * k]));
    std::vector<float> t(offsets.begin() + k * floats, offsets.begin() + (k + 1) * floats);
    for (size_t i = 0; i < floats; ++i) t[i] += p.neutral_maps[i];
    p.expression_maps.push_back(std::move(t));
  }
  return p;
}


int ScanPersonIndex(const io::H5File& f, const std::string& path, const std::string& person, int P) {
  if (f.Exists("/scans/people/names")) {
    const auto names = f.ReadStrings("/scans/people/names");
    for (size_t j = 0; j < names.size(); ++j) {
      if (names[j] == person) return static_cast<int>(j);
    }
  }
  char* end = nullptr;
  const long j = std::strtol(person.c_str(), &end, 10);
  if (end == person.c_str() || *end != '\0' || j < 0 || j >= P) {
    throw InvalidInputError("person '" + person + "' is neither a name nor an index in [0, " +
                            std::to_string(P) + ") of " + path);
  }
  return static_cast<int>(j);
}

TextureModel::TextureModel(const std::string& path) : path_(path) {
  const io::H5File f = io::H5File::OpenRead(path);
  const char* p = "/model/parameters";
  if (!f.Exists(p) || !f.HasAttribute(p, "size") || !f.Exists("/model/facs_weights")) {
    throw FileIOError(path + ": not a texture network model (no /model/parameters with a size, or no "
                      "/model/facs_weights); make one with textures train");
  }
  template_ = io::ReadRig(f, "/template");
  size_ = static_cast<int>(f.GetIntAttribute(p, "size"));
  nn::TextureNetOptions o;
  o.channels = static_cast<int>(f.GetIntAttribute(p, "channels"));
  o.residual_blocks = static_cast<int>(f.GetIntAttribute(p, "residual_blocks"));
  try {
    nets_ = std::make_unique<nn::TextureNets>(o, size_);
  } catch (const InvalidInputError& e) {
    throw FileIOError(path + ": " + e.what());
  }
  nets_->SetParameters(f.ReadVector<float>(p, nets_->NumParameters()));
  person_.mean = f.ReadVector<float>("/model/person_mean", textures::kPersonChannels);
  person_.scale = f.ReadVector<float>("/model/person_scale", textures::kPersonChannels);
  expression_.scale = f.ReadVector<float>("/model/expression_scale", textures::kExpressionChannels);
  expression_.mean.assign(textures::kExpressionChannels, 0.f);
  output_.scale = f.ReadVector<float>("/model/output_scale", textures::kOutputChannels);
  output_.mean.assign(textures::kOutputChannels, 0.f);
  const auto shape = f.DatasetShape("/model/facs_weights");
  if (shape.size() != 2 || shape[1] != template_.NumShapes()) {
    throw FileIOError(path + ": /model/facs_weights is not [K, " + std::to_string(template_.NumShapes()) + "]");
  }
  const std::vector<float> w = f.Read<float>("/model/facs_weights", shape);
  facs_weights_ = Eigen::Map<const Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
      w.data(), shape[0], shape[1]);
  facs_names_ = f.ReadStrings("/model/facs_names");
  texels_ = std::make_unique<textures::TexelInterpolator>(template_, size_);
  ring_ = textures::BuildOneRing(template_.triangles, template_.NumVertices());
  coverage_.resize(static_cast<size_t>(size_) * size_);
  for (size_t t = 0; t < coverage_.size(); ++t) coverage_[t] = texels_->Covered(static_cast<int>(t)) ? 1.f : 0.f;
}

TextureModel::~TextureModel() = default;

std::vector<float> TextureModel::ExpressionMaps(const rig::Vertices& neutral, const std::vector<float>& neutral_maps,
                                                const rig::Vertices& expression) const {
  if (neutral.rows() != template_.NumVertices() || expression.rows() != template_.NumVertices()) {
    throw InvalidInputError("texture model " + path_ + ": meshes of " + std::to_string(neutral.rows()) +
                            " vertices, its template has " + std::to_string(template_.NumVertices()));
  }
  std::vector<float> person = textures::PersonChannels(*texels_, neutral, template_.neutral, neutral_maps);
  person_.Apply(person.data(), coverage_.data(), size_);
  const Eigen::VectorXf en = textures::MeanEdgeLength(ring_, neutral);
  std::vector<float> e = textures::ExpressionChannels(*texels_, ring_, en, neutral, expression);
  expression_.Apply(e.data(), coverage_.data(), size_);
  std::vector<float> out = nets_->Predict(person.data(), e.data());
  output_.Invert(out.data(), coverage_.data(), size_);
  return textures::ExpressionMapsFromOutputs(neutral_maps, out.data(), size_);
}

}  // namespace facecap::stages
