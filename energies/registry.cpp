// Registration of the energies: one line per energy class. Each class declares its name, its
// options (which read and check themselves) and a summary; see framework/core/registry.h.
#include "energies/registry.h"

#include "energies/arap.h"
#include "energies/asap_mls.h"
#include "energies/balloon.h"
#include "energies/external.h"
#include "energies/internal.h"
#include "energies/landmarks.h"
#include "energies/laplacian.h"
#include "energies/patch.h"
#include "energies/profile.h"
#include "energies/region_term.h"
#include "energies/similarity.h"
#include "framework/core/program_plugins.h"

namespace dsnake {

template <int D>
const Registry<Energy<D>>& energy_registry() {
  static const Registry<Energy<D>> registry = [] {
    Registry<Energy<D>> r;
    r.template add<InternalEnergy<D>>();
    r.template add<ExternalEnergy<D>>();
    r.template add<AsapMlsEnergy<D>>();
    r.template add<LaplacianEnergy<D>>();
    r.template add<ArapEnergy<D>>();
    r.template add<BalloonEnergy<D>>();
    r.template add<SimilarityEnergy<D>>();
    r.template add<ProfileEnergy<D>>();
    r.template add<PatchEnergy<D>>();
    r.template add<RegionTermEnergy<D>>();
    r.template add<LandmarksEnergy<D>>();
    ProgramPlugins<Energy<D>>::instance().add_to(r);  // framework/core/program_plugins.h
    return r;
  }();
  return registry;
}

template const Registry<Energy<2>>& energy_registry<2>();
template const Registry<Energy<3>>& energy_registry<3>();

}  // namespace dsnake
