#include "framework/core/evolver.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

namespace dsnake {
namespace {

// Proposes a fixed target for every governed vertex.
class ConstantEnergy : public Energy<2> {
 public:
  ConstantEnergy(Point<2> target, Governs governs) : target_(target), governs_(governs) {}
  std::string type() const override { return "constant"; }
  Governs governs() const override { return governs_; }
  void bind(const EnergyContext<2>&, const Snake<2>&) override { ++binds; }
  void begin_phase(const Snake<2>& snake) override { phase_starts.push_back(snake.positions()[0]); }
  void propose(const Snake<2>& snake, PointList<2>& out) override {
    for (int v = 0; v < snake.num_vertices(); ++v)
      if (governs_ == Governs::kAllVertices || snake.is_deformation_vertex(v)) out[v] = target_;
  }
  double value(const Snake<2>& snake) const override {
    double e = 0;
    for (const auto& q : snake.positions()) e += (q - target_).squaredNorm();
    return e;
  }
  int binds = 0;
  PointList<2> phase_starts;  // vertex 0 at each begin_phase()

 private:
  Point<2> target_;
  Governs governs_;
};

// Moves every vertex halfway towards the origin.
class HalfwayEnergy : public Energy<2> {
 public:
  std::string type() const override { return "halfway"; }
  void bind(const EnergyContext<2>&, const Snake<2>&) override {}
  void propose(const Snake<2>& snake, PointList<2>& out) override {
    for (int v = 0; v < snake.num_vertices(); ++v) out[v] = 0.5 * snake.positions()[v];
  }
  double value(const Snake<2>& snake) const override {
    double e = 0;
    for (const auto& q : snake.positions()) e += q.squaredNorm();
    return e;
  }
};

// Inserts a free vertex in the middle of edge (0, 1) once.
class InsertOnce : public Remesher<2> {
 public:
  std::string type() const override { return "insert_once"; }
  RemeshReport apply(Snake<2>& s, const RemeshContext<2>& ctx) override {
    ++calls;
    iterations_seen.push_back(ctx.phase_iteration);
    if (calls > 1) return {"insert_once", s.num_vertices(), s.num_vertices(), 0};
    PointList<2> q = s.positions();
    std::vector<int> ids = s.template_ids();
    q.insert(q.begin() + 1, 0.5 * (q[0] + q[1]));
    ids.insert(ids.begin() + 1, -1);
    const int n = static_cast<int>(q.size());
    s.set_topology(std::move(q), Connectivity::polygon(n), std::move(ids));
    return {"insert_once", n - 1, n, 0};
  }
  int calls = 0;
  std::vector<int> iterations_seen;
};

// The divergence of a run that stopped in its first phase (checks the status and the phase count;
// throws, failing the test, when there is none).
const Divergence& first_phase_divergence(const EvolveSummary& summary) {
  EXPECT_EQ(summary.status, EvolveStatus::kDiverged);
  EXPECT_EQ(summary.phases.size(), 1u);
  if (summary.phases.empty() || !summary.phases[0].divergence) throw std::runtime_error("the run did not diverge");
  return *summary.phases[0].divergence;
}

Snake<2> square_snake() {
  Template<2> t{{{1, 1}, {-1, 1}, {-1, -1}, {1, -1}}, Connectivity::polygon(4), {}};
  return Snake<2>::from_template(t, t.positions);
}

TEST(Evolver, StepIsTheWeightedAverageOfTheProposals) {
  // Section 3.1: q = (q_int + kappa q_ext + eta q_def) / (1 + kappa + eta), here with
  // constant proposals a, b, c and weights 1, 0.4, 0.5.
  std::vector<WeightedEnergy<2>> e;
  e.push_back({1.0, std::make_unique<ConstantEnergy>(Point<2>(1, 0), Governs::kAllVertices)});
  e.push_back({0.4, std::make_unique<ConstantEnergy>(Point<2>(0, 5), Governs::kAllVertices)});
  e.push_back({0.5, std::make_unique<ConstantEnergy>(Point<2>(-2, 2), Governs::kDeformationVertices)});
  Evolver<2> evolver({}, std::move(e));
  Snake<2> s = square_snake();
  s.set_topology(s.positions(), Connectivity::polygon(4), {0, 1, -1, 3});  // vertex 2 is free
  evolver.step(s);
  const Point<2> deformation = (Point<2>(1, 0) + 0.4 * Point<2>(0, 5) + 0.5 * Point<2>(-2, 2)) / 1.9;
  const Point<2> free = (Point<2>(1, 0) + 0.4 * Point<2>(0, 5)) / 1.4;  // no ASAP proposal (§6)
  EXPECT_NEAR((s.positions()[0] - deformation).norm(), 0, 1e-15);
  EXPECT_NEAR((s.positions()[2] - free).norm(), 0, 1e-15);
}

// A phase's weights switch terms off and on (§3: a first phase with some forces only); the
// energy trace reports 0 for a term that is off.
TEST(Evolver, PhaseWeightsSwitchTermsOffAndOn) {
  std::vector<WeightedEnergy<2>> e;
  e.push_back({1.0, std::make_unique<ConstantEnergy>(Point<2>(1, 0), Governs::kAllVertices)});
  e.push_back({3.0, std::make_unique<HalfwayEnergy>()});
  Evolver<2> evolver({}, std::move(e));
  std::vector<double> constant_terms;
  struct Trace : EvolverObserver<2> {
    std::vector<double>* terms;
    void on_iteration(const IterationInfo& info, const Snake<2>&) override { terms->push_back(info.energy_terms[0]); }
  } trace;
  trace.terms = &constant_terms;
  evolver.add_observer(&trace);
  Snake<2> s = square_snake();
  std::vector<Phase<2>> phases(3);
  phases[0].iterations = 1;
  phases[0].weights = {0.0, 1.0};  // halfway only: q -> q / 2
  phases[1].iterations = 1;        // the energies' own weights: (1 * (1, 0) + 3 * q / 2) / 4
  phases[2].iterations = 1;
  phases[2].weights = {2.0, 0.0};  // constant only: q -> (1, 0)
  evolver.run(s, phases);
  ASSERT_EQ(constant_terms.size(), 3u);
  EXPECT_EQ(constant_terms[0], 0.0);
  EXPECT_GT(constant_terms[1], 0.0);
  EXPECT_NEAR((s.positions()[1] - Point<2>(1, 0)).norm(), 0, 1e-15);
  Snake<2> check = square_snake();
  const Point<2> after_phase2 = (Point<2>(1, 0) + 3.0 * 0.25 * check.positions()[1]) / 4.0;
  // replay the first two phases to check the weighted average of phase 2
  std::vector<Phase<2>> two(2);
  two[0].iterations = 1;
  two[0].weights = {0.0, 1.0};
  two[1].iterations = 1;
  evolver.run(check, two);
  EXPECT_NEAR((check.positions()[1] - after_phase2).norm(), 0, 1e-15);
}

// Every energy hears begin_phase() once at the start of each phase, after bind(), with the snake
// as the previous phase left it (an energy whose rest shape is the phase's start takes it there).
TEST(Evolver, EveryPhaseBeginsWithBeginPhaseOnTheSnakeAsLeft) {
  std::vector<WeightedEnergy<2>> e;
  e.push_back({1.0, std::make_unique<ConstantEnergy>(Point<2>(3, 4), Governs::kAllVertices)});
  auto* constant = static_cast<ConstantEnergy*>(e[0].energy.get());
  Evolver<2> evolver({}, std::move(e));
  Snake<2> s = square_snake();
  std::vector<Phase<2>> phases(3);
  for (auto& p : phases) p.iterations = 1;
  evolver.run(s, phases);
  ASSERT_EQ(constant->phase_starts.size(), 3u);
  EXPECT_EQ(constant->phase_starts[0], Point<2>(1, 1));
  EXPECT_EQ(constant->phase_starts[1], Point<2>(3, 4));
  EXPECT_EQ(constant->phase_starts[2], Point<2>(3, 4));
}

TEST(Evolver, PhasesStopAtTheToleranceOrTheBudget) {
  std::vector<WeightedEnergy<2>> e;
  e.push_back({1.0, std::make_unique<HalfwayEnergy>()});
  Evolver<2> evolver({}, std::move(e));
  Snake<2> s = square_snake();
  std::vector<Phase<2>> phases(2);
  phases[0].iterations = 100;
  phases[0].tolerance = 1e-3;  // moves are sqrt(2) / 2^k: below 1e-3 at k = 11
  phases[1].iterations = 3;
  const EvolveSummary summary = evolver.run(s, phases);
  ASSERT_EQ(summary.phases.size(), 2u);
  EXPECT_EQ(summary.phases[0].status, EvolveStatus::kConverged);
  EXPECT_EQ(summary.phases[0].iterations, 11);
  EXPECT_EQ(summary.phases[1].status, EvolveStatus::kIterationBudget);
  EXPECT_EQ(summary.iterations, 14);
  EXPECT_NEAR(s.positions()[0].x(), std::pow(0.5, 14), 1e-18);
}

// Moves every vertex by a fixed step (a snake sliding at a steady rate), or, with `alternate`,
// by +step and -step in turn (a snake oscillating about an edge), or shrinks it by `shrink` per
// iteration towards the origin (a snake still changing shape). Energy: the sum of |q|^2 of the
// shape about its centroid, flat under sliding and oscillation.
class DriftEnergy : public Energy<2> {
 public:
  DriftEnergy(Point<2> step, bool alternate, double shrink) : step_(step), alternate_(alternate), shrink_(shrink) {}
  std::string type() const override { return "drift"; }
  void bind(const EnergyContext<2>&, const Snake<2>&) override {}
  void propose(const Snake<2>& snake, PointList<2>& out) override {
    const Point<2> d = alternate_ && (calls_++ % 2) ? Point<2>(-step_) : step_;
    for (int v = 0; v < snake.num_vertices(); ++v) out[v] = (1 - shrink_) * snake.positions()[v] + d;
  }
  double value(const Snake<2>& snake) const override {
    Point<2> c = Point<2>::Zero();
    for (const auto& q : snake.positions()) c += q;
    c /= snake.num_vertices();
    double e = 0;
    for (const auto& q : snake.positions()) e += (q - c).squaredNorm();
    return e;
  }

