// Private to remesh/: the steps one remeshing stage borrows from another (§5), run on the
// mesh-edit kernel (framework/mesh/edit_mesh.h).
#pragma once

#include "framework/mesh/edit_mesh.h"

namespace dsnake::remesh_detail {

// The flips of the "delaunay" stage (delaunay.cpp), also run by "simplify" after its collapses.
// delaunay_by_flips: flips until every edge is locally Delaunay (intrinsic: the opposite angles
// sum to at most pi); regularize_valences: flips that lower sum (valence - 6)^2 over the four
// vertices without pushing the smaller minimum angle below min_angle_rad (or lower than it
// was), then moves of defects (a flip that leaves the sum as it was, kept only when one or two
// further flips at its vertices then lower it) with the same floor. Both through try_flip;
// they return the number of flips it rejected.
int delaunay_by_flips(EditMesh& m, double cos_max_dihedral);
int regularize_valences(EditMesh& m, double cos_max_dihedral, double min_angle_rad, bool reuse_refusals);

// One sweep of the "uniform" stage's relaxation (uniform.cpp, §5.1): every free vertex towards
// the centre of its parameterised one-ring, each move checked (normals turning beyond
// acos(cos_max_normal), the fan's smallest angle below min(its old value, 15 degrees), a
// crossing). Also run by "simplify" after its flips. Returns the number of rejected moves.
int relax_sweep(EditMesh& m, double cos_max_normal);

// The "planar" method of §5.2 (delaunay_planar.cpp): disc patches, mean-value parameterisation,
// planar Delaunay, adopted patch by patch. Returns the number of patches left as they were.
int planar_delaunay(EditMesh& m, double cos_max_dihedral);

}  // namespace dsnake::remesh_detail
