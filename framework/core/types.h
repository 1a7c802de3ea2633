// Basic geometric types shared by every folder: points in physical units (mm, or voxels
// where the spacing is 1) and integer grid indices, for D = 2 and D = 3.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

namespace dsnake {

template <int D>
using Point = Eigen::Matrix<double, D, 1>;  // a position or a vector, physical units

template <int D>
using PointList = std::vector<Point<D>>;  // n positions; index = vertex index

template <int D>
using GridIndex = Eigen::Matrix<int, D, 1>;  // voxel index, x fastest

using Triangle = std::array<int, 3>;  // vertex indices, counter-clockwise seen from outside

}  // namespace dsnake
