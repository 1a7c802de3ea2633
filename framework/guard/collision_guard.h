// CollisionGuard<D>: the non-self-intersection constraint on the snake iteration (a MoveGuard,
// framework/core/move_guard.h), in the manner of MIRTK's deformable surface model: a vertex move
// that would make the surface cross itself is halved, up to `halvings` times, and then refused
// (the vertex stays where it was). The registration (registration/registration.h) gives one to
// the phase driver for snake runs (§3.1). Facets: the polygon's segments (2D) or the mesh's
// triangles (3D). A pair of facets "conflicts" at some positions as the remeshing stages' checks
// say (framework/geometry/triangle_pairs.h): facets sharing no vertex must not touch; in 3D,
// triangles sharing a vertex must not pierce each other and triangles sharing an edge must not
// fold onto each other.
// A move is blamed only for conflicts it creates: a pair that conflicts at q(t) already is left
// to the forces. Every vertex of a newly conflicting pair that moved takes the next step back
// (half its move, then a quarter, ...; refused after `halvings`), and the pairs around the
// vertices that stepped back are tested again, until no new conflict is left. Since a vertex
// only steps back along its own move and q(t) itself has no new conflict, this ends without one.
// Cost: a broad phase over the facets' boxes widened by a margin, kept while no vertex leaves
// its margin (a Verlet list), the swept boxes (the box of each facet at q(t) and at q(t+1))
// of its pairs, then one exact test per close pair; the later rounds test only the
// pairs around the vertices that stepped back. In 3D, a pair of triangles that share one vertex
// or one edge (the adjacent pairs, which every step would test) carries a certificate: a
// radius within which its vertices may move from where the certificate was made without the
// pair being able to conflict (shared_vertex_radius and shared_edge_radius of triangle_pairs.h, with
// their proofs); it is not tested while they stay within it. Certificates are made with the broad phase and made again
// once the tests of those that ran out have cost as much as making them. The exact tests are
// skipped only where they could not find a conflict, so the steps are the same as with every
// pair tested; `checks` counts the tests made. Deterministic, the same bits with any thread
// count.
#pragma once

#include "framework/core/move_guard.h"
#include "framework/core/options.h"

#include <cstdint>
#include <vector>

namespace dsnake {

struct CollisionGuardOptions {
  bool enabled = true;  // experiment files: off runs the snake iteration unchecked
  int halvings = 3;     // a colliding move is halved up to this many times, then refused

  template <class V>
  void visit(V& v) {
    v(enabled, Key{"enabled", "", "check the snake iteration's moves: a move that would make the surface cross itself is shortened or refused"});
    v(halvings, Key{"halvings", "", "a colliding move is halved up to this many times before it is refused", Range::closed(0, 30)});
  }
};

template <int D>
class CollisionGuard final : public MoveGuard<D> {
 public:
  using Options = CollisionGuardOptions;
  static constexpr const char* kType = "collision_guard";

  explicit CollisionGuard(const CollisionGuardOptions& options = {});
  std::string type() const override { return kType; }
  MoveGuardReport guard(const Snake<D>& snake, PointList<D>& proposed) override;

 private:
  CollisionGuardOptions options_;
  // Scratch kept between iterations (the per-iteration path allocates only while it grows).
  std::vector<std::array<int, D>> facets_;
  std::vector<std::array<int, 2>> pairs_;
  std::vector<uint8_t> moved_, changed_;
  std::vector<int> level_;
  // The broad phase's pairs, kept across iterations (a Verlet list): every pair of
  // facets whose swept boxes, widened by a margin on every side, overlapped when the list was
  // built. While every vertex of the same facets stays in its allowed box (its positions then,
  // widened by the margin), at q(t) and at q(t+1), each swept box lies in its widened box, so
  // the pairs whose swept boxes overlap are among these: they are picked out by the same box
  // test, and the result is the same as with a broad phase per iteration. Rebuilt when a
  // vertex leaves its box or the facets change.
  // 3D: per pair, a radius within which its vertices may move from `reference` (the positions
  // at the build) without the pair being able to conflict (0: none); such pairs are not tested
  // while their vertices stay within it (collision_guard.cpp, shared_vertex_radius).
  struct PairCache {
    std::vector<std::array<int, D>> facets;
    std::vector<std::array<int, 2>> pairs;
    std::vector<double> radius;
    std::vector<int64_t> adjacent;  // the pairs that share one vertex or one edge
    // 3D, made with the certificates: the pairs without one (in order), and per facet the
    // smallest certificate of its pairs (infinity: none) and its certified pairs (CSR over
    // facets, each pair under both of its facets). While a facet's drift stays below its
    // smallest certificate, none of its certified pairs is due a test, so a step looks only at
    // the certified pairs of the facets that have drifted that far (filtering
    // every certified pair instead, three in five of the pairs filtered would stay untested).
    std::vector<int64_t> uncertified;
    std::vector<double> facet_radius;
    std::vector<int64_t> certified_start, certified_of;
    PointList<D> reference;
    // Pairs with a certificate; the tests since it was made of those whose certificate ran out.
    int64_t certified = 0, expired = 0;
    PointList<D> allowed_lo, allowed_hi;
    int64_t builds = 0;
  };
  PairCache cache_;
  // Scratch: per vertex, how far it is from the certificates' reference (at q(t) or q(t+1),
  // whichever is farther); per facet, the farthest of its vertices.
  std::vector<double> vertex_drift_, drift_;

 public:
  // Broad phases run so far (a diagnostic for tests: not every iteration needs one).
  int64_t broad_phases() const { return cache_.builds; }
  // false: every kept pair filtered at every step (the reference for tests; the default looks
  // at the certified pairs of drifted facets only, with the same pairs tested).
  void set_certificate_index(bool on) { certificate_index_ = on; }

 private:
  bool certificate_index_ = true;
};

}  // namespace dsnake
