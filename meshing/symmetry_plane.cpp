// Symmetry planes of label maps and images; see symmetry_plane.h.
#include "meshing/symmetry_plane.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

namespace dsnake {

namespace {

// Candidate planes are "steps" k: the plane through index k / 2 along the axis, which maps the
// voxel at index i to the voxel at index k - i (k even: through a voxel centre; odd: through the
// face between two voxels). Its world offset is origin + k / 2 * spacing.

// The voxels of a grid seen along one axis: value (o * n + i) * inner + t has index i along it.
struct AxisLayout {
  int64_t outer = 1, n = 1, inner = 1;
};

template <int D>
AxisLayout axis_layout(const GridIndex<D>& size, int axis) {
  AxisLayout l;
  l.n = size[axis];
  for (int a = 0; a < axis; ++a) l.inner *= size[a];
  for (int a = axis + 1; a < D; ++a) l.outer *= size[a];
  return l;
}

// Calls f(v, w) for every voxel v whose reflection w by step k lies in the grid.
template <class F>
void for_each_reflected_pair(const AxisLayout& l, int64_t k, F&& f) {
  const int64_t lo = std::max<int64_t>(0, k - (l.n - 1)), hi = std::min<int64_t>(l.n - 1, k);
  for (int64_t o = 0; o < l.outer; ++o)
    for (int64_t i = lo; i <= hi; ++i) {
      const int64_t v = (o * l.n + i) * l.inner, w = (o * l.n + (k - i)) * l.inner;
      for (int64_t t = 0; t < l.inner; ++t) f(v + t, w + t);
    }
}

template <int D>
double step_offset(const Grid<D>& g, int axis, double k) {
  return g.origin[axis] + 0.5 * k * g.spacing[axis];
}

template <int D>
int64_t nearest_step(const Grid<D>& g, int axis, double offset) {
  return std::llround(2 * (offset - g.origin[axis]) / g.spacing[axis]);
}

// How a score falls off about its peak, for the sub-step fit: a count of matching voxels falls
// linearly on both sides (a cone: the overlap of a shape with its shifted mirror), a correlation
// of intensities smoothly (a parabola).
enum class PeakShape { kParabola, kCone };

// The best step of `score` in [lo, hi], searched from k0 in a window of radius r that moves on
// while the best lies on its edge; then the step plus a sub-step shift in [-0.5, 0.5], from the
// parabola or the cone (two lines of opposite slopes) through the best and its two neighbours
// (no shift at the range's ends).
double best_step(const std::function<double(int64_t)>& score, int64_t lo, int64_t hi, int64_t k0, int64_t r,
                 PeakShape shape) {
  std::map<int64_t, double> seen;
  auto at = [&](int64_t k) {
    auto it = seen.find(k);
    return it != seen.end() ? it->second : seen.emplace(k, score(k)).first->second;
  };
  int64_t a = std::clamp(k0 - r, lo, hi), b = std::clamp(k0 + r, lo, hi), best = a;
  for (;;) {
    best = a;
    for (int64_t k = a; k <= b; ++k)
      if (at(k) > at(best)) best = k;
    if (best == a && a > lo) a = std::max(lo, a - r);
    else if (best == b && b < hi) b = std::min(hi, b + r);
    else break;
  }
  if (best == lo || best == hi) return double(best);
  const double ym = at(best - 1), y0 = at(best), yp = at(best + 1);
  const double shift = shape == PeakShape::kCone ? 0.5 * (yp - ym) / (y0 - std::min(ym, yp))
                                                 : 0.5 * (ym - yp) / (ym - 2 * y0 + yp);
  return std::isfinite(shift) ? double(best) + std::clamp(shift, -0.5, 0.5) : double(best);
}

// The best step of `score` over all of [lo, hi] (the coarse search).
int64_t best_step_everywhere(const std::function<double(int64_t)>& score, int64_t lo, int64_t hi) {
  int64_t best = lo;
  double best_score = -std::numeric_limits<double>::infinity();
  for (int64_t k = lo; k <= hi; ++k)
    if (const double s = score(k); s > best_score) best_score = s, best = k;
  return best;
}

// The coarse level's factor: box averaging by f per axis leaves at most ~2^18 voxels.
template <int D>
int coarse_factor(const Grid<D>& g) {
  const double f = std::ceil(std::pow(double(g.num_voxels()) / double(1 << 18), 1.0 / D) - 1e-9);
  int smallest = g.size[0];
  for (int a = 1; a < D; ++a) smallest = std::min(smallest, g.size[a]);
  return std::clamp(int(f), 1, std::max(1, smallest / 4));
}

// The box average of `image` over blocks of f^D voxels (a partial block at the far end is
// dropped); the block's centre is the coarse voxel's position.
template <int D>
Image<D> box_averaged(const Image<D>& image, int f) {
  Grid<D> g = image.grid();
  for (int a = 0; a < D; ++a) {
    g.size[a] = std::max(1, image.size()[a] / f);
    g.origin[a] += 0.5 * (f - 1) * image.spacing()[a];
    g.spacing[a] *= f;
  }
  Image<D> coarse(g, 0.0f);
  std::vector<int> count(size_t(g.num_voxels()), 0);
  for (int64_t v = 0; v < image.num_voxels(); ++v) {
    GridIndex<D> i = image.grid().index(v);
    bool inside = true;
    for (int a = 0; a < D; ++a) inside = inside && (i[a] /= f) < g.size[a];
    if (!inside) continue;
    const int64_t c = g.linear(i);
    coarse[c] += image[v];
    ++count[size_t(c)];
  }
  for (int64_t c = 0; c < coarse.num_voxels(); ++c) coarse[c] /= float(std::max(1, count[size_t(c)]));
  return coarse;
}

template <int D>
void check_grid(const Grid<D>& g, int axis, const char* what) {
  if (axis < 0 || axis >= D) throw std::invalid_argument(std::string(what) + ": no axis " + std::to_string(axis));
  if (!g.axis_aligned())
    throw std::invalid_argument(std::string(what) + ": the grid is oblique (its axes do not run along the world's)");
}

// Overlap of a non-negative image with its reflection by step k: sum of f(v) f(w).
template <int D>
double overlap(const Image<D>& f, const AxisLayout& l, int64_t k) {
  double s = 0;
  const float* p = f.data().data();
  for_each_reflected_pair(l, k, [&](int64_t v, int64_t w) { s += double(p[v]) * p[w]; });
  return s;
}

// The steps whose planes lie within the extent of the image's non-zero voxels along the axis.
template <int D>
std::pair<int64_t, int64_t> non_zero_steps(const Image<D>& f, const AxisLayout& l) {
  int64_t first = l.n, last = -1;
  for (int64_t o = 0; o < l.outer; ++o)
    for (int64_t i = 0; i < l.n; ++i)
      for (int64_t t = 0; t < l.inner; ++t)
        if (f[(o * l.n + i) * l.inner + t] != 0) first = std::min(first, i), last = std::max(last, i);
  return {2 * first, 2 * last};
}

// Label values as dense ids (0: background, 1...: the non-zero values in any order).
template <int D>
std::vector<int> label_ids(const Image<D>& labels, int& count) {
  std::unordered_map<float, int> id;
  std::vector<int> out(size_t(labels.num_voxels()), 0);
  float last_value = 0;
  int last_id = 0;
  for (int64_t v = 0; v < labels.num_voxels(); ++v) {
    const float x = labels[v];
    if (x == 0) continue;
    if (x != last_value) {
      last_value = x;
      last_id = id.emplace(x, int(id.size()) + 1).first->second;
    }
    out[size_t(v)] = last_id;
  }
  count = int(id.size());
  return out;
}

// Each label's counterpart at step k: the non-zero label on which most of its reflected voxels
// fall (-1: none, all fall on the background or outside the grid).
std::vector<int> counterparts(const std::vector<int>& ids, int count, const AxisLayout& l, int64_t k) {
  std::vector<uint64_t> pairs;
  for_each_reflected_pair(l, k, [&](int64_t v, int64_t w) {
    if (ids[size_t(v)] > 0 && ids[size_t(w)] > 0) pairs.push_back(uint64_t(ids[size_t(v)]) << 32 | uint64_t(ids[size_t(w)]));
  });
  std::sort(pairs.begin(), pairs.end());
  std::vector<int> partner(size_t(count) + 1, -1);
  std::vector<int64_t> best(size_t(count) + 1, 0);
  for (size_t s = 0; s < pairs.size();) {
    size_t e = s;
    while (e < pairs.size() && pairs[e] == pairs[s]) ++e;
    const int a = int(pairs[s] >> 32), b = int(pairs[s] & 0xffffffffu);
    if (int64_t(e - s) > best[size_t(a)]) best[size_t(a)] = int64_t(e - s), partner[size_t(a)] = b;
    s = e;
  }
  return partner;
}

}  // namespace

template <int D>
Point<D> reflect(const Point<D>& p, const MirrorPlane& plane) {
  Point<D> r = p;
  r[plane.axis] = 2 * plane.offset - p[plane.axis];
  return r;
}

template <int D>
std::pair<double, double> world_extent(const Grid<D>& grid, int axis) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (int corner = 0; corner < (1 << D); ++corner) {
    Point<D> frame = grid.origin;
    for (int a = 0; a < D; ++a) frame[a] += ((corner >> a & 1) ? grid.size[a] - 0.5 : -0.5) * grid.spacing[a];
    const double x = grid.to_world(frame)[axis];
    lo = std::min(lo, x), hi = std::max(hi, x);
  }
  return {lo, hi};
}

