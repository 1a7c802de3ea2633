// Acceptance for oriented images: an image stored with flipped or permuted axes, or with a rotated
// direction matrix, gives the same world-space result as the same data stored axis-aligned, on
// real scans, through `dsnake run`:
//  3D: a piece of CGAL's liver label (box-averaged to ~3.7 mm voxels and cropped), its template
//      from template_from_labels enlarged by template.transform scale 1.08, the full-size template
//      as ground-truth surface and targets, the label as ground-truth mask. Stored (a)
//      axis-aligned, (b) with x flipped and the axes permuted (MetaImage TransformMatrix, and a
//      second signed permutation as NIfTI sform/qform), (c) with the voxels unchanged and an
//      oblique direction R, the template and truth rotated by R about the image origin, (d) (c)
//      with its last axis reversed (an oblique reflection, NRRD), which the reader makes (c).
//  2D: ITK's BrainProtonDensitySliceBorder20 (the head's outline as template and truth), stored
//      with x and y flips, a transpose (a reflection), a transpose with a flip (a rotation by
//      90 degrees), and ITK's own BrainProtonDensitySliceBorder20DirectionPlus30.mhd (the same
//      voxels with a +30 degree direction), and that file with y reversed (an oblique reflection, NRRD).
// The GVF runs also guard the blur's support against a spacing a rounding error off 1 mm (NRRD's
// spacing is |space direction|): without image_filters.cpp's margin, (d) in 2D differs by 2.6e-4 mm.
// Asserted: the metrics of every storage equal (a)'s to 1e-6; final and initial positions
// (final.vtk, initial.vtk, world coordinates) equal (a)'s, or R (a)'s about the origin, to 1e-6;
// result_mask.nii.gz has the voxels of (a)'s, and the oblique one has the direction R.
#include "framework/io/image_io.h"
#include "framework/io/mesh_io.h"
#include "meshing/template_from_labels.h"

#include "tests/experiments/temp_dir_test.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <Eigen/Geometry>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>

