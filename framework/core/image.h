// Regular grids in physical space: Grid<D> (size, spacing, origin, direction), Image<D> (one
// float per voxel) and VectorField<D> (one D-vector per voxel).
//
// World coordinates are LPS millimetres (ITK's, MetaImage's and DICOM's convention; the NIfTI
// reader converts from RAS). Every computation of the framework runs in the grid's *frame*:
// voxel centres sit at origin + index * spacing, axis-aligned. `direction` is the rotation that
// takes the frame to world about the origin, world = origin + direction * (frame - origin)
// (to_world / to_frame). It is the identity for every image whose axes run along the world's,
// which the readers make of any image stored with flipped or permuted axes (they reorder the
// voxels); only an oblique scan keeps a rotation, and the experiment runner maps templates into
// its frame and results back to world (assemble.cpp, runner.cpp). Distances, the energies
// (similarity-invariant, §2) and fields computed on the index grid are unchanged by that map.
// Sampling is (bi/tri)linear. Outside the grid, a sample takes the value at the nearest point
// of the grid's bounding box (border replication), so forces stay defined everywhere.
#pragma once

#include "framework/core/types.h"

#include <cstdint>
#include <vector>

namespace dsnake {

template <int D>
struct Grid {
  GridIndex<D> size = GridIndex<D>::Zero();      // voxels per axis
  Point<D> spacing = Point<D>::Ones();           // physical size of a voxel per axis
  Point<D> origin = Point<D>::Zero();            // physical position of voxel 0
  Eigen::Matrix<double, D, D> direction = Eigen::Matrix<double, D, D>::Identity();  // frame -> world rotation

  int64_t num_voxels() const;
  int64_t linear(const GridIndex<D>& idx) const;  // x fastest
  GridIndex<D> index(int64_t linear) const;
  Point<D> to_physical(const GridIndex<D>& idx) const;
  Point<D> to_continuous_index(const Point<D>& x) const;  // (x - origin) / spacing
  bool inside(const Point<D>& x) const;  // within the box spanned by the voxel centres
  bool same_geometry(const Grid& other, double tol = 1e-9) const;  // size, spacing, origin, direction
  bool axis_aligned() const { return direction.isIdentity(0.0); }  // frame == world
  Point<D> to_world(const Point<D>& frame_point) const { return origin + direction * (frame_point - origin); }
  Point<D> to_frame(const Point<D>& world_point) const {
    return origin + direction.transpose() * (world_point - origin);
  }

  // Linear interpolation stencil: the 2^D voxels around x (clamped) and their weights.
  struct Stencil {
    std::array<int64_t, (D == 2 ? 4 : 8)> voxel;
    std::array<double, (D == 2 ? 4 : 8)> weight;
  };
  Stencil stencil(const Point<D>& x) const;
};

template <int D>
class Image {
 public:
  Image() = default;
  explicit Image(const Grid<D>& grid, float value = 0.0f);

  const Grid<D>& grid() const { return grid_; }
  const GridIndex<D>& size() const { return grid_.size; }
  const Point<D>& spacing() const { return grid_.spacing; }
  const Point<D>& origin() const { return grid_.origin; }
  int64_t num_voxels() const { return static_cast<int64_t>(data_.size()); }
  bool empty() const { return data_.empty(); }

  float& operator[](int64_t i) { return data_[i]; }
  float operator[](int64_t i) const { return data_[i]; }
  float& at(const GridIndex<D>& idx) { return data_[grid_.linear(idx)]; }
  float at(const GridIndex<D>& idx) const { return data_[grid_.linear(idx)]; }
  std::vector<float>& data() { return data_; }
  const std::vector<float>& data() const { return data_; }

  double sample(const Point<D>& x) const;  // linear interpolation, physical coordinates

 private:
  Grid<D> grid_;
  std::vector<float> data_;
};

template <int D>
class VectorField {
 public:
  VectorField() = default;
  explicit VectorField(const Grid<D>& grid);

  const Grid<D>& grid() const { return grid_; }
  int64_t num_voxels() const { return static_cast<int64_t>(vectors_.size()); }
  bool empty() const { return vectors_.empty(); }
  Point<D>& operator[](int64_t i) { return vectors_[i]; }
  const Point<D>& operator[](int64_t i) const { return vectors_[i]; }
  PointList<D>& data() { return vectors_; }
  const PointList<D>& data() const { return vectors_; }

  Point<D> sample(const Point<D>& x) const;  // linear interpolation per component
  // Asks the CPU to fetch the voxels sample(x) will read (a hint: no effect on results). Loops
  // over a snake's vertices call it a few vertices ahead, so that the stencils of consecutive
  // vertices, scattered over a large volume, load in parallel instead of one miss at a time.
  void prefetch(const Point<D>& x) const;
  Image<D> component(int axis) const;        // one component as a scalar image

 private:
  Grid<D> grid_;
  PointList<D> vectors_;
};

}  // namespace dsnake
