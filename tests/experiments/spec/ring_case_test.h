// The template-keys tests' common case: a contour template (40 vertices, r = 14 mm) sitting on
// the outer edge of a ring image (the reference, reference.mha), a target that is the ring moved
// by kRingShift = (2, -2) mm with another intensity scale (target.mha), the moved circle as the
// truth (truth.txt), and an experiment with the profile energy; and how an experiment document
// is made, or which JSON path it is refused at.
#pragma once

#include "experiments/spec/experiment.h"
#include "framework/core/errors.h"
#include "framework/io/image_io.h"
#include "framework/io/mesh_io.h"
#include "tests/energies/edge_images.h"
#include "tests/experiments/temp_dir_test.h"

#include <fstream>
#include <nlohmann/json.hpp>

namespace dsnake::test_support {

inline const Point<2> kRingShift(2.0, -2.0);

class RingCaseTest : public TempDirTest {
 protected:
  // Writes the reference, the target, the template and the truth; returns the experiment document.
  nlohmann::ordered_json write_ring_case(const std::string& name) {
    write_image<2>(radial_image<2>(72, 1.0, dark_ring(8.0, 14.0), 1.0), (dir_ / "reference.mha").string());
    write_image<2>(radial_image<2>(72, 1.0, [](double r) { return 0.4 * (r < 8 ? 200 : r < 14 ? 50 : 200) + 50; }, 1.0,
                                   kRingShift),
                   (dir_ / "target.mha").string());
    write_contour(ring_template(), (dir_ / "template.txt").string());
    write_contour(round_template<2>(14.0, kRingShift, 400).positions, (dir_ / "truth.txt").string());
    return {{"name", name}, {"dimension", 2},
            {"image", {{"file", "target.mha"}}},
            {"template", {{"file", "template.txt"}, {"reference_image", "reference.mha"}}},
            {"ground_truth", {{"surface", "truth.txt"}}},
            {"field", {{"type", "gradient"}}},
            {"energies", {{{"type", "internal"}, {"weight", 1.0}, {"alpha", 0.05}},
                          {{"type", "profile"}, {"weight", 4.0}}}},
            {"phases", {{{"iterations", 60}}}},
            {"output", {{"figures", false}, {"result_mask", false}}}};
  }
  static PointList<2> ring_template() { return round_template<2>(14.0, Point<2>::Zero(), 40).positions; }

  // The document as dir_/experiment.json, loaded.
  ExperimentFile file_of(const nlohmann::ordered_json& j) {
    const std::filesystem::path path = dir_ / "experiment.json";
    std::ofstream(path) << j.dump(2);
    return load_experiment_file(path.string());
  }
  // The InputError's JSON path when the experiment is made, or "" if it is accepted.
  template <int D = 2>
  std::string error_path(const nlohmann::ordered_json& j) {
    try {
      make_experiment<D>(file_of(j));
    } catch (const InputError& e) {
      return e.where();
    }
    return "";
  }
};

}  // namespace dsnake::test_support
