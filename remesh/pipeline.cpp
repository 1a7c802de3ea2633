#include "remesh/pipeline.h"

#include "framework/core/errors.h"
#include "remesh/pass.h"

#include <utility>

namespace dsnake {

template <int D>
RemeshPipeline<D>::RemeshPipeline(std::vector<std::unique_ptr<Remesher<D>>> stages) : stages_(std::move(stages)) {
  for (const auto& stage : stages_) DSNAKE_ASSERT(stage != nullptr, "RemeshPipeline: a null stage");
  if constexpr (D == 3) edit_stages_ = remesh_detail::edit_stages(stages_);
}

template <int D>
RemeshPipeline<D>::~RemeshPipeline() = default;

template <int D>
std::vector<RemeshReport> RemeshPipeline<D>::apply_all(Snake<D>& snake, const RemeshContext<D>& context) {
  if constexpr (D == 3) {
    return remesh_detail::apply_pass(stages_, edit_stages_, snake, context);
  } else {
    std::vector<RemeshReport> reports;
    reports.reserve(stages_.size());
    for (const auto& stage : stages_) reports.push_back(stage->apply(snake, context));
    return reports;
  }
}

template <int D>
RemeshReport RemeshPipeline<D>::apply(Snake<D>& snake, const RemeshContext<D>& context) {
  RemeshReport total{kType, snake.num_vertices(), snake.num_vertices(), 0};
  const std::vector<RemeshReport> reports = apply_all(snake, context);
  for (const RemeshReport& r : reports) total.rejected_edits += r.rejected_edits;
  total.vertices_after = snake.num_vertices();
  return total;
}

template class RemeshPipeline<2>;
template class RemeshPipeline<3>;

}  // namespace dsnake
