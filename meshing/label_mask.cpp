// Label masks: selection, largest component, cavity filling, padding; see label_mask.h.
#include "meshing/label_mask.h"

#include <algorithm>

namespace dsnake {

namespace {

constexpr uint8_t kOutside = 0, kObject = 1, kSeen = 2, kKept = 3, kReached = 4;

// Neighbour offsets in index space with at most `max_nonzero` non-zero coordinates: 1 gives the
// face neighbours (3D 6-, 2D 4-connectivity), D all of them (3D 26-, 2D 8-connectivity).
template <int D>
std::vector<GridIndex<D>> neighbour_offsets(int max_nonzero) {
  std::vector<GridIndex<D>> out;
  const int count = D == 2 ? 9 : 27;
  for (int c = 0; c < count; ++c) {
    GridIndex<D> o;
    int rest = c, nonzero = 0;
    for (int a = 0; a < D; ++a) {
      o[a] = rest % 3 - 1;
      rest /= 3;
      nonzero += o[a] != 0;
    }
    if (nonzero == 0 || nonzero > max_nonzero) continue;
    out.push_back(o);
  }
  return out;
}

// Flood fill from `seed` over voxels whose value is `from`, setting them to `to`; returns the
// number of voxels set. Depth-first with an explicit stack, bounds checked per neighbour.
template <int D>
int64_t flood(const Grid<D>& g, std::vector<uint8_t>& v, int64_t seed, uint8_t from, uint8_t to,
              const std::vector<GridIndex<D>>& offsets, std::vector<int64_t>& stack) {
  auto matches = [&](int64_t i) { return v[i] == from || (from == kOutside && v[i] == kSeen); };
  if (!matches(seed)) return 0;
  stack.assign(1, seed);
  v[seed] = to;
  int64_t count = 0;
  while (!stack.empty()) {
    const int64_t i = stack.back();
    stack.pop_back();
    ++count;
    const GridIndex<D> x = g.index(i);
    for (const GridIndex<D>& o : offsets) {
      const GridIndex<D> y = x + o;
      if ((y.array() < 0).any() || (y.array() >= g.size.array()).any()) continue;
      const int64_t j = g.linear(y);
      if (matches(j)) {
        v[j] = to;
        stack.push_back(j);
      }
    }
  }
  return count;
}

// The labels' voxels == label, copied into the padded grid (value kObject); counts them.
template <int D>
LabelMask<D> padded_selection(const Image<D>& labels, int label) {
  LabelMask<D> m;
  m.grid = labels.grid();
  m.grid.size = labels.size() + GridIndex<D>::Constant(2);
  m.grid.origin = labels.origin() - labels.spacing();
  m.inside.assign(size_t(m.grid.num_voxels()), kOutside);
  const float value = float(label);
  for (int64_t i = 0; i < labels.num_voxels(); ++i) {
    if (labels[i] != value) continue;
    m.inside[size_t(m.grid.linear(labels.grid().index(i) + GridIndex<D>::Ones()))] = kObject;
    ++m.report.label_voxels;
  }
  return m;
}

// True when the kept component has a voxel on the image's (unpadded) border.
template <int D>
bool kept_touches_border(const LabelMask<D>& m) {
  for (int64_t i = 0; i < m.grid.num_voxels(); ++i) {
    if (m.inside[size_t(i)] != kKept) continue;
    const GridIndex<D> x = m.grid.index(i);
    if ((x.array() == 1).any() || (x.array() == m.grid.size.array() - 2).any()) return true;
  }
  return false;
}

}  // namespace

template <int D>
LabelMask<D> extract_label_mask(const Image<D>& labels, int label) {
  LabelMask<D> m = padded_selection(labels, label);
  std::vector<int64_t> stack;
  const auto faces = neighbour_offsets<D>(1), all = neighbour_offsets<D>(D);
  // Components of the object (face neighbours), marked kSeen; remember the largest one's seed.
  int64_t best_seed = -1, best_size = 0;
  for (int64_t i = 0; i < m.grid.num_voxels(); ++i) {
    if (m.inside[size_t(i)] != kObject) continue;
    const int64_t n = flood(m.grid, m.inside, i, kObject, kSeen, faces, stack);
    ++m.report.components;
    if (n > best_size) best_size = n, best_seed = i;
  }
  if (best_seed < 0) return m;
  m.report.kept_voxels = flood(m.grid, m.inside, best_seed, kSeen, kKept, faces, stack);
  m.report.touches_border = kept_touches_border(m);
  // The background reachable from the padding (all neighbours: the connectivity the surface
  // extraction gives the background; through the other components); whatever it does not reach
  // is the kept component or enclosed by it.
  flood(m.grid, m.inside, 0, kOutside, kReached, all, stack);
  int64_t inside = 0;
  for (uint8_t& v : m.inside) {
    v = v == kReached ? 0 : 1;
    inside += v;
  }
  m.report.filled_voxels = inside - m.report.kept_voxels;
  return m;
}

template <int D>
Image<D> label_indicator(const Image<D>& labels, int label) {
  Image<D> out(labels.grid(), 0.0f);
  for (int64_t i = 0; i < labels.num_voxels(); ++i) out[i] = labels[i] == float(label) ? 1.0f : 0.0f;
  return out;
}

template LabelMask<2> extract_label_mask<2>(const Image<2>&, int);
template LabelMask<3> extract_label_mask<3>(const Image<3>&, int);
template Image<2> label_indicator<2>(const Image<2>&, int);
template Image<3> label_indicator<3>(const Image<3>&, int);

}  // namespace dsnake
