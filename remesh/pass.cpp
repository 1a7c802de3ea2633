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

namespace {

// A run of EditStages on one mesh, committed at the end (see apply_pass).
void apply_edit_stages(std::span<EditStage* const> stages, Snake<3>& snake, const RemeshContext<3>& context,
                       std::vector<RemeshReport>& reports) {
  remesh_detail::EditMesh m(snake);
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
  std::vector<RemeshReport> out;
  if (optimistic) {
    m.drop_grid();
    remesh_detail::EditMesh before = m;
    m.begin_optimistic();
    out = run_all(false);
    if (!m.end_optimistic(true)) {
      m = std::move(before);
      out = run_all(false);  // not optimistic now: every edit is checked
    }
  } else {
    out = run_all(true);
  }
  reports.insert(reports.end(), out.begin(), out.end());
  m.commit(snake);
}

}  // namespace

std::vector<RemeshReport> apply_pass(std::span<const std::unique_ptr<Remesher<3>>> stages, Snake<3>& snake,
                                     const RemeshContext<3>& context) {
  std::vector<RemeshReport> reports;
  reports.reserve(stages.size());
  std::vector<EditStage*> run;
  for (size_t i = 0; i <= stages.size(); ++i) {
    auto* edit = i < stages.size() ? dynamic_cast<EditStage*>(stages[i].get()) : nullptr;
    if (edit) {
      run.push_back(edit);
      continue;
    }
    if (!run.empty()) apply_edit_stages(run, snake, context, reports);
    run.clear();
    if (i < stages.size()) reports.push_back(stages[i]->apply(snake, context));
  }
  return reports;
}

}  // namespace dsnake
