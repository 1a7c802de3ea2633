#include "experiments/output/runner.h"

#include "experiments/output/provenance.h"

#include "experiments/output/output_folder.h"

#include "framework/core/image_filters.h"

#include "experiments/output/figures.h"
#include "experiments/output/pose_report.h"
#include "framework/core/atomic_file.h"
#include "framework/core/errors.h"
#include "framework/core/image_filters.h"
#include "framework/io/image_io.h"
#include "framework/io/mesh_io.h"
#include "framework/metrics/metrics.h"
#include "registration/registration.h"
#include "remesh/quality.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <sstream>
#include <unistd.h>

#ifndef DSNAKE_VERSION
#define DSNAKE_VERSION "unknown"
#endif

namespace dsnake {

namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// What the progress lines and result.json need of each phase once the registration has taken
// the phases over.
struct PhaseOutline {
  int iterations = 0;   // the iteration budget
  bool windowed = false;  // the windowed stop is on (result.json's "centroid_rate")
};

// Progress lines on stderr: the first iteration, then at most twice a second, and each phase end.
template <int D>
class ProgressObserver : public EvolverObserver<D> {
 public:
  ProgressObserver(const std::vector<PhaseOutline>& phases, std::vector<std::string> names, bool global)
      : phases_(phases), names_(std::move(names)), global_(global) {}
  void on_iteration(const IterationInfo& info, const Snake<D>&) override {
    const bool last = !global_ && info.phase_iteration == phases_[info.phase].iterations;
    if (info.phase_iteration != 1 && !last && seconds_since(last_print_) < 0.5) return;
    print(info);
  }
  void on_phase_end(int phase, const PhaseSummary& s, const Snake<D>& snake) override {
    std::fprintf(stderr, "dsnake: phase %d/%zu %s after %d iterations (last move %.3g, %d vertices)\n",
                 phase + 1, phases_.size(), to_string(s.status).c_str(), s.iterations, s.last_displacement,
                 snake.num_vertices());
  }

 private:
  void print(const IterationInfo& info) {
    last_print_ = Clock::now();
    if (global_)
      std::fprintf(stderr, "dsnake: phase %d/%zu %s Ceres iteration %d  energy %.6g  max move %.3g  vertices %d\n",
                   info.phase + 1, phases_.size(), names_[info.phase].c_str(), info.phase_iteration,
                   info.total_energy, info.max_displacement, info.vertices);
    else
      std::fprintf(stderr, "dsnake: phase %d/%zu %s iteration %d/%d  energy %.6g  max move %.3g  vertices %d\n",
                   info.phase + 1, phases_.size(), names_[info.phase].c_str(), info.phase_iteration,
                   phases_[info.phase].iterations, info.total_energy, info.max_displacement, info.vertices);
  }
  const std::vector<PhaseOutline>& phases_;
  std::vector<std::string> names_;
  bool global_ = false;
  Clock::time_point last_print_{};
};

// Positions in the image's frame (image.h; where the snake runs) as world positions, for every
// file the run writes. The identity for an axis-aligned image.
template <int D>
PointList<D> world_positions(const Grid<D>& frame, const PointList<D>& points) {
  if (frame.axis_aligned()) return points;
  PointList<D> world(points.size());
  for (size_t i = 0; i < points.size(); ++i) world[i] = frame.to_world(points[i]);
  return world;
}

// Keeps the energy trace in memory and writes snapshots.
template <int D>
class RecordingObserver : public EvolverObserver<D> {
 public:
  RecordingObserver(std::string snapshot_dir, int snapshot_every, const Grid<D>& frame)
      : snapshot_dir_(std::move(snapshot_dir)), every_(snapshot_every), frame_(frame) {}
  void on_iteration(const IterationInfo& info, const Snake<D>& snake) override {
    trace.push_back(info);
    if (every_ > 0 && info.iteration % every_ == 0) {
      fs::create_directories(snapshot_dir_);
      std::ostringstream name;
      name << snapshot_dir_ << "/iteration_" << std::setw(6) << std::setfill('0') << info.iteration << ".vtk";
      write_shape<D>(world_positions(frame_, snake.positions()), snake.connectivity(), name.str(),
                     template_id_scalars(snake));
    }
  }
  static std::vector<VertexScalars> template_id_scalars(const Snake<D>& snake) {
    VertexScalars ids{"template_id", {}};
    for (int t : snake.template_ids()) ids.values.push_back(t);
    return {ids};
  }
  // Mesh quality after each 3D phase that remeshed ("mesh_quality" in result.json, docs/experiment-file.md).
  void on_phase_end(int phase, const PhaseSummary& summary, const Snake<D>& snake) override {
    if (keep_phase_ends) phase_ends[phase] = snake;
    if constexpr (D == 3) {
      if (summary.remesh_reports.empty()) return;
      nlohmann::json j;
      to_json(j, compute_mesh_quality(snake));
      mesh_quality[phase] = j;
    }
  }
  std::vector<IterationInfo> trace;
  std::map<int, nlohmann::json> mesh_quality;  // per phase index
  bool keep_phase_ends = false;  // output.start_metrics: each phase's last snake, to be measured
  std::map<int, Snake<D>> phase_ends;  // per phase index

