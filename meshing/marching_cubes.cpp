// Marching cubes and marching squares on a binary mask, with loops instead of a case table;
// see surface_extraction.h for the rules and why.
#include "meshing/surface_extraction.h"

#include "framework/core/errors.h"

#include <Eigen/Geometry>
#include <array>
#include <unordered_map>

namespace dsnake {

namespace {

// One directed segment on a cube face or in a square, between two crossings (edge keys).
struct Segment {
  int64_t from, to;
};

// The crossings of a face whose corners (cube corner numbers, counter-clockwise seen from outside
// the cell) are `corner`, joined so that each run of inside corners is cut off by itself (on an
// ambiguous face, each of the two diagonal inside corners alone). Each segment goes from the
// crossing where the counter-clockwise walk leaves a run to the one where it entered it, so that
// the inside lies to the left seen from outside. edge_key(a, b) names the crossing between
// corners a and b.
template <class EdgeKey>
void face_segments(const std::array<int, 4>& corner, const std::array<bool, 8>& in, const EdgeKey& edge_key,
                   std::vector<Segment>& out) {
  for (int i = 0; i < 4; ++i) {
    const int c = corner[i], d = corner[(i + 1) % 4];
    if (!(!in[c] && in[d])) continue;  // an entry: outside c, inside d
    for (int k = 1; k <= 4; ++k) {     // the end of this run: inside a, outside b
      const int a = corner[(i + k) % 4], b = corner[(i + k + 1) % 4];
      if (in[a] && !in[b]) {
        out.push_back({edge_key(a, b), edge_key(c, d)});
        break;
      }
    }
  }
}

// The six faces of the unit cube as corner numbers (bit a of a corner number = its offset along
// axis a), counter-clockwise seen from outside.
std::array<std::array<int, 4>, 6> cube_faces() {
  std::array<std::array<int, 4>, 6> faces;
  for (int a = 0; a < 3; ++a)
    for (int s = 0; s < 2; ++s) {
      const int u = (a + 1) % 3, v = (a + 2) % 3;
      const int uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};  // counter-clockwise about +axis a
      std::array<int, 4>& f = faces[2 * a + s];
      for (int k = 0; k < 4; ++k) f[k] = (s << a) | (uv[k][0] << u) | (uv[k][1] << v);
      if (s == 0) std::swap(f[1], f[3]);  // seen from -axis a: the reverse turn
    }
  return faces;
}

// Vertices of the surface: one per crossing (grid edge key = 3 * lower voxel + axis) and one per
// loop centroid.
class VertexTable {
 public:
  explicit VertexTable(const Grid<3>& g) : grid_(g) {}
  int crossing(int64_t key, ExtractedSurface& s) {
    auto [it, added] = ids_.try_emplace(key, int(s.points.size()));
    if (added) {
      Point<3> idx = grid_.index(key / 3).cast<double>();
      idx[int(key % 3)] += 0.5;
      s.points.push_back(grid_.origin + idx.cwiseProduct(grid_.spacing));
    }
    return it->second;
  }

 private:
  const Grid<3>& grid_;
  std::unordered_map<int64_t, int> ids_;
};

// The loops of one cube: each face segment followed to the next one, as vertex ids.
std::vector<std::vector<int>> cube_loops(const std::vector<Segment>& segs, VertexTable& vertices, ExtractedSurface& s) {
  std::array<bool, 16> used{};
  std::vector<std::vector<int>> loops;
  for (size_t start = 0; start < segs.size(); ++start) {
    if (used[start]) continue;
    std::vector<int>& loop = loops.emplace_back();
    size_t k = start;
    do {
      used[k] = true;
      loop.push_back(vertices.crossing(segs[k].from, s));
      size_t next = segs.size();
      for (size_t j = 0; j < segs.size(); ++j)
        if (segs[j].from == segs[k].to) next = j;
      DSNAKE_ASSERT(next < segs.size(), "every crossing of a cube ends one face segment and starts another");
      k = next;
    } while (k != start);
  }
  return loops;
}

// The tunnel of a cube whose only outside corners are two opposite ones (its two loops are the
// triangles around them): a band of six triangles joining the triangles a and b, so that the two
// corners are joined through the cube (background 26-connectivity; the six inside corners then
// form a ring around the tunnel, as in the object's 6-connected cubical complex). The band keeps
// each loop edge's direction; b is walked backwards. Seen along the cube's diagonal the six
// crossings alternate (an antiprism), so the rotation is the one that puts each b vertex nearest
// to the midpoint of its a edge (nearest to the a vertices would tie with the twisted band).
void tunnel(const std::vector<int>& a, const std::vector<int>& b, ExtractedSurface& s) {
  int best = 0;
  double best_len = 1e300;
  for (int r = 0; r < 3; ++r) {
    double len = 0;
    for (int i = 0; i < 3; ++i)
      len += (s.points[a[i]] + s.points[a[(i + 1) % 3]] - 2 * s.points[b[((r - i) % 3 + 3) % 3]]).squaredNorm();
    if (len < best_len) best_len = len, best = r;
  }
  for (int i = 0; i < 3; ++i) {
    const int bj = b[((best - i) % 3 + 3) % 3], bprev = b[((best - i - 1) % 3 + 3) % 3];
    const int ai = a[i], anext = a[(i + 1) % 3];
    s.triangles.push_back({ai, anext, bj});
    s.triangles.push_back({bprev, bj, anext});
  }
}

// The triangles of one cube from its face segments: each loop of 3 crossings one triangle, a
// longer loop a fan around its centroid; the two-opposite-corners case is a tunnel.
void triangulate_loops(const std::vector<Segment>& segs, bool opposite_outside_pair, VertexTable& vertices,
                       ExtractedSurface& s) {
  const std::vector<std::vector<int>> loops = cube_loops(segs, vertices, s);
  if (opposite_outside_pair) {
    DSNAKE_ASSERT(loops.size() == 2 && loops[0].size() == 3 && loops[1].size() == 3, "two corner triangles");
    tunnel(loops[0], loops[1], s);
    return;
  }
  for (const std::vector<int>& loop : loops) {
    if (loop.size() == 3) {
      s.triangles.push_back({loop[0], loop[1], loop[2]});
      continue;
    }
    Point<3> c = Point<3>::Zero();
    for (int v : loop) c += s.points[v];
    const int centre = int(s.points.size());
    s.points.push_back(c / double(loop.size()));
    for (size_t i = 0; i < loop.size(); ++i) s.triangles.push_back({centre, loop[i], loop[(i + 1) % loop.size()]});
  }
}

// Flips every triangle when the surface's signed volume is negative (the segment direction of
// face_segments is meant to make it outward; this keeps the promise whatever the handedness).
void orient_outward(ExtractedSurface& s) {
  double volume = 0;
  for (const Triangle& t : s.triangles) volume += s.points[t[0]].dot(s.points[t[1]].cross(s.points[t[2]]));
  if (volume < 0)
    for (Triangle& t : s.triangles) std::swap(t[1], t[2]);
}

}  // namespace