template <int D>
MirrorPlane label_symmetry_plane(const Image<D>& labels, int axis) {
  check_grid(labels.grid(), axis, "label symmetry plane");
  Image<D> foreground(labels.grid(), 0.0f);
  for (int64_t v = 0; v < labels.num_voxels(); ++v) foreground[v] = labels[v] != 0;
  const AxisLayout fine = axis_layout<D>(labels.size(), axis);
  const auto [lo, hi] = non_zero_steps(foreground, fine);
  if (hi < lo) throw std::invalid_argument("label symmetry plane: no labelled voxel");
  // (1) The foreground's plane: coarse over its whole extent, then at full resolution.
  const int f = coarse_factor(labels.grid());
  const Image<D> coarse = box_averaged(foreground, f);
  const AxisLayout cl = axis_layout<D>(coarse.size(), axis);
  const auto [clo, chi] = non_zero_steps(coarse, cl);
  const int64_t kc = best_step_everywhere([&](int64_t k) { return overlap(coarse, cl, k); }, clo, chi);
  const int64_t k0 = nearest_step(labels.grid(), axis, step_offset(coarse.grid(), axis, double(kc)));
  const double k_fg =
      best_step([&](int64_t k) { return overlap(foreground, fine, k); }, lo, hi, k0, f + 1, PeakShape::kCone);
  // (2) Counterparts there; (3) the plane that maps labels onto them best, near (1).
  int count = 0;
  const std::vector<int> ids = label_ids(labels, count);
  const std::vector<int> partner = counterparts(ids, count, fine, std::llround(k_fg));
  const double k = best_step(
      [&](int64_t k) {
        int64_t matched = 0;
        for_each_reflected_pair(fine, k, [&](int64_t v, int64_t w) {
          matched += ids[size_t(v)] > 0 && ids[size_t(w)] == partner[size_t(ids[size_t(v)])];
        });
        return double(matched);
      },
      lo, hi, std::llround(k_fg), 2, PeakShape::kCone);
  return {axis, step_offset(labels.grid(), axis, k)};
}