 private:
  std::string snapshot_dir_;
  int every_;
  Grid<D> frame_;  // the image's grid: its frame is where the snake lives
};

nlohmann::ordered_json optional_number(const std::optional<double>& v) {
  return v && std::isfinite(*v) ? nlohmann::ordered_json(*v) : nlohmann::ordered_json(nullptr);
}

// {"terms": {name: w_e E_e}, "total": their sum}: the run's energy as the snake and the global
// solve both minimise it (a term without a value, which no registered energy has, is null and
// left out of the total).
nlohmann::ordered_json energy_json(const std::vector<std::string>& names, const std::vector<double>& values) {
  nlohmann::ordered_json terms = nlohmann::ordered_json::object();
  double total = 0.0;
  for (size_t i = 0; i < names.size(); ++i) {
    const double v = i < values.size() ? values[i] : std::numeric_limits<double>::quiet_NaN();
    terms[names[i]] = optional_number(v);
    if (std::isfinite(v)) total += v;
  }
  return {{"terms", terms}, {"total", total}};
}

std::string csv_number(double v) {
  if (!std::isfinite(v)) return "";  // a missing value: an empty field, as CSV readers take it
  std::ostringstream s;
  s << std::setprecision(10) << v;
  return s.str();
}

template <int D>
std::string trace_csv(const std::vector<IterationInfo>& trace, const std::vector<std::string>& names) {
  std::ostringstream s;
  s << "iteration,phase,phase_iteration,vertices,max_displacement";
  for (const auto& n : names) s << "," << n;
  s << ",total\n";
  for (const auto& t : trace) {
    s << t.iteration << "," << t.phase << "," << t.phase_iteration << "," << t.vertices << ","
      << csv_number(t.max_displacement);
    for (double e : t.energy_terms) s << "," << csv_number(e);
    s << "," << csv_number(t.total_energy) << "\n";
  }
  return s.str();
}

// correspondence.csv: per template vertex its start, end, displacement, target and error; positions
// in world coordinates, an empty field where a value does not exist (a CSV reader's missing value).
template <int D>
std::string correspondence_csv(const Experiment<D>& ex, const Snake<D>& snake, const CorrespondenceError& err) {
  static const char* axis[3] = {"x", "y", "z"};
  const Grid<D>& frame = ex.image.grid();
  std::map<int, std::string> landmark_of;
  for (const auto& [name, id] : ex.tmpl.landmarks) landmark_of[id] = name;
  std::ostringstream s;
  s << "template_id,landmark";
  for (int a = 0; a < D; ++a) s << ",initial_" << axis[a];
  for (int a = 0; a < D; ++a) s << ",final_" << axis[a];
  s << ",displacement";
  for (int a = 0; a < D; ++a) s << ",target_" << axis[a];
  s << ",error\n";
  for (int t = 0; t < ex.tmpl.num_vertices(); ++t) {
    const int v = snake.vertex_of_template_id(t);
    s << t << "," << (landmark_of.count(t) ? landmark_of[t] : "");
    const Point<D> start = frame.to_world(ex.initial[t]);
    const Point<D> end = v >= 0 ? frame.to_world(snake.positions()[v]) : Point<D>::Constant(NAN);
    for (int a = 0; a < D; ++a) s << "," << csv_number(start[a]);
    for (int a = 0; a < D; ++a) s << "," << csv_number(end[a]);
    s << "," << csv_number(v >= 0 ? (end - start).norm() : NAN);
    const bool has_target = t < int(ex.truth.targets.size()) && ex.truth.targets[t];
    const Point<D> target = has_target ? frame.to_world(*ex.truth.targets[t]) : Point<D>::Constant(NAN);
    for (int a = 0; a < D; ++a) s << "," << csv_number(target[a]);
    s << "," << csv_number(t < int(err.per_vertex.size()) ? err.per_vertex[t] : NAN) << "\n";
  }
  return s.str();
}

// result.json's "global": the solver options and Ceres' summary of every solve, per phase.
template <int D>
nlohmann::ordered_json global_json(const Experiment<D>& ex, size_t phase_count,
                                   const std::vector<std::vector<GlobalSolveSummary>>& solves) {
  const GlobalSolverOptions& g = ex.global;
  nlohmann::ordered_json j = {{"linear_solver", enum_name(g.linear_solver)}, {"max_iterations", g.max_iterations},
                              {"initial_trust_region_radius", g.initial_trust_region_radius},
                              {"max_trust_region_radius", g.max_trust_region_radius},
                              {"function_tolerance", g.function_tolerance},
                              {"gradient_tolerance", g.gradient_tolerance},
                              {"parameter_tolerance", g.parameter_tolerance}, {"threads", g.threads},
                              {"remesh_rounds", g.remesh_rounds}};
  int iterations = 0, residual_evaluations = 0, jacobian_evaluations = 0;
  nlohmann::ordered_json phases = nlohmann::ordered_json::array();
  std::vector<std::vector<GlobalSolveSummary>> per_phase = solves;
  per_phase.resize(std::max(per_phase.size(), phase_count));  // phases after a divergence: no solve
  for (const auto& phase : per_phase) {
    nlohmann::ordered_json list = nlohmann::ordered_json::array();
    for (const auto& s : phase) {
      list.push_back({{"iterations", s.iterations}, {"successful_steps", s.successful_steps},
                      {"residual_evaluations", s.residual_evaluations},
                      {"jacobian_evaluations", s.jacobian_evaluations}, {"initial_cost", s.initial_cost},
                      {"final_cost", s.final_cost}, {"termination", s.termination}, {"message", s.message},
                      {"time_s", s.time_s}});
      iterations += s.iterations;
      residual_evaluations += s.residual_evaluations;
      jacobian_evaluations += s.jacobian_evaluations;
    }
    phases.push_back(list);
  }
  j["iterations"] = iterations;
  j["residual_evaluations"] = residual_evaluations;
  j["jacobian_evaluations"] = jacobian_evaluations;
  j["solves"] = phases;
  return j;
}

template <int D>
void write_figures(const Experiment<D>& ex, const Snake<D>& snake, const fs::path& dir);

}  // namespace

