#include "remesh/pass.h"

#include "remesh/mesh_edit.h"

#include <optional>

namespace dsnake {

RemeshReport EditStage::apply(Snake<3>& snake, const RemeshContext<3>& context) {
  remesh_detail::EditMesh m(snake);
  const int before = m.num_live_vertices();
  RemeshReport report = run_checked(m, context);
  report.vertices_before = before;
  report.vertices_after = m.commit(snake);
  return report;
}

RemeshReport EditStage::run_checked(remesh_detail::EditMesh& m, const RemeshContext<3>& context) {
  if (checking_ == EditChecking::kEveryEdit) return run(m, context);
  if (!edits_can_cross() || checking_ == EditChecking::kUnchecked) {
    m.begin_optimistic();  // (also drops the grid, which nothing here asks)
    RemeshReport report = run(m, context);
    m.end_optimistic(false);
    return report;
  }
  m.drop_grid();
  remesh_detail::EditMesh before = m;
  m.begin_optimistic();
  RemeshReport report = run(m, context);
  if (m.end_optimistic(true)) return report;
  m = std::move(before);
  return run(m, context);
}

// A run of EditStages edits one mesh, committed when the run ends (at the end of the pass or
// before a remesher of another kind). refresh_mean_edge() gives a stage the value a fresh
// EditMesh of the committed snake would have.
std::vector<RemeshReport> apply_pass(std::span<const std::unique_ptr<Remesher<3>>> stages, Snake<3>& snake,
                                     const RemeshContext<3>& context) {
  std::vector<RemeshReport> reports;
  reports.reserve(stages.size());
  std::optional<remesh_detail::EditMesh> m;
  for (const auto& stage : stages) {
    auto* edit = dynamic_cast<EditStage*>(stage.get());
    if (!edit) {
      if (m) {
        m->commit(snake);
        m.reset();
      }
      reports.push_back(stage->apply(snake, context));
      continue;
    }
    if (m) m->refresh_mean_edge();
    else m.emplace(snake);
    const int before = m->num_live_vertices();
    RemeshReport report = edit->run_checked(*m, context);
    report.vertices_before = before;
    report.vertices_after = m->num_live_vertices();
    reports.push_back(std::move(report));
  }
  if (m) m->commit(snake);
  return reports;
}

}  // namespace dsnake
