// One remeshing pass of the 3D stages of §5 on one editable mesh. Each stage is made of checked
// local edits on an EditMesh (framework/mesh/edit_mesh.h); run one by one through Remesher::apply, every stage
// copies the snake into an EditMesh and writes it back (rebuilding the connectivity with its
// ordered one-rings), which costs about as much as the edits of a settled pass. apply_pass
// shares one EditMesh (and its intersection grid) across consecutive stages and writes back
// once. The result is the same as applying the stages one by one: the live vertices and
// triangles keep their relative order (a commit only drops dead ones), and each stage starts
// from the mean edge length of the mesh it receives.
#pragma once

#include "framework/core/remesher.h"
#include "framework/mesh/edit_mesh.h"

#include <memory>
#include <span>
#include <vector>

namespace dsnake {

// How a stage keeps its edits from crossing the surface.
// kOptimistic (the default): the edits run with their local checks only; then every triangle
// they created or moved is tested once against the final mesh. If one conflicts, the mesh is
// restored and the stage runs again with kEveryEdit, so the stage's output never has a new
// conflict. Without a conflict the result is kEveryEdit's, unless an edit's crossing was undone
// by a later edit of the same stage (then the optimistic result is kept: a different, equally
// conflict-free mesh). A settled pass then tests each new triangle once, instead of each edit's
// triangles against all their neighbours.
// kEveryEdit: each edit is tested before it is made (an edit that would cross is rejected).
// kUnchecked: no test at all; for benchmarks and tests only (the cost of the checks).
enum class EditChecking { kOptimistic, kEveryEdit, kUnchecked };

// A 3D stage made of checked local edits (refine, delaunay, uniform, simplify).
class EditStage : public Remesher<3> {
 public:
  // EditMesh from the snake, run_checked(), then commit (the snake changes only if the mesh
  // did).
  RemeshReport apply(Snake<3>& snake, const RemeshContext<3>& context) final;
  // run() under the stage's EditChecking.
  RemeshReport run_checked(EditMesh& m, const RemeshContext<3>& context);
  // The stage's edits on m. Fills the report's stage name and rejected edits; the caller fills
  // the vertex counts.
  virtual RemeshReport run(EditMesh& m, const RemeshContext<3>& context) = 0;
  // false for a stage whose edits cannot cross the surface (refine: its new triangles tile the
  // old ones), which then runs without any test.
  virtual bool edits_can_cross() const { return true; }
  void set_checking(EditChecking checking) { checking_ = checking; }
  EditChecking checking() const { return checking_; }

 private:
  EditChecking checking_ = EditChecking::kOptimistic;
};

// Applies `stages` in order to the snake, one report per stage. Consecutive EditStages share one
// EditMesh, written back once at the end of the run of them (other remeshers apply as usual).
// Vertex counts in the reports are those of the shared mesh before and after each stage. When
// every stage of such a run checks optimistically, the run is checked as one: one test of the
// triangles its stages created or moved, and on a conflict the whole run again, checking every
// edit.
std::vector<RemeshReport> apply_pass(std::span<const std::unique_ptr<Remesher<3>>> stages, Snake<3>& snake,
                                     const RemeshContext<3>& context);

namespace remesh_detail {

// Each stage as an EditStage, or null for another remesher (the one type test of a pass; a
// RemeshPipeline makes it once, when it is built).
std::vector<EditStage*> edit_stages(std::span<const std::unique_ptr<Remesher<3>>> stages);
// apply_pass with that test made: edit[i] is stages[i] as an EditStage, or null.
std::vector<RemeshReport> apply_pass(std::span<const std::unique_ptr<Remesher<3>>> stages,
                                     std::span<EditStage* const> edit, Snake<3>& snake,
                                     const RemeshContext<3>& context);

}  // namespace remesh_detail

}  // namespace dsnake
