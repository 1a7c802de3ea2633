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
  // Adopts `data` as the voxels of `grid` (one value per voxel, x fastest) without a copy.
  Image(const Grid<D>& grid, std::vector<float>&& data);

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
  // sample() at the lattice x + h (i - half) for i in {0 .. 2 half}^D, first axis fastest, into
  // out ((2 half + 1)^D values): the same values, bit for bit, with the interpolation's per-axis
  // indices and weights computed once per axis instead of once per point (patch matching).
  void sample_lattice(const Point<D>& x, double h, int half, double* out) const;
  // Asks the CPU to fetch the voxels sample(x) will read (a hint: no effect on results), for
  // loops that sample a volume larger than the caches a few points ahead.
  void prefetch(const Point<D>& x) const;

 private:
  Grid<D> grid_;
  std::vector<float> data_;
};

// A mask on a grid, one byte per voxel (inside or not): a ground truth's mask, which a run holds
// from start to end, in a quarter of an Image's memory. Made from an image, a voxel is inside
// where the image is non-zero.
template <int D>
class BinaryMask {
 public:
  BinaryMask() = default;
  // Adopts `inside` (one value per voxel of `grid`, x fastest; non-zero = inside).
  BinaryMask(const Grid<D>& grid, std::vector<uint8_t>&& inside);
  // Inside where `image` is non-zero; implicit, as a mask is read and made as an image.
  BinaryMask(const Image<D>& image);  // NOLINT(google-explicit-constructor)

  const Grid<D>& grid() const { return grid_; }
  const Point<D>& spacing() const { return grid_.spacing; }
  int64_t num_voxels() const { return static_cast<int64_t>(inside_.size()); }
  bool operator[](int64_t i) const { return inside_[i] != 0; }
  bool at(const GridIndex<D>& idx) const { return inside_[grid_.linear(idx)] != 0; }
  const std::vector<uint8_t>& data() const { return inside_; }
  std::vector<uint8_t>& data() { return inside_; }

 private:
  Grid<D> grid_;
  std::vector<uint8_t> inside_;
};

// `mask` on a grid whose axes run along `direction` (a frame -> world rotation, Grid::direction):
// the smallest such grid that holds the mask's inside, with the mask's smallest spacing on every
// axis (coarser only where that grid would hold more than 32 times the voxels of the mask's own
// box around its inside), a voxel inside where the mask's linear interpolant at its centre is at
// least 0.5 (0 beyond the mask's voxel centres). For a ground truth whose grid is turned against
// the image's: the metrics run in the image's frame, on masks whose axes are its axes.
template <int D>
BinaryMask<D> resample_along(const BinaryMask<D>& mask, const Eigen::Matrix<double, D, D>& direction);

// One D-vector per voxel, stored as D interleaved floats: 12 bytes a voxel in 3D instead of the
// 24 of Point<D>. Every field's solver works in float, and the vectors are what a run
// keeps for its whole evolution. Sampling converts to double before interpolating, so a field
// whose values are floats samples to the same bits it did when stored in double; a field computed
// in double (distance, DDGVF's sum of its two halves) is rounded once, to float, when stored.
template <int D>
class VectorField {
 public:
  // Voxel i's vector as a writable view: assigning a Point rounds it to float; reading it gives
  // the Point in double. Lets `field[i] = p` and `field[i][a] = x` read as they would on Points.
  class VoxelRef {
   public:
    explicit VoxelRef(float* p) : p_(p) {}
    VoxelRef& operator=(const Point<D>& v) {
      for (int a = 0; a < D; ++a) p_[a] = static_cast<float>(v[a]);
      return *this;
    }
    float& operator[](int a) { return p_[a]; }
    operator Point<D>() const { return Point<D>(Eigen::Map<const Eigen::Matrix<float, D, 1>>(p_).template cast<double>()); }
    double norm() const { return Point<D>(*this).norm(); }
    double squaredNorm() const { return Point<D>(*this).squaredNorm(); }

   private:
    float* p_;
  };

  VectorField() = default;
  explicit VectorField(const Grid<D>& grid);

  const Grid<D>& grid() const { return grid_; }
  int64_t num_voxels() const { return static_cast<int64_t>(values_.size() / D); }
  bool empty() const { return values_.empty(); }
  Point<D> operator[](int64_t i) const {  // voxel i's vector, in double
    return Point<D>(Eigen::Map<const Eigen::Matrix<float, D, 1>>(at(i)).template cast<double>());
  }
  VoxelRef operator[](int64_t i) { return VoxelRef(at(i)); }
  float* at(int64_t i) { return values_.data() + size_t(i) * D; }  // voxel i's D floats
  const float* at(int64_t i) const { return values_.data() + size_t(i) * D; }
  // All values, voxel-major (x fastest), D components each.
  std::vector<float>& data() { return values_; }
  const std::vector<float>& data() const { return values_; }
  int64_t bytes() const { return int64_t(values_.size() * sizeof(float)); }

  Point<D> sample(const Point<D>& x) const;  // linear interpolation per component
  // Asks the CPU to fetch the voxels sample(x) will read (a hint: no effect on results). Loops
  // over a snake's vertices call it a few vertices ahead, so that the stencils of consecutive
  // vertices, scattered over a large volume, load in parallel instead of one miss at a time.
  void prefetch(const Point<D>& x) const;
  Image<D> component(int axis) const;        // one component as a scalar image

 private:
  Grid<D> grid_;
  std::vector<float> values_;
};

}  // namespace dsnake
