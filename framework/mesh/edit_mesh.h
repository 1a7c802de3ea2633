// EditMesh: an editable closed triangle mesh for the local edits of the remeshing stages (§5:
// vertex moves, edge flips, 1->3 splits, half-edge collapses), with the checks that keep every
// edit safe: the mesh stays closed and manifold, and an edit whose new triangles would cross
// the rest of the surface is rejected (a flat uniform grid over triangle boxes, each triangle
// listed exactly in the cells its box covers, updated as triangles come, go and move; the pair
// tests of framework/geometry/triangle_pairs.h). Built from a Snake<3> and written back into it
// (commit); one EditMesh may serve all the stages of a remeshing pass (remesh/pass.h).
// Implementation: edit_mesh.cpp (the mesh, its edits and write-back, try_flip),
// edit_mesh_broad_phase.cpp (the grid and the queries of single edits),
// edit_mesh_optimistic_check.cpp (begin/end_optimistic and the check of a stage's result).
#pragma once

#include "framework/core/shape.h"
#include "framework/geometry/triangle_pairs.h"

#include <Eigen/Geometry>

#include <array>
#include <cmath>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

namespace dsnake {

// A live triangle f at vertex v, with the corners that follow v in it: (v, next, prev) in
// counter-clockwise order. A vertex's corners answer face_with_edge() and ring() without
// touching the triangle array.
struct MeshCorner {
  int f, next, prev;
};

// The corners of every vertex, in the order they came (an erase keeps the others' order): up to
// kInline of them in one flat array (a vertex's corners are one block of it, its count in an
// array of ints), more in a list of their own (the vertex "spills" and stays spilled). The
// valence scans of the remeshers (every edge, its four vertices' valences and one vertex's
// corners) read a dense array and one block instead of a list header and a block allocated
// apart. A span from of(v) lives until v's corners next change.
class CornerFans {
 public:
  static constexpr int kInline = 8;
  explicit CornerFans(size_t vertices = 0) : count_(vertices, 0), inline_(vertices * kInline) {}
  void add_vertex() {
    count_.push_back(0);
    inline_.resize(inline_.size() + kInline);
  }
  int size(int v) const { return count_[v] & kCountMask; }
  std::span<const MeshCorner> of(int v) const {
    const int c = count_[v];
    if (c & kSpilled) return spilled_corners(v);
    return {inline_.data() + size_t(v) * kInline, size_t(c)};
  }
  void push(int v, const MeshCorner& corner);
  // Erases the corner of triangle f (which must be there); returns where it stood.
  int erase_face(int v, int f);
  // Undo steps (EditMesh::undo_flip): the last corner off, a corner back where it stood.
  void pop(int v);
  void insert(int v, int at, const MeshCorner& corner);

 private:
  static constexpr int kSpilled = 1 << 30, kCountMask = kSpilled - 1;
  std::span<const MeshCorner> spilled_corners(int v) const { return spilled_[size_t(slot_.at(v))]; }
  std::vector<int> count_;          // per vertex: its corners, | kSpilled once spilled
  std::vector<MeshCorner> inline_;  // kInline per vertex
  // The corners of the spilled vertices, and per vertex its list there (read only for those).
  std::vector<std::vector<MeshCorner>> spilled_;
  std::vector<int> slot_;
};

class EditMesh {
 public:
  using Corner = MeshCorner;

  // Copies the snake's positions, template ids and triangles; throws InputError (naming the
  // first bad element) if the snake is not a closed manifold mesh.
  explicit EditMesh(const Snake<3>& snake);

  int num_vertices() const { return static_cast<int>(pos_.size()); }
  const Point<3>& pos(int v) const { return pos_[v]; }
  bool is_free(int v) const { return ids_[v] < 0; }
  bool vertex_alive(int v) const { return vfan_.size(v) != 0; }
  const Triangle& tri(int f) const { return tri_[f]; }
  bool tri_alive(int f) const { return alive_[f] != 0; }
  int num_triangle_slots() const { return static_cast<int>(tri_.size()); }
  // The live triangles at v (in the order they came), into `out`; or v's corners.
  void triangles_of(int v, std::vector<int>& out) const;
  std::span<const Corner> corners(int v) const { return vfan_.of(v); }
  // The mean edge length of the live triangles, computed at the first call after construction
  // or refresh_mean_edge() and kept until the next refresh (a stage that needs it reads it at
  // its start; only some stages do, so it is not computed for every stage). The first call
  // after a refresh writes the cache: not from a parallel region.
  double mean_edge_length() const;
  // Makes the next mean_edge_length() measure the mesh as it is then (a stage starting on a
  // mesh that earlier stages edited sees the same value as on a freshly built EditMesh).
  void refresh_mean_edge() { mean_edge_known_ = false; }
  // Vertices in at least one live triangle (what commit() would keep).
  int num_live_vertices() const { return live_vertices_; }

