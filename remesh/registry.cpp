#include "remesh/registry.h"

#include "remesh/resample.h"

namespace dsnake {

template <>
const Registry<Remesher<2>>& remesher_registry<2>() {
  static const Registry<Remesher<2>> registry = [] {
    Registry<Remesher<2>> r;
    r.add("resample", make_resample_remesher);
    return r;
  }();
  return registry;
}

template <>
const Registry<Remesher<3>>& remesher_registry<3>() {
  static const Registry<Remesher<3>> registry;  // the 3D stages of §5 come with the remeshing issue
  return registry;
}

}  // namespace dsnake
