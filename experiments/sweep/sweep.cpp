// dsnake sweep: expansion of a sweep file into runs, and their execution as child processes
// (or as a manifest for GNU parallel / Slurm). The robustness study is the paper's §8.
#include "experiments/sweep/sweep.h"
#include "experiments/sweep/sweep_summary.h"

#include "experiments/output/output_folder.h"
#include "experiments/output/provenance.h"
#include "framework/core/json_text.h"

#include "experiments/spec/experiment.h"
#include "framework/core/atomic_file.h"
#include "framework/core/errors.h"
#include "framework/core/json_reader.h"

#include <sched.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <fcntl.h>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <sstream>
#include <sys/file.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

namespace dsnake {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// 64-bit FNV-1a: a stable hash of a run's resolved document (std::map keys: canonical order).
uint64_t fnv1a(const std::string& s) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : s) h = (h ^ c) * 1099511628211ull;
  return h;
}

// The 8 hex digits of a run id: the hash folded to 32 bits.
std::string hex8(uint64_t h) {
  char buf[9];
  std::snprintf(buf, sizeof buf, "%08x", static_cast<unsigned>((h ^ (h >> 32)) & 0xffffffffu));
  return buf;
}

// A grid value as written in labels and overrides: strings bare, everything else as JSON.
std::string value_text(const json& v) { return v.is_string() ? v.get<std::string>() : v.dump(); }

