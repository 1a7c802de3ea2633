// Templates from label maps (`dsnake template`): the boundary of one label of a label image as
// a closed, outward triangle mesh (3D) or counter-clockwise polygon (2D) with about the asked
// number of vertices.
//  3D: [a label much finer than the template: box-averaged onto a coarser, nearly isotropic grid
//      (about 20 boundary voxel faces per asked vertex; template_from_labels.cpp)] ->
//      label mask (largest 6-connected component, cavities filled, padded; label_mask.h) ->
//      marching cubes (surface_extraction.h) -> Taubin smoothing -> OpenMesh decimation ->
//      checks: closed, manifold, Euler characteristic as extracted, no self-intersection,
//      vertex count within 10% of the target. A result failing a check is redone with the next,
//      stricter decimation limits (decimation_attempts()); when all fail, or the vertex count is
//      missed (stricter limits cannot help), the label is refused (InputError: nothing written).
//  2D: label mask (largest 4-connected component, holes filled) -> marching squares -> Taubin
//      smoothing -> uniform arc-length resampling to exactly the asked count -> checks: no
//      self-intersection (else refused), counter-clockwise.
// Mirroring (optional) comes last: the reflection about a given plane normal to a world axis
// (symmetry_plane.h finds the data's own), with the orientation flipped back (triangles' vertex
// order / polygon order reversed).
#pragma once

#include "framework/core/image.h"
#include "framework/core/shape.h"
#include "meshing/label_mask.h"
#include "meshing/symmetry_plane.h"

#include <optional>
#include <string>

namespace dsnake {

struct LabelTemplateOptions {
  int label = 1;
  int vertices = 400;        // target vertex count, [kMinTemplateVertices, kMaxTemplateVertices]
  std::optional<MirrorPlane> mirror;  // reflect the template about this plane (world, mm)
  int smoothing_steps = 10;  // Taubin λ|μ pairs before decimation / resampling
  bool allow_border = true;  // false: refuse a label touching the image border (cut off)
};

constexpr int kMinTemplateVertices = 4;
constexpr int kMaxTemplateVertices = 1000000;

struct LabelTemplateReport {
  LabelMaskReport mask;
  int extracted_vertices = 0;    // after marching cubes / squares
  int euler_characteristic = 0;  // V - E + F of the extracted surface (3D)
  int genus = 0;                 // of the result: (2 - χ) / 2 (3D; 0 in 2D)
  int self_intersections = 0;    // of the result (0 unless refused)
  int attempt = 1;               // decimation attempt that passed the checks (3D)
  double dice = 0;               // rasterised result (before mirroring) vs label == N, label grid
  Point<3> coarsened_spacing = Point<3>::Zero();  // 3D: the coarser grid's spacing, if the label was coarsened (else 0)
};

template <int D>
struct LabelTemplate {
  Template<D> shape;
  LabelTemplateReport report;
};

// The template of `options.label` in `labels`; `file` names the label image in errors (no voxel
// with the label, refused result, bad options).
template <int D>
LabelTemplate<D> template_from_labels(const Image<D>& labels, const LabelTemplateOptions& options,
                                      const std::string& file);

// The reflection of p about `plane` (mirroring, above).
template <int D>
PointList<D> mirror_points(const PointList<D>& p, const MirrorPlane& plane);

}  // namespace dsnake