namespace {

// What a run produced, for the output files and result.json.
template <int D>
struct RunRecord {
  RunRecord(const fs::path& staging, int snapshot_every, const Grid<D>& frame)
      : recorder((staging / "snapshots").string(), snapshot_every, frame) {}
  // The snake, its summary, the energy terms' column names, the field's region and strength,
  // the global solves and the timings of the field, the potential and the phases.
  RegistrationResult<D> registration;
  std::vector<PhaseOutline> phases;  // the experiment's, as they were handed to the registration
  RecordingObserver<D> recorder;
  Metrics metrics;
  std::optional<Metrics> start_metrics;  // output.start_metrics: the placed template's
  std::map<int, Metrics> phase_metrics;  // output.start_metrics: each phase's end (phases_json)
  nlohmann::ordered_json pose;           // result.json's "pose" (experiments/output/pose_report.h)
  CorrespondenceError correspondence;
  bool finite = false;  // a diverged snake (non-finite positions) has no meaningful metrics
  double metrics_s = 0;
};

// result.json's "landmarks" (landmark energies only): per landmark energy, each landmark's
// distance to its point (mm) at the start and at the end.
nlohmann::ordered_json landmarks_json(const std::vector<ReportedDistances>& energies) {
  nlohmann::ordered_json list;
  for (const auto& d : energies) {
    double largest = 0.0;
    for (const auto& [name, mm] : d.final_mm) largest = std::max(largest, mm);
    list.push_back({{"energy", "energies[" + std::to_string(d.energy) + "]"}, {"initial_distance_mm", d.initial_mm},
                    {"final_distance_mm", d.final_mm}, {"final_max_mm", largest}});
  }
  return list;
}

nlohmann::ordered_json guard_json(const MoveGuardReport& r) {
  return {{"shortened", r.shortened}, {"refused", r.refused}, {"checks", r.checks}};
}

// The numeric watchdog: "watchdog.max_move" 0 is the image's diagonal in mm.
template <int D>
Watchdog watchdog_of(const Experiment<D>& ex) {
  Watchdog w = ex.watchdog;
  if (!(w.max_move > 0)) {
    const Grid<D>& g = ex.image.grid();
    w.max_move = (g.size.template cast<double>().cwiseProduct(g.spacing)).norm();
  }
  return w;
}

// The experiment as a registration problem (registration/registration.h); its field, energies
// and phases are handed over.
template <int D>
RegistrationProblem<D> registration_problem(Experiment<D>& ex) {
  RegistrationProblem<D> problem;
  problem.tmpl = &ex.tmpl;
  problem.initial = ex.initial;
  problem.image = &ex.image;
  problem.reference_image = ex.reference_image ? &*ex.reference_image : nullptr;
  problem.field = std::move(ex.field);
  problem.field_region = ex.field_region;
  problem.potential = ex.potential;
  problem.energies = std::move(ex.energies);
  problem.phases = std::move(ex.phases);
  problem.solver = ex.solver;
  problem.global = ex.global;
  problem.collision_guard = ex.collision_guard;
  problem.watchdog = watchdog_of(ex);
  problem.source = ex.file.path;
  return problem;
}

// RunOptions::on_iteration as an observer.
template <int D>
class CallbackObserver : public EvolverObserver<D> {
 public:
  explicit CallbackObserver(const std::function<void(const IterationInfo&)>& call) : call_(call) {}
  void on_iteration(const IterationInfo& info, const Snake<D>&) override { call_(info); }

