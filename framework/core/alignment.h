// Pre-alignment of a template (ours; the paper's §9 names landmarks as future work): the
// moments of the solid a contour or closed mesh encloses and of a region of voxels, and the
// closed-form similarities that match one set of moments to another or one set of points to
// another. Pure geometry: experiments/spec/template_init.h reads the experiment keys and applies them.
#pragma once

#include "framework/core/image.h"
#include "framework/core/shape.h"

#include <functional>
#include <string>

namespace dsnake {

// x -> scale * rotation * x + translation (rotation proper, det +1; scale > 0).
template <int D>
struct Similarity {
  double scale = 1.0;
  Eigen::Matrix<double, D, D> rotation = Eigen::Matrix<double, D, D>::Identity();
  Point<D> translation = Point<D>::Zero();
  Point<D> apply(const Point<D>& x) const { return Point<D>(scale * (rotation * x) + translation); }
};

// The moments of a solid: its measure (area in mm^2, volume in mm^3), its centroid (mm) and its
// covariance C = int (x - c)(x - c)^T dx / measure (D x D, mm^2).
template <int D>
struct Moments {
  double measure = 0.0;
  Point<D> centroid = Point<D>::Zero();
  Eigen::Matrix<double, D, D> covariance = Eigen::Matrix<double, D, D>::Zero();
};

// The exact moments of the region a closed polygon (2D, either orientation) or a closed oriented
// mesh (3D) encloses: a fan of simplices from the vertex mean, so independent of how finely the
// boundary is sampled (vertex moments are not).
template <int D>
Moments<D> enclosed_moments(const PointList<D>& positions, const Connectivity& connectivity);

// The moments of the voxels whose value satisfies `inside`, each voxel a box of the grid's
// spacing (its own second moment h^2 / 12 per axis included), in world coordinates (the grid's
// direction applied, image.h). measure 0 when no voxel is inside.
template <int D>
Moments<D> region_moments(const Image<D>& image, const std::function<bool(float)>& inside);

// The similarity S(x) = c_to + s R (x - c_from) that takes `from` onto `to`: s = (measure_to /
// measure_from)^(1/D) and R taking the principal axes of `from` (eigenvectors of its covariance,
// by increasing eigenvalue) onto those of `to`. Of the proper rotations that do (the axes' signs
// are free: 2 candidates in 2D, 4 in 3D), R is the one closest to the identity (largest trace:
// the smallest rotation angle), so the template's given orientation settles the ambiguity.
// Eigenvalues closer than isotropy_tolerance * the largest (in either shape) leave their axes
// undetermined: in 2D R is then the identity; in 3D with one distinct axis left R is the
// smallest rotation that takes that axis onto its counterpart, and with none the identity.
// `axes_matched`, if given, receives how many principal axes were matched: D, 1 (3D, one
// distinct axis) or 0 (near-isotropic).
template <int D>
Similarity<D> align_moments(const Moments<D>& from, const Moments<D>& to, double isotropy_tolerance,
                            int* axes_matched = nullptr);

// The least-squares similarity (with_scale) or rigid motion minimising sum_i |S(a_i) - b_i|^2,
// a and b of the same size (Horn 1987; Umeyama, PAMI 1991; the derivation is in the .cpp).
template <int D>
Similarity<D> fit_similarity(const PointList<D>& a, const PointList<D>& b, bool with_scale);

// "" when the pairs determine a similarity (2D: two distinct points; 3D: three points not on one
// line, in both sets), else why not.
template <int D>
std::string point_pairs_problem(const PointList<D>& a, const PointList<D>& b);

}  // namespace dsnake
