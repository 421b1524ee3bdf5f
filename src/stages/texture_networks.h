// What the texture network stages share: a person's meshes and skin maps as the scan database
// holds them, and a trained texture network model (textures train) loaded for inference.
//
// Model file (textures train):
//   /template                        the database's template rig (topology, UV layout)
//   /model/parameters                both networks' parameters (nn/texture_net.h), with the
//        attributes size, channels, residual_blocks, low_frequency_sigma (texels)
//   /model/person_mean, person_scale [9], expression_scale [5], output_scale [6]: the
//        channels' normalization (textures/network_channels.h)
//   /model/facs_weights [K, N], /model/facs_names [K]: the expressions the library is made of
//   /optimizer/state                 parameters, Adam moments and step (training continues)
#ifndef FACECAP_STAGES_TEXTURE_NETWORKS_H_
#define FACECAP_STAGES_TEXTURE_NETWORKS_H_

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "io/hdf5.h"
#include "rig/rig.h"
#include "textures/influence.h"
#include "textures/network_channels.h"

namespace facecap::nn {
class TextureNets;
}

namespace facecap::stages {

// Person j of a textured scan database: neutral and K expression meshes (V x 3, cm) and skin
// maps (S x S x 5). FileIOError naming the file when it has no skin maps.
struct ScanTexturedPerson {
  rig::Vertices neutral;
  std::vector<rig::Vertices> expressions;
  std::vector<float> neutral_maps;
  std::vector<std::vector<float>> expression_maps;
};
ScanTexturedPerson ReadScanTexturedPerson(const io::H5File& scans, const std::string& path, int j);

// The index of `person` (a name of /scans/people/names, or an index) among the P people of
// the scan database at `path`; InvalidInputError naming both otherwise.
int ScanPersonIndex(const io::H5File& scans, const std::string& path, const std::string& person, int P);

class TextureModel {
 public:
  // FileIOError naming the file when it is not a texture network model.
  explicit TextureModel(const std::string& path);
  ~TextureModel();

  int size() const { return size_; }
  const rig::Rig& template_rig() const { return template_; }
  const Eigen::MatrixXf& facs_weights() const { return facs_weights_; }  // K x N
  const std::vector<std::string>& facs_names() const { return facs_names_; }

  // The networks' skin maps (S x S x 5) of `expression` for a person with this neutral mesh and
  // neutral maps (S x S x 5), meshes of the template's topology. Safe to call from several
  // threads.
  std::vector<float> ExpressionMaps(const rig::Vertices& neutral, const std::vector<float>& neutral_maps,
                                    const rig::Vertices& expression) const;

 private:
  std::string path_;
  int size_ = 0;
  rig::Rig template_;
  Eigen::MatrixXf facs_weights_;
  std::vector<std::string> facs_names_;
  std::unique_ptr<nn::TextureNets> nets_;
  std::unique_ptr<textures::TexelInterpolator> texels_;
  textures::OneRing ring_;
  textures::ChannelNormalization person_, expression_, output_;
  std::vector<float> coverage_;
};

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_TEXTURE_NETWORKS_H_
