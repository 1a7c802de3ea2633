// Registration of the remeshing stages: one line per stage class. Each class declares its name,
// its options (which read and check themselves) and a summary; see framework/core/registry.h. A stage
// of the other dimension is refused with a message naming both dimensions.
#include "remesh/registry.h"

#include "remesh/delaunay.h"
#include "remesh/refine.h"
#include "remesh/resample.h"
#include "remesh/simplify.h"
#include "remesh/uniform.h"
#include "framework/core/program_plugins.h"

#include <string>

namespace dsnake {

namespace {

// A stage asked in the wrong dimension: a configuration error naming the "type" key.
std::string wrong_dimension(const std::string& name, int other, int dimension) {
  return "\"" + name + "\" is a " + std::to_string(other) + "D remeshing stage; this experiment is " +
         std::to_string(dimension) + "D";
}

}  // namespace

template <>
const Registry<Remesher<2>>& remesher_registry<2>() {
  static const Registry<Remesher<2>> registry = [] {
    Registry<Remesher<2>> r;
    r.add<ResampleRemesher>();
    for (const char* s : {"uniform", "delaunay", "refine", "simplify"}) r.add_refusal(s, wrong_dimension(s, 3, 2));
    ProgramPlugins<Remesher<2>>::instance().add_to(r);  // framework/core/program_plugins.h
    return r;
  }();
  return registry;
}

template <>
const Registry<Remesher<3>>& remesher_registry<3>() {
  static const Registry<Remesher<3>> registry = [] {
    Registry<Remesher<3>> r;
    r.add<UniformRemesher>();   // §5.1
    r.add<DelaunayRemesher>();  // §5.2
    r.add<RefineRemesher>();    // §5.3
    r.add<SimplifyRemesher>();  // §5.4
    r.add_refusal("resample", wrong_dimension("resample", 2, 3));
    ProgramPlugins<Remesher<3>>::instance().add_to(r);  // framework/core/program_plugins.h
    return r;
  }();
  return registry;
}

}  // namespace dsnake
