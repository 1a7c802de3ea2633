// The landmark energy; see landmarks.h.
#include "energies/landmarks.h"

#include "energies/residual_blocks.h"
#include "framework/core/errors.h"
#include "framework/core/image.h"

#include <cmath>

namespace dsnake {

template <int D>
struct LandmarksEnergy<D>::Data {
  std::vector<std::string> names;  // in the options' (sorted) order
  std::vector<int> template_ids;   // per landmark
  PointList<D> targets;            // per landmark, in the image's frame
  std::vector<int> vertices;       // per landmark: its snake vertex
  std::vector<uint8_t> mask;       // per snake vertex: a landmark vertex
  bool bound = false;
};

template <int D>
LandmarksEnergy<D>::LandmarksEnergy(const LandmarksOptions& options)
    : options_(checked(options, kType)), data_(std::make_unique<Data>()) {
  try {
    check_options(options_);
  } catch (const OptionError& e) {
    throw_invalid_options(kType, e);
  }
}

template <int D>
LandmarksEnergy<D>::~LandmarksEnergy() = default;

template <int D>
void LandmarksEnergy<D>::check_options(const LandmarksOptions& options) {
  for (const auto& [name, p] : options.points)
    if (int(p.size()) != D) throw OptionError{"points." + name, "expected " + std::to_string(D) + " numbers"};
}

template <int D>
void LandmarksEnergy<D>::check_template(const Template<D>& tmpl) const {
  for (const auto& [name, p] : options_.points) {
    if (tmpl.landmarks.count(name)) continue;
    std::string known;
    for (const auto& [k, id] : tmpl.landmarks) known += (known.empty() ? "" : ", ") + k;
    throw OptionError{"points." + name, "the template has no landmark \"" + name + "\" (its landmarks: " +
                                            (known.empty() ? "none; name them in template.landmarks" : known) + ")"};
  }
}

// The template ids and the targets depend on the template and the image only; the snake
// vertices and the mask are found again on every bind (cheap: one lookup per landmark).
template <int D>
void LandmarksEnergy<D>::bind(const EnergyContext<D>& context, const Snake<D>& snake) {
  Data& d = *data_;
  if (context.tmpl) {
    d.names.clear(), d.template_ids.clear(), d.targets.clear();
    for (const auto& [name, p] : options_.points) {
      const Point<D> world = Eigen::Map<const Point<D>>(p.data());
      d.names.push_back(name);
      DSNAKE_ASSERT(context.tmpl->landmarks.count(name), "check_template() passed: " + name + " is a landmark");
      d.template_ids.push_back(context.tmpl->landmarks.at(name));
      d.targets.push_back(context.image ? context.image->grid().to_frame(world) : world);
    }
  }
  DSNAKE_ASSERT(context.tmpl || d.bound, "landmarks is bound to a template");
  d.vertices.resize(d.names.size());
  d.mask.assign(snake.num_vertices(), 0);
  for (size_t l = 0; l < d.names.size(); ++l) {
    d.vertices[l] = snake.vertex_of_template_id(d.template_ids[l]);
    DSNAKE_ASSERT(d.vertices[l] >= 0, "every template vertex is on the snake (remesher.h)");
    d.mask[d.vertices[l]] = 1;
  }
  d.bound = true;
}

template <int D>
std::span<const uint8_t> LandmarksEnergy<D>::governed_mask() const {
  return data_->mask;
}

template <int D>
void LandmarksEnergy<D>::propose(const Snake<D>& snake, PointList<D>& out) {
  const Data& d = *data_;
  DSNAKE_ASSERT(d.bound && int(d.mask.size()) == snake.num_vertices(), "bind() before propose()");
  for (size_t l = 0; l < d.vertices.size(); ++l) out[d.vertices[l]] = d.targets[l];
}

template <int D>
double LandmarksEnergy<D>::value(const Snake<D>& snake) const {
  double e = 0.0;
  for (const auto& [name, distance] : distances(snake)) e += distance * distance;
  return e;
}

template <int D>
bool LandmarksEnergy<D>::add_residuals(const Snake<D>& snake, double weight, GlobalProblem<D>& problem) const {
  const Data& d = *data_;
  DSNAKE_ASSERT(d.bound && int(d.mask.size()) == snake.num_vertices(), "bind() before add_residuals()");
  for (size_t l = 0; l < d.vertices.size(); ++l) add_anchor_residual<D>(problem, d.vertices[l], d.targets[l], std::sqrt(weight));
  return true;
}

// Looks the vertices up again: value() may be asked about a snake the energy was not bound to
// (the runner's report of the start).
template <int D>
std::map<std::string, double> LandmarksEnergy<D>::distances(const Snake<D>& snake) const {
  const Data& d = *data_;
  DSNAKE_ASSERT(d.bound, "bind() before value()");
  std::map<std::string, double> out;
  for (size_t l = 0; l < d.names.size(); ++l) {
    const int v = snake.vertex_of_template_id(d.template_ids[l]);
    DSNAKE_ASSERT(v >= 0, "every template vertex is on the snake (remesher.h)");
    out[d.names[l]] = (snake.positions()[v] - d.targets[l]).norm();
  }
  return out;
}

template class LandmarksEnergy<2>;
template class LandmarksEnergy<3>;

}  // namespace dsnake
