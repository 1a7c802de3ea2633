// The region of interest a field is computed on.
// By default a field is computed on the box of the voxels around the placed template, widened
// by a margin, cut out of the image without resampling (whole voxels, the same spacing, origin
// and direction): the edge map is then normalised by the strongest edge near the object rather
// than in the whole scan (a head MRI's scalp), and the cost follows the template's size rather
// than the scan's. Outside the region a field's sample takes the value at the region's border
// (framework/core/image.h), so a snake that leaves the region feels the border's force: the
// margin must cover how far the snake may travel. `"region": {"extent": "whole"}` computes the
// field on the whole image.
#pragma once

#include "framework/core/image.h"
#include "framework/core/options.h"

namespace dsnake {

enum class RegionExtent { kTemplate, kWhole };
template <>
struct EnumNames<RegionExtent> {
  static constexpr std::array<std::pair<RegionExtent, const char*>, 2> table{
      {{RegionExtent::kTemplate, "template"}, {RegionExtent::kWhole, "whole"}}};
};

// "field.region": the template's bounding box widened on every side by
// max(margin, margin_share x the box's largest extent), clamped to the image.
struct FieldRegionOptions {
  RegionExtent extent = RegionExtent::kTemplate;
  double margin = 20.0;        // mm
  double margin_share = 0.25;  // of the template box's largest extent

  template <class V>
  void visit(V& v) {
    v(extent, Key{"extent", "", "where the field is computed: around the placed template (template) or on the whole image (whole)"});
    v(margin, Key{"margin", "mm", "the smallest widening of the template's bounding box on every side", Range::at_least(0)});
    v(margin_share, Key{"margin_share", "1",
                        "the widening as a share of the box's largest extent, when that is more than margin (a start "
                        "10% too small is 5% of the extent off on each side)",
                        Range::at_least(0)});
  }
};

// A box of whole voxels: lo is the first voxel's index, size the voxels per axis.
template <int D>
struct VoxelBox {
  GridIndex<D> lo = GridIndex<D>::Zero();
  GridIndex<D> size = GridIndex<D>::Zero();
  int64_t num_voxels() const;
};

// The voxels whose centres lie within the points' bounding box widened as the options say (in
// the grid's frame: points in frame coordinates), clamped to the grid; at least one voxel per
// axis. With extent "whole", or no points, the whole grid.
template <int D>
VoxelBox<D> region_of_interest(const Grid<D>& grid, const PointList<D>& points, const FieldRegionOptions& options);

// The voxels of `box` as an image of their own: same spacing and direction, the origin moved to
// the box's first voxel, so that a physical point names the same place in both. Whole voxels,
// no resampling.
template <int D>
Image<D> crop(const Image<D>& image, const VoxelBox<D>& box);

}  // namespace dsnake
