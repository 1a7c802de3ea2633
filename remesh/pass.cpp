#include "remesh/pass.h"

#include "framework/core/errors.h"
#include "framework/mesh/edit_mesh.h"

#include <vector>

namespace dsnake {

RemeshReport EditStage::apply(Snake<3>& snake, const RemeshContext<3>& context) {
  EditMesh m(snake);
  const int before = m.num_live_vertices();
  RemeshReport report = run_checked(m, context);
  report.vertices_before = before;
  report.vertices_after = m.commit(snake);
  return report;
}

namespace {

// edits() on m optimistically, then the check; on a conflict m is restored and edits() runs
// again with every edit checked. (The copy is taken without the grid, which the check rebuilds.)
template <class Edits>
auto run_optimistically(EditMesh& m, Edits edits) {
  m.drop_grid();
  EditMesh before = m;
  m.begin_optimistic();
  auto result = edits();
  if (m.end_optimistic(true)) return result;
  m = std::move(before);
  return edits();
}

}  // namespace

RemeshReport EditStage::run_checked(EditMesh& m, const RemeshContext<3>& context) {
  if (checking_ == EditChecking::kEveryEdit) return run(m, context);
  if (!edits_can_cross() || checking_ == EditChecking::kUnchecked) {
    m.begin_optimistic();  // (also drops the grid, which nothing here asks)
    RemeshReport report = run(m, context);
    m.end_optimistic(false);
    return report;
  }
  return run_optimistically(m, [&] { return run(m, context); });
}

namespace {

// A run of EditStages on one mesh, committed at the end (see apply_pass).
void apply_edit_stages(std::span<EditStage* const> stages, Snake<3>& snake, const RemeshContext<3>& context,
                       std::vector<RemeshReport>& reports) {
  EditMesh m(snake);
  // Each stage from the mean edge of the mesh it receives (as a fresh EditMesh of the committed
  // snake would have it); `checked`: through the stage's own checking, else its bare edits.
  auto run_all = [&](bool checked) {
    std::vector<RemeshReport> out;
    for (size_t k = 0; k < stages.size(); ++k) {
      if (k > 0) m.refresh_mean_edge();
      const int before = m.num_live_vertices();
      RemeshReport report = checked ? stages[k]->run_checked(m, context) : stages[k]->run(m, context);
      report.vertices_before = before;
      report.vertices_after = m.num_live_vertices();
      out.push_back(std::move(report));
    }
    return out;
  };
  bool optimistic = stages.size() > 1;
  for (const EditStage* stage : stages) optimistic &= stage->checking() == EditChecking::kOptimistic;
  // Optimistic as one run: the stages' bare edits (on the fallback, m is no longer optimistic,
  // so every edit is checked); else each stage under its own checking.
  const std::vector<RemeshReport> out = optimistic ? run_optimistically(m, [&] { return run_all(false); })
                                                   : run_all(true);
  reports.insert(reports.end(), out.begin(), out.end());
  m.commit(snake);
}

}  // namespace

namespace remesh_detail {

std::vector<EditStage*> edit_stages(std::span<const std::unique_ptr<Remesher<3>>> stages) {
  std::vector<EditStage*> edit;
  edit.reserve(stages.size());
  for (const auto& stage : stages) edit.push_back(dynamic_cast<EditStage*>(stage.get()));
  return edit;
}

std::vector<RemeshReport> apply_pass(std::span<const std::unique_ptr<Remesher<3>>> stages,
                                     std::span<EditStage* const> edit, Snake<3>& snake,
                                     const RemeshContext<3>& context) {
  DSNAKE_ASSERT(edit.size() == stages.size(), "apply_pass: one EditStage view per stage");
  std::vector<RemeshReport> reports;
  reports.reserve(stages.size());
  std::vector<EditStage*> run;
  for (size_t i = 0; i <= stages.size(); ++i) {
    EditStage* stage = i < stages.size() ? edit[i] : nullptr;
    if (stage) {
      run.push_back(stage);
      continue;
    }
    if (!run.empty()) apply_edit_stages(run, snake, context, reports);
    run.clear();
    if (i < stages.size()) reports.push_back(stages[i]->apply(snake, context));
  }
  return reports;
}

}  // namespace remesh_detail

std::vector<RemeshReport> apply_pass(std::span<const std::unique_ptr<Remesher<3>>> stages, Snake<3>& snake,
                                     const RemeshContext<3>& context) {
  const std::vector<EditStage*> edit = remesh_detail::edit_stages(stages);
  return remesh_detail::apply_pass(stages, edit, snake, context);
}

}  // namespace dsnake