 private:
  const std::function<void(const IterationInfo&)>& call_;
};

// Runs the experiment's registration with the recorder, the caller's callback and, unless quiet,
// progress lines.
template <int D>
void evolve(Experiment<D>& ex, const RunOptions& options, RunRecord<D>& rec) {
  for (const auto& phase : ex.phases) rec.phases.push_back({phase.iterations, phase.window > 0});
  ProgressObserver<D> progress(rec.phases, ex.phase_names, ex.solver == SolverKind::kGlobal);
  CallbackObserver<D> callback(options.on_iteration);
  rec.recorder.keep_phase_ends = ex.output.start_metrics;
  std::vector<EvolverObserver<D>*> observers{&rec.recorder};
  if (options.on_iteration) observers.push_back(&callback);
  RegistrationProgress say;
  if (!options.quiet) {
    observers.push_back(&progress);
    say = [&ex](const std::string& message) { std::fprintf(stderr, "dsnake: %s: %s\n", ex.name.c_str(), message.c_str()); };
  }
  rec.registration = register_template(registration_problem(ex), observers, say);
}

template <int D>
void measure(const Experiment<D>& ex, RunRecord<D>& rec) {
  const auto t = Clock::now();
  const Snake<D>& end = rec.registration.snake;
  const auto& q = end.positions();
  rec.finite = std::all_of(q.begin(), q.end(), [](const Point<D>& p) { return p.allFinite(); });
  rec.metrics = rec.finite ? compute_metrics(end, ex.truth, ex.metrics) : Metrics{};
  const Snake<D> start = Snake<D>::from_template(ex.tmpl, ex.initial);
  if (ex.output.start_metrics) rec.start_metrics = compute_metrics(start, ex.truth, ex.metrics);
  for (const auto& [phase, snake] : rec.recorder.phase_ends) {
    const bool finite = std::all_of(snake.positions().begin(), snake.positions().end(),
                                    [](const Point<D>& p) { return p.allFinite(); });
    if (finite) rec.phase_metrics[phase] = compute_metrics(snake, ex.truth, ex.metrics);
  }
  rec.metrics_s = seconds_since(t);
  if (rec.finite) rec.pose = pose_json(start, end, ex.image.grid());
  rec.correspondence = correspondence_error(end, ex.truth.targets);
}

// final.vtk's per-vertex arrays (docs/experiment-file.md, "Outputs"): template_id (-1 for a
// free vertex, inserted by refinement), has_target (1 where the ground truth gives this
// vertex's counterpart), error (distance to it; the sentinel -1 where has_target is 0),
// displacement (distance from the template vertex's start; 0 for a free vertex) and
// displacement_vector (end - start in world coordinates; 3 components, z = 0 in 2D). All
// finite, as VTK's legacy reader needs.
template <int D>
std::vector<VertexScalars> final_arrays(const Experiment<D>& ex, const Snake<D>& snake, const CorrespondenceError& err) {
  auto arrays = RecordingObserver<D>::template_id_scalars(snake);
  VertexScalars has_target{"has_target", {}}, error{"error", {}}, displacement{"displacement", {}};
  VertexScalars vector{"displacement_vector", {}, 3};
  const Grid<D>& frame = ex.image.grid();
  for (int v = 0; v < snake.num_vertices(); ++v) {
    const int id = snake.template_id(v);
    const bool target = id >= 0 && id < int(err.per_vertex.size()) && std::isfinite(err.per_vertex[id]);
    has_target.values.push_back(target ? 1 : 0);
    error.values.push_back(target ? err.per_vertex[id] : -1.0);
    const Point<D> move = id >= 0 ? Point<D>(frame.direction * (snake.positions()[v] - ex.initial[id])) : Point<D>::Zero();
    displacement.values.push_back(move.norm());
    for (int a = 0; a < 3; ++a) vector.values.push_back(a < D ? move[a] : 0.0);
  }
  arrays.insert(arrays.end(), {has_target, error, displacement, vector});
  return arrays;
}

// Whether the run writes image.nii.gz (OutputOptions::image).
template <int D>
bool writes_image(const Experiment<D>& ex) {
  return ex.output.image == ImageOutput::kAlways || (ex.output.image == ImageOutput::kAuto && !ex.image_is_file_as_read);
}

// An image on the experiment image's grid, written on the grid of the user's file when the image
// is one (its dimensions, voxel order and header, so that numpy compares it voxel by voxel with
// the user's own arrays), else (a phantom) with the image's geometry.
template <int D>
void write_from_image(const Experiment<D>& ex, const Image<D>& image, const std::string& path,
                      const ImageWriteOptions& options) {
  if (ex.image_layout) write_image_on_source_grid<D>(image, *ex.image_layout, path, options);
  else write_image<D>(image, path, options);
}

// result_mask.nii.gz: the result's interior (1) on the image's grid, with the image's geometry,
// as a label map that 3D Slicer and ITK-SNAP overlay on the image.
template <int D>
void write_result_mask(const Experiment<D>& ex, const Snake<D>& snake, const fs::path& staging) {
  Image<D> mask = rasterize_interior<D>({snake.positions(), snake.connectivity()}, ex.image.grid());
  write_from_image<D>(ex, mask, (staging / "result_mask.nii.gz").string(), ImageWriteOptions{.compress = true, .label = true});
}

// final.* and initial.* (positions in world coordinates; final.vtk with final_arrays), the CSV
// tables, the label map of the result and the registered image (unless it is a file read as it
// is), and the figures (drawn in the image's frame: world orientation unless the scan is oblique).
template <int D>
void write_outputs(const Experiment<D>& ex, const RunRecord<D>& rec, const fs::path& staging) {
  const Snake<D>& snake = rec.registration.snake;
  const std::vector<std::string>& names = rec.registration.term_names;
  const Grid<D>& frame = ex.image.grid();
  const std::string mesh_ext = D == 2 ? ".txt" : ".ply";
  const PointList<D> final_world = world_positions(frame, snake.positions());
  const PointList<D> initial_world = world_positions(frame, ex.initial);
  write_shape<D>(final_world, snake.connectivity(), (staging / "final.vtk").string(),
                 final_arrays(ex, snake, rec.correspondence));
  write_shape<D>(final_world, snake.connectivity(), (staging / ("final" + mesh_ext)).string());
  write_shape<D>(initial_world, ex.tmpl.connectivity, (staging / "initial.vtk").string());
  write_shape<D>(initial_world, ex.tmpl.connectivity, (staging / ("initial" + mesh_ext)).string());
  write_file_atomically((staging / "correspondence.csv").string(), correspondence_csv(ex, snake, rec.correspondence));
  write_file_atomically((staging / "energy_trace.csv").string(), trace_csv<D>(rec.recorder.trace, names));
  if (rec.finite && ex.output.result_mask) write_result_mask(ex, snake, staging);
  if (writes_image(ex)) write_from_image<D>(ex, ex.image, (staging / "image.nii.gz").string(), ImageWriteOptions{.compress = true});
  if (ex.output.figures && rec.finite) write_figures(ex, snake, staging);
}

nlohmann::ordered_json metrics_json(const Metrics& m, bool finite) {
  return {{"mean_surface_distance", optional_number(m.mean_surface_distance)},
          {"hausdorff95", optional_number(m.hausdorff95)},
          {"hausdorff", optional_number(m.hausdorff)},
          {"dice", optional_number(m.dice)},
          {"correspondence_error_mean", optional_number(m.correspondence_error_mean)},
          {"correspondence_error_max", optional_number(m.correspondence_error_max)},
          {"self_intersections", finite ? nlohmann::ordered_json(m.self_intersections) : nlohmann::ordered_json(nullptr)}};
}

// The watchdog's report of a diverged phase: the reason, the iteration within the phase, the
// vertex, the energy term ("energies[i]" and its type, or "remesh", "collapse", "global") and the
// move (mm; null when not finite); a collapse adds the enclosed area's or volume's share of the
// start's at the iteration that failed ("size_share").
nlohmann::ordered_json divergence_json(const Divergence& d) {
  nlohmann::ordered_json j = {{"reason", d.reason}, {"phase_iteration", d.phase_iteration}};
  j["vertex"] = d.vertex >= 0 ? nlohmann::ordered_json(d.vertex) : nlohmann::ordered_json(nullptr);
  j["term"] = d.term_index >= 0 ? "energies[" + std::to_string(d.term_index) + "] (" + d.term + ")" : d.term;
  j["move"] = std::isfinite(d.move) ? nlohmann::ordered_json(d.move) : nlohmann::ordered_json(nullptr);
  if (d.size_share) j["size_share"] = optional_number(*d.size_share);
  return j;
}

// result.json's "phases": per phase its name, iterations, status, remeshing and mesh quality.
template <int D>
nlohmann::ordered_json phases_json(const Experiment<D>& ex, const RunRecord<D>& rec) {
  nlohmann::ordered_json phases = nlohmann::ordered_json::array();
  const EvolveSummary& summary = rec.registration.summary;
  for (size_t p = 0; p < summary.phases.size(); ++p) {
    const auto& ps = summary.phases[p];
    nlohmann::ordered_json j = {{"name", ex.phase_names[p]}, {"iterations", ps.iterations},
                                {"status", to_string(ps.status)}, {"last_displacement", ps.last_displacement}};
    if (!ps.converged_on.empty()) j["converged_on"] = ps.converged_on;
    if (rec.phases[p].windowed) j["centroid_rate"] = ps.centroid_rate;
    for (const auto& r : ps.remesh_reports)
      j["remesh"].push_back({{"stage", r.stage}, {"vertices_before", r.vertices_before},
                             {"vertices_after", r.vertices_after}, {"rejected_edits", r.rejected_edits}});
    const auto quality = rec.recorder.mesh_quality.find(int(p));
    if (quality != rec.recorder.mesh_quality.end()) j["mesh_quality"] = quality->second;
    if (rec.registration.guarded) j["collision_guard"] = guard_json(ps.move_guard);
    if (ps.divergence) j["divergence"] = divergence_json(*ps.divergence);
    const auto measured = rec.phase_metrics.find(int(p));
    if (measured != rec.phase_metrics.end()) j["metrics"] = metrics_json(measured->second, true);
    phases.push_back(j);
  }
  return phases;
}

// result.json's "external_force": how strong the field is at the template (docs/experiment-file.md):
// |F| in the field's units (1/mm for the edge-map fields), and relative to the field's largest.
nlohmann::ordered_json external_force_json(const ForceMagnitudes& force) {
  auto relative = [&](double m) { return optional_number(force.max > 0 && std::isfinite(m) ? std::optional<double>(m / force.max) : std::nullopt); };
  auto finite = [](double m) { return optional_number(std::isfinite(m) ? std::optional<double>(m) : std::nullopt); };
  return {{"max", force.max},
          {"median_start", finite(force.median_start)},
          {"median_end", finite(force.median_end)},
          {"median_start_relative", relative(force.median_start)},
          {"median_end_relative", relative(force.median_end)}};
}

// result.json's "field_region": the voxels the field was computed on (fields/region.h), as the
// first voxel's index, the voxels per axis and their share of the image.
template <int D>
nlohmann::ordered_json field_region_json(const Experiment<D>& ex, const VoxelBox<D>& b) {
  return {{"extent", enum_name(ex.field_region.extent)},
          {"first_voxel", std::vector<int>(b.lo.data(), b.lo.data() + D)},
          {"size", std::vector<int>(b.size.data(), b.size.data() + D)},
          {"share_of_image", double(b.num_voxels()) / double(std::max<int64_t>(1, ex.image.num_voxels()))}};
}

// The one-line reason a run did not succeed: the divergence (phase, iteration, reason), the
// thresholds not met with their values, and how each phase ended (converged on what, or at its
// iteration budget), e.g. "dice 0.812 < 0.9; phase fit: iteration_budget after 300 iterations".
template <int D>
std::string failure_summary(const Experiment<D>& ex, const EvolveSummary& summary,
                            const std::vector<SuccessCriteria::Failure>& failed) {
  std::vector<std::string> parts;
  for (size_t p = 0; p < summary.phases.size(); ++p)
    if (const auto& d = summary.phases[p].divergence)
      parts.push_back("diverged in phase " + ex.phase_names[p] + " at iteration " +
                      std::to_string(d->phase_iteration) + ": " + d->reason);
  for (const auto& f : failed) parts.push_back(f.describe());
  for (size_t p = 0; p < summary.phases.size(); ++p) {
    const auto& ps = summary.phases[p];
    if (ps.divergence) continue;
    std::string end = "phase " + ex.phase_names[p] + ": " + to_string(ps.status);
    if (!ps.converged_on.empty()) end += " on " + ps.converged_on;
    parts.push_back(end + " after " + std::to_string(ps.iterations) + " iterations");
  }
  std::string line;
  for (const auto& part : parts) line += (line.empty() ? "" : "; ") + part;
  return line;
}

template <int D>
nlohmann::ordered_json result_json(const Experiment<D>& ex, const RunRecord<D>& rec, Clock::time_point start,
                                   const RunOptions& options, std::chrono::system_clock::time_point started) {
  const RegistrationResult<D>& reg = rec.registration;
  nlohmann::ordered_json result;
  result["name"] = ex.name;
  result["metrics"] = metrics_json(rec.metrics, rec.finite);
  if (rec.start_metrics) result["start"] = {{"metrics", metrics_json(*rec.start_metrics, true)}};
  if (!rec.pose.is_null()) result["pose"] = rec.pose;
  const std::vector<SuccessCriteria::Failure> failed = ex.success.failures(rec.metrics);
  result["success"] = reg.summary.status != EvolveStatus::kDiverged && failed.empty();
  result["status"] = to_string(reg.summary.status);
  // Why success is false: each threshold not met, with the metric's value, and one line that
  // says it together with a divergence and how each phase ended.
  nlohmann::ordered_json thresholds = nlohmann::ordered_json::array();
  for (const auto& f : failed)
    thresholds.push_back({{"metric", f.metric}, {"value", optional_number(f.value)}, {"needs", f.comparison},
                          {"threshold", f.threshold}});
  result["failed_thresholds"] = thresholds;
  result["failure"] = result["success"].get<bool>() ? nlohmann::ordered_json(nullptr)
                                                    : nlohmann::ordered_json(failure_summary(ex, reg.summary, failed));
  for (size_t p = 0; p < reg.summary.phases.size(); ++p)
    if (const auto& d = reg.summary.phases[p].divergence) {
      result["divergence"] = divergence_json(*d);
      result["divergence"]["phase"] = ex.phase_names[p];
    }
  result["iterations"] = reg.summary.iterations;
  result["vertices"] = {{"initial", reg.initial_vertices}, {"final", reg.snake.num_vertices()},
                        {"deformation", reg.snake.num_deformation_vertices()}};
  result["phases"] = phases_json(ex, rec);
  if (ex.init) result["init"] = init_report_json(*ex.init);
  if (!reg.landmarks.empty()) result["landmarks"] = landmarks_json(reg.landmarks);
  if (reg.guarded) {
    MoveGuardReport total;
    for (const auto& ps : reg.summary.phases) total += ps.move_guard;
    result["collision_guard"] = guard_json(total);
  }
  const auto& recorder = rec.recorder;
  if (!recorder.mesh_quality.empty()) result["mesh_quality"] = recorder.mesh_quality.rbegin()->second;
  if (!recorder.trace.empty()) {
    result["energy"] = energy_json(reg.term_names, recorder.trace.back().energy_terms);
    result["energy"]["start"] = energy_json(reg.term_names, reg.start_energy_terms);
  }
  result["external_force"] = external_force_json(reg.force);
  result["field_region"] = field_region_json(ex, reg.field_region);
  if (ex.potential)
    result["potential"] = {{"type", enum_name(ex.potential->type)}, {"interpolation", enum_name(ex.potential->interpolation)}};
  if (ex.solver == SolverKind::kGlobal)
    result["global"] = global_json(ex, rec.phases.size(), reg.global_solves);
  result["timings"] = {{"field_s", reg.timings.field_s}, {"potential_s", reg.timings.potential_s},
                       {"evolve_s", reg.timings.evolve_s}, {"metrics_s", rec.metrics_s}, {"total_s", seconds_since(start)}};
  result["seed"] = ex.seed;
  result["config"] = ex.file.document;
  result["version"] = dsnake_version();
  ProvenanceContext provenance;
  provenance.document = &ex.file.document;
  provenance.base_dir = ex.file.base_dir;
  provenance.command_line = options.command_line;
  provenance.started = started;
  provenance.finished = std::chrono::system_clock::now();
  result["provenance"] = provenance_json(provenance);
  return result;
}

// What the caller gets back of a run: the result document and the snake, moved out of the record.
template <int D>
RunOutcome<D> outcome_of(const Experiment<D>& ex, RunRecord<D>& rec, nlohmann::ordered_json result) {
  RunOutcome<D> outcome;
  outcome.result = std::move(result);
  outcome.final_world = world_positions(ex.image.grid(), rec.registration.snake.positions());
  outcome.snake = std::move(rec.registration.snake);
  outcome.trace = std::move(rec.recorder.trace);
  outcome.term_names = std::move(rec.registration.term_names);
  outcome.correspondence = std::move(rec.correspondence);
  return outcome;
}

}  // namespace

