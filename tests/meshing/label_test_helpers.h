// Helpers of the meshing tests: synthetic label images from a predicate in world coordinates,
// and the checks every template from a label map must pass (a test on a real label file, e.g.
// the liver, is one more TEST calling expect_valid_template_of_file with its path).
#pragma once

#include "framework/io/image_io.h"
#include "framework/metrics/metrics.h"
#include "meshing/label_mask.h"
#include "meshing/template_from_labels.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>

namespace dsnake::test_support {

// A label image on `grid`: `label` where inside(world position of the voxel centre), else 0.
template <int D>
Image<D> label_image(const Grid<D>& grid, const std::function<bool(const Point<D>&)>& inside, int label) {
  Image<D> img(grid, 0.0f);
  for (int64_t i = 0; i < img.num_voxels(); ++i)
    if (inside(grid.to_physical(grid.index(i)))) img[i] = float(label);
  return img;
}

// The anisotropic grid with a non-zero origin of the synthetic 3D tests: about `extent` (world
// units) per axis around `centre`.
inline Grid<3> anisotropic_grid(const Point<3>& centre, const Point<3>& extent) {
  Grid<3> g;
  g.spacing = Point<3>(0.8, 1.0, 1.25);
  for (int a = 0; a < 3; ++a) g.size[a] = int(std::ceil(extent[a] / g.spacing[a])) + 1;
  g.origin = centre - 0.5 * (g.size.cast<double>() - Point<3>::Ones()).cwiseProduct(g.spacing);
  return g;
}

// V - E + F - C of the cubical complex on the inside voxel centres of a mask (6-neighbour
// edges, squares of 4 and cubes of 8 inside voxels): the Euler characteristic of the 6-connected
// object, computed without the surface.
inline int object_euler(const LabelMask<3>& m) {
  auto in = [&](int x, int y, int z) {
    const GridIndex<3> i(x, y, z);
    if ((i.array() < 0).any() || (i.array() >= m.grid.size.array()).any()) return false;
    return m.inside[size_t(m.grid.linear(i))] != 0;
  };
  int chi = 0;
  for (int z = 0; z < m.grid.size[2]; ++z)
    for (int y = 0; y < m.grid.size[1]; ++y)
      for (int x = 0; x < m.grid.size[0]; ++x) {
        if (!in(x, y, z)) continue;
        for (int c = 0; c < 8; ++c) {  // the cells whose lowest corner is this voxel
          bool all = true;
          for (int k = 0; k < 8 && all; ++k)
            if ((k & ~c) == 0) all = in(x + (k & 1), y + ((k >> 1) & 1), z + ((k >> 2) & 1));
          if (all) chi += (((c & 1) + ((c >> 1) & 1) + ((c >> 2) & 1)) % 2 == 0) ? 1 : -1;
        }
      }
  return chi;
}

// The genus of a connected mask without cavities (extract_label_mask's): 1 - χ.
inline int label_genus(const LabelMask<3>& m) { return 1 - object_euler(m); }

// Measured properties of a 3D template, each computed here independently of the pipeline.
struct MeshCheck {
  int vertices = 0, genus = -1, self_intersections = -1;
  double dice = 0, signed_volume = 0;
};

// Checks closed/manifold/outward and measures the rest (against label == `label` of `labels`).
inline MeshCheck check_template(const Template<3>& t, const Image<3>& labels, int label) {
  EXPECT_EQ(t.connectivity.closed_manifold_problem(), "");
  MeshCheck c;
  c.vertices = t.num_vertices();
  c.genus = (2 - t.connectivity.euler_characteristic()) / 2;
  c.self_intersections = count_self_intersections<3>({t.positions, t.connectivity});
  Image<3> truth(labels.grid(), 0.0f);
  for (int64_t i = 0; i < labels.num_voxels(); ++i) truth[i] = labels[i] == float(label);
  c.dice = dice<3>(rasterize_interior<3>({t.positions, t.connectivity}, labels.grid()), truth);
  c.signed_volume = signed_measure<3>(t.positions, t.connectivity);
  return c;
}

// The contract of a 3D template: closed, manifold, outward, the genus, no self-intersection,
// vertex count within 10% of `target`, Dice >= min_dice; and the report says the same.
inline void expect_valid_template(const LabelTemplate<3>& t, const Image<3>& labels, int label, int target,
                                  int genus, double min_dice, const std::string& what) {
  const MeshCheck c = check_template(t.shape, labels, label);
  std::printf("[ measured ] %s: %d vertices (target %d), genus %d, %d self-intersections, Dice %.5f, attempt %d\n",
              what.c_str(), c.vertices, target, c.genus, c.self_intersections, c.dice, t.report.attempt);
  EXPECT_EQ(c.genus, genus) << what;
  EXPECT_EQ(t.report.genus, genus) << what;
  EXPECT_EQ(c.self_intersections, 0) << what;
  EXPECT_LE(std::abs(c.vertices - target), 0.1 * target) << what;
  EXPECT_GE(c.dice, min_dice) << what;
  EXPECT_NEAR(t.report.dice, c.dice, 1e-12) << what;
  EXPECT_GT(c.signed_volume, 0) << what << ": outward";
}

// The template of `label` in the label file at `path` (any 3D format read_image reads), checked
// as expect_valid_template does: a test on a real label volume is one call.
inline LabelTemplate<3> expect_valid_template_of_file(const std::string& path, int label, int target, int genus,
                                                      double min_dice) {
  const Image<3> labels = read_image<3>(path);
  LabelTemplateOptions o;
  o.label = label;
  o.vertices = target;
  LabelTemplate<3> t = template_from_labels<3>(labels, o, path);
  expect_valid_template(t, labels, label, target, genus, min_dice, path);
  return t;
}

}  // namespace dsnake::test_support
