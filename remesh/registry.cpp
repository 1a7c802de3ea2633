#include "remesh/registry.h"

#include "remesh/delaunay.h"
#include "remesh/refine.h"
#include "remesh/resample.h"
#include "remesh/simplify.h"
#include "remesh/uniform.h"

namespace dsnake {

namespace {

// A stage asked in the wrong dimension: a configuration error naming the "type" key.
template <int D>
typename Registry<Remesher<D>>::Factory wrong_dimension(const std::string& name, int other) {
  return [name, other](JsonReader& r) -> std::unique_ptr<Remesher<D>> {
    r.fail("type", "\"" + name + "\" is a " + std::to_string(other) + "D remeshing stage; this experiment is " +
                       std::to_string(D) + "D");
  };
}

}  // namespace

template <>
const Registry<Remesher<2>>& remesher_registry<2>() {
  static const Registry<Remesher<2>> registry = [] {
    Registry<Remesher<2>> r;
    r.add("resample", make_resample_remesher);
    for (const char* s : {"uniform", "delaunay", "refine", "simplify"}) r.add(s, wrong_dimension<2>(s, 3));
    return r;
  }();
  return registry;
}

template <>
const Registry<Remesher<3>>& remesher_registry<3>() {
  static const Registry<Remesher<3>> registry = [] {
    Registry<Remesher<3>> r;
    r.add("uniform", make_uniform_remesher);    // §5.1
    r.add("delaunay", make_delaunay_remesher);  // §5.2
    r.add("refine", make_refine_remesher);      // §5.3
    r.add("simplify", make_simplify_remesher);  // §5.4
    r.add("resample", wrong_dimension<3>("resample", 2));
    return r;
  }();
  return registry;
}

}  // namespace dsnake
