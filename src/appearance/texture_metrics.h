// How close a captured texture is to a known one, measured where a face capture matters.
#ifndef FACECAP_APPEARANCE_TEXTURE_METRICS_H_
#define FACECAP_APPEARANCE_TEXTURE_METRICS_H_

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "render/texel_map.h"
#include "rig/rig.h"
#include "util/image.h"

namespace facecap::appearance {

// Per texel of `texels` (row-major), whether it is in the face region: its triangle's region
// is skin, nose, brows, eyelids or lips (not hair, neck, eyes or the mouth's inside), and its
// point on the neutral mesh lies, seen from the front, inside the convex hull of the rig's 68
// landmarks (brows to chin, ear to ear), on the front of the head (z above the mean of the
// jaw-line ends, landmarks 0 and 16). The rig needs its 68 landmarks and region names.
std::vector<uint8_t> FaceRegionMask(const rig::Rig& rig, const render::TexelMap& texels);

struct TextureComparison {
  int64_t face_texels = 0;     // texels in the region
  double coverage = 0.;        // fraction of them the capture covers (confidence > 0)
  Eigen::Vector3d gain{1., 1., 1.};  // per-channel gain applied to the capture (least squares)
  double psnr_db = 0.;         // over covered region texels, linear RGB, after the gain
  // The same for a flat texture of the capture's mean colour over those texels, after its own
  // gain: the score of an answer that knows nothing of the face's detail.
  double psnr_flat_db = 0.;
};

// Compares `captured` (3 channels, linear RGB) with `truth` over the texels of `mask` that
// `confidence` (1 channel, > 0 where captured) marks as covered. One gain per colour channel
// (least squares) maps the capture onto the truth first: lighting baked into any capture
// scales each channel. Both textures must have the mask's size; InvalidInputError otherwise.
TextureComparison CompareTextures(const ImageF& captured, const ImageF& confidence,
                                  const ImageF& truth, const std::vector<uint8_t>& mask);

// The texture position of each of the rig's landmark vertices `landmarks` (indices into its 68
// landmarks), as (u, v): the UV of the vertex's first triangle corner. InvalidInputError when
// the rig has no UVs or 68 landmarks, or an index is outside 0..67.
std::vector<Eigen::Vector2f> LandmarkUVs(const rig::Rig& rig, const std::vector<int>& landmarks);

// The eye and mouth corners of the 68 iBUG landmarks: 36, 39, 42, 45, 48, 54.
const std::vector<int>& CornerLandmarks();

struct CornerAlignment {
  std::vector<double> shift_texels;  // per corner: how far the capture's detail is displaced
  std::vector<double> correlation;   // per corner: the normalized cross-correlation at the shift
  double mean_shift_texels = 0.;     // mean of shift_texels
  int found = 0;                     // corners whose correlation reached min_correlation
};

// Where the detail around each point of `uvs` lies in `captured` against `truth` (both
// [N, N, 3] textures of the same size): the window of (2 window + 1)^2 texels of the truth's
// luminance around the point is matched against the capture's at every whole-texel shift up to
// `search` texels (normalized cross-correlation), refined to a fraction of a texel by a
// parabola through the best shift and its neighbours. A corner whose best correlation stays
// below `min_correlation` (a capture without that detail, or a flat one), or whose best shift
// lies on the border of the search (no peak within it), counts as not found and shifted by
// `search`, the most this measures. InvalidInputError for textures of different sizes, window
// or search below 1, or a window that does not fit the texture.
CornerAlignment MeasureCornerAlignment(const ImageF& captured, const ImageF& truth,
                                       const std::vector<Eigen::Vector2f>& uvs, int window,
                                       int search, double min_correlation = 0.3);

// How well textures explain footage: the face pixels of tracked frames against each texture
// sampled at the pixels' U(I) (render::SampleBilinear) and shaded by the frame's own light,
// fitted per frame and colour channel by least squares as first-order shading of the surface
// normal: f ~ r (a + b . n). Any rotation of the normals is absorbed by b, so the rig's own
// frame serves. A flat texture (r = 1) is scored beside them.
class RerenderScore {
 public:
  // The textures to score: 3-channel linear RGB, any sizes; they must outlive this object.
  explicit RerenderScore(std::vector<const ImageF*> textures);

  // One frame: `image` (linear RGB), its `uv_image` (U(I): u, v, coverage) and per pixel the
  // unit surface normal (3 channels), of one size; the pixels scored are those with coverage
  // above 0.5 and `mask` (1 channel) above 0.5. InvalidInputError when the sizes differ.
  void AddFrame(const ImageF& image, const ImageF& uv_image, const ImageF& normals,
                const ImageF& mask);

  int frames() const { return frames_; }
  int64_t pixels() const { return pixels_; }
  // PSNR (dB, linear RGB in [0, 1]) of texture t over every pixel added; of the flat texture.
  double PsnrDb(size_t t) const;
  double FlatPsnrDb() const;

 private:
  std::vector<const ImageF*> textures_;
  std::vector<double> error_;  // per texture: squared error after the per-frame shading fits
  double flat_error_ = 0.;
  int frames_ = 0;
  int64_t pixels_ = 0;
};

}  // namespace facecap::appearance

#endif  // FACECAP_APPEARANCE_TEXTURE_METRICS_H_
