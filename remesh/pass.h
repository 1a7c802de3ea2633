// One remeshing pass of the 3D stages of §5 on one editable mesh. Each stage is made of checked
// local edits on an EditMesh (mesh_edit.h); run one by one through Remesher::apply, every stage
// copies the snake into an EditMesh and writes it back (rebuilding the connectivity with its
// ordered one-rings), which costs about as much as the edits of a settled pass. apply_pass
// shares one EditMesh (and its intersection grid) across consecutive stages and writes back
// once. The result is the same as applying the stages one by one: the live vertices and
// triangles keep their relative order (a commit only drops dead ones), and each stage starts
// from the mean edge length of the mesh it receives.
#pragma once

#include "framework/remesher.h"

#include <memory>
#include <span>
#include <vector>

namespace dsnake {

namespace remesh_detail {
class EditMesh;
}  // namespace remesh_detail

// A 3D stage made of checked local edits (refine, delaunay, uniform, simplify).
class EditStage : public Remesher<3> {
 public:
  // EditMesh from the snake, run(), then commit (the snake changes only if the mesh did).
  RemeshReport apply(Snake<3>& snake, const RemeshContext<3>& context) final;
  // The stage's edits on m. Fills the report's stage name and rejected edits; the caller fills
  // the vertex counts.
  virtual RemeshReport run(remesh_detail::EditMesh& m, const RemeshContext<3>& context) = 0;
};

// Applies `stages` in order to the snake, one report per stage. Consecutive EditStages share one
// EditMesh, written back once at the end of the run of them (other remeshers apply as usual).
// Vertex counts in the reports are those of the shared mesh before and after each stage.
std::vector<RemeshReport> apply_pass(std::span<const std::unique_ptr<Remesher<3>>> stages, Snake<3>& snake,
                                     const RemeshContext<3>& context);

}  // namespace dsnake