  // Neighbours of v in counter-clockwise order (seen from outside), into `out`.
  void ring(int v, std::vector<int>& out) const;
  int valence(int v) const { return vfan_.size(v); }
  // The triangle holding the directed edge a->b, or -1.
  int face_with_edge(int a, int b) const {
    for (const Corner& c : vfan_.of(a))
      if (c.next == b) return c.f;
    return -1;
  }
  bool has_edge(int a, int b) const { return face_with_edge(a, b) >= 0 || face_with_edge(b, a) >= 0; }
  // The vertex opposite the directed edge a->b in its triangle f (a and b must be corners of f).
  // (The sum of f's corners less a and b: no branch to mispredict; unsigned, so it may wrap.)
  int opposite(int f, int a, int b) const {
    const auto& t = tri_[f];
    return static_cast<int>(static_cast<unsigned>(t[0]) + static_cast<unsigned>(t[1]) + static_cast<unsigned>(t[2]) -
                            static_cast<unsigned>(a) - static_cast<unsigned>(b));
  }

  int add_vertex(const Point<3>& p);  // a free vertex (template id -1)
  void set_pos(int v, const Point<3>& p) { pos_[v] = p, changed_at_[v] = ++clock_; }  // tentative: no grid update
  // Commits a move of v: updates the boxes of its triangles in the intersection grid.
  void move_vertex(int v, const Point<3>& p);
  int add_triangle(const Triangle& t);
  // Removes triangle f; with `at`, where its corners stood in the corner lists of tri(f)[0..2].
  void remove_triangle(int f, std::array<int, 3>* at = nullptr);

  // A flip as try_flip made it, for undo_flip: the two triangles it removed (slots f1 and f2),
  // where their corners stood in their vertices' corner lists, and the mesh's flags before it.
  struct FlipRecord {
    int f1 = -1, f2 = -1;
    std::array<int, 3> at1{}, at2{};
    bool changed = false, connectivity_changed = false;
    std::array<std::pair<int, int64_t>, 4> changed_at{};  // a, b, c, d and their changed_at()
  };
  // Undoes flip r, which must be the mesh's last edit (later ones undone first): the two new
  // triangles (the last two slots) go and f1, f2 come back, their corners where they stood.
  // The mesh is then as before the flip bit for bit (slots, corner order, flags), so a flip that
  // is tried and undone leaves no trace on what follows (the defect moves of the
  // valence regularisation try about seventeen flips for each one they keep).
  void undo_flip(const FlipRecord& r);

  // true if the triangle (a, b, c) at the current positions crosses, touches away from shared
  // vertices, or folds onto (shared edge, opposite sides closing to < ~8 degrees) any live
  // triangle other than those in `ignore`.
  bool intersects(const Triangle& t, std::span<const int> ignore) const;
  // The same for several triangles at once (a fan): one grid walk over their common box.
  bool intersects_any(std::span<const Triangle> ts, std::span<const int> ignore) const;
  // The reference for tests: the same pair tests against every live triangle, no grid.
  bool intersects_any_brute_force(std::span<const Triangle> ts, std::span<const int> ignore) const;

  // Optimistic edits (remesh/pass.h): from begin_optimistic() on, intersects_any() answers
  // false without looking, and every triangle that is created or whose corner moves is marked.
  // end_optimistic(true) then tests each marked live triangle against every live triangle with
  // the pair tests of intersects_any (once per pair) and returns false if one conflicts;
  // end_optimistic(false) only ends the mode. Begins by dropping the grid.
  void begin_optimistic();
  bool end_optimistic(bool verify);
  // True if no two triangles of v's fan can conflict (end_optimistic's test of the pairs that
  // share a vertex): their normals within 80 degrees of the fan's normal n, and the fan one to
  // one onto the plane normal to n.
  bool fan_is_embedded(int v) const;
  // Drops the intersection grid (rebuilt by the next check), so that a copy of the mesh is
  // cheap and edits no longer keep the grid up to date.
  void drop_grid();

