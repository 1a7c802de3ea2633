// docs/extending.md's worked example of a new remesher: smooths the free vertices (those that
// remeshing inserted, §6) towards the mean of their one-ring by a share `lambda`, leaving every
// deformation vertex, the connectivity and so the energies' precomputation as they are
// (framework/core/remesher.h: a remesher that only moves free vertices writes positions in place).
#pragma once

#include "framework/core/options.h"
#include "framework/core/remesher.h"

namespace dsnake {

struct FreeSmoothingOptions {
  double lambda = 0.5;

  template <class V>
  void visit(V& v) {
    v(lambda, Key{"lambda", "1", "share of the way to the one-ring's mean a free vertex moves", Range::open_closed(0, 1)});
  }
};

template <int D>
class FreeSmoothingRemesher final : public Remesher<D> {
 public:
  using Options = FreeSmoothingOptions;
  static constexpr const char* kType = "free_smoothing";
  static constexpr const char* kSummary = "moves the free vertices towards their one-ring's mean";

  explicit FreeSmoothingRemesher(const Options& options = {}) : options_(checked(options, kType)) {}
  std::string type() const override { return kType; }
  RemeshReport apply(Snake<D>& snake, const RemeshContext<D>& context) override;

 private:
  Options options_;
};

}  // namespace dsnake
