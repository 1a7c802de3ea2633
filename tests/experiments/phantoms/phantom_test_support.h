// Phantoms made from JSON as the experiment reader makes them (experiments/phantoms/phantoms.h),
// and what the phantoms' tests measure on them.
#pragma once

#include "experiments/phantoms/phantoms.h"

#include <nlohmann/json.hpp>
#include <string>

namespace dsnake {

// The image phantom of an experiment file's "image" section, every key read.
template <int D>
Phantom<D> image_phantom(const std::string& spec) {
  const auto j = nlohmann::json::parse(spec);
  JsonReader r(j, "test", "image");
  auto p = make_phantom<D>(r);
  r.finish();
  return p;
}

// A mask's area (2D, mm^2) or volume (3D, mm^3): its voxel values times the voxel's measure.
template <int D>
double mask_measure(const Image<D>& m) {
  double n = 0;
  for (float v : m.data()) n += v;
  return n * m.spacing().prod();
}

// The correspondence targets of a pair of phantom sections given as JSON, read through the
// phantom registries as the experiment reader reads them.

template <int D>
std::vector<std::optional<Point<D>>> targets_of(const nlohmann::json& image, const nlohmann::json& tmpl,
                                                const Template<D>& t) {
  JsonReader ri(image, "test", "image"), rt(tmpl, "test", "template");
  const auto image_spec = image_phantoms<D>().read(ri);
  const auto template_spec = template_phantoms<D>().read(rt);
  return phantom_targets<D>(image_spec, template_spec, t);
}

}  // namespace dsnake