// Method names become file names: letters, digits, '_', '-', '.', not starting with '.'.
bool safe_name(const std::string& s) {
  if (s.empty() || s[0] == '.' || s.size() > 64) return false;
  return std::all_of(s.begin(), s.end(), [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.'; });
}

// The keys of an object in file order (nlohmann::json sorts them; ordered_json keeps them).
std::vector<std::string> keys_in_file_order(const nlohmann::ordered_json& doc, const std::string& key) {
  std::vector<std::string> keys;
  if (doc.contains(key) && doc[key].is_object())
    for (auto it = doc[key].begin(); it != doc[key].end(); ++it) keys.push_back(it.key());
  return keys;
}

struct MethodSpec {
  std::string name, base;                // base: a path as given in the sweep file, or builtin:NAME
  std::vector<std::string> overrides;    // "key.path=json"
};

// The base experiment with `overrides` applied (paths relative to the sweep file's folder).
ExperimentFile load_base(const std::string& base, const std::string& sweep_dir, const std::vector<std::string>& overrides) {
  if (base.rfind("builtin:", 0) == 0) return builtin_experiment(base.substr(8), overrides);
  const fs::path p = fs::path(base).is_absolute() || sweep_dir.empty() ? fs::path(base) : fs::path(sweep_dir) / base;
  return load_experiment_file(p.string(), overrides);
}

// The experiment file's relative paths (every key that names an input file,
// experiments/output/provenance.h), made absolute so that configs/<id>.json runs anywhere.
void absolutise_paths(json& doc, const std::string& base_dir) {
  if (base_dir.empty()) return;
  for (const std::string& pointer : input_file_pointers()) {
    const json::json_pointer p(pointer);
    if (!doc.contains(p) || !doc[p].is_string()) continue;
    const fs::path path = doc[p].get<std::string>();
    if (!path.empty() && path.is_relative()) doc[p] = fs::absolute(fs::path(base_dir) / path).lexically_normal().string();
  }
}

// "seeds": a list, or {"count", "first"}; absent: one run with the base's own seed (`given` false).
std::vector<uint64_t> read_seeds(JsonReader& top, bool& given) {
  std::vector<uint64_t> seeds;
  given = top.has("seeds");
  if (!given) return {0};
  const json& s = top.raw("seeds");
  auto as_seed = [&](const json& v, const std::string& where) {
    if (!v.is_number_integer() || v.get<int64_t>() < 0) top.fail(where, "expected a non-negative integer seed, found " + v.dump());
    return v.get<uint64_t>();
  };
  if (s.is_array()) {
    for (size_t i = 0; i < s.size(); ++i) seeds.push_back(as_seed(s[i], "seeds[" + std::to_string(i) + "]"));
  } else if (s.is_object()) {
    JsonReader r = top.child("seeds");
    int count = 0, first = 0;
    r.require("count", count);
    r.read("first", first);
    r.expect(count >= 1 && count <= 100000, "count", "must be in [1, 100000]");
    r.expect(first >= 0, "first", "must be >= 0");
    r.finish();
    for (int i = 0; i < count; ++i) seeds.push_back(static_cast<uint64_t>(first) + i);
  } else {
    top.fail("seeds", "expected an array of seeds or {\"count\": n, \"first\": s}");
  }
  if (seeds.empty()) top.fail("seeds", "expected at least one seed");
  std::set<uint64_t> unique(seeds.begin(), seeds.end());
  if (unique.size() != seeds.size()) top.fail("seeds", "a seed is listed twice");
  return seeds;
}

// Builds one run's experiment (without running it) and rethrows its errors against the sweep.
void validate_run(const Sweep& sweep, const SweepRun& run, const std::string& base, const std::string& context) {
  ExperimentFile f;
  f.path = base;
  f.document = run.config;
  f.dimension = run.config.value("dimension", 2);
  try {
    if (f.dimension == 3) make_experiment<3>(f);
    else make_experiment<2>(f);
  } catch (const InputError& e) {
    throw InputError(sweep.path, "run " + run.id + " (" + context + ")", e.what());
  }
}

}  // namespace

std::string SweepRun::label() const {
  std::string s = method.empty() ? "" : method + "/";
  for (size_t i = 0; i < parameters.size(); ++i)
    s += parameters[i].first + "=" + value_text(parameters[i].second) + (i + 1 < parameters.size() ? "," : "/");
  return s + describe_corruption(corruption, corruption_level).label + "/seed=" + std::to_string(seed);
}

namespace {

// The sweep file parsed twice: `doc` to read, `ordered` for the keys in file order.
void parse_sweep_file(const std::string& path, json& doc, nlohmann::ordered_json& ordered) {
  const std::string text = read_input_text(path, "sweep file");
  doc = parse_json_text(text, path);
  ordered = parse_ordered_json_text(text, path);
}

// Everything a sweep file asks for, read and checked, before the expansion into runs.
struct SweepPlan {
  std::string sweep_dir;                       // the sweep file's folder
  std::vector<std::vector<json>> grid_values;  // per grid key (sweep.grid_keys), its values
  size_t grid_points = 1;
  bool has_levels = false;
  std::vector<json> levels;  // corruption lists; without "corruptions" one null (the base's own)
  bool seeds_given = false;
  std::vector<uint64_t> seeds;
  std::vector<MethodSpec> methods;
  std::string success_override;  // "success=..." or empty
};

// The grid: one list of values per key path (the keys in file order).
std::vector<std::vector<json>> read_grid(JsonReader& top, const std::vector<std::string>& grid_keys) {
  std::vector<std::vector<json>> grid_values;
  if (top.has("grid")) {
    JsonReader g = top.child("grid");
    for (const auto& key : grid_keys) {
      const json& values = g.raw(key);
      if (!values.is_array() || values.empty()) g.fail(key, "expected a non-empty array of values");
      if (key.find('=') != std::string::npos) g.fail(key, "a key path cannot contain '='");
      grid_values.emplace_back(values.begin(), values.end());
    }
    g.finish();
  }
  return grid_values;
}

// Corruption levels: each a list replacing the experiment's "corruption".
void read_levels(JsonReader& top, SweepPlan& plan) {
  plan.has_levels = top.has("corruptions");
  if (plan.has_levels) {
    const json& l = top.raw("corruptions");
    if (!l.is_array() || l.empty()) top.fail("corruptions", "expected a non-empty array of corruption lists");
    for (size_t i = 0; i < l.size(); ++i)
      if (!l[i].is_array()) top.fail("corruptions[" + std::to_string(i) + "]", "expected a list of corruptions ([] for none)");
    plan.levels.assign(l.begin(), l.end());
  } else {
    plan.levels.push_back(json());  // the base's own corruption
  }
}

// "methods": per name (in file order) its base (default: the sweep's) and overrides; absent:
// one unnamed method, the base itself.
std::vector<MethodSpec> read_methods(JsonReader& top, const nlohmann::ordered_json& ordered, const std::string& base) {
  std::vector<MethodSpec> methods;
  if (top.has("methods")) {
    JsonReader m = top.child("methods");
    const auto names = keys_in_file_order(ordered, "methods");
    if (names.empty()) m.fail("", "expected at least one method");
    for (const auto& name : names) {
      if (!safe_name(name)) m.fail(name, "a method name may hold only letters, digits, '_', '-' and '.'");
      JsonReader r = m.child(name);
      MethodSpec spec{name, base, {}};
      r.read("base", spec.base);
      if (r.has("overrides")) {
        JsonReader o = r.child("overrides");
        for (auto it = o.object().begin(); it != o.object().end(); ++it) {
          o.skip(it.key());
          if (it.key().find('=') != std::string::npos) o.fail(it.key(), "a key path cannot contain '='");
          spec.overrides.push_back(it.key() + "=" + it.value().dump());
        }
      }
      r.finish();
      methods.push_back(spec);
    }
    m.finish();
  } else {
    methods.push_back({"", base, {}});
  }
  return methods;
}

// The most runs a sweep file may expand to (a grid of 10^9 points would hang the expansion).
constexpr int64_t kMaxSweepRuns = 100000;

// The top level of a sweep file, in the order its errors are reported; fills sweep.grid_keys.
SweepPlan read_sweep_plan(Sweep& sweep, const json& doc, const nlohmann::ordered_json& ordered) {
  SweepPlan plan;
  plan.sweep_dir = fs::path(sweep.path).parent_path().string();
  JsonReader top(doc, sweep.path, "");
  std::string description, base;
  top.read("description", description);
  top.require("base", base);
  top.expect(!base.empty(), "base", "must name an experiment file");
  sweep.grid_keys = keys_in_file_order(ordered, "grid");
  plan.grid_values = read_grid(top, sweep.grid_keys);
  double points = 1;  // in double: a product of many lists overflows size_t
  for (const auto& v : plan.grid_values) points *= double(v.size());
  if (points > double(kMaxSweepRuns))
    top.fail("grid", "the grid has " + std::to_string(points) + " points, more than " + std::to_string(kMaxSweepRuns) + " runs");
  for (const auto& v : plan.grid_values) plan.grid_points *= v.size();
  read_levels(top, plan);
  plan.seeds = read_seeds(top, plan.seeds_given);
  plan.methods = read_methods(top, ordered, base);
  const double runs = double(plan.methods.size()) * double(plan.grid_points) * double(plan.levels.size()) * double(plan.seeds.size());
  if (runs > double(kMaxSweepRuns))
    top.fail("grid", "methods x grid points x corruption levels x seeds make " + std::to_string(int64_t(runs)) +
                         " runs, more than " + std::to_string(kMaxSweepRuns));
  if (top.has("success")) {
    const json& s = top.raw("success");
    if (!s.is_object()) top.fail("success", "expected an object of thresholds");
    plan.success_override = "success=" + s.dump();
  }
  top.finish();
  return plan;
}

// One grid point of the expansion: its (key, value) pairs and the method's overrides with them.
struct GridPoint {
  size_t index = 0;
  std::vector<std::pair<std::string, json>> parameters;
  std::vector<std::string> overrides;
};

// One run: the method's base with the grid point's, the level's, the seed's and the success
// overrides; its id from the resolved document; validated (if asked) for the first seed.
void add_run(Sweep& sweep, const SweepPlan& plan, const MethodSpec& method, const std::string& base_dir,
             const GridPoint& point, size_t l, size_t s, const std::string& context, bool validate) {
  std::vector<std::string> all = point.overrides;
  if (plan.has_levels) all.push_back("corruption=" + plan.levels[l].dump());
  if (plan.seeds_given) all.push_back("seed=" + std::to_string(plan.seeds[s]));
  if (!plan.success_override.empty()) all.push_back(plan.success_override);
  ExperimentFile f;
  try {
    f = load_base(method.base, plan.sweep_dir, all);
  } catch (const InputError& e) {  // an override's key path that does not fit the base
    std::string where = context;
    for (const auto& key : sweep.grid_keys)
      if (e.where() == key) where = "grid." + key + " (" + context + ")";
    throw InputError(sweep.path, where, e.what());
  }
  // A method's run is named by its method, unless an override names it: the base's name and
  // description describe the base, not a method that replaced one of its energies (figure titles
  // and result.json would call an ARAP run "star_dsnake").
  const bool named = std::any_of(point.overrides.begin(), point.overrides.end(),
                                 [](const std::string& o) { return o.rfind("name=", 0) == 0; });
  if (!method.name.empty() && !named) {
    const std::string base_name = f.document.value("name", std::string());
    const std::string base_description = f.document.value("description", std::string());
    f.document["name"] = method.name;
    f.document["description"] = "Method \"" + method.name + "\" of the sweep " + fs::path(sweep.path).filename().string() +
                                " (base: " + (base_name.empty() ? method.base : base_name) + ")" +
                                (base_description.empty() ? std::string() : ". The base: " + base_description);
  }
  // A sweep keeps each run's image only on request (output.image): a phantom and its corruptions
  // are made again from the run's seed, and a file read as it is stays where it is. Each run's
  // report (a python3 process per run) is also on request (output.report): the sweep's
  // own report.html covers its runs.
  if (!f.document.contains("output")) f.document["output"] = json::object();
  if (f.document["output"].is_object()) {
    if (!f.document["output"].contains("image")) f.document["output"]["image"] = "never";
    if (!f.document["output"].contains("report")) f.document["output"]["report"] = false;
  }
  const size_t g = point.index;
  SweepRun run;
  run.method = method.name;
  run.grid_point = static_cast<int>(g);
  run.parameters = point.parameters;
  run.corruption_level = static_cast<int>(l);
  run.corruption = f.document.contains("corruption") ? f.document["corruption"] : json::array();
  const json& seed = f.document.contains("seed") ? f.document["seed"] : json(0);
  run.seed = seed.is_number_unsigned() ? seed.get<uint64_t>()
             : seed.is_number()        ? static_cast<uint64_t>(std::max(0.0, seed.get<double>()))
                                       : 0;
  run.id = (method.name.empty() ? "" : method.name + "-") + "g" + std::to_string(g) + "-c" + std::to_string(l) + "-s" +
           std::to_string(run.seed) + "-" + hex8(fnv1a(f.document.dump()));
  run.config = f.document;
  absolutise_paths(run.config, base_dir);
  if (validate && s == 0) validate_run(sweep, run, f.path, context);
  sweep.runs.push_back(std::move(run));
}

// A method's runs: grid point (last key fastest), level, seed.
void expand_method(Sweep& sweep, const SweepPlan& plan, const MethodSpec& method, bool validate) {
  const std::string where_method = method.name.empty() ? "base" : "methods." + method.name;
  std::string base_dir;
  try {
    base_dir = load_base(method.base, plan.sweep_dir, method.overrides).base_dir;
  } catch (const InputError& e) {
    throw InputError(sweep.path, method.name.empty() ? "base" : where_method + (e.where().empty() || e.file().empty() ? "" : ".overrides"),
                     e.what());
  }
  for (size_t g = 0; g < plan.grid_points; ++g) {
    GridPoint point;
    point.index = g;
    point.overrides = method.overrides;
    size_t rest = g;
    for (size_t k = plan.grid_values.size(); k-- > 0;) {
      point.parameters.emplace_back(sweep.grid_keys[k], plan.grid_values[k][rest % plan.grid_values[k].size()]);
      rest /= plan.grid_values[k].size();
    }
    std::reverse(point.parameters.begin(), point.parameters.end());
    for (const auto& [key, value] : point.parameters) point.overrides.push_back(key + "=" + value.dump());
    for (size_t l = 0; l < plan.levels.size(); ++l)
      for (size_t s = 0; s < plan.seeds.size(); ++s) {
        const std::string context = where_method + ", grid point " + std::to_string(g) +
                                    (plan.has_levels ? ", corruptions[" + std::to_string(l) + "]" : "");
        add_run(sweep, plan, method, base_dir, point, l, s, context, validate);
      }
  }
}

}  // namespace

// Reads and checks the whole file first, then expands it: method, grid point, level, seed.
Sweep load_sweep(const std::string& path, bool validate) {
  Sweep sweep;
  sweep.path = path;
  json doc;
  nlohmann::ordered_json ordered;
  parse_sweep_file(path, doc, ordered);
  const SweepPlan plan = read_sweep_plan(sweep, doc, ordered);
  for (const auto& method : plan.methods) expand_method(sweep, plan, method, validate);
  std::set<std::string> ids;
  for (const auto& r : sweep.runs)
    if (!ids.insert(r.id).second) throw InputError(path, "", "two runs resolve to the same id " + r.id);
  return sweep;
}

namespace {

volatile std::sig_atomic_t g_stop = 0;
extern "C" void on_stop_signal(int) { g_stop = 1; }

// SIGINT/SIGTERM stop the sweep cleanly (children terminated, staging removed, table written).
class StopSignals {
 public:
  StopSignals() {
    g_stop = 0;
    struct sigaction sa {};
    sa.sa_handler = on_stop_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = 0;  // no SA_RESTART: waitpid returns EINTR
    sigaction(SIGINT, &sa, &old_int_);
    sigaction(SIGTERM, &sa, &old_term_);
  }
  ~StopSignals() {
    sigaction(SIGINT, &old_int_, nullptr);
    sigaction(SIGTERM, &old_term_, nullptr);
  }

 private:
  struct sigaction old_int_ {}, old_term_ {};
};

// One sweep per output folder at a time: an exclusive lock on DIR/.sweep.lock, released when
// the process ends (children do not inherit it).
class FolderLock {
 public:
  explicit FolderLock(const fs::path& dir) {
    const std::string p = (dir / ".sweep.lock").string();
    fd_ = ::open(p.c_str(), O_CREAT | O_RDWR | O_CLOEXEC, 0644);
    if (fd_ < 0) throw InputError(dir.string(), "", std::string("cannot create the lock file: ") + std::strerror(errno));
    if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
      ::close(fd_);
      throw InputError(dir.string(), "", "another dsnake sweep is running in this folder");
    }
  }
  ~FolderLock() { ::close(fd_); }
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;

 private:
  int fd_ = -1;
};

// Removes staging folders and temporary files left by killed processes.
void remove_leftovers(const fs::path& out) {
  for (const fs::path& dir : {out / "runs", out / "configs", out})
    if (fs::is_directory(dir))
      for (const auto& e : fs::directory_iterator(dir)) {
        const long pid = owner_pid(e.path().filename().string());
        std::error_code ec;
        if (pid > 0 && !process_alive(pid)) fs::remove_all(e.path(), ec);
      }
}

// A word for sh: bare when it is safe, else in single quotes.
std::string shell_quote(const std::string& s) {
  if (!s.empty() && s.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-./=:+,") == std::string::npos)
    return s;
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// A run is finished exactly when this file exists (the runner moves it in last).
fs::path result_path(const fs::path& out, const SweepRun& run) { return out / "runs" / run.id / "result.json"; }

// A finished run's result.json, or nullopt.
std::optional<json> read_result(const fs::path& p) {
  std::ifstream in(p);
  if (!in) return std::nullopt;
  try {
    return json::parse(in);
  } catch (const json::exception&) {
    return std::nullopt;  // cannot happen for a published result (written atomically)
  }
}

// The command line of one run: `dsnake run CONFIG --out DIR [--threads T] [--quiet]`.
std::vector<std::string> run_arguments(const SweepOptions& o, const fs::path& out, const SweepRun& run, int threads,
                                       bool quiet) {
  std::vector<std::string> args = {o.executable, "run", (out / "configs" / (run.id + ".json")).string(), "--out",
                                   (out / "runs" / run.id).string()};
  if (threads > 0) args.insert(args.end(), {"--threads", std::to_string(threads)});
  if (quiet) args.push_back("--quiet");
  return args;
}

// Starts one run as a child process whose stdout and stderr go to `log`. The child gets
// SIGKILL when the sweep dies, so no orphan keeps writing into the folder of a resumed sweep.
pid_t spawn(const std::vector<std::string>& args, const std::string& log) {
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) throw std::runtime_error(std::string("cannot start a run: fork failed: ") + std::strerror(errno));
  if (pid == 0) {  // only async-signal-safe calls until exec
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(127);
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int null_fd = ::open("/dev/null", O_RDONLY);
    if (fd < 0 || null_fd < 0) ::_exit(127);
    ::dup2(null_fd, 0);
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  return pid;
}

// The last non-empty line of a run's log: the error of a failed run.
std::string last_line(const fs::path& p) {
  std::ifstream in(p);
  std::string line, last;
  while (std::getline(in, line))
    if (!line.empty()) last = line;
  return last;
}

// The executable in a manifest line: $DSNAKE if set, else the one that wrote the manifest (a
// path that needs no quoting inside double quotes), else dsnake on PATH.
std::string manifest_executable(const std::string& path) {
  const bool plain = !path.empty() && path.find_first_of("\"$`\\\n") == std::string::npos;
  return "\"${DSNAKE:-" + (plain ? path : std::string("dsnake")) + "}\"";
}

// What the finished runs of this sweep measured: the slowest wall time (s), the median (s) and the
// largest peak memory (MB), from their result.json (timings.total_s, provenance.peak_memory_mb).
struct MeasuredRuns {
  int count = 0;
  double slowest_s = 0, median_s = 0, peak_mb = 0;
};
MeasuredRuns measured_runs(const Sweep& sweep, const fs::path& out) {
  MeasuredRuns m;
  std::vector<double> times;
  for (const auto& run : sweep.runs) {
    const auto r = read_result(result_path(out, run));
    if (!r || !r->contains("timings") || !(*r)["timings"].contains("total_s")) continue;
    times.push_back((*r)["timings"]["total_s"].get<double>());
    if (r->contains("provenance") && (*r)["provenance"].contains("peak_memory_mb"))
      m.peak_mb = std::max(m.peak_mb, (*r)["provenance"]["peak_memory_mb"].get<double>());
  }
  m.count = int(times.size());
  if (times.empty()) return m;
  std::sort(times.begin(), times.end());
  m.slowest_s = times.back();
  m.median_s = times[times.size() / 2];
  return m;
}

// The Slurm job array's resources: each task runs `lines` manifest lines one after another, so
// that a task lasts about kSlurmTaskTarget (many tasks of seconds each load the scheduler more
// than the runs load the nodes); --time covers them at the slowest measured run, twice over, at
// least 10 minutes; --mem is twice the largest measured peak, at least 1 GB. Without measured
// runs: one line per task, 60 minutes, 4 GB. Options given on the command line win.
struct SlurmResources {
  int lines = 1, time_minutes = 60, memory_mb = 4096, max_running = 0;
};
constexpr double kSlurmTaskTarget = 300.0;  // s
SlurmResources slurm_resources(const SweepOptions& o, const MeasuredRuns& m) {
  SlurmResources r;
  if (m.count > 0) {
    r.lines = int(std::clamp(std::ceil(kSlurmTaskTarget / std::max(m.median_s, 0.1)), 1.0, 1000.0));
    r.time_minutes = std::max(10, int(std::ceil(2.0 * r.lines * m.slowest_s / 60.0)));
    r.memory_mb = std::max(1024, int(std::ceil(2.0 * m.peak_mb)));
  }
  if (o.slurm.lines_per_task > 0) r.lines = o.slurm.lines_per_task;
  if (o.slurm.time_minutes > 0) r.time_minutes = o.slurm.time_minutes;
  if (o.slurm.memory_mb > 0) r.memory_mb = o.slurm.memory_mb;
  r.max_running = o.slurm.max_running;
  return r;
}

// manifest.txt: one shell command per unfinished run, with paths relative to the sweep's folder
// (run it there: `cd DIR && parallel -j N < manifest.txt`), so that the folder can move to a
// cluster; with "slurm" also sweep.slurm, a job array whose tasks run consecutive lines.
void write_manifest(const Sweep& sweep, const SweepOptions& o, const fs::path& out, const std::vector<size_t>& pending) {
  const int threads = o.threads > 0 ? o.threads : 1;
  std::string manifest;
  for (size_t i : pending) {
    const SweepRun& run = sweep.runs[i];
    manifest += manifest_executable(o.executable) + " run " + shell_quote("configs/" + run.id + ".json") + " --out " +
                shell_quote("runs/" + run.id) + " --threads " + std::to_string(threads) + " --quiet\n";
  }
  write_file_atomically((out / "manifest.txt").string(), manifest);
  if (!o.quiet)
    std::fprintf(stderr, "dsnake sweep: wrote %s (%zu runs; run them with: cd %s && parallel -j N < manifest.txt)\n",
                 (out / "manifest.txt").c_str(), pending.size(), shell_quote(out.string()).c_str());
  if (o.manifest != "slurm") return;
  if (pending.empty()) {
    if (!o.quiet) std::fprintf(stderr, "dsnake sweep: every run is finished: no Slurm script written\n");
    return;
  }
  const MeasuredRuns measured = measured_runs(sweep, out);
  const SlurmResources r = slurm_resources(o, measured);
  const size_t tasks = (pending.size() + r.lines - 1) / r.lines;
  std::ostringstream s;
  s << "#!/bin/bash\n"
    << "# dsnake sweep " << sweep.path << ": " << pending.size() << " unfinished runs, " << r.lines
    << " manifest line(s) per array task.\n"
    << "# Submit from the sweep's folder (the paths are relative to it): cd DIR && sbatch sweep.slurm\n"
    << "# Then aggregate: dsnake sweep SWEEP_FILE --out DIR --aggregate-only\n"
    << "# Resources: " << (measured.count > 0 ? "from " + std::to_string(measured.count) + " finished runs (slowest " +
                                                      json(measured.slowest_s).dump() + " s, median " +
                                                      json(measured.median_s).dump() + " s, peak " +
                                                      json(measured.peak_mb).dump() + " MB)"
                                                : std::string("no finished run to measure: defaults"))
    << "; override with --slurm-time, --slurm-mem, --slurm-lines-per-task, --slurm-max-running.\n"
    << "#SBATCH --job-name=dsnake-sweep\n"
    << "#SBATCH --array=0-" << tasks - 1 << (r.max_running > 0 ? "%" + std::to_string(r.max_running) : "") << "\n"
    << "#SBATCH --cpus-per-task=" << threads << "\n"
    << "#SBATCH --time=" << r.time_minutes << "\n"
    << "#SBATCH --mem=" << r.memory_mb << "M\n"
    << "#SBATCH --output=logs/slurm-%A_%a.log\n"
    << "cd \"${DSNAKE_SWEEP_DIR:-${SLURM_SUBMIT_DIR:-.}}\"\n"
    << "first=$((SLURM_ARRAY_TASK_ID * " << r.lines << " + 1))\n"
    << "status=0\n"
    << "while IFS= read -r line; do\n"
    << "  eval \"$line\" || status=1\n"
    << "done < <(sed -n \"${first},$((first + " << r.lines - 1 << "))p\" manifest.txt)\n"
    << "exit $status\n";
  write_file_atomically((out / "sweep.slurm").string(), s.str());
  fs::permissions(out / "sweep.slurm", fs::perms::owner_exec | fs::perms::group_exec | fs::perms::others_exec,
                  fs::perm_options::add);
  if (!o.quiet)
    std::fprintf(stderr, "dsnake sweep: wrote %s (%zu array tasks; submit with: cd %s && sbatch sweep.slurm)\n",
                 (out / "sweep.slurm").c_str(), tasks, shell_quote(out.string()).c_str());
}

// The SHA-256 of the sweep's input files, each read once per invocation.
class InputChecksums {
 public:
  // "" when the file cannot be read.
  const std::string& of(const std::string& path) {
    auto it = sums_.find(path);
    if (it != sums_.end()) return it->second;
    std::string sum;
    try {
      sum = file_sha256(path);
    } catch (const InputError&) {
    }
    return sums_.emplace(path, sum).first->second;
  }

 private:
  std::map<std::string, std::string> sums_;
};

// Why a finished run's result no longer stands for its run, or "" when it does: it was made by
// another build, or an input file the run reads has changed (or cannot be read) since. The
// experiment itself is in the run's id.
std::string stale_reason(const json& result, const SweepRun& run, InputChecksums& sums) {
  const auto p = result.find("provenance");
  if (p == result.end() || !p->is_object() || !p->contains("build") || !p->contains("inputs"))
    return "it records no provenance (an older dsnake made it)";
  const json build = build_json();
  if ((*p)["build"] != build) {
    const json& made = (*p)["build"];
    if (made.value("version", "") != build.value("version", ""))
      return "another build made it (version " + made.value("version", "?") + "; this is " + build.value("version", "?") + ")";
    return "another build made it (compiler or flags differ)";
  }
  const json& inputs = (*p)["inputs"];
  for (const InputFile& f : input_files(run.config, "")) {
    const std::string recorded = inputs.contains(f.key) && inputs[f.key].is_object() ? inputs[f.key].value("sha256", "") : "";
    const std::string& now = sums.of(f.path);
    if (now.empty()) return "its input " + f.key + " (" + f.path + ") cannot be read";
    if (recorded != now) return "its input " + f.key + " (" + f.path + ") changed since it ran";
  }
  return "";
}

// The stale reason of every run (stale_reason; "" for a run that has not finished).
std::vector<std::string> stale_reasons(const Sweep& sweep, const std::vector<std::optional<json>>& results) {
  InputChecksums sums;
  std::vector<std::string> reasons(sweep.runs.size());
  for (size_t i = 0; i < sweep.runs.size(); ++i)
    if (results[i]) reasons[i] = stale_reason(*results[i], sweep.runs[i], sums);
  return reasons;
}

// At most five lines, one per stale run, then how many more.
void report_stale(const Sweep& sweep, const std::vector<std::string>& reasons, const char* what) {
  int shown = 0, total = 0;
  for (size_t i = 0; i < reasons.size(); ++i) {
    if (reasons[i].empty()) continue;
    if (++total <= 5) std::fprintf(stderr, "dsnake sweep: %s %s: %s\n", what, sweep.runs[i].label().c_str(), reasons[i].c_str());
    else ++shown;
  }
  if (shown > 0) std::fprintf(stderr, "dsnake sweep: ... and %d more (results.csv's column \"stale\" says why)\n", shown);
}

// results.csv and breakdown.csv from every finished run, written atomically.
void aggregate(const Sweep& sweep, const fs::path& out, bool quiet) {
  std::vector<std::optional<json>> results;
  int finished = 0;
  for (const auto& run : sweep.runs) {
    results.push_back(read_result(result_path(out, run)));
    finished += results.back().has_value();
  }
  const std::vector<std::string> stale = stale_reasons(sweep, results);
  const int stale_count = int(std::count_if(stale.begin(), stale.end(), [](const std::string& r) { return !r.empty(); }));
  const std::string table = results_csv(sweep, results, stale);
  write_file_atomically((out / "results.csv").string(), table);
  write_file_atomically((out / "breakdown.csv").string(), breakdown_csv(sweep, results));
  const SummaryTables summary = summary_tables(table, (out / "results.csv").string());
  write_file_atomically((out / "summary.csv").string(), summary.csv);
  write_file_atomically((out / "summary.md").string(), summary.markdown);
  write_file_atomically((out / "summary.tex").string(), summary.latex);
  // A result that no longer stands is aggregated (kept on purpose, or seen by --aggregate-only)
  // but never silently: one line says how many, results.csv's column "stale" says why.
  if (stale_count > 0)
    std::fprintf(stderr, "dsnake sweep: warning: %d of the %d finished results no longer stand (another build, or changed "
                 "inputs): results.csv's column \"stale\" says why; run the sweep without --aggregate-only or "
                 "--keep-stale to run them again\n", stale_count, finished);
  if (!quiet)
    std::fprintf(stderr, "dsnake sweep: wrote %s, breakdown.csv and summary.{csv,md,tex} (%d of %zu runs finished)\n",
                 (out / "results.csv").c_str(), finished, sweep.runs.size());
}

// The unfinished runs and, unless o.keep_stale, the finished ones whose results no longer stand
// (the others counted as skipped), each with a fresh folder and its configs/<id>.json written.
std::vector<size_t> prepare_pending(const Sweep& sweep, const SweepOptions& o, const fs::path& out, SweepSummary& summary) {
  std::vector<size_t> pending;
  std::vector<std::optional<json>> results;
  for (const auto& run : sweep.runs) results.push_back(read_result(result_path(out, run)));
  std::vector<std::string> reasons = stale_reasons(sweep, results);
  for (size_t i = 0; i < sweep.runs.size(); ++i) {
    if (!results[i]) {
      pending.push_back(i);
    } else if (!reasons[i].empty() && !o.keep_stale) {
      pending.push_back(i);
      ++summary.rerun;
    } else {
      ++summary.skipped;
      if (reasons[i].empty()) continue;
      ++summary.kept_stale;
    }
  }
  if (!o.quiet) {
    if (!o.keep_stale) report_stale(sweep, reasons, "running again");
    else report_stale(sweep, reasons, "kept (--keep-stale), although it no longer stands:");
  }
  // An unfinished run's folder holds at most what a killed publish moved in: start it afresh.
  for (size_t i : pending) {
    std::error_code ec;
    fs::remove_all(out / "runs" / sweep.runs[i].id, ec);
  }
  for (size_t i : pending)
    write_file_atomically((out / "configs" / (sweep.runs[i].id + ".json")).string(), sweep.runs[i].config.dump(2) + "\n");
  return pending;
}

// The progress line of a run that ended: its outcome, or why it failed and its log's last line.
void report_run(const SweepRun& run, int status, const std::optional<json>& result, bool ok, double seconds,
                const fs::path& out, const SweepSummary& summary) {
  const int done = summary.skipped + summary.completed + summary.failed;
  if (ok) {
    const bool success = result->value("success", false);
    std::fprintf(stderr, "[%d/%d] %s: %s (%.1f s)\n", done, summary.total, run.label().c_str(),
                 success ? "met its thresholds" : "missed its thresholds", seconds);
  } else {
    const std::string why = WIFEXITED(status) ? "exit code " + std::to_string(WEXITSTATUS(status))
                                              : "killed by signal " + std::to_string(WTERMSIG(status));
    const fs::path log = out / "logs" / (run.id + ".log");
    std::fprintf(stderr, "[%d/%d] %s: run failed (%s; %s): %s\n", done, summary.total, run.label().c_str(),
                 why.c_str(), log.c_str(), last_line(log).c_str());
  }
}

// Runs the pending runs as up to o.jobs child processes, counting them in `summary`; a stop
// signal terminates the running children (which then count as neither completed nor failed).
void run_children(const Sweep& sweep, const SweepOptions& o, const fs::path& out, const std::vector<size_t>& pending,
                  int threads, SweepSummary& summary) {
  using Clock = std::chrono::steady_clock;
  struct Child {
    size_t run;
    Clock::time_point start;
  };
  std::map<pid_t, Child> running;
  bool terminated = false;
  size_t next = 0;
  while ((next < pending.size() && !g_stop) || !running.empty()) {
    while (!g_stop && static_cast<int>(running.size()) < o.jobs && next < pending.size()) {
      const SweepRun& run = sweep.runs[pending[next]];
      const pid_t pid = spawn(run_arguments(o, out, run, threads, false), (out / "logs" / (run.id + ".log")).string());
      running[pid] = {pending[next++], Clock::now()};
    }
    if (g_stop && !terminated) {
      for (const auto& [pid, child] : running) ::kill(pid, SIGTERM);
      terminated = true;
    }
    int status = 0;
    const pid_t pid = ::waitpid(-1, &status, 0);
    if (pid < 0) {
      if (errno == EINTR) continue;
      if (errno == ECHILD) break;
      throw std::runtime_error(std::string("waitpid failed: ") + std::strerror(errno));
    }
    const auto it = running.find(pid);
    if (it == running.end()) continue;
    const SweepRun& run = sweep.runs[it->second.run];
    const double seconds = std::chrono::duration<double>(Clock::now() - it->second.start).count();
    running.erase(it);
    const auto result = read_result(result_path(out, run));
    const bool ok = WIFEXITED(status) && WEXITSTATUS(status) == 0 && result;
    if (ok) ++summary.completed;
    else if (!terminated) ++summary.failed;
    if (o.quiet || (terminated && !ok)) continue;
    report_run(run, status, result, ok, seconds, out, summary);
  }
}

// OpenMP threads for each of `jobs` concurrent runs: the cores this process may use
// (its CPU affinity, so taskset and cgroup cpusets count), shared evenly, at least one; 0 (the
// OpenMP default, every core) for a single job.
int threads_per_job(int jobs) {
  if (jobs <= 1) return 0;
  cpu_set_t set;
  const int cores = sched_getaffinity(0, sizeof(set), &set) == 0 ? CPU_COUNT(&set) : 1;
  return std::max(1, cores / jobs);
}

}  // namespace

SweepSummary run_sweep(const Sweep& sweep, const SweepOptions& o) {
  DSNAKE_ASSERT(o.jobs >= 1, "at least one job");
  const fs::path out = fs::absolute(o.out_dir).lexically_normal();
  SweepSummary summary;
  summary.total = static_cast<int>(sweep.runs.size());
  fs::create_directories(out);
  if (o.aggregate_only) {
    aggregate(sweep, out, o.quiet);
    for (const auto& run : sweep.runs) summary.skipped += fs::exists(result_path(out, run));
    return summary;
  }
  FolderLock lock(out);
  for (const char* sub : {"runs", "configs", "logs"}) fs::create_directories(out / sub);
  remove_leftovers(out);

  const std::vector<size_t> pending = prepare_pending(sweep, o, out, summary);
  if (!o.manifest.empty()) {
    write_manifest(sweep, o, out, pending);
    return summary;
  }

  const int threads = o.threads > 0 ? o.threads : threads_per_job(o.jobs);
  if (!o.quiet)
    std::fprintf(stderr, "dsnake sweep: %d runs, %d finished already (skipped), running %zu with %d jobs%s\n",
                 summary.total, summary.skipped, pending.size(), o.jobs,
                 threads > 0 ? (" (" + std::to_string(threads) + " OpenMP thread" + (threads > 1 ? "s" : "") + " each)").c_str() : "");
  StopSignals signals;  // installed until the return, the aggregation included
  run_children(sweep, o, out, pending, threads, summary);
  summary.interrupted = g_stop != 0;
  remove_leftovers(out);  // staging folders of runs stopped by a signal
  aggregate(sweep, out, o.quiet);
  if (!o.quiet)
    std::fprintf(stderr, "dsnake sweep: %d runs: %d skipped, %d finished%s, %d process failed (logs/)%s\n", summary.total,
                 summary.skipped, summary.completed,
                 summary.rerun > 0 ? (" (" + std::to_string(summary.rerun) + " of them again: stale)").c_str() : "",
                 summary.failed, summary.interrupted ? ", interrupted" : "");
  return summary;
}

}  // namespace dsnake
