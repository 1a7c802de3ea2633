// Synthetic images with edges at known places, for the polarity-aware forces (profile_test,
// external_polarity_test): radial images I(|x - c|) on a grid about the origin, blurred, and
// circles / spheres to start from.
#pragma once

#include "experiments/phantoms/phantoms.h"
#include "framework/core/energy.h"
#include "framework/core/image_filters.h"
#include "framework/core/shape.h"

#include <cmath>
#include <functional>

namespace dsnake::test_support {

// A cube (square) grid of `size` voxels per axis of `spacing` mm centred on the origin, voxel
// values radial(|x - centre|), then a Gaussian blur of `blur` mm.
template <int D>
Image<D> radial_image(int size, double spacing, const std::function<double(double)>& radial, double blur,
                      const Point<D>& centre = Point<D>::Zero()) {
  Grid<D> g;
  g.size = GridIndex<D>::Constant(size);
  g.spacing = Point<D>::Constant(spacing);
  g.origin = Point<D>::Constant(-0.5 * (size - 1) * spacing);
  Image<D> image(g);
  for (int64_t l = 0; l < image.num_voxels(); ++l)
    image[l] = static_cast<float>(radial((g.to_physical(g.index(l)) - centre).norm()));
  return gaussian_blur(image, blur);
}

// A bright disk / ball of `radius` (200 inside, 50 outside).
inline std::function<double(double)> bright_disk(double radius) {
  return [radius](double r) { return r < radius ? 200.0 : 50.0; };
}
// Two concentric edges of opposite polarity: bright inside `inner`, dark ring, bright beyond `outer`.
inline std::function<double(double)> dark_ring(double inner, double outer) {
  return [inner, outer](double r) { return r < inner ? 200.0 : r < outer ? 50.0 : 200.0; };
}

// A template circle (n vertices, counter-clockwise) or icosphere of `radius` about `centre`.
template <int D>
Template<D> round_template(double radius, const Point<D>& centre = Point<D>::Zero(), int n = 48) {
  Template<D> t;
  if constexpr (D == 2) {
    constexpr double kPi = 3.14159265358979323846;
    for (int i = 0; i < n; ++i)
      t.positions.push_back(centre + radius * Point<2>(std::cos(2 * kPi * i / n), std::sin(2 * kPi * i / n)));
    t.connectivity = Connectivity::polygon(n);
  } else {
    t = make_icosphere(2);
    for (auto& p : t.positions) p = centre + radius * p;
  }
  return t;
}

// The mean and the largest | |q_v - centre| - radius | over the snake's vertices.
template <int D>
std::pair<double, double> radial_error(const Snake<D>& snake, double radius, const Point<D>& centre = Point<D>::Zero()) {
  double sum = 0.0, worst = 0.0;
  for (const auto& q : snake.positions()) {
    const double e = std::abs((q - centre).norm() - radius);
    sum += e;
    worst = std::max(worst, e);
  }
  return {sum / snake.num_vertices(), worst};
}

// The mean signed |q_v - centre| - radius over the snake's vertices.
template <int D>
double mean_radial_offset(const Snake<D>& snake, double radius, const Point<D>& centre = Point<D>::Zero()) {
  double sum = 0.0;
  for (const auto& q : snake.positions()) sum += (q - centre).norm() - radius;
  return sum / snake.num_vertices();
}

// Where the gradient of a disk / ball of radius R blurred by a Gaussian of sigma peaks: inside R by
// about (D - 1) sigma^2 / (2 R) (the blur of a curved edge; first order in sigma / R).
inline double blurred_edge_radius(int dimension, double radius, double sigma) {
  return radius - (dimension - 1) * sigma * sigma / (2 * radius);
}

// Moves the snake to the energy's proposals `iterations` times (the energy alone, weight 1).
template <int D>
void iterate_alone(Energy<D>& energy, const EnergyContext<D>& context, Snake<D>& snake, int iterations) {
  energy.bind(context, snake);
  PointList<D> out(snake.num_vertices());
  for (int i = 0; i < iterations; ++i) {
    energy.propose(snake, out);
    snake.positions() = out;
  }
}

}  // namespace dsnake::test_support
