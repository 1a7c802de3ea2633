// The landmark energy (ours; landmarks are the future work of the paper's §9): soft
// springs that pull named template vertices towards points the user gives,
//   E_lm(q) = sum_l |q_{v(l)} - y_l|^2   [mm^2],
// over the landmarks l named in "points" (template.landmarks gives each name its template vertex
// v(l); y_l is the user's point, world coordinates in LPS mm, mapped into the image's frame at
// bind, as the template is: image.h).
// Snake view: propose() moves each landmark vertex to its point, out[v(l)] = y_l, and governs
// those vertices only (Governs::kMarkedVertices): in the average of §3.1 a landmark vertex goes
// to (sum_e w_e q_e + w y_l) / (sum_e w_e + w), the weight w the spring's stiffness against the
// other terms; no other vertex's update changes (free and non-landmark vertices average the
// other terms exactly as without it). Global view: r_l = sqrt(weight) (q_{v(l)} - y_l), linear
// in q, so that sum |r_l|^2 = weight E_lm.
#pragma once

#include "framework/core/energy.h"
#include "framework/core/options.h"

#include <map>
#include <memory>
#include <string>

namespace dsnake {

struct LandmarksOptions {
  NamedPoints points;  // landmark name -> [x, y(, z)], world mm

  template <class V>
  void visit(V& v) {
    v(points, Key{"points", "mm (world, LPS)",
                  "the point each named template landmark (template.landmarks) is pulled to: {\"name\": [x, y(, z)]}"});
  }
};

template <int D>
class LandmarksEnergy final : public Energy<D> {
 public:
  using Options = LandmarksOptions;
  static constexpr const char* kType = "landmarks";
  static constexpr const char* kSummary =
      "soft springs pulling named template vertices to user points, E = sum |q_v - y|^2 (ours; the paper's §9 future work)";

  explicit LandmarksEnergy(const LandmarksOptions& options = {});
  ~LandmarksEnergy() override;
  // Every point has D coordinates (OptionError naming "points.<name>").
  static void check_options(const LandmarksOptions& options);
  std::string type() const override { return kType; }
  Governs governs() const override { return Governs::kMarkedVertices; }
  std::span<const uint8_t> governed_mask() const override;
  const LandmarksOptions& options() const { return options_; }

  // Every name is a landmark of the template (OptionError naming "points.<name>").
  void check_template(const Template<D>& tmpl) const override;
  // Maps the points into the image's frame (when there is an image) and finds each landmark's
  // snake vertex.
  void bind(const EnergyContext<D>& context, const Snake<D>& snake) override;
  // out[v(l)] = y_l for every landmark l.
  void propose(const Snake<D>& snake, PointList<D>& out) override;
  // E_lm(q) = sum_l |q_{v(l)} - y_l|^2, mm^2.
  double value(const Snake<D>& snake) const override;
  // r_l = sqrt(weight) (q_{v(l)} - y_l), D residuals per landmark.
  bool add_residuals(const Snake<D>& snake, double weight, GlobalProblem<D>& problem) const override;
  bool has_least_squares_form() const override { return true; }

  // |q_{v(l)} - y_l| per landmark name, mm (result.json's "landmarks"); after bind().
  std::map<std::string, double> distances(const Snake<D>& snake) const;
  std::optional<std::map<std::string, double>> reported_distances(const Snake<D>& snake) const override {
    return distances(snake);
  }

 private:
  struct Data;
  LandmarksOptions options_;
  std::unique_ptr<Data> data_;
};

}  // namespace dsnake