template <int D>
RunOutcome<D> run_experiment_outcome(Experiment<D>& ex, const RunOptions& options) {
  const auto start = Clock::now();
  const auto started = std::chrono::system_clock::now();
  const fs::path out = options.out_dir.empty() ? fs::path("out") / (ex.name.empty() ? "run" : ex.name)
                                               : fs::path(options.out_dir);
  check_output_folder(out, options.force);
  const fs::path staging = make_staging_folder(out);
  try {
    RunRecord<D> rec(staging, ex.output.snapshot_every, ex.image.grid());
    evolve(ex, options, rec);
    measure(ex, rec);
    write_outputs(ex, rec, staging);
    const nlohmann::ordered_json result = result_json(ex, rec, start, options, started);
    write_file_atomically((staging / "result.json").string(), result.dump(2) + "\n");
    publish_outputs(staging, out);
    if (!options.quiet)
      std::fprintf(stderr, "dsnake: wrote %s (success: %s)\n", (out / "result.json").string().c_str(),
                   result["success"].get<bool>() ? "true" : ("false: " + result["failure"].get<std::string>()).c_str());
    return outcome_of(ex, rec, result);
  } catch (...) {
    std::error_code ec;
    fs::remove_all(staging, ec);
    throw;
  }
}

template <int D>
nlohmann::ordered_json run_experiment(Experiment<D>& ex, const RunOptions& options) {
  return run_experiment_outcome(ex, options).result;
}

