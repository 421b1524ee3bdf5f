// Secondary parts of a face rig and their assembly (paper 001 Sec. 6): eyeballs with iris and
// cornea, lacrimal fluid, eyelashes, upper and lower teeth, gums and a tongue, each a separate
// mesh with one blendshape delta per shape of the face's blendshape set.
//
// The generic parts belong to the demo head's topology (rig/demo_head.h): they are built around
// its eyeballs, eye slits and mouth cavity, and their deltas follow the template's shapes (the
// eyeballs rotate as the head's eyeballs do, the lashes and the lacrimal strip turn with the lid
// margins about the eyeball centre, the lower teeth, lower gums and tongue follow the jaw).
//
// Assembly onto a personalized rig of the same topology:
//   1. each part group (left eye, right eye, mouth) is placed by the similarity transform that
//      best maps the generic face's group vertices onto the person's neutral (Umeyama);
//   2. each personalized shape i is fitted linearly by the generic shapes over the group's
//      facial vertices, c_i = argmin |A c - d_i|^2 + lambda |c - e_i|^2, and drives the parts
//      with the generic part deltas: delta_i = s R (G c_i);
//      The jaw group (lower teeth, lower gums, tongue) instead follows the rigid motion of the
//      face vertices that only the jaw moves (Procrustes per shape), as the jaw skinning of the
//      rig (paper 000 Sec. 6) moves them, and each eyeball (with its cornea) the rigid motion of
//      the face's own eyeball sphere;
//   3. part vertices bound to a face vertex (lash roots, the lacrimal strip's outer edge) add
//      that vertex's fit residual, so that they stay on the person's lid;
//   4. an eyeball that the person's lids could reach into, in any combination of up to 8
//      shapes at weights in [0, 1], is set back (with its cornea and the lacrimal strip's inner
//      edge) until they clear it.
// The template's own neutral and shapes give c_i = e_i and zero residuals: the generic parts.
//
// The parts are rig::PartSet (rig/parts.h). Units: centimetres.
#ifndef FACECAP_ASSETS_SECONDARY_PARTS_H_
#define FACECAP_ASSETS_SECONDARY_PARTS_H_

#include <string>
#include <vector>

#include <Eigen/Core>

#include "assets/template_shapes.h"
#include "rig/parts.h"
#include "rig/rig.h"
#include "util/image.h"

namespace facecap::assets {

using rig::PartGroup;
using rig::PartSet;
using rig::SecondaryPart;



// Face vertices that the assembly's checks use (all ascending, in the face's topology).
struct FaceParts {
  std::vector<int> eyeball[2];        // the face mesh's own eyeball spheres (0: left, +x)
  std::vector<int> upper_margin[2];   // upper lid margin along the eye slit, ordered by x
  std::vector<int> lower_margin[2];   // lower lid margin, ordered by x
  std::vector<int> lid_triangles[2];  // triangles of the upper and lower lid regions
  std::vector<int> lid_vertices[2];   // their vertices
  std::vector<int> jaw;               // skin vertices that follow the jaw rigidly (weight ~1)
};

// Finds the eyeballs, lid margins and lid regions of a demo-head topology from its regions
// (left_upper_eyelid, ..., sclera, iris) and, for `jaw`, its jaw weights (empty when the rig has
// none). InvalidInputError when a region is missing or an eye has no eyeball or margin.
FaceParts FindFaceParts(const rig::Rig& head);


// The generic parts of the demo head `head` (with its ARKit shapes, jaw angles and pivot), with
// one delta per shape of `shapes` (MakeTemplateShapes(head), or LinearizeRig(head)); a shape
// absent from the rig moves no jaw. InvalidInputError as FindFaceParts.
PartSet MakeGenericParts(const rig::Rig& head, const LinearShapes& shapes);

struct AssemblyOptions {
  // lambda of step 2, relative to the mean diagonal of A^T A: it keeps the coefficients of
  // shapes that do not move a region's vertices at their prior.
  float regularization = 1e-3f;
  // Step 3 (bound vertices add their face vertex's fit residual).
  bool follow_residual = true;
  // Step 4: the lids clear the eyeball in every combination of this many shapes at weights
  // in [0, 1] (a bound linear in the weights); 0 skips step 4.
  int clearance_shapes = 8;