  // Writes back into the snake (dropping dead vertices and triangles) if anything changed.
  // Returns the snake's vertex count.
  int commit(Snake<3>& snake);
  bool changed() const { return changed_; }
  // When v's corners or position last changed: a count of the mesh's edits that only grows
  // (edit_clock(), the latest). undo_flip puts back the times of the vertices the flip changed.
  int64_t changed_at(int v) const { return changed_at_[v]; }
  int64_t edit_clock() const { return clock_; }
  // The valence regularisation's memo (remesh/delaunay.cpp, regularize_valences), kept with the mesh
  // through the stages of an optimistic run (emptied when one begins or ends), for the floors it
  // was made with: per listed edge 3 f + k, the edit_clock() of its last failed defect move (0:
  // none) and the flips try_flip rejected in it; when it was last found not neutral; and the
  // greedy flips' refusals.
  struct RegularizationMemo {
    double cos_max_dihedral = 0, floor_key = 0;
    std::vector<int64_t> failed_at;
    std::vector<int> rejections;
    // Per listed edge: the edit_clock() when it was last found not to be a neutral flip (0:
    // never), and its fourth vertex then (the one opposite it in its other triangle).
    std::vector<int64_t> plain_at;
    std::vector<int> fourth;
    // The greedy valence flips' refusals (delaunay.cpp): per listed edge, the edit_clock() of
    // its last refusal on local grounds (0: none) and its fourth vertex then.
    std::vector<int64_t> refused_at;
    std::vector<int> refused_fourth;
  };
  RegularizationMemo& regularization_memo() { return regularization_memo_; }
  bool connectivity_changed() const { return connectivity_changed_; }
  bool optimistic() const { return optimistic_; }

 private:
  // Cell index range {x0, y0, z0, x1, y1, z1} covered by box [lo, hi], clamped to the grid.
  std::array<int, 6> cell_range(const Point<3>& lo, const Point<3>& hi) const;
  void grid_insert(int f) const;   // computes f's box and lists f in its cells
  void grid_erase(int f) const;    // unlists f from the cells of its stored range
  void grid_update(int f) const;   // after a move of one of f's corners
  void set_box(int f, const Point<3>& lo, const Point<3>& hi) const;  // f's float box
  void build_grid() const;  // on the first intersects() call: stages that never ask pay nothing

  std::vector<Point<3>> pos_;
  std::vector<int> ids_;
  std::vector<Triangle> tri_;
  std::vector<uint8_t> alive_;
  CornerFans vfan_;  // live triangles per vertex, as corners
  int live_vertices_ = 0;
  mutable double mean_edge_ = 1;
  mutable bool mean_edge_known_ = false;
  // The grid: dims_ cells of size cell_ from origin_ (the mesh's box when it was built; boxes
  // outside are clamped to the border cells, which keeps every overlap), cell (x, y, z) at
  // cells_[x + dims_x (y + dims_y z)], listing the live triangles whose box meets it.
  mutable double cell_ = 1;
  mutable Point<3> origin_ = Point<3>::Zero();
  mutable std::array<int, 3> dims_ = {0, 0, 0};
  mutable std::vector<std::vector<int>> cells_;
  mutable bool grid_built_ = false;
  // Per triangle in the grid: its bounding box in floats rounded outwards, and the query that
  // last tested it; one half cache line, so that a candidate costs one memory access.
  struct GridBox {
    FloatBox box;
    uint32_t stamp = 0, unused = 0;
  };
  mutable std::vector<GridBox> gbox_;
  mutable std::vector<std::array<int, 6>> range_;  // per triangle in the grid: its cell range
  mutable std::vector<int> candidates_;  // intersects_any's scratch
  mutable uint32_t query_ = 0;
  bool optimistic_ = false;
  std::vector<uint8_t> dirty_;      // while optimistic: per triangle slot, created or moved
  bool changed_ = false;            // anything to write back
  std::vector<int64_t> changed_at_;  // per vertex: the clock_ of its last change (corners or position)
  int64_t clock_ = 0;
  RegularizationMemo regularization_memo_;
  bool connectivity_changed_ = false;  // triangles added or removed (else positions only)
};

// Flips edge a-b to the other diagonal c-d of its two triangles (a, b, c) and (b, a, d).
// kTopology: not flippable (c-d already an edge, or a or b has valence 3); kRejected: the
// bend across a-b or c-d exceeds the limit, a new triangle is degenerate, or one would cross
// the surface. Used by the "delaunay" stage (both of its methods).
enum class FlipResult { kFlipped, kTopology, kRejected };
FlipResult try_flip(EditMesh& m, int a, int b, double cos_max_dihedral);
// The same with the triangles f1 = (a, b, c) and f2 = (b, a, d) already known; a flip made is
// recorded in `record` (for EditMesh::undo_flip) when one is given.
FlipResult try_flip(EditMesh& m, int a, int b, int f1, int f2, int c, int d, double cos_max_dihedral,
                    EditMesh::FlipRecord* record = nullptr);

}  // namespace dsnake
