#include "experiments/spec/experiment.h"

#include "experiments/spec/builtin.h"
#include "framework/core/errors.h"
#include "framework/core/json_text.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace dsnake {

namespace fs = std::filesystem;

namespace {

// An array index in a --set path: 1 to 9 decimal digits (no sign, no "0x", no fraction).
bool is_index(const std::string& key) {
  return !key.empty() && key.size() <= 9 && key.find_first_not_of("0123456789") == std::string::npos;
}

// Applies one "a.b[2].c=value" override to the document. The path is read strictly: keys are
// non-empty, separated by single dots, and an index is 1 to 9 digits in brackets; anything else
// is an InputError naming the --set path (a lax reading would apply "energies[0.5]" to energies[0]).
void apply_override(nlohmann::json& doc, const std::string& assignment, const std::string& file) {
  const auto eq = assignment.find('=');
  const std::string shown = assignment.substr(0, std::min<size_t>(eq, 200));
  if (eq == std::string::npos || eq == 0) throw InputError("", "--set " + shown, "expected key.path=value");
  // JSON text is UTF-8; a byte that is not would make every later dump() throw (found by fuzzing).
  if (!is_valid_utf8(assignment)) throw InputError("", "--set " + shown, "is not valid UTF-8 text");
  const std::string path = assignment.substr(0, eq), text = assignment.substr(eq + 1);
  nlohmann::json value = nlohmann::json::accept(text, /*ignore_comments=*/true) ? parse_json_text(text, "--set " + shown)
                                                                               : nlohmann::json(text);  // a bare word
  nlohmann::json* node = &doc;
  auto bad = [&](const std::string& why) { return InputError("", "--set " + shown, why); };
  auto descend = [&](const std::string& key, bool index) {
    if (index) {
      if (!node->is_array()) throw InputError(file, path, "\"" + key + "\" indexes something that is not an array");
      const size_t i = std::stoul(key);
      if (i >= node->size()) throw InputError(file, path, "index " + key + " is out of range");
      node = &(*node)[i];
    } else {
      if (node->is_null()) *node = nlohmann::json::object();  // "output.figures=false" creates "output"
      if (!node->is_object()) throw InputError(file, path, "\"" + key + "\" names a key of something that is not an object");
      node = &(*node)[key];
    }
  };
  size_t i = 0;
  while (i < path.size()) {
    if (path[i] == '[') {
      const auto close = path.find(']', i);
      if (close == std::string::npos) throw bad("unclosed '['");
      const std::string key = path.substr(i + 1, close - i - 1);
      if (!is_index(key)) throw bad("\"[" + key.substr(0, 40) + "]\" is not an index (1 to 9 digits)");
      descend(key, true);
      i = close + 1;
    } else {
      const auto end = std::min(path.find_first_of(".[]", i), path.size());
      const std::string key = path.substr(i, end - i);
      if (key.empty()) throw bad("an empty key (a leading, doubled or trailing '.', or a ']' without '[')");
      descend(key, is_index(key) && node->is_array());
      i = end;
    }
    if (i < path.size() && path[i] == ']') throw bad("a ']' without '['");
    if (i < path.size() && path[i] == '.') {
      ++i;
      if (i == path.size() || path[i] == '.' || path[i] == '[') throw bad("an empty key after '.'");
    }
  }
  *node = std::move(value);
}

ExperimentFile finish_file(ExperimentFile f, const std::vector<std::string>& overrides) {
  for (const auto& o : overrides) apply_override(f.document, o, f.path);
  if (!f.document.is_object()) throw InputError(f.path, "(top level)", "expected a JSON object");
  const auto it = f.document.find("dimension");
  if (it == f.document.end()) throw InputError(f.path, "dimension", "is required (2 or 3)");
  if (!it->is_number_integer() || (it->get<int>() != 2 && it->get<int>() != 3))
    throw InputError(f.path, "dimension", "must be 2 or 3, found " + it->dump());
  f.dimension = it->get<int>();
  return f;
}

}  // namespace

bool SuccessCriteria::met(const Metrics& m) const { return failures(m).empty(); }

std::vector<SuccessCriteria::Failure> SuccessCriteria::failures(const Metrics& m) const {
  std::vector<Failure> out;
  // A limit on a metric the ground truth does not give fails unless skip_null_metrics.
  auto check = [&](const char* key, const std::optional<double>& limit, const std::optional<double>& v, bool at_least) {
    if (!limit) return;
    const bool ok = v ? (at_least ? *v >= *limit : *v <= *limit) : skip_null_metrics;
    if (!ok) out.push_back({key, v, at_least ? ">=" : "<=", *limit});
  };
  check("mean_surface_distance", mean_surface_distance, m.mean_surface_distance, false);
  check("hausdorff95", hausdorff95, m.hausdorff95, false);
  check("hausdorff", hausdorff, m.hausdorff, false);
  check("dice", dice, m.dice, true);
  check("correspondence_error_mean", correspondence_error_mean, m.correspondence_error_mean, false);
  check("correspondence_error_max", correspondence_error_max, m.correspondence_error_max, false);
  if (self_intersections) check("self_intersections", double(*self_intersections), double(m.self_intersections), false);
  return out;
}

std::string SuccessCriteria::Failure::describe() const {
  char buf[160];
  if (!value)
    std::snprintf(buf, sizeof(buf), "%s null (needs %s %.4g)", metric.c_str(), comparison.c_str(), threshold);
  else
    std::snprintf(buf, sizeof(buf), "%s %.4g %s %.4g", metric.c_str(), *value, comparison == ">=" ? "<" : ">",
                  threshold);
  return buf;
}

SuccessCriteria SuccessCriteria::defaults() {
  SuccessCriteria s;
  s.mean_surface_distance = 1.0;
  s.hausdorff95 = 2.0;
  s.correspondence_error_max = 2.0;
  s.dice = 0.9;
  s.self_intersections = 0;
  s.skip_null_metrics = true;
  return s;
}

ExperimentFile load_experiment_file(const std::string& path, const std::vector<std::string>& overrides) {
  ExperimentFile f;
  f.path = path;
  f.base_dir = fs::path(path).parent_path().string();
  f.document = parse_json_text(read_input_text(path, "experiment file"), path);
  return finish_file(std::move(f), overrides);
}

ExperimentFile builtin_experiment(const std::string& name, const std::vector<std::string>& overrides) {
  ExperimentFile f;
  f.path = "builtin:" + name;
  f.document = nlohmann::json::parse(builtin_experiment_text(name));
  return finish_file(std::move(f), overrides);
}

}  // namespace dsnake