namespace dsnake {
namespace {

namespace fs = std::filesystem;

const std::string kScans = DSNAKE_SCANS_DIR;
constexpr double kTol = 1e-6;
// The template is enlarged about its centroid, so the snake has something to fit; it comes in
// from outside (a shrunk one is caught by the edges inside the head and the liver).
constexpr double kScale = 1.08;

template <int D>
using Matrix = Eigen::Matrix<double, D, D>;

// `a` stored with index axis k running along a's axis to[k] in direction sign[k]: the voxels
// reordered, the origin at the world position of the first stored voxel and the direction
// a's with its columns permuted and signed, so every voxel keeps its world position. With an
// axis-aligned `a` the direction is a signed permutation; with an oblique one, a reflection
// when the signs' product is -1.
template <int D>
Image<D> stored_permuted(const Image<D>& a, const std::array<int, D>& to, const std::array<int, D>& sign) {
  const Grid<D>& ga = a.grid();
  Grid<D> g;
  GridIndex<D> corner;
  for (int k = 0; k < D; ++k) {
    g.size[k] = a.size()[to[k]];
    g.spacing[k] = a.spacing()[to[k]];
    g.direction.col(k) = sign[k] * ga.direction.col(to[k]);
    corner[to[k]] = sign[k] > 0 ? 0 : a.size()[to[k]] - 1;
  }
  g.origin = ga.to_world(ga.to_physical(corner));
  Image<D> s(g);
  for (int64_t l = 0; l < s.num_voxels(); ++l) {
    const GridIndex<D> j = g.index(l);
    GridIndex<D> i;
    for (int k = 0; k < D; ++k) i[to[k]] = sign[k] > 0 ? j[k] : a.size()[to[k]] - 1 - j[k];
    s[l] = a.at(i);
    // the test's own construction: the stored voxel sits where a's does
    if (l % 997 == 0) {
      EXPECT_LT((g.to_world(g.to_physical(j)) - ga.to_world(ga.to_physical(i))).norm(), 1e-9);
    }
  }
  return s;
}

// The same voxels and origin with the direction R.
template <int D>
Image<D> with_direction(const Image<D>& a, const Matrix<D>& r) {
  Grid<D> g = a.grid();
  g.direction = r;
  Image<D> s(g);
  s.data() = a.data();
  return s;
}

template <int D>
PointList<D> rotated(const PointList<D>& p, const Matrix<D>& r, const Point<D>& o) {
  PointList<D> out(p.size());
  for (size_t i = 0; i < p.size(); ++i) out[i] = o + r * (p[i] - o);
  return out;
}

template <int D>
void write_targets_any(const PointList<D>& p, const fs::path& path) {
  nlohmann::json t = nlohmann::json::array();
  for (const auto& x : p) {
    nlohmann::json q = nlohmann::json::array();
    for (int a = 0; a < D; ++a) q.push_back(x[a]);
    t.push_back(q);
  }
  std::ofstream(path) << nlohmann::json{{"targets", t}}.dump();
}

// The POINTS of a legacy VTK file (2D: z dropped).
template <int D>
PointList<D> vtk_points(const fs::path& path) {
  std::ifstream in(path);
  std::string word;
  while (in >> word && word != "POINTS") {}
  size_t n = 0;
  std::string type;
  in >> n >> type;
  PointList<D> p(n);
  for (size_t i = 0; i < n; ++i) {
    double x[3];
    in >> x[0] >> x[1] >> x[2];
    for (int a = 0; a < D; ++a) p[i][a] = x[a];
  }
  EXPECT_TRUE(bool(in)) << path;
  return p;
}

// One storage of the scan: the files of one experiment.
template <int D>
struct Storage {
  std::string name;
  std::string image;   // path of the image file
  Image<D> mask;       // stored as the image is
  Template<D> tmpl;    // template (full size; the experiment scales it by kScale), truth surface and targets
};

struct RunResult {
  nlohmann::json metrics;
  fs::path out;
};

class WorldOrientationTest : public test_support::TempDirTest {
 protected:
  // Writes the experiment of `s` into dir_/name and runs `dsnake run` on it.
  template <int D>
  RunResult run(const Storage<D>& s, const nlohmann::json& settings) {
    const fs::path d = dir_ / s.name;
    fs::create_directories(d);
    const std::string shape_ext = D == 2 ? ".txt" : ".off";
    write_image<D>(s.mask, (d / "mask.mha").string(), ImageWriteOptions{.label = true});
    write_shape<D>(s.tmpl.positions, s.tmpl.connectivity, (d / ("template" + shape_ext)).string());
    write_targets_any<D>(s.tmpl.positions, d / "targets.json");
    nlohmann::json j = settings;
    j["name"] = s.name;
    j["dimension"] = D;
    j["seed"] = 1;
    j["image"] = {{"file", s.image}};
    j["ground_truth"] = {{"mask", "mask.mha"}, {"surface", "template" + shape_ext}, {"correspondence", "targets.json"}};
    j["template"] = {{"file", "template" + shape_ext}, {"transform", {{"scale", kScale}}}};
    j["output"] = {{"figures", false}};
    std::ofstream(d / "exp.json") << j.dump(2);
    const fs::path out = d / "out";
    const std::string cmd = std::string(DSNAKE_EXE) + " run " + (d / "exp.json").string() + " --out " + out.string() +
                            " --threads 1 --quiet 2>" + (d / "stderr.txt").string();
    const int status = std::system(cmd.c_str());
    EXPECT_EQ(status, 0) << s.name << ": " << slurp(d / "stderr.txt");
    std::ifstream in(out / "result.json");
    return {nlohmann::json::parse(in)["metrics"], out};
  }

