#include "experiments/experiment.h"

#include "experiments/builtin.h"
#include "framework/core/errors.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace dsnake {

namespace fs = std::filesystem;

namespace {

// Strips nlohmann's "[json.exception.x.y] " prefix from a message.
std::string clean_json_message(const std::string& what) {
  const auto p = what.find("] ");
  return p == std::string::npos ? what : what.substr(p + 2);
}

// Applies one "a.b[2].c=value" override to the document.
void apply_override(nlohmann::json& doc, const std::string& assignment, const std::string& file) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw InputError("", "--set " + assignment, "expected key.path=value");
  const std::string path = assignment.substr(0, eq), text = assignment.substr(eq + 1);
  nlohmann::json value;
  try {
    value = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception&) {
    value = text;  // a bare word is a string
  }
  nlohmann::json* node = &doc;
  std::string token;
  auto descend = [&](const std::string& key, bool is_index) {
    if (is_index) {
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
    if (path[i] == '.') { ++i; continue; }
    if (path[i] == '[') {
      const auto close = path.find(']', i);
      if (close == std::string::npos) throw InputError("", "--set " + path, "unclosed '['");
      descend(path.substr(i + 1, close - i - 1), true);
      i = close + 1;
      continue;
    }
    const auto end = path.find_first_of(".[", i);
    token = path.substr(i, end == std::string::npos ? std::string::npos : end - i);
    const bool numeric = !token.empty() && token.find_first_not_of("0123456789") == std::string::npos;
    descend(token, numeric && node->is_array());
    i = end == std::string::npos ? path.size() : end;
  }
  *node = value;
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

bool SuccessCriteria::met(const Metrics& m) const {
  auto at_most = [this](const std::optional<double>& limit, const std::optional<double>& v) {
    return !limit || (v ? *v <= *limit : skip_null_metrics);
  };
  return at_most(mean_surface_distance, m.mean_surface_distance) && at_most(hausdorff95, m.hausdorff95) &&
         at_most(hausdorff, m.hausdorff) && (!dice || (m.dice ? *m.dice >= *dice : skip_null_metrics)) &&
         at_most(correspondence_error_mean, m.correspondence_error_mean) &&
         at_most(correspondence_error_max, m.correspondence_error_max) &&
         (!self_intersections || m.self_intersections <= *self_intersections);
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
  std::ifstream in(path);
  if (!in) throw InputError(path, "", fs::exists(path) ? "cannot read the experiment file" : "no such experiment file");
  ExperimentFile f;
  f.path = path;
  f.base_dir = fs::path(path).parent_path().string();
  try {
    f.document = nlohmann::json::parse(in, nullptr, true, /*ignore_comments=*/true);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(path, "", "JSON syntax error: " + clean_json_message(e.what()));
  }
  return finish_file(std::move(f), overrides);
}

ExperimentFile builtin_experiment(const std::string& name, const std::vector<std::string>& overrides) {
  ExperimentFile f;
  f.path = "builtin:" + name;
  f.document = nlohmann::json::parse(builtin_experiment_text(name));
  return finish_file(std::move(f), overrides);
}

}  // namespace dsnake
