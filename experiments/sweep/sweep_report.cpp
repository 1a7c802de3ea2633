// dsnake sweep: the aggregates. results.csv has one row per run; breakdown.csv has the success
// rate over seeds per method x grid point x corruption type x level and each group's
// breakdown level, the first level (by increasing severity, the clean level first) whose
// success rate falls below 50% (the robustness criterion of §8, Figs. 13-18).
#include "experiments/sweep/sweep.h"

#include "experiments/sweep/csv_text.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <map>
#include <sstream>

namespace dsnake {

using json = nlohmann::json;

namespace {

// A missing value is an empty field, as CSV readers (pandas, R) read a missing value.
std::string number_text(double v) {
  if (!std::isfinite(v)) return "";
  std::ostringstream s;
  s << std::setprecision(10) << v;
  return s.str();
}

std::string value_text(const json& v) {
  if (v.is_string()) return v.get<std::string>();
  if (v.is_number_float()) return number_text(v.get<double>());
  return v.dump();
}

// A number or boolean from result.json at `a`.`b` ("" when absent or null).
std::string field(const json& result, const char* a, const char* b = nullptr) {
  if (!result.contains(a)) return "";
  const json* v = &result[a];
  if (b) {
    if (!v->is_object() || !v->contains(b)) return "";
    v = &(*v)[b];
  }
  if (v->is_null()) return "";
  if (v->is_boolean()) return v->get<bool>() ? "true" : "false";
  return value_text(*v);
}

// The magnitude key of each corruption type (experiments/phantoms/corruption.h).
const char* magnitude_key(const std::string& type) {
  if (type == "outliers") return "fraction";
  if (type == "noise") return "sigma";
  if (type == "perturb") return "radius";
  return nullptr;
}

std::string grid_label(const SweepRun& run) {
  std::string s;
  for (const auto& [key, value] : run.parameters) s += (s.empty() ? "" : ";") + key + "=" + value_text(value);
  return s;
}

}  // namespace

CorruptionLevel describe_corruption(const json& list, int level_index) {
  CorruptionLevel level{"clean", "clean", 0.0};
  if (!list.is_array() || list.empty()) return level;
  level.type.clear();
  level.label.clear();
  for (const auto& c : list) {
    const std::string type = c.is_object() && c.contains("type") && c["type"].is_string() ? c["type"].get<std::string>() : "?";
    const char* key = magnitude_key(type);
    std::string part = type;
    if (key && c.contains(key)) {
      part += "=" + value_text(c[key]);
      if (list.size() == 1 && c[key].is_number()) level.magnitude = c[key].get<double>();
    }
    level.type += (level.type.empty() ? "" : "+") + type;
    level.label += (level.label.empty() ? "" : "+") + part;
  }
  if (list.size() > 1) level.magnitude = level_index;  // combined corruptions: the file's order
  return level;
}

std::string results_csv(const Sweep& sweep, const std::vector<std::optional<json>>& results,
                        const std::vector<std::string>& stale) {
  static const char* kMetrics[] = {"mean_surface_distance", "hausdorff95", "hausdorff", "dice",
                                   "correspondence_error_mean", "correspondence_error_max", "self_intersections"};
  std::ostringstream s;
  s << "run_id,method";
  for (const auto& k : sweep.grid_keys) s << "," << csv_field(k);
  s << ",corruption_level,corruption,seed,status,success";
  for (const char* m : kMetrics) s << "," << m;
  s << ",vertices_initial,vertices_final,vertices_deformation,iterations,field_s,evolve_s,metrics_s,total_s,build,stale\n";
  for (size_t i = 0; i < sweep.runs.size(); ++i) {
    const SweepRun& run = sweep.runs[i];
    s << csv_field(run.id) << "," << csv_field(run.method);
    for (const auto& [key, value] : run.parameters) s << "," << csv_field(value_text(value));
    s << "," << run.corruption_level << "," << csv_field(describe_corruption(run.corruption, run.corruption_level).label)
      << "," << run.seed;
    const json r = i < results.size() && results[i] ? *results[i] : json::object();
    s << "," << (r.empty() ? "missing" : csv_field(field(r, "status"))) << "," << field(r, "success");
    for (const char* m : kMetrics) s << "," << field(r, "metrics", m);
    s << "," << field(r, "vertices", "initial") << "," << field(r, "vertices", "final") << ","
      << field(r, "vertices", "deformation") << "," << field(r, "iterations");
    for (const char* t : {"field_s", "evolve_s", "metrics_s", "total_s"}) s << "," << field(r, "timings", t);
    const json build = r.contains("provenance") && r["provenance"].is_object() ? r["provenance"].value("build", json::object())
                                                                             : json::object();
    s << "," << csv_field(build.is_object() ? build.value("version", std::string()) : std::string()) << ","
      << csv_field(i < stale.size() ? stale[i] : std::string()) << "\n";
  }
  return s.str();
}

std::string breakdown_csv(const Sweep& sweep, const std::vector<std::optional<json>>& results) {
  // Counts per (method, grid point, level), in the sweep's order.
  struct Cell {
    int runs = 0, finished = 0, successes = 0;
  };
  struct Group {
    std::string method, grid;
    std::map<int, CorruptionLevel> levels;
    std::map<int, Cell> cells;
  };
  std::vector<Group> groups;  // one per (method, grid point)
  std::map<std::pair<std::string, int>, size_t> group_of;
  std::vector<std::string> types;  // corruption types other than "clean", in first appearance
  for (size_t i = 0; i < sweep.runs.size(); ++i) {
    const SweepRun& run = sweep.runs[i];
    const auto key = std::make_pair(run.method, run.grid_point);
    if (!group_of.count(key)) {
      group_of[key] = groups.size();
      groups.push_back({run.method, grid_label(run), {}, {}});
    }
    Group& g = groups[group_of[key]];
    const CorruptionLevel level = describe_corruption(run.corruption, run.corruption_level);
    g.levels[run.corruption_level] = level;
    if (level.type != "clean" && std::find(types.begin(), types.end(), level.type) == types.end())
      types.push_back(level.type);
    Cell& c = g.cells[run.corruption_level];
    ++c.runs;
    if (i < results.size() && results[i]) {
      ++c.finished;
      c.successes += results[i]->value("success", false) ? 1 : 0;
    }
  }
  if (types.empty()) types.push_back("clean");

  std::ostringstream s;
  s << "method,grid,corruption_type,level,corruption,magnitude,runs,finished,successes,success_rate,breakdown\n";
  for (const Group& g : groups) {
    for (const std::string& type : types) {
      // The clean levels and this type's, by increasing magnitude (ties: the file's order).
      std::vector<int> order;
      for (const auto& [index, level] : g.levels)
        if (level.type == type || level.type == "clean") order.push_back(index);
      std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
        const auto &la = g.levels.at(a), &lb = g.levels.at(b);
        if ((la.type == "clean") != (lb.type == "clean")) return la.type == "clean";
        return la.magnitude < lb.magnitude;
      });
      if (std::none_of(order.begin(), order.end(), [&](int l) { return g.levels.at(l).type == type; }) && type != "clean")
        continue;
      // Breakdown: the first level below 50% success; a level without finished runs before it
      // leaves the answer open.
      std::string breakdown = "none";
      for (int l : order) {
        const Cell& c = g.cells.at(l);
        if (c.finished == 0) {
          breakdown = "incomplete";
          break;
        }
        if (2 * c.successes < c.finished) {
          breakdown = g.levels.at(l).label;
          break;
        }
      }
      for (int l : order) {
        const Cell& c = g.cells.at(l);
        const CorruptionLevel& level = g.levels.at(l);
        s << csv_field(g.method) << "," << csv_field(g.grid) << "," << csv_field(type) << "," << l << ","
          << csv_field(level.label) << "," << number_text(level.magnitude) << "," << c.runs << "," << c.finished << ","
          << c.successes << "," << (c.finished > 0 ? number_text(double(c.successes) / c.finished) : "") << ","
          << csv_field(breakdown) << "\n";
      }
    }
  }
  return s.str();
}

}  // namespace dsnake
