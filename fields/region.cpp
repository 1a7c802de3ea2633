// The field's region of interest; see region.h.
#include "fields/region.h"

#include "framework/core/errors.h"

#include <algorithm>
#include <cmath>

namespace dsnake {

template <int D>
int64_t VoxelBox<D>::num_voxels() const {
  int64_t n = 1;
  for (int a = 0; a < D; ++a) n *= size[a];
  return n;
}

// The box in the frame, widened, then to voxel indices: first index whose centre is >= the
// box's low end, last whose centre is <= its high end (clamped).
template <int D>
VoxelBox<D> region_of_interest(const Grid<D>& grid, const PointList<D>& points, const FieldRegionOptions& options) {
  VoxelBox<D> whole{GridIndex<D>::Zero(), grid.size};
  if (options.extent == RegionExtent::kWhole || points.empty()) return whole;
  Point<D> lo = points[0], hi = points[0];
  for (const Point<D>& p : points) {
    if (!p.allFinite()) return whole;
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const double margin = std::max(options.margin, options.margin_share * (hi - lo).maxCoeff());
  VoxelBox<D> box;
  for (int a = 0; a < D; ++a) {
    const double first = std::ceil((lo[a] - margin - grid.origin[a]) / grid.spacing[a]);
    const double last = std::floor((hi[a] + margin - grid.origin[a]) / grid.spacing[a]);
    const double n = double(grid.size[a]);
    const int64_t f = int64_t(std::clamp(first, 0.0, n - 1));
    const int64_t l = int64_t(std::clamp(last, double(f), n - 1));
    box.lo[a] = int(f);
    box.size[a] = int(l - f + 1);
  }
  return box;
}

template <int D>
Image<D> crop(const Image<D>& image, const VoxelBox<D>& box) {
  const Grid<D>& g = image.grid();
  for (int a = 0; a < D; ++a)
    DSNAKE_ASSERT(box.lo[a] >= 0 && box.size[a] >= 1 && box.lo[a] + box.size[a] <= g.size[a], "crop: a box inside the grid");
  Grid<D> cg = g;
  cg.size = box.size;
  cg.origin = g.to_physical(box.lo);
  Image<D> out(cg);
  const int64_t rows = box.num_voxels() / box.size[0];
  for (int64_t r = 0; r < rows; ++r) {  // one x-row at a time
    GridIndex<D> idx = GridIndex<D>::Zero();
    int64_t rest = r;
    for (int a = 1; a < D; ++a) {
      idx[a] = int(rest % box.size[a]);
      rest /= box.size[a];
    }
    const int64_t dst = cg.linear(idx);
    const int64_t src = g.linear(GridIndex<D>(idx + box.lo));
    std::copy_n(image.data().begin() + src, box.size[0], out.data().begin() + dst);
  }
  return out;
}

template struct VoxelBox<2>;
template struct VoxelBox<3>;
template VoxelBox<2> region_of_interest(const Grid<2>&, const PointList<2>&, const FieldRegionOptions&);
template VoxelBox<3> region_of_interest(const Grid<3>&, const PointList<3>&, const FieldRegionOptions&);
template Image<2> crop(const Image<2>&, const VoxelBox<2>&);
template Image<3> crop(const Image<3>&, const VoxelBox<3>&);

}  // namespace dsnake