namespace {

// Normalised cross-correlation of the image with its reflection by step k, over the voxels that
// both cover (that set is its own reflection, so both sides have the same mean and variance).
template <int D>
double reflected_ncc(const Image<D>& image, const AxisLayout& l, int64_t k) {
  double n = 0, sum = 0, sum2 = 0, cross = 0;
  const float* p = image.data().data();
  for_each_reflected_pair(l, k, [&](int64_t v, int64_t w) {
    n += 1;
    sum += p[v];
    sum2 += double(p[v]) * p[v];
    cross += double(p[v]) * p[w];
  });
  const double mean = sum / n, var = sum2 / n - mean * mean;
  return var > 0 ? (cross / n - mean * mean) / var : -1.0;
}

// The steps of the planes through the middle half of the grid along the axis.
std::pair<int64_t, int64_t> middle_half_steps(int64_t n) {
  return {int64_t(std::ceil(0.5 * double(n - 1))), int64_t(std::floor(1.5 * double(n - 1)))};
}

}  // namespace

template <int D>
MirrorPlane image_symmetry_plane(const Image<D>& image, int axis) {
  check_grid(image.grid(), axis, "image symmetry plane");
  if (image.size()[axis] < 4) throw std::invalid_argument("image symmetry plane: fewer than 4 voxels along the axis");
  const auto [min_it, max_it] = std::minmax_element(image.data().begin(), image.data().end());
  if (*min_it == *max_it) throw std::invalid_argument("image symmetry plane: the image is constant");
  const AxisLayout fine = axis_layout<D>(image.size(), axis);
  const int f = coarse_factor(image.grid());
  const Image<D> coarse = box_averaged(image, f);
  const AxisLayout cl = axis_layout<D>(coarse.size(), axis);
  const auto [clo, chi] = middle_half_steps(cl.n);
  const int64_t kc = best_step_everywhere([&](int64_t k) { return reflected_ncc(coarse, cl, k); }, clo, chi);
  const auto [lo, hi] = middle_half_steps(fine.n);
  const int64_t k0 = std::clamp(nearest_step(image.grid(), axis, step_offset(coarse.grid(), axis, double(kc))), lo, hi);
  const double k =
      best_step([&](int64_t k) { return reflected_ncc(image, fine, k); }, lo, hi, k0, f + 1, PeakShape::kParabola);
  return {axis, step_offset(image.grid(), axis, k)};
}

template Point<2> reflect<2>(const Point<2>&, const MirrorPlane&);
template Point<3> reflect<3>(const Point<3>&, const MirrorPlane&);
template std::pair<double, double> world_extent<2>(const Grid<2>&, int);
template std::pair<double, double> world_extent<3>(const Grid<3>&, int);
template MirrorPlane label_symmetry_plane<2>(const Image<2>&, int);
template MirrorPlane label_symmetry_plane<3>(const Image<3>&, int);
template MirrorPlane image_symmetry_plane<2>(const Image<2>&, int);
template MirrorPlane image_symmetry_plane<3>(const Image<3>&, int);

}  // namespace dsnake
