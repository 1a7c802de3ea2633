// Built-in synthetic phantoms with their ground truth, for the default experiment, the tests
// and quick studies. Images follow the paper's star experiment (§8): 8-bit grey levels,
// background 170, foreground 85; binary unless "partial_volume" is true (then boundary voxels
// take the covered fraction), then blurred by "blur" (Gaussian sigma, physical units; 0: none).
//  - image phantoms: "disk", "square", "star" (2D); "sphere", "ellipsoid" (3D);
//  - template phantoms: "circle", "star" (2D); "sphere", "ellipsoid" (3D);
//  - the paper's phantoms (experiments/phantoms/paper_phantoms.h, binary by default: blur 0):
//    image and template "puzzle", "lung_slice" (2D, default images 128^2), "star" (80^3),
//    "tetris", "bone" (64^3), "lung" (230 x 300 x 80, with bronchi) (3D); templates "bar" and
//    "c_shape" (3D). A template's default "center" is the centre of its family's default image.
//  - from a mesh file (experiments/phantoms/bunny.h): image "mesh" (any closed mesh, key "mesh") and
//    "points" (small balls); template "bunny" (the simplified, stretched, ear-twisted bunny).
// Every phantom knows its true boundary (a fine polygon / mesh) and its mask; a template
// phantom of a matching family also gets correspondence targets (see phantom_targets).
#pragma once

#include "framework/core/image.h"
#include "framework/core/json_reader.h"
#include "framework/core/shape.h"

#include <optional>
#include <string>

namespace dsnake {

template <int D>
struct Phantom {
  std::string kind;
  Image<D> image;        // grey levels
  Image<D> mask;         // 1 inside (voxel centre inside the shape), 0 outside
  Template<D> surface;   // the true boundary, finely sampled
};

// Reads the phantom's parameters from the "image" object (which has "phantom": kind) and
// builds it. Unknown keys are rejected by the caller's reader.finish().
template <int D>
Phantom<D> make_phantom(JsonReader& reader);

// Builds a template phantom from the "template" object (with "phantom": kind).
template <int D>
Template<D> make_template_phantom(JsonReader& reader);

// Correspondence targets for a template phantom registered to an image phantom, where the
// pairing is known: circle/sphere -> disk/sphere/ellipsoid (the template stretched along its
// axes onto the shape), circle -> square (radial projection from the centres, a convention),
// star -> star with the same arm count (vertex k to vertex k); the paper's phantoms to the same
// family (see paper_targets in experiments/phantoms/paper_phantoms.h). Empty otherwise.
template <int D>
std::vector<std::optional<Point<D>>> phantom_targets(const nlohmann::json& image_spec,
                                                     const nlohmann::json& template_spec,
                                                     const Template<D>& tmpl);

// The kinds that "image": {"phantom": ...} and "template": {"phantom": ...} accept in D dimensions.
template <int D>
std::vector<std::string> image_phantom_kinds();
template <int D>
std::vector<std::string> template_phantom_kinds();

// A closed icosphere of radius 1 about the origin: 10 * 4^k + 2 vertices, outward triangles.
Template<3> make_icosphere(int subdivisions);

}  // namespace dsnake