 private:
  Point<2> step_;
  bool alternate_;
  double shrink_;
  int calls_ = 0;
};

// The windowed stop (framework/core/stall.h): a snake that slides at 0.05 mm per iteration
// (above the tolerance 0.01, so the displacement stop never fires) or oscillates by 0.05 mm
// converges at the first window's end; a shrinking one (shape changing by more than the
// tolerance per iteration) runs its budget; without a window, sliding runs its budget too.
TEST(Evolver, TheWindowedStopEndsSlidingAndOscillationButNotShapeChange) {
  const auto run = [](Point<2> step, bool alternate, double shrink, int window) {
    std::vector<WeightedEnergy<2>> e;
    e.push_back({1.0, std::make_unique<DriftEnergy>(step, alternate, shrink)});
    Evolver<2> evolver({}, std::move(e));
    Snake<2> s = square_snake();
    std::vector<Phase<2>> phases(1);
    phases[0].iterations = 200;
    phases[0].tolerance = 0.01;
    phases[0].window = window;
    return evolver.run(s, phases).phases[0];
  };
  const PhaseSummary sliding = run(Point<2>(0.03, 0.04), false, 0, 20);
  EXPECT_EQ(sliding.status, EvolveStatus::kConverged);
  EXPECT_EQ(sliding.converged_on, "window");
  EXPECT_EQ(sliding.iterations, 20);
  EXPECT_NEAR(sliding.centroid_rate, 0.05, 1e-12);
  const PhaseSummary oscillating = run(Point<2>(0.03, 0.04), true, 0, 20);
  EXPECT_EQ(oscillating.converged_on, "window");
  EXPECT_EQ(oscillating.iterations, 20);
  EXPECT_NEAR(oscillating.centroid_rate, 0.0, 1e-12);
  // shrinking by 1% per iteration about (3, 4) while drifting: the corners move 0.014 mm per
  // iteration about the centroid at first and less than the tolerance after about 35 iterations,
  // but the energy falls by a third per window, so no window stops it; the displacement stop
  // does, once the shape has nearly vanished
  const PhaseSummary shrinking = run(Point<2>(0.03, 0.04), false, 0.01, 20);
  EXPECT_EQ(shrinking.converged_on, "displacement");
  EXPECT_GT(shrinking.iterations, 150);
  const PhaseSummary off = run(Point<2>(0.03, 0.04), false, 0, 0);
  EXPECT_EQ(off.status, EvolveStatus::kIterationBudget);
  EXPECT_EQ(off.iterations, 200);
}

// Halves every vertex towards the origin for its first `turn` proposals, then scales it by 1.2
// (a snake that fits, then drifts). Energy: scale * sum |q|^2.
class TurnAroundEnergy : public Energy<2> {
 public:
  TurnAroundEnergy(int turn, double scale) : turn_(turn), scale_(scale) {}
  std::string type() const override { return "turn_around"; }
  void bind(const EnergyContext<2>&, const Snake<2>&) override {}
  void propose(const Snake<2>& snake, PointList<2>& out) override {
    const double f = calls_++ < turn_ ? 0.5 : 1.2;
    for (int v = 0; v < snake.num_vertices(); ++v) out[v] = f * snake.positions()[v];
  }
  double value(const Snake<2>& snake) const override {
    double e = 0;
    for (const auto& q : snake.positions()) e += q.squaredNorm();
    return scale_ * e;
  }