template <int D>
RunOutcome<D> compute_experiment(Experiment<D>& ex, const RunOptions& options) {
  const auto start = Clock::now();
  const auto started = std::chrono::system_clock::now();
  RunRecord<D> rec(fs::path(), /*snapshot_every=*/0, ex.image.grid());
  evolve(ex, options, rec);
  measure(ex, rec);
  nlohmann::ordered_json result = result_json(ex, rec, start, options, started);
  return outcome_of(ex, rec, std::move(result));
}

template nlohmann::ordered_json run_experiment<2>(Experiment<2>&, const RunOptions&);
template RunOutcome<2> run_experiment_outcome<2>(Experiment<2>&, const RunOptions&);
template RunOutcome<3> run_experiment_outcome<3>(Experiment<3>&, const RunOptions&);
template RunOutcome<2> compute_experiment<2>(Experiment<2>&, const RunOptions&);
template RunOutcome<3> compute_experiment<3>(Experiment<3>&, const RunOptions&);
template nlohmann::ordered_json run_experiment<3>(Experiment<3>&, const RunOptions&);

}  // namespace dsnake

namespace dsnake {
namespace {

template <int D>
void write_figures(const Experiment<D>& ex, const Snake<D>& snake, const fs::path& dir) {
  std::vector<int> template_marks, result_marks;
  for (const auto& [name, id] : ex.tmpl.landmarks) {
    template_marks.push_back(id);
    if (snake.vertex_of_template_id(id) >= 0) result_marks.push_back(snake.vertex_of_template_id(id));
  }
  ShapeLayer<D> initial{ex.initial, ex.tmpl.connectivity, kTemplateYellow, template_marks, "template (initial)"};
  ShapeLayer<D> result{snake.positions(), snake.connectivity(), kResultRed, result_marks, "result"};
  // The ground truth under both, so that a leak past it shows: its surface when the file gives
  // one (the more precise), else the outline of its mask.
  std::vector<ShapeLayer<D>> layers;
  std::vector<MaskLayer<D>> masks;
  if (ex.truth.surface)
    layers.push_back({ex.truth.surface->positions, ex.truth.surface->connectivity, kTruthCyan, {}, "ground truth"});
  else if (ex.truth.mask)
    masks.push_back({*ex.truth.mask, kTruthCyan, "ground truth"});
  layers.push_back(initial);
  layers.push_back(result);
  const std::string title = ex.name;
  if constexpr (D == 2) {
    // Correspondence: each template vertex joined to where it landed, at most kMaxLinks of them
    // evenly spaced along the template so that a fine contour stays readable.
    constexpr int kMaxLinks = 64;
    const int n = static_cast<int>(ex.initial.size());
    const int stride = std::max(1, (n + kMaxLinks - 1) / kMaxLinks);
    std::vector<std::array<Point<2>, 2>> links;
    for (int id = 0; id < n; id += stride)
      if (const int v = snake.vertex_of_template_id(id); v >= 0) links.push_back({ex.initial[id], snake.positions()[v]});
    write_overlay_figure(ex.image, layers, (dir / "overlay.png").string(), title, masks, links);
  } else {
    Point<3> centre = Point<3>::Zero();
    for (const auto& p : snake.positions()) centre += p;
    centre /= std::max(1, snake.num_vertices());
    write_slice_figure(ex.image, layers, centre, (dir / "slices.png").string(), title, masks);
  }
}

}  // namespace
}  // namespace dsnake
