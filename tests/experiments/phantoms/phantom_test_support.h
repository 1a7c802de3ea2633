// The correspondence targets of a pair of phantom sections given as JSON, read through the
// phantom registries as the experiment reader reads them (experiments/phantoms/phantoms.h).
#pragma once

#include "experiments/phantoms/phantoms.h"

#include <nlohmann/json.hpp>

namespace dsnake {

template <int D>
std::vector<std::optional<Point<D>>> targets_of(const nlohmann::json& image, const nlohmann::json& tmpl,
                                                const Template<D>& t) {
  JsonReader ri(image, "test", "image"), rt(tmpl, "test", "template");
  const auto image_spec = image_phantoms<D>().read(ri);
  const auto template_spec = template_phantoms<D>().read(rt);
  return phantom_targets<D>(image_spec, template_spec, t);
}

}  // namespace dsnake
