// The experiment file's sections read through their declared options (experiments/spec/
// experiment_spec.h): values land in the typed sections, a value out of range is refused naming
// its JSON path and the range, and the assembled experiment holds the sections whole.
#include "experiments/spec/experiment.h"
#include "experiments/phantoms/paper_phantoms.h"
#include "experiments/spec/experiment_spec.h"
#include "framework/core/errors.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace dsnake {
namespace {

// "where: message" of reading the built-in experiment with the overrides ("" if it reads).
template <int D>
std::string spec_error(const std::string& builtin, const std::vector<std::string>& overrides) {
  try {
    read_experiment_spec<D>(builtin_experiment(builtin, overrides));
  } catch (const InputError& e) {
    return e.where() + ": " + e.message();
  }
  return "";
}

TEST(ExperimentSpec, WatchdogAndPlacementOutOfRangeAreRefusedNamingTheirPath) {
  EXPECT_EQ(spec_error<2>("default", {"watchdog.min_size=1"}), "watchdog.min_size: must be in [0, 1)");
  EXPECT_EQ(spec_error<2>("default", {"watchdog.max_vertices=2"}), "watchdog.max_vertices: must be in [3, 1e+08]");
  EXPECT_EQ(spec_error<2>("default", {"watchdog.max_move=-1"}), "watchdog.max_move: must be >= 0");
  EXPECT_EQ(spec_error<2>("default", {"template.transform.scale=0"}), "template.transform.scale: must be > 0");
  EXPECT_EQ(spec_error<2>("default", {"template.transform.rotation_deg=[10, 20]"}),
            "template.transform.rotation_deg: expected one angle");
  EXPECT_EQ(spec_error<3>("ellipsoid", {"template.transform.rotation_deg=[1, 2, 3, 4]"}),
            "template.transform.rotation_deg: expected up to three angles (x, y, z)");
  EXPECT_EQ(spec_error<3>("ellipsoid", {"template.transform.translation=[1, 2]"}),
            "template.transform.translation: expected 3 numbers");
  EXPECT_EQ(spec_error<2>("default", {"template.transform.shear=1"}), "template.transform.shear: unknown key");
}

TEST(ExperimentSpec, RunKeysFieldCacheAndPhantomKeysAreCheckedAtReading) {
  EXPECT_EQ(spec_error<2>("default", {"seed=-1"}), "seed: must be a non-negative integer");
  EXPECT_EQ(spec_error<2>("default", {"seed=1.5"}), "seed: must be a non-negative integer");
  EXPECT_EQ(spec_error<2>("default", {"solver=newton"}), "solver: must be \"snake\" or \"global\", found \"newton\"");
  EXPECT_EQ(spec_error<2>("default", {"field.cache=\"\""}), "field.cache: must be a non-empty folder name");
  EXPECT_EQ(spec_error<2>("default", {"image={\"file\": \"\"}"}), "image.file: must be a non-empty file name");
  EXPECT_EQ(spec_error<3>("ellipsoid", {"template={\"file\": \"\"}"}), "template.file: must be a non-empty file name");
  EXPECT_EQ(spec_error<2>("default", {"field.cache_compression=lzma"}),
            "field.cache_compression: must be \"none\" or \"zlib\", found \"lzma\"");
  EXPECT_EQ(spec_error<2>("default", {"energies[0].weight=0"}), "energies[0].weight: must be > 0");
  EXPECT_EQ(spec_error<2>("default", {"ground_truth={\"masks\": \"m.nii\"}"}), "ground_truth.masks: unknown key");
  EXPECT_EQ(spec_error<2>("default", {"template.landmarks={\"a\": -1}"}),
            "template.landmarks.a: expected a template vertex id (an integer >= 0)");
  // A phantom's keys are read with the section, before any assembly.
  EXPECT_EQ(spec_error<2>("default", {"image.radiuss=3"}), "image.radiuss: unknown key");
  EXPECT_EQ(spec_error<2>("default", {"template.corner_width_deg=0"}), "template.corner_width_deg: must be in (0, 180]");
  EXPECT_EQ(spec_error<3>("ellipsoid", {"image.semi_axes=[24, -1, 14]"}), "image.semi_axes: must be > 0");
  EXPECT_EQ(spec_error<2>("default", {}), "");
}

TEST(ExperimentSpec, ThePhasesStopsNeedTheirWindow) {
  EXPECT_EQ(spec_error<2>("default", {"phases[0].stop_when_worse=true", "phases[0].window=0"}),
            "phases[0].stop_when_worse: needs a window > 0 (the iterations between the compared states)");
  EXPECT_EQ(spec_error<2>("default", {"phases[0].window=10", "phases[0].tolerance=0"}),
            "phases[0].window: needs a tolerance > 0 (the net move per iteration below which the shape is still)");
  EXPECT_EQ(spec_error<2>("default", {"phases[0].stop_when_worse=1", "phases[0].window=10", "phases[0].tolerance=0.01"}),
            "phases[0].stop_when_worse: expected true or false, found number");
  EXPECT_EQ(spec_error<2>("default", {"phases[0].stop_when_worse=true", "phases[0].window=10", "phases[0].tolerance=0.01"}), "");
}

TEST(ExperimentSpec, TheSectionsLandInTheirOptionsAndTheExperimentHoldsThemWhole) {
  const ExperimentFile file = builtin_experiment(
      "default", {"seed=12", "watchdog.max_move=7.5", "template.transform.scale=1.25", "field.cache=cache_dir",
                  "phases[0].every=3", "phases[0].name=first"});
  const ExperimentSpec<2> spec = read_experiment_spec<2>(file);
  EXPECT_EQ(spec.seed, 12u);
  EXPECT_EQ(spec.watchdog.max_move, 7.5);
  EXPECT_EQ(spec.tmpl.transform.scale, 1.25);
  ASSERT_TRUE(spec.field.cache.cache);
  EXPECT_EQ(*spec.field.cache.cache, "cache_dir");
  ASSERT_TRUE(spec.image.phantom);
  EXPECT_EQ(spec.image.phantom->kind, "lung_slice");
  EXPECT_NE(spec.image.phantom->options_as<LungSliceImageOptions>(), nullptr);
  // Assembled without the cache (it would create its folder when the field is built).
  const Experiment<2> ex = make_experiment<2>(builtin_experiment(
      "default", {"seed=12", "watchdog.max_move=7.5", "template.transform.scale=1.25", "phases[0].every=3", "phases[0].name=first"}));
  EXPECT_EQ(ex.seed, 12u);
  EXPECT_EQ(ex.watchdog.max_move, 7.5);
  EXPECT_EQ(ex.phases[0].every, 3);
  EXPECT_EQ(ex.phases[0].name, "first");
  EXPECT_EQ(ex.phase_names[0], "first");
  EXPECT_EQ(ex.phases[0].iterations, spec.phases[0].iterations);
}

}  // namespace
}  // namespace dsnake