 private:
  int turn_;
  double scale_;
  int calls_ = 0;
};

// stop_when_worse: two terms that both fall for 10 iterations and then both rise; with a window
// of 5 the windows ending at 5 and 10 are better than their starts, the one ending at 15 worse
// in both terms: the phase goes back to iteration 10's positions (exactly 0.5^10 of the start)
// and stops there, its last traced energy and its last move those of iteration 10. Without the
// key the snake drifts to its budget; a trade-off (one term falls while the other rises: a
// balance of forces) never stops it.
TEST(Evolver, StopWhenWorseGoesBackToTheWindowsStartWhenEveryTermRose) {
  struct Recorder : EvolverObserver<2> {
    void on_iteration(const IterationInfo& info, const Snake<2>&) override { infos.push_back(info); }
    std::vector<IterationInfo> infos;
  };
  const auto run = [](bool stop, Snake<2>& s, Recorder& recorder) {
    std::vector<WeightedEnergy<2>> e;
    e.push_back({1.0, std::make_unique<TurnAroundEnergy>(10, 1.0)});
    e.push_back({3.0, std::make_unique<TurnAroundEnergy>(10, 2.0)});
    Evolver<2> evolver({}, std::move(e));
    evolver.add_observer(&recorder);
    std::vector<Phase<2>> phases(1);
    phases[0].iterations = 40;
    phases[0].tolerance = 1e-9;
    phases[0].window = 5;
    phases[0].stop_when_worse = stop;
    return evolver.run(s, phases).phases[0];
  };
  Snake<2> s = square_snake();
  Recorder recorder;
  const PhaseSummary stopped = run(true, s, recorder);
  EXPECT_EQ(stopped.status, EvolveStatus::kConverged);
  EXPECT_EQ(stopped.converged_on, "worse");
  EXPECT_EQ(stopped.iterations, 15);
  EXPECT_EQ(s.positions()[0], Point<2>(std::pow(0.5, 10), std::pow(0.5, 10)));
  EXPECT_EQ(s.positions()[2], Point<2>(-std::pow(0.5, 10), -std::pow(0.5, 10)));
  ASSERT_EQ(recorder.infos.size(), 15u);
  EXPECT_EQ(recorder.infos[14].energy_terms, recorder.infos[9].energy_terms);
  EXPECT_EQ(recorder.infos[14].total_energy, recorder.infos[9].total_energy);
  // weights 1 and 3 on sum |q|^2 = 4 * 2 * 0.25^10 and twice that
  EXPECT_NEAR(recorder.infos[14].total_energy, (1.0 + 6.0) * 8.0 * std::pow(0.25, 10), 1e-20);
  // the reported last move is iteration 10's (the corner (1, 1) halved from 0.5^9 to 0.5^10),
  // not that of the undone iteration 15
  EXPECT_EQ(stopped.last_displacement, recorder.infos[9].max_displacement);
  EXPECT_NEAR(stopped.last_displacement, std::sqrt(2.0) * std::pow(0.5, 10), 1e-15);

  Snake<2> drifting = square_snake();
  Recorder unused;
  const PhaseSummary off = run(false, drifting, unused);
  EXPECT_EQ(off.status, EvolveStatus::kIterationBudget);
  // halved 10 times, then grown by 1.2 for 30 iterations
  EXPECT_NEAR(drifting.positions()[0].x() / (std::pow(0.5, 10) * std::pow(1.2, 30)), 1.0, 1e-12);

  // A balance: a constant target (4, 0) and the pull towards the origin meet at (4, 0) / 1.5;
  // the first term falls as the second rises, and the displacement stop ends the phase there.
  std::vector<WeightedEnergy<2>> e;
  e.push_back({1.0, std::make_unique<ConstantEnergy>(Point<2>(4, 0), Governs::kAllVertices)});
  e.push_back({1.0, std::make_unique<HalfwayEnergy>()});
  Evolver<2> evolver({}, std::move(e));
  Snake<2> balanced = square_snake();
  std::vector<Phase<2>> phases(1);
  phases[0].iterations = 200;
  phases[0].tolerance = 1e-9;
  phases[0].window = 5;
  phases[0].stop_when_worse = true;
  const PhaseSummary trade = evolver.run(balanced, phases).phases[0];
  EXPECT_EQ(trade.converged_on, "displacement");
  EXPECT_NEAR(balanced.positions()[0].x(), 4.0 / 1.5, 1e-8);
}

TEST(Evolver, RemeshersRunEveryKIterationsAndEnergiesRebind) {
  std::vector<WeightedEnergy<2>> e;
  auto constant = std::make_unique<ConstantEnergy>(Point<2>(0, 0), Governs::kAllVertices);
  ConstantEnergy* raw = constant.get();
  e.push_back({1.0, std::move(constant)});
  Evolver<2> evolver({}, std::move(e));
  evolver.set_trace_energy(false);
  Snake<2> s = square_snake();
  std::vector<Phase<2>> phases(1);
  phases[0].iterations = 10;
  phases[0].every = 4;
  auto remesher = std::make_unique<InsertOnce>();
  InsertOnce* r = remesher.get();
  phases[0].remesher = std::move(remesher);
  evolver.run(s, phases);
  EXPECT_EQ(r->iterations_seen, (std::vector<int>{4, 8}));
  EXPECT_EQ(s.num_vertices(), 5);
  EXPECT_EQ(raw->binds, 2);  // once at the start, once after the topology changed
}

TEST(Evolver, ObserversSeeEveryIterationWithTheEnergyTrace) {
  struct Recorder : EvolverObserver<2> {
    void on_iteration(const IterationInfo& info, const Snake<2>&) override { infos.push_back(info); }
    std::vector<IterationInfo> infos;
  } recorder;
  std::vector<WeightedEnergy<2>> e;
  e.push_back({2.0, std::make_unique<HalfwayEnergy>()});
  Evolver<2> evolver({}, std::move(e));
  evolver.add_observer(&recorder);
  Snake<2> s = square_snake();
  std::vector<Phase<2>> phases(1);
  phases[0].iterations = 3;
  evolver.run(s, phases);
  ASSERT_EQ(recorder.infos.size(), 3u);
  // After k halvings, each of the 4 vertices has |q|^2 = 2 / 4^k; weighted by 2.
  EXPECT_NEAR(recorder.infos[2].total_energy, 2.0 * 4 * 2.0 / 64.0, 1e-15);
  EXPECT_NEAR(recorder.infos[0].max_displacement, std::sqrt(2.0) / 2, 1e-15);
  EXPECT_EQ(recorder.infos[2].iteration, 3);
}

// Keeps vertex 0 where it is and halves vertex 1's move; counts its calls.
class PinFirstGuard : public MoveGuard<2> {
 public:
  std::string type() const override { return "pin_first"; }
  MoveGuardReport guard(const Snake<2>& snake, PointList<2>& proposed) override {
    ++calls;
    EXPECT_NE(proposed[0], snake.positions()[0]);  // called before the positions change
    proposed[0] = snake.positions()[0];
    proposed[1] = 0.5 * (snake.positions()[1] + proposed[1]);
    return {1, 1, 10};
  }
  int calls = 0;
};

TEST(Evolver, TheMoveGuardAdjustsMovesBeforeTheyAreMadeAndIsCounted) {
  std::vector<WeightedEnergy<2>> e;
  e.push_back({1.0, std::make_unique<HalfwayEnergy>()});
  Evolver<2> evolver({}, std::move(e));
  auto guard = std::make_unique<PinFirstGuard>();
  PinFirstGuard* g = guard.get();
  evolver.set_move_guard(std::move(guard));
  Snake<2> s = square_snake();
  std::vector<Phase<2>> phases(2);
  phases[0].iterations = 2;
  phases[1].iterations = 3;
  const EvolveSummary summary = evolver.run(s, phases);
  EXPECT_EQ(g->calls, 5);
  EXPECT_EQ(s.positions()[0], Point<2>(1, 1));                 // pinned
  EXPECT_NEAR(s.positions()[1].x(), -std::pow(0.75, 5), 1e-15);  // moved by a quarter each time
  EXPECT_NEAR(s.positions()[2].x(), -std::pow(0.5, 5), 1e-15);   // unguarded
  ASSERT_EQ(summary.phases.size(), 2u);
  EXPECT_EQ(summary.phases[0].move_guard.refused, 2);
  EXPECT_EQ(summary.phases[1].move_guard.shortened, 3);
  EXPECT_EQ(summary.phases[1].move_guard.checks, 30);
  // The largest move is measured on the guarded positions: vertex 1's quarter of sqrt(2) 0.75^4
  // (unguarded, the halfway moves of vertices 0 and 1 would be larger).
  EXPECT_NEAR(summary.phases[1].last_displacement, 0.25 * std::sqrt(2.0) * std::pow(0.75, 4), 1e-15);
}

TEST(Evolver, NonFiniteProposalsStopWithDivergedStatus) {
  std::vector<WeightedEnergy<2>> e;
  e.push_back({1.0, std::make_unique<ConstantEnergy>(Point<2>(0, 0), Governs::kAllVertices)});
  e.push_back({1.0, std::make_unique<ConstantEnergy>(Point<2>(NAN, 0), Governs::kAllVertices)});
  Evolver<2> evolver({}, std::move(e));
  Snake<2> s = square_snake();
  const PointList<2> start = s.positions();
  std::vector<Phase<2>> phases(2);
  const EvolveSummary summary = evolver.run(s, phases);
  EXPECT_EQ(summary.iterations, 1);
  // The watchdog's report names the first vertex, the NaN term, and the positions are the start's.
  const Divergence& d = first_phase_divergence(summary);
  EXPECT_EQ(d.phase_iteration, 1);
  EXPECT_EQ(d.vertex, 0);
  EXPECT_EQ(d.term_index, 1);
  EXPECT_EQ(d.term, "constant");
  EXPECT_EQ(s.positions(), start);
}

// The watchdog: a move larger than max_move stops the phase as diverged at the
// last positions that passed; the vertex with the largest move and the term that moves it
// farthest are named.
TEST(Evolver, AMoveLargerThanTheWatchdogsBoundStopsTheRun) {
  std::vector<WeightedEnergy<2>> e;
  e.push_back({1.0, std::make_unique<HalfwayEnergy>()});
  e.push_back({1.0, std::make_unique<ConstantEnergy>(Point<2>(40, 0), Governs::kAllVertices)});
  Evolver<2> evolver({}, std::move(e));
  Watchdog w;
  w.max_move = 5.0;
  evolver.set_watchdog(w);
  Snake<2> s = square_snake();
  std::vector<Phase<2>> phases(1);
  phases[0].iterations = 50;
  // Each step moves every vertex to the average of (q / 2) and (40, 0): the first steps move
  // about 20 mm, more than the bound.
  const EvolveSummary summary = evolver.run(s, phases);
  EXPECT_EQ(summary.status, EvolveStatus::kDiverged);
  ASSERT_TRUE(summary.phases[0].divergence.has_value());
  const Divergence& d = *summary.phases[0].divergence;
  EXPECT_EQ(d.phase_iteration, 1);
  EXPECT_GT(d.move, 5.0);
  EXPECT_EQ(d.vertex, 1);  // (-1, 1) and (-1, -1) move farthest; the first of them
  EXPECT_EQ(d.term_index, 1);
  EXPECT_EQ(s.positions(), square_snake().positions());
  // The same run with the default watchdog (non-finite moves only) goes on to its budget.
  std::vector<WeightedEnergy<2>> e2;
  e2.push_back({1.0, std::make_unique<HalfwayEnergy>()});
  e2.push_back({1.0, std::make_unique<ConstantEnergy>(Point<2>(40, 0), Governs::kAllVertices)});
  Evolver<2> free_run({}, std::move(e2));
  Snake<2> s2 = square_snake();
  EXPECT_NE(free_run.run(s2, phases).status, EvolveStatus::kDiverged);
}

// Proposes every vertex where it is (a term that holds the shape).
class StayEnergy : public Energy<2> {
 public:
  std::string type() const override { return "stay"; }
  void bind(const EnergyContext<2>&, const Snake<2>&) override {}
  void propose(const Snake<2>& snake, PointList<2>& out) override { out = snake.positions(); }
  double value(const Snake<2>&) const override { return 0; }
};

// Mirrors every vertex in the y axis: the polygon turns inside out at once.
class MirrorEnergy : public Energy<2> {
 public:
  std::string type() const override { return "mirror"; }
  void bind(const EnergyContext<2>&, const Snake<2>&) override {}
  void propose(const Snake<2>& snake, PointList<2>& out) override {
    for (int v = 0; v < snake.num_vertices(); ++v) out[v] = Point<2>(-snake.positions()[v].x(), snake.positions()[v].y());
  }
  double value(const Snake<2>&) const override { return 0; }
};

// The watchdog's collapse check: with the halfway and the stay terms each step scales the square
// by 3/4 about its centre, so its area by 9/16 per iteration. 0.5625^12 = 1.0023e-3 and
// 0.5625^13 = 5.64e-4: with min_size 1e-3 the run stops at iteration 13, the positions those of
// iteration 12, and the halfway term is named (its proposals alone shrink the area most).
TEST(Evolver, ACollapseBelowMinSizeStopsTheRunAtThatIteration) {
  auto energies = [] {
    std::vector<WeightedEnergy<2>> e;
    e.push_back({1.0, std::make_unique<StayEnergy>()});
    e.push_back({1.0, std::make_unique<HalfwayEnergy>()});
    return e;
  };
  Evolver<2> evolver({}, energies());
  evolver.set_watchdog(Watchdog{.min_size = 1e-3});
  Snake<2> s = square_snake();
  std::vector<Phase<2>> phases(2);
  phases[0].iterations = 50;
  const EvolveSummary summary = evolver.run(s, phases);
  EXPECT_EQ(summary.iterations, 13);
  const Divergence& d = first_phase_divergence(summary);
  EXPECT_EQ(d.phase_iteration, 13);
  ASSERT_TRUE(d.size_share.has_value());
  EXPECT_NEAR(*d.size_share, std::pow(0.5625, 13), 1e-15);
  EXPECT_EQ(d.term_index, 1);
  EXPECT_EQ(d.term, "halfway");
  EXPECT_NE(d.reason.find("collapsed"), std::string::npos) << d.reason;
  EXPECT_NE(d.reason.find("watchdog.min_size"), std::string::npos) << d.reason;
  for (int v = 0; v < 4; ++v)
    EXPECT_NEAR((s.positions()[v] - std::pow(0.75, 12) * square_snake().positions()[v]).norm(), 0, 1e-15);
  EXPECT_NEAR(evolver.size_share(s), std::pow(0.5625, 12), 1e-15);
  // Off (min_size 0, the library's default): the same run goes on to its budget.
  Evolver<2> free_run({}, energies());
  Snake<2> s2 = square_snake();
  const EvolveSummary free_summary = free_run.run(s2, phases);
  EXPECT_NE(free_summary.status, EvolveStatus::kDiverged);
  EXPECT_EQ(free_summary.iterations, 150);  // 50, then the second phase's default 100
}

// The share is signed: a snake turned inside out (its area's sign reversed) has collapsed through
// zero, at its first iteration here; the positions are the start's.
TEST(Evolver, ASnakeTurnedInsideOutIsACollapse) {
  std::vector<WeightedEnergy<2>> e;
  e.push_back({1.0, std::make_unique<MirrorEnergy>()});
  Evolver<2> evolver({}, std::move(e));
  evolver.set_watchdog(Watchdog{.min_size = 1e-3});
  Snake<2> s = square_snake();
  std::vector<Phase<2>> phases(1);
  const EvolveSummary summary = evolver.run(s, phases);
  const Divergence& d = first_phase_divergence(summary);
  EXPECT_EQ(d.phase_iteration, 1);
  EXPECT_NEAR(*d.size_share, -1.0, 1e-15);
  EXPECT_EQ(s.positions(), square_snake().positions());
}

// Adds n free vertices on edge (0, 1) unless that would exceed the context's vertex budget, as
// the remeshers do.
class InsertWithinBudget : public Remesher<2> {
 public:
  std::string type() const override { return "insert_within_budget"; }
  RemeshReport apply(Snake<2>& s, const RemeshContext<2>& ctx) override {
    RemeshReport report{"insert_within_budget", s.num_vertices(), s.num_vertices(), 0};
    if (s.num_vertices() + 2 > ctx.max_vertices) {
      report.over_budget = true;
      return report;
    }
    PointList<2> q = s.positions();
    std::vector<int> ids = s.template_ids();
    for (int k = 0; k < 2; ++k) {
      q.insert(q.begin() + 1, 0.5 * (q[0] + q[1]));
      ids.insert(ids.begin() + 1, -1);
    }
    const int n = static_cast<int>(q.size());
    s.set_topology(std::move(q), Connectivity::polygon(n), std::move(ids));
    report.vertices_after = n;
    return report;
  }
};

// The watchdog's max_vertices reaches the remeshers as their budget; a stage that stops at it
// stops the run as diverged, naming the stage, at that iteration.
TEST(Evolver, ARemeshingPastTheVertexBudgetStopsTheRun) {
  std::vector<WeightedEnergy<2>> e;
  e.push_back({1.0, std::make_unique<StayEnergy>()});
  Evolver<2> evolver({}, std::move(e));
  evolver.set_watchdog(Watchdog{.max_vertices = 9});
  Snake<2> s = square_snake();
  std::vector<Phase<2>> phases(1);
  phases[0].iterations = 10;
  phases[0].remesher = std::make_unique<InsertWithinBudget>();
  const EvolveSummary summary = evolver.run(s, phases);
  const Divergence& d = first_phase_divergence(summary);
  EXPECT_EQ(d.phase_iteration, 3);  // 4 -> 6 -> 8 vertices, then 10 would exceed 9
  EXPECT_EQ(d.term, "remesh");
  EXPECT_NE(d.reason.find("insert_within_budget"), std::string::npos) << d.reason;
  EXPECT_EQ(s.num_vertices(), 8);
}

}  // namespace
}  // namespace dsnake
