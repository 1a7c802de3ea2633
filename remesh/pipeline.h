// RemeshPipeline<D>: the remeshing stages of a phase (§5) as one Remesher. In 3D the stages run
// as one pass (remesh/pass.h: consecutive edit stages share one EditMesh, written back once),
// with the same result as applying them one by one; in 2D each stage applies in turn. Which
// stages are edit stages is found once, when the pipeline is built, so that a caller (the phase
// driver) needs neither a type test nor a hook of its own: apply_all() gives one report per
// stage, apply() one for the whole.
#pragma once

#include "framework/core/remesher.h"

#include <memory>
#include <string>
#include <vector>

namespace dsnake {

class EditStage;

template <int D>
class RemeshPipeline final : public Remesher<D> {
 public:
  static constexpr const char* kType = "pipeline";

  // The stages in the order they run (none null; an empty pipeline changes nothing).
  explicit RemeshPipeline(std::vector<std::unique_ptr<Remesher<D>>> stages);
  ~RemeshPipeline() override;

  std::string type() const override { return kType; }
  // apply_all(), summed: stage "pipeline", the vertex counts before the first stage and after
  // the last, the rejected edits of all stages.
  RemeshReport apply(Snake<D>& snake, const RemeshContext<D>& context) override;
  // Runs the stages on the snake; one report per stage, in order (as apply_pass in 3D, or each
  // stage's apply() in 2D).
  std::vector<RemeshReport> apply_all(Snake<D>& snake, const RemeshContext<D>& context);
  std::vector<RemeshReport> apply_stages(Snake<D>& snake, const RemeshContext<D>& context) override {
    return apply_all(snake, context);
  }

  const std::vector<std::unique_ptr<Remesher<D>>>& stages() const { return stages_; }

 private:
  std::vector<std::unique_ptr<Remesher<D>>> stages_;
  std::vector<EditStage*> edit_stages_;  // 3D: stages_[i] as an EditStage, or null; 2D: empty
};

}  // namespace dsnake