  // Compares a storage's run with the axis-aligned one: `r` and `o` map (a)'s world positions to
  // this storage's (identity for a reordered storage). Returns the largest deviations seen.
  template <int D>
  void compare(const std::string& name, const RunResult& a, const RunResult& b, const Matrix<D>& r,
               const Point<D>& o, bool oblique) {
    double metric_dev = 0, position_dev = 0;
    for (const char* key : {"mean_surface_distance", "hausdorff95", "hausdorff", "dice", "correspondence_error_mean",
                            "correspondence_error_max", "self_intersections"}) {
      ASSERT_TRUE(a.metrics[key].is_number()) << key;
      ASSERT_TRUE(b.metrics[key].is_number()) << name << " " << key;
      const double dev = std::abs(a.metrics[key].get<double>() - b.metrics[key].get<double>());
      EXPECT_LE(dev, kTol) << name << " " << key << ": " << a.metrics[key] << " vs " << b.metrics[key];
      metric_dev = std::max(metric_dev, dev);
    }
    for (const char* file : {"final.vtk", "initial.vtk"}) {
      const PointList<D> pa = vtk_points<D>(a.out / file), pb = vtk_points<D>(b.out / file);
      ASSERT_EQ(pa.size(), pb.size()) << name << " " << file;
      for (size_t i = 0; i < pa.size(); ++i) {
        const double dev = (pb[i] - (o + r * (pa[i] - o))).norm();
        position_dev = std::max(position_dev, dev);
      }
    }
    EXPECT_LE(position_dev, kTol) << name;
    // result_mask.nii.gz: the voxels of (a)'s, with this storage's direction.
    const Image<D> ma = read_image<D>((a.out / "result_mask.nii.gz").string());
    const Image<D> mb = read_image<D>((b.out / "result_mask.nii.gz").string());
    ASSERT_EQ(ma.size(), mb.size()) << name;
    EXPECT_EQ(ma.data(), mb.data()) << name;
    EXPECT_LE((mb.grid().direction - (oblique ? r : Matrix<D>::Identity())).cwiseAbs().maxCoeff(), kTol) << name;
    std::cout << "[ orientation ] " << name << ": largest metric difference " << metric_dev
              << ", largest position difference " << position_dev << " mm\n";
  }