  bool Check(std::string* why) const;
};

struct AssemblyReport {
  std::vector<float> fit_rms_cm;  // per person shape: rms residual of step 2 over the fitted groups' vertices
  float placement_rms_cm = 0.f;   // rms of step 1's residual over the placement vertices
  float eyeball_setback_cm[2] = {0.f, 0.f};  // step 4, left and right eye
};

// Assembles `generic` (made with `generic_shapes`) onto the personalized blendshape set
// `person` of the same topology. Shape names are matched: a person shape whose name the
// generic set has is regularized towards that generic shape, others towards zero.
// InvalidInputError when the vertex counts differ.
PartSet AssembleParts(const PartSet& generic, const LinearShapes& generic_shapes,
                      const LinearShapes& person, const AssemblyOptions& options = AssemblyOptions(),
                      AssemblyReport* report = nullptr);

// Least-squares sphere through the rows `rows` of `points`.
struct Sphere {
  Eigen::Vector3f centre = Eigen::Vector3f::Zero();
  float radius = 0.f;
};
Sphere FitSphere(const rig::Vertices& points, const std::vector<int>& rows);

// ---- irises --------------------------------------------------------------------------------

// Mean linear RGB of each procedural iris; IrisTexture(k) draws iris k.
const std::vector<Eigen::Vector3f>& IrisColors();
// Texture of an eyeball's front, size x size linear RGB, row 0 at v = 1: sclera, iris k with
// radial fibres and a limbal ring, pupil; the eyeball parts' UVs map it onto the front.
ImageF IrisTexture(int k, int size);
// The mean of `albedo` (linear RGB) at the centres of the iris triangles of `face` (region
// "iris"); false when the albedo is empty or the face has no iris region or UVs.
bool AlbedoIrisColor(const rig::Rig& face, const ImageF& albedo, Eigen::Vector3f* color);
// The iris whose mean colour is nearest (in linear RGB) to AlbedoIrisColor; 0 without one.
int MatchIris(const rig::Rig& face, const ImageF& albedo);

// ---- checks (analysis/assembly.sh) ----------------------------------------------------------

struct AssemblyChecks {
  float lash_root_mean_mm = 0.f;   // lash roots to the lid surface, mean over roots and poses
  float lash_root_max_mm = 0.f;
  float penetration_max_mm = 0.f;  // deepest lid vertex inside an eyeball part, over poses
  float teeth_jaw_mean_deg = 0.f;  // lower teeth rotation against the jaw's, over jaw shapes
  float teeth_jaw_max_deg = 0.f;
  int poses = 0;                   // shapes + random combinations evaluated
  int jaw_shapes = 0;
};

// Evaluates `parts` on the face shapes `face` (same topology and shape order): every single
// shape at weight 1, then `combinations` random weight vectors (8 shapes with weights uniform
// in [0, 1], drawn from `seed`). The teeth check runs over `jaw_shapes` (indices of the shapes
// that move the jaw): the jaw's rotation of a shape is the rigid fit of the jaw group's
// vertices in `jaw_truth` (the face itself when null; same shape order).
AssemblyChecks CheckAssembly(const PartSet& parts, const LinearShapes& face, const FaceParts& where,
                             const rig::Triangles& triangles, int combinations, unsigned seed,
                             const std::vector<int>& jaw_shapes, const LinearShapes* jaw_truth = nullptr);

// Indices into `shapes` of the shapes that the rig `head` drives through its jaw (by name).
std::vector<int> JawShapes(const rig::Rig& head, const LinearShapes& shapes);

}  // namespace facecap::assets

#endif  // FACECAP_ASSETS_SECONDARY_PARTS_H_
