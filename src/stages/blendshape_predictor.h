// A trained blendshape generator (blendshapes train) as a function from a neutral to the
// personalized shapes, for stages other than blendshapes infer (torch stays in its .cpp).
#ifndef FACECAP_STAGES_BLENDSHAPE_PREDICTOR_H_
#define FACECAP_STAGES_BLENDSHAPE_PREDICTOR_H_

#include <memory>
#include <string>

#include "assets/template_shapes.h"
#include "rig/rig.h"

namespace facecap::stages {

class BlendshapePredictor {
 public:
  // Loads the model file; FileIOError naming it when it is not a blendshape model.
  explicit BlendshapePredictor(const std::string& model_path);
  ~BlendshapePredictor();
  BlendshapePredictor(const BlendshapePredictor&) = delete;
  BlendshapePredictor& operator=(const BlendshapePredictor&) = delete;

  // The template's topology (jaw-free, as rig.h5 files hold it).
  const rig::Rig& topology() const;
  // The personalized shapes of `neutral` (#V x 3, the template's topology), named as the
  // template's; InvalidInputError for another vertex count.
  assets::LinearShapes Personalize(const rig::Vertices& neutral) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace facecap::stages

#endif  // FACECAP_STAGES_BLENDSHAPE_PREDICTOR_H_