  // Checks the axis-aligned run did register: the snake moved and fits its truth.
  template <int D>
  static void expect_registered(const RunResult& a, double min_dice) {
    EXPECT_GT(a.metrics["dice"].get<double>(), min_dice) << a.metrics;
    EXPECT_GT(a.metrics["correspondence_error_mean"].get<double>(), 0.0) << a.metrics;
    const PointList<D> p0 = vtk_points<D>(a.out / "initial.vtk"), p1 = vtk_points<D>(a.out / "final.vtk");
    ASSERT_EQ(p0.size(), p1.size());
    double move = 0;
    for (size_t i = 0; i < p0.size(); ++i) move += (p1[i] - p0[i]).norm() / double(p0.size());
    EXPECT_GT(move, 0.5) << "the snake hardly moved";
    std::cout << "[ orientation ] axis-aligned: " << a.metrics.dump() << ", mean move " << move << " mm\n";
  }
};

// A 3D piece of CGAL's liver label: box-averaged by 6 x 6 x 3 voxels (the partial-volume
// fraction as the image) and cropped to the liver with a margin. Spacing and origin are put on
// binary-exact values (0.6171875 for the file's 0.617188 mm) so that NIfTI's float32 header
// holds the grid exactly: any difference left is the orientation's, not the format's precision.
Image<3> liver_piece() {
  const Image<3> full = read_image<3>(kScans + "/cgal/images/liver.inr.gz");
  const GridIndex<3> f(6, 6, 3);
  Grid<3> coarse;
  for (int a = 0; a < 3; ++a) coarse.size[a] = full.size()[a] / f[a];
  Image<3> frac(coarse);
  for (int64_t l = 0; l < full.num_voxels(); ++l) {
    const GridIndex<3> i = full.grid().index(l);
    GridIndex<3> c;
    bool in = true;
    for (int a = 0; a < 3; ++a) in &= (c[a] = i[a] / f[a]) < coarse.size[a];
    if (in && full[l] >= 128) frac.at(c) += 1.0f / float(f.prod());
  }
  GridIndex<3> lo = coarse.size, hi = GridIndex<3>::Zero();
  for (int64_t l = 0; l < frac.num_voxels(); ++l)
    if (frac[l] > 0) {
      const GridIndex<3> i = coarse.index(l);
      lo = lo.cwiseMin(i);
      hi = hi.cwiseMax(i);
    }
  Grid<3> g;
  const Point<3> spacing(0.6171875 * f[0], 0.6171875 * f[1], 4.0);  // 3 x 1.33333 mm in z
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::max(0, lo[a] - 3);
    hi[a] = std::min(coarse.size[a] - 1, hi[a] + 3);
    g.size[a] = hi[a] - lo[a] + 1;
    g.spacing[a] = spacing[a];
  }
  g.origin = Point<3>(-96.25, 41.5, -120.75);  // an LPS origin away from 0, exact in float32
  Image<3> piece(g);
  for (int64_t l = 0; l < piece.num_voxels(); ++l) piece[l] = frac.at(GridIndex<3>(g.index(l) + lo));
  return piece;
}

template <int D>
Image<D> thresholded(const Image<D>& image, float t) {
  Image<D> m(image.grid());
  for (int64_t l = 0; l < m.num_voxels(); ++l) m[l] = image[l] > t ? 1.0f : 0.0f;
  return m;
}

TEST_F(WorldOrientationTest, RealVolumeStoredFlippedPermutedOrObliqueGivesTheSameWorldResult3d) {
  const Image<3> image = liver_piece();
  const Image<3> mask = thresholded(image, 0.5f);
  ASSERT_GT(image.size().minCoeff(), 20) << image.size().transpose();
  LabelTemplateOptions options;
  options.label = 1;
  options.vertices = 300;
  const Template<3> tmpl = template_from_labels<3>(mask, options, "liver piece").shape;

  const nlohmann::json settings = {
      {"field", {{"type", "gvf"}, {"mu", 0.2}}},
      {"energies",
       // umbrella: the dice floor below was measured with the per-vertex form (the test is about orientation)
       {{{"type", "internal"}, {"weight", 1.0}, {"alpha", 0.1}, {"beta", 0.0}, {"discretization", "umbrella"}},
        {{"type", "external"}, {"weight", 1.0}, {"tau", 3.0}},
        {{"type", "asap_mls"}, {"weight", 0.5}, {"variant", "approximate"}, {"neighborhood", "rings"}, {"rings", 1}}}},
      {"phases", {{{"iterations", 60}}}}};

  // (a) axis-aligned
  Storage<3> a{"aligned", (dir_ / "aligned.mha").string(), mask, tmpl};
  write_image<3>(image, a.image);

  // (b) reordered: the stored index axes run along (world z, -world x, world y) in a MetaImage
  // (x flipped, axes permuted), and along (-world y, world z, -world x) in a NIfTI file.
  struct Perm {
    std::string name, ext;
    std::array<int, 3> to, sign;
  };
  const Perm perms[] = {{"flip_x_permuted_mha", ".mha", {2, 0, 1}, {1, -1, 1}},
                        {"flip_permuted_nifti", ".nii.gz", {1, 2, 0}, {-1, 1, -1}}};
  std::vector<Storage<3>> reordered;
  for (const Perm& p : perms) {
    Storage<3> s{p.name, (dir_ / (p.name + p.ext)).string(), stored_permuted<3>(mask, p.to, p.sign), tmpl};
    write_image<3>(stored_permuted<3>(image, p.to, p.sign), s.image);
    // the reader puts it back on (a)'s grid
    const Image<3> back = read_image<3>(s.image);
    EXPECT_TRUE(back.grid().same_geometry(image.grid(), 1e-12)) << p.name;
    EXPECT_EQ(back.data(), image.data()) << p.name;
    reordered.push_back(std::move(s));
  }

  // (c) oblique: the voxels unchanged, direction R (40 degrees about (1, 2, 3)), the template,
  // truth surface and targets rotated by R about the image's origin.
  const Matrix<3> r = Eigen::AngleAxisd(40.0 * M_PI / 180.0, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Point<3> o = image.origin();
  Storage<3> c{"oblique", (dir_ / "oblique.mha").string(), with_direction<3>(mask, r), tmpl};
  c.tmpl.positions = rotated<3>(tmpl.positions, r, o);
  write_image<3>(with_direction<3>(image, r), c.image);
  EXPECT_LE((read_image<3>(c.image).grid().direction - r).cwiseAbs().maxCoeff(), 1e-12);

  // (d) oblique and reflected: (c) with its last axis reversed (direction R diag(1, 1, -1), a
  // reflection, in NRRD space directions); the reader reverses it back into a rotation.
  Storage<3> e{"oblique_reflected_nrrd", (dir_ / "oblique_reflected.nrrd").string(),
               stored_permuted<3>(c.mask, {0, 1, 2}, {1, 1, -1}), c.tmpl};
  write_image<3>(stored_permuted<3>(with_direction<3>(image, r), {0, 1, 2}, {1, 1, -1}), e.image);
  {
    const Image<3> back = read_image<3>(e.image), back_c = read_image<3>(c.image);
    EXPECT_TRUE(back.grid().same_geometry(back_c.grid(), 1e-9)) << back.grid().direction;
    EXPECT_EQ(back.data(), back_c.data());
  }

  const RunResult ra = run<3>(a, settings);
  expect_registered<3>(ra, 0.93);
  for (const auto& s : reordered) compare<3>(s.name, ra, run<3>(s, settings), Matrix<3>::Identity(), o, false);
  compare<3>("oblique", ra, run<3>(c, settings), r, o, true);
  compare<3>("oblique_reflected_nrrd", ra, run<3>(e, settings), r, o, true);
}

TEST_F(WorldOrientationTest, RealSliceStoredFlippedTransposedOrObliqueGivesTheSameWorldResult2d) {
  const Image<2> image = read_image<2>(kScans + "/itk/BrainProtonDensitySliceBorder20.mhd");
  ASSERT_TRUE(image.grid().axis_aligned());
  const Image<2> mask = thresholded(image, 20.0f);  // the head
  LabelTemplateOptions options;
  options.label = 1;
  options.vertices = 120;
  const Template<2> tmpl = template_from_labels<2>(mask, options, "head").shape;

  const nlohmann::json settings = {
      {"field", {{"type", "gvf"}, {"mu", 0.2}}},
      {"energies",
       {{{"type", "internal"}, {"weight", 1.0}, {"alpha", 0.1}, {"beta", 0.0}},
        {{"type", "external"}, {"weight", 1.0}, {"tau", 3.0}},
        {{"type", "asap_mls"}, {"weight", 0.5}, {"variant", "approximate"}, {"neighborhood", "rings"}, {"rings", 2}}}},
      {"phases", {{{"iterations", 100}}}}};

  Storage<2> a{"aligned", (dir_ / "aligned.mha").string(), mask, tmpl};
  write_image<2>(image, a.image);
  struct Perm {
    std::string name;
    std::array<int, 2> to, sign;
  };
  const Perm perms[] = {{"flip_x", {0, 1}, {-1, 1}},
                        {"flip_y", {0, 1}, {1, -1}},
                        {"transpose", {1, 0}, {1, 1}},           // TransformMatrix 0 1 1 0: a reflection
                        {"transpose_flip", {1, 0}, {-1, 1}}};    // a rotation by 90 degrees
  std::vector<Storage<2>> reordered;
  for (const Perm& p : perms) {
    Storage<2> s{p.name, (dir_ / (p.name + ".mha")).string(), stored_permuted<2>(mask, p.to, p.sign), tmpl};
    write_image<2>(stored_permuted<2>(image, p.to, p.sign), s.image);
    const Image<2> back = read_image<2>(s.image);
    EXPECT_TRUE(back.grid().same_geometry(image.grid(), 1e-12)) << p.name;
    EXPECT_EQ(back.data(), image.data()) << p.name;
    reordered.push_back(std::move(s));
  }

  // (c) ITK's own oblique file: the same voxels, direction +30 degrees.
  const std::string plus30 = kScans + "/itk/BrainProtonDensitySliceBorder20DirectionPlus30.mhd";
  const Image<2> oblique = read_image<2>(plus30);
  ASSERT_EQ(oblique.data(), image.data());
  const Matrix<2> r = oblique.grid().direction;
  EXPECT_LE((r - Eigen::Rotation2Dd(M_PI / 6).toRotationMatrix()).cwiseAbs().maxCoeff(), 1e-7);
  const Point<2> o = oblique.origin();
  Storage<2> c{"oblique_plus30", plus30, with_direction<2>(mask, r), tmpl};
  c.tmpl.positions = rotated<2>(tmpl.positions, r, o);

  // (d) oblique and reflected: the +30 degree file with its y axis reversed (direction
  // R diag(1, -1), a reflection; origin at the far corner), as NRRD.
  Storage<2> e{"oblique_reflected_nrrd", (dir_ / "oblique_reflected.nrrd").string(),
               stored_permuted<2>(c.mask, {0, 1}, {1, -1}), c.tmpl};
  write_image<2>(stored_permuted<2>(oblique, {0, 1}, {1, -1}), e.image);
  {
    const Image<2> back = read_image<2>(e.image);
    EXPECT_TRUE(back.grid().same_geometry(oblique.grid(), 1e-9)) << back.grid().direction;
    EXPECT_EQ(back.data(), oblique.data());
  }

  const RunResult ra = run<2>(a, settings);
  expect_registered<2>(ra, 0.97);
  for (const auto& s : reordered) compare<2>(s.name, ra, run<2>(s, settings), Matrix<2>::Identity(), o, false);
  compare<2>("oblique_plus30", ra, run<2>(c, settings), r, o, true);
  compare<2>("oblique_reflected_nrrd", ra, run<2>(e, settings), r, o, true);
}

}  // namespace
}  // namespace dsnake
