// Small procedural meshes with known geometry: test scenes and benchmarks for the renderer
// (the analytic area of a sphere's silhouette, exact pixel-aligned quads).
#ifndef FACECAP_RENDER_PRIMITIVES_H_
#define FACECAP_RENDER_PRIMITIVES_H_

#include "rig/rig.h"

namespace facecap::render {

// Unit icosphere: an icosahedron whose triangles are split in four `subdivisions` times,
// with every vertex pushed onto the unit sphere. 10 * 4^s + 2 vertices, 20 * 4^s triangles
// (s = 4: 2,562 / 5,120; s = 5: 10,242 / 20,480).
//
// Inputs:
//   subdivisions  s >= 0
// Outputs:
//   vertices   #V by 3 list of unit-length positions
//   triangles  #F by 3 list of vertex indices, counter-clockwise seen from outside
void Icosphere(int subdivisions, rig::Vertices* vertices, rig::Triangles* triangles);

// A rig-shaped sphere for renderer tests and benchmarks: an icosphere of the given radius
// (centred at the origin, +z towards a frontal camera) with longitude/latitude UVs
// (per-corner, so triangles across the seam at u = 0 / 1 get u > 1 rather than wrapping),
// num_regions flat-colour regions as longitude sectors, and landmarks at the vertices
// nearest to the front pole (+z), the back pole (-z) and 45 degrees up from the front
// (+y +z), in that order. Shapes, jaw and identity modes are empty. Near the poles
// (|y| close to the radius) the longitude mapping is strongly distorted.
//
// Inputs:
//   subdivisions  icosphere subdivisions (5 gives about 10k vertices and 20k triangles)
//   radius        sphere radius (scene units)
//   num_regions   number of regions (>= 1)
// Returns the rig.
rig::Rig IcosphereRig(int subdivisions, float radius, int num_regions);

}  // namespace facecap::render

#endif  // FACECAP_RENDER_PRIMITIVES_H_
