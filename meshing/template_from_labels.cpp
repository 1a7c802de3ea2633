// Templates from label maps; see template_from_labels.h.
#include "meshing/template_from_labels.h"

#include "framework/core/errors.h"
#include "framework/metrics/metrics.h"
#include "meshing/mesh_processing.h"
#include "meshing/surface_extraction.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

namespace dsnake {

namespace {

std::string label_where(int label) { return "label " + std::to_string(label); }

// Up to ten of the values present in the image, for the message of a missing label.
template <int D>
std::string present_values(const Image<D>& labels) {
  std::set<float> values;
  for (int64_t i = 0; i < labels.num_voxels() && values.size() <= 10; ++i) values.insert(labels[i]);
  std::ostringstream s;
  int k = 0;
  for (float v : values) {
    if (k++ == 10) {
      s << ", ...";
      break;
    }
    s << (k > 1 ? ", " : "") << v;
  }
  return s.str();
}

// Checks the options and the label's presence; returns the label's mask.
template <int D>
LabelMask<D> checked_mask(const Image<D>& labels, const LabelTemplateOptions& o, const std::string& file) {
  if (o.vertices < kMinTemplateVertices || o.vertices > kMaxTemplateVertices)
    throw InputError("", "--vertices " + std::to_string(o.vertices),
                     "must be in [" + std::to_string(kMinTemplateVertices) + ", " +
                         std::to_string(kMaxTemplateVertices) + "]");
  if (o.mirror_axis < -1 || o.mirror_axis >= D)
    throw InputError("", "--mirror", "must be one of the image's axes");
  if (labels.empty()) throw InputError(file, "", "the label image is empty (no voxel)");
  LabelMask<D> mask = extract_label_mask(labels, o.label);
  if (mask.report.label_voxels == 0)
    throw InputError(file, label_where(o.label),
                     "no voxel has this label (values present: " + present_values(labels) + ")");
  if (!o.allow_border && mask.report.touches_border)
    throw InputError(file, label_where(o.label),
                     "the label touches the image border, so the object is cut off there "
                     "(--allow-border closes it with a flat cap)");
  return mask;
}

// The checks of a decimated mesh; "" when it passes, else what failed (count_missed: the vertex
// count, which stricter limits cannot bring nearer).
std::string decimation_problem(const DecimatedMesh& m, int euler, int target, int& self_intersections,
                               bool& count_missed) {
  if (std::string p = m.connectivity.closed_manifold_problem(); !p.empty()) return p;
  if (m.connectivity.euler_characteristic() != euler)
    return "Euler characteristic " + std::to_string(m.connectivity.euler_characteristic()) + " instead of " +
           std::to_string(euler);
  const int n = int(m.points.size());
  count_missed = std::abs(n - target) > 0.1 * target;
  if (count_missed)
    return std::to_string(n) + " vertices, not within 10% of " + std::to_string(target);
  self_intersections = count_self_intersections<3>({m.points, m.connectivity});
  if (self_intersections > 0) return std::to_string(self_intersections) + " self-intersecting triangle pairs";
  return "";
}

// Smoothing and decimation of the extracted surface, retried with stricter limits until the
// result passes its checks; refuses (InputError) when no attempt passes.
DecimatedMesh decimate_checked(const ExtractedSurface& s, const LabelTemplateOptions& o, const std::string& file,
                               LabelTemplateReport& report) {
  const Connectivity c = Connectivity::mesh(int(s.points.size()), s.triangles);
  DSNAKE_ASSERT(c.closed_manifold_problem().empty(), "marching cubes gives a closed manifold: " + c.closed_manifold_problem());
  report.extracted_vertices = c.num_vertices();
  report.euler_characteristic = c.euler_characteristic();
  if (o.vertices > c.num_vertices())
    throw InputError("", "--vertices " + std::to_string(o.vertices),
                     "more than the " + std::to_string(c.num_vertices()) + " vertices of the surface of " +
                         label_where(o.label) + " in " + file);
  const PointList<3> smooth = taubin_smooth<3>(s.points, c, o.smoothing_steps);
  std::string last;
  const auto attempts = decimation_attempts();
  for (size_t a = 0; a < attempts.size(); ++a) {
    DecimatedMesh m = decimate_mesh(smooth, c, o.vertices, attempts[a]);
    report.self_intersections = 0;
    bool count_missed = false;
    last = decimation_problem(m, report.euler_characteristic, o.vertices, report.self_intersections, count_missed);
    if (last.empty()) {
      report.attempt = int(a) + 1;
      return m;
    }
    if (count_missed) break;  // stricter limits forbid more collapses, never fewer
  }
  throw InputError(file, label_where(o.label),
                   "no decimation to " + std::to_string(o.vertices) + " vertices passed the checks (last attempt: " +
                       last + "); try another --vertices");
}

template <int D>
Template<D> mirrored(Template<D> t, const Grid<D>& grid, int axis) {
  t.positions = mirror_points<D>(t.positions, grid, axis);
  if constexpr (D == 3) {
    std::vector<Triangle> tris = t.connectivity.triangles();
    for (Triangle& tri : tris) std::swap(tri[1], tri[2]);
    t.connectivity = Connectivity::mesh(t.num_vertices(), std::move(tris));
  } else {
    std::reverse(t.positions.begin() + 1, t.positions.end());  // vertex 0 stays first
  }
  return t;
}

// The 3D pipeline (header).
LabelTemplate<3> mesh_template(const Image<3>& labels, const LabelTemplateOptions& o, const std::string& file) {
  LabelTemplate<3> out;
  const LabelMask<3> mask = checked_mask(labels, o, file);
  out.report.mask = mask.report;
  const DecimatedMesh m = decimate_checked(marching_cubes(mask), o, file, out.report);
  out.shape.positions = m.points;
  out.shape.connectivity = m.connectivity;
  out.report.genus = (2 - out.report.euler_characteristic) / 2;
  return out;
}

// The 2D pipeline (header).
LabelTemplate<2> contour_template(const Image<2>& labels, const LabelTemplateOptions& o, const std::string& file) {
  LabelTemplate<2> out;
  const LabelMask<2> mask = checked_mask(labels, o, file);
  out.report.mask = mask.report;
  std::vector<PointList<2>> contours = marching_squares(mask);
  DSNAKE_ASSERT(contours.size() == 1, "one component without holes has one contour");
  PointList<2>& c = contours[0];
  out.report.extracted_vertices = int(c.size());
  const Connectivity ring = Connectivity::polygon(int(c.size()));
  if (signed_measure<2>(c, ring) < 0) std::reverse(c.begin(), c.end());
  out.shape.positions = resample_closed_polygon(taubin_smooth<2>(c, ring, o.smoothing_steps), o.vertices);
  out.shape.connectivity = Connectivity::polygon(o.vertices);
  out.report.self_intersections = count_self_intersections<2>({out.shape.positions, out.shape.connectivity});
  if (out.report.self_intersections > 0)
    throw InputError(file, label_where(o.label),
                     "the contour with " + std::to_string(o.vertices) + " vertices crosses itself (" +
                         std::to_string(out.report.self_intersections) + " crossings); try more --vertices");
  return out;
}

}  // namespace

template <int D>
PointList<D> mirror_points(const PointList<D>& p, const Grid<D>& grid, int axis) {
  const double mid = grid.origin[axis] + 0.5 * (grid.size[axis] - 1) * grid.spacing[axis];
  PointList<D> out = p;
  for (auto& x : out) x[axis] = 2 * mid - x[axis];
  return out;
}

template <int D>
LabelTemplate<D> template_from_labels(const Image<D>& labels, const LabelTemplateOptions& options,
                                      const std::string& file) {
  LabelTemplate<D> out;
  if constexpr (D == 3) out = mesh_template(labels, options, file);
  else out = contour_template(labels, options, file);
  out.report.dice = dice<D>(rasterize_interior<D>({out.shape.positions, out.shape.connectivity}, labels.grid()),
                            label_indicator(labels, options.label));
  if (options.mirror_axis >= 0) out.shape = mirrored(std::move(out.shape), labels.grid(), options.mirror_axis);
  return out;
}

template LabelTemplate<2> template_from_labels<2>(const Image<2>&, const LabelTemplateOptions&, const std::string&);
template LabelTemplate<3> template_from_labels<3>(const Image<3>&, const LabelTemplateOptions&, const std::string&);
template PointList<2> mirror_points<2>(const PointList<2>&, const Grid<2>&, int);
template PointList<3> mirror_points<3>(const PointList<3>&, const Grid<3>&, int);

}  // namespace dsnake
