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
  if (o.mirror && (o.mirror->axis < 0 || o.mirror->axis >= D || !std::isfinite(o.mirror->offset)))
    throw InputError("", "--mirror", "must be one of the image's axes, at a finite offset");
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
  // After a self-intersection, stricter limits; after a missed vertex count (the limits forbade
  // the collapses needed, e.g. in a thin lobe), looser ones: the checks still guard the result.
  const auto stricter = decimation_attempts();
  const auto looser = decimation_fallbacks();
  size_t next_strict = 0, next_loose = 0;
  DecimationLimits limits = stricter[next_strict++];
  for (int a = 1;; ++a) {
    DecimatedMesh m = decimate_mesh(smooth, c, o.vertices, limits);
    report.self_intersections = 0;
    bool count_missed = false;
    last = decimation_problem(m, report.euler_characteristic, o.vertices, report.self_intersections, count_missed);
    if (last.empty()) {
      report.attempt = a;
      return m;
    }
    if (count_missed && next_loose < looser.size()) limits = looser[next_loose++];
    else if (!count_missed && next_strict < stricter.size()) limits = stricter[next_strict++];
    else break;
  }
  throw InputError(file, label_where(o.label),
                   "no decimation to " + std::to_string(o.vertices) + " vertices passed the checks (last attempt: " +
                       last + "); try another --vertices");
}

template <int D>
Template<D> mirrored(Template<D> t, const MirrorPlane& plane) {
  t.positions = mirror_points<D>(t.positions, plane);
  if constexpr (D == 3) {
    std::vector<Triangle> tris = t.connectivity.triangles();
    for (Triangle& tri : tris) std::swap(tri[1], tri[2]);
    t.connectivity = Connectivity::mesh(t.num_vertices(), std::move(tris));
  } else {
    std::reverse(t.positions.begin() + 1, t.positions.end());  // vertex 0 stays first
  }
  return t;
}

// Faces between a voxel with the label and one without (6-neighbours; the grid's border counts):
// about the number of vertices marching cubes gives.
int64_t boundary_faces(const Image<3>& labels, float label) {
  const GridIndex<3> n = labels.size();
  int64_t faces = 0;
  for (int z = 0; z < n[2]; ++z)
    for (int y = 0; y < n[1]; ++y)
      for (int x = 0; x < n[0]; ++x) {
        if (labels.at(GridIndex<3>(x, y, z)) != label) continue;
        const GridIndex<3> i(x, y, z);
        for (int a = 0; a < 3; ++a)
          for (int d : {-1, 1}) {
            GridIndex<3> j = i;
            j[a] += d;
            faces += j[a] < 0 || j[a] >= n[a] || labels.at(j) != label;
          }
      }
  return faces;
}

// A label much finer than the template (more than kFinePerTarget boundary faces per asked vertex,
// e.g. a CT organ at 0.6 mm for 2000 vertices) is first box-averaged onto a coarser grid of
// (nearly) isotropic voxels, where the label keeps the voxels at least half inside. Details
// below the template's own resolution go (they would only slow the decimation and block its
// last collapses), so extraction and decimation take seconds; Dice is still measured against
// the original label. Returns `labels` unchanged when it is not that fine.
constexpr double kFinePerTarget = 20;
Image<3> coarsened_for_target(const Image<3>& labels, const LabelTemplateOptions& o) {
  const float label = float(o.label);
  const double faces = double(boundary_faces(labels, label));
  const double wanted = kFinePerTarget * o.vertices;
  if (faces <= wanted) return labels;
  const Point<3> s = labels.spacing();
  const double h = std::cbrt(s[0] * s[1] * s[2]) * std::sqrt(faces / wanted);
  Grid<3> g = labels.grid();
  for (int a = 0; a < 3; ++a) {
    g.spacing[a] = std::max(s[a], h);
    g.size[a] = int(std::floor((labels.size()[a] - 1) * s[a] / g.spacing[a])) + 1;
  }
  std::vector<float> inside(size_t(g.num_voxels()), 0.0f), total(size_t(g.num_voxels()), 0.0f);
  for (int64_t l = 0; l < labels.num_voxels(); ++l) {
    const Point<3> c = g.to_continuous_index(labels.grid().to_physical(labels.grid().index(l)));
    GridIndex<3> k;
    for (int a = 0; a < 3; ++a) k[a] = std::clamp(int(std::lround(c[a])), 0, g.size[a] - 1);
    const int64_t m = g.linear(k);
    total[size_t(m)] += 1;
    inside[size_t(m)] += labels[l] == label;
  }
  Image<3> coarse(g, label + 1);
  for (int64_t m = 0; m < g.num_voxels(); ++m)
    if (total[size_t(m)] > 0 && inside[size_t(m)] >= 0.5f * total[size_t(m)]) coarse[m] = label;
  return coarse;
}

// The 3D pipeline (header).
LabelTemplate<3> mesh_template(const Image<3>& fine_labels, const LabelTemplateOptions& o, const std::string& file) {
  LabelTemplate<3> out;
  checked_mask(fine_labels, o, file);  // the checks on the label as given
  const Image<3> labels = coarsened_for_target(fine_labels, o);
  if (labels.size() != fine_labels.size()) out.report.coarsened_spacing = labels.spacing();
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
PointList<D> mirror_points(const PointList<D>& p, const MirrorPlane& plane) {
  PointList<D> out = p;
  for (auto& x : out) x = reflect<D>(x, plane);
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
  // The surface is extracted in the grid's frame (origin + index * spacing); a template's
  // positions are world mm, which an oblique grid (a direction other than the identity: most
  // clinical scans, or a scan in its scanner's frame) rotates about its origin.
  if (!labels.grid().axis_aligned())
    for (Point<D>& p : out.shape.positions) p = labels.grid().to_world(p);
  if (options.mirror) out.shape = mirrored(std::move(out.shape), *options.mirror);
  return out;
}

template LabelTemplate<2> template_from_labels<2>(const Image<2>&, const LabelTemplateOptions&, const std::string&);
template LabelTemplate<3> template_from_labels<3>(const Image<3>&, const LabelTemplateOptions&, const std::string&);
template PointList<2> mirror_points<2>(const PointList<2>&, const MirrorPlane&);
template PointList<3> mirror_points<3>(const PointList<3>&, const MirrorPlane&);

}  // namespace dsnake