ExtractedSurface marching_cubes(const LabelMask<3>& mask) {
  const Grid<3>& g = mask.grid;
  const auto faces = cube_faces();
  std::array<int64_t, 8> offset;
  for (int b = 0; b < 8; ++b) offset[b] = (b & 1) + ((b >> 1) & 1) * g.size[0] + ((b >> 2) & 1) * g.size[0] * g.size[1];
  ExtractedSurface s;
  VertexTable vertices(g);
  std::vector<Segment> segs;
  for (int z = 0; z + 1 < g.size[2]; ++z)
    for (int y = 0; y + 1 < g.size[1]; ++y)
      for (int x = 0; x + 1 < g.size[0]; ++x) {
        const int64_t base = g.linear(GridIndex<3>(x, y, z));
        std::array<bool, 8> in;
        int count = 0;
        for (int b = 0; b < 8; ++b) count += in[b] = mask.inside[size_t(base + offset[b])] != 0;
        if (count == 0 || count == 8) continue;
        // The crossing between corners a and b (one bit apart): key of the lower corner's edge.
        auto edge_key = [&](int a, int b) {
          const int bit = a ^ b, axis = bit == 1 ? 0 : bit == 2 ? 1 : 2;
          return (base + offset[a & b]) * 3 + axis;
        };
        segs.clear();
        for (const auto& f : faces) face_segments(f, in, edge_key, segs);
        const bool opposite_pair = count == 6 && [&] {
          for (int b = 0; b < 8; ++b)
            if (!in[b]) return !in[b ^ 7];
          return false;
        }();
        triangulate_loops(segs, opposite_pair, vertices, s);
      }
  orient_outward(s);
  return s;
}

std::vector<PointList<2>> marching_squares(const LabelMask<2>& mask) {
  const Grid<2>& g = mask.grid;
  const std::array<int, 4> square = {0, 1, 3, 2};  // corners (bit 0: +x, bit 1: +y), counter-clockwise
  const std::array<int64_t, 4> offset = {0, 1, g.size[0], g.size[0] + 1};
  std::unordered_map<int64_t, int64_t> next;  // crossing -> the next one along its contour
  std::vector<Segment> segs;
  for (int y = 0; y + 1 < g.size[1]; ++y)
    for (int x = 0; x + 1 < g.size[0]; ++x) {
      const int64_t base = g.linear(GridIndex<2>(x, y));
      std::array<bool, 8> in{};
      for (int b = 0; b < 4; ++b) in[b] = mask.inside[size_t(base + offset[b])] != 0;
      auto edge_key = [&](int a, int b) { return (base + offset[a & b]) * 2 + ((a ^ b) == 1 ? 0 : 1); };
      segs.clear();
      face_segments(square, in, edge_key, segs);
      for (const Segment& sg : segs) next[sg.from] = sg.to;
    }
  std::vector<PointList<2>> contours;
  std::unordered_map<int64_t, bool> done;
  for (const auto& [start, unused] : next) {
    if (done[start]) continue;
    PointList<2> c;
    int64_t k = start;
    do {
      done[k] = true;
      Point<2> idx = g.index(k / 2).cast<double>();
      idx[int(k % 2)] += 0.5;
      c.push_back(g.origin + idx.cwiseProduct(g.spacing));
      k = next.at(k);
    } while (k != start);
    contours.push_back(std::move(c));
  }
  return contours;
}

}  // namespace dsnake
