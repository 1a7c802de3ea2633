// The global similarity term (pose capture; ours, not the paper's): the squared
// distance of the snake's template vertices to the nearest similar (or congruent) copy of the
// template,
//   E_sim(q) = min_{S} sum_i |S(p_i) - q_i|^2,  S(x) = mu R x + t (mu = 1 for "rigid"),
// over the template vertices i (p: template positions, q: their current positions). The optimal
// S* is closed form (Umeyama, PAMI 1991; Horn, JOSA A 1987; mls_weights.h's best_similarity and
// best_rotation on the centred data).
// Snake view: propose() moves every template vertex to S*(p_i). With the external term alone,
// q <- (kappa q_ext + w S*(p)) / (kappa + w) makes the snake follow the field's pull as one
// similar body (an ICP-like pose phase); a later phase switches it off (phase weight 0) and lets
// ASAP fit the shape locally. Governs the template ("deformation") vertices only. No
// least-squares form: the global solve already turns the template (REPRODUCTION.md).
#pragma once

#include "framework/core/energy.h"
#include "framework/core/options.h"

#include <memory>
#include <string>

namespace dsnake {

enum class SimilarityTransform { kSimilarity, kRigid };
template <>
struct EnumNames<SimilarityTransform> {
  static constexpr std::array<std::pair<SimilarityTransform, const char*>, 2> table{
      {{SimilarityTransform::kSimilarity, "similarity"}, {SimilarityTransform::kRigid, "rigid"}}};
};

struct SimilarityOptions {
  SimilarityTransform transform = SimilarityTransform::kSimilarity;
  template <class V>
  void visit(V& v) {
    v(transform, Key{"transform", "", "S of E_sim: a similarity (rotation, translation, uniform scale) or a rigid motion (scale 1)"});
  }
};

template <int D>
class SimilarityEnergy final : public Energy<D> {
 public:
  using Options = SimilarityOptions;
  static constexpr const char* kType = "similarity";
  static constexpr const char* kSummary = "distance to the best similar copy of the template (a pose phase: the snake moves as one similar body)";

  explicit SimilarityEnergy(const SimilarityOptions& options = {});
  ~SimilarityEnergy() override;
  std::string type() const override { return kType; }
  Governs governs() const override { return Governs::kDeformationVertices; }
  const SimilarityOptions& options() const { return options_; }

  // Precomputes the centred template; the id -> snake vertex map on every bind.
  void bind(const EnergyContext<D>& context, const Snake<D>& snake) override;
  // out[v] = S*(p_v) for every template vertex v, S* fitted to the current positions.
  void propose(const Snake<D>& snake, PointList<D>& out) override;
  // E_sim(q) = sum_i |S*(p_i) - q_i|^2.
  double value(const Snake<D>& snake) const override;

 private:
  struct Data;
  SimilarityOptions options_;
  std::unique_ptr<Data> data_;
};

}  // namespace dsnake
