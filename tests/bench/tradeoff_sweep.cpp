// Speed/accuracy trade of the implicit step (issue 4): how far a run at a real-time dt,
// or with a loose conjugate-gradient tolerance, drifts from a small-dt reference
// trajectory, and what each setting costs per simulated second; and where the exact and
// warped stiffness models part on a fast-spinning beam. Prints Markdown tables for
// BENCHMARKS.md, and with --csv DIR also DIR/dt.csv, tolerance.csv and spin.csv, which
// pipelines/tradeoffs plots.
//
//   fissure_tradeoff_sweep [--threads N] [--cases beam,bunny,spin] [--csv DIR] [--quick]
//
// Every case is released from rest under gravity and runs for kSimulatedSeconds. The
// reference runs at 1/Plan::reference_rate s with the same stiffness model, solved to a
// relative residual of kReferenceTolerance; a coarser run is compared with it only at the
// times both have a state, so no interpolation error enters the figures.
#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "common/error.h"
#include "formats/cage_io.h"
#include "player/sim/implicit_integrator.h"
#include "tests/support/bench_args.h"
#include "tests/support/csv_table.h"
#include "tests/support/procedural.h"
#include "tests/support/spinning_beam.h"

namespace {

using namespace fissure;
using Clock = std::chrono::steady_clock;

constexpr int kSimulatedSeconds = 1;
/// The reference solves with lagged-Cholesky CG to this residual rather than with the
/// direct solver: every figure of these tables came out the same to the digits printed
/// against either, and the CG reference takes a third to a half of the time, which keeps
/// the default run under two minutes on a busy 2-core machine.
constexpr double kReferenceTolerance = 1e-12;
/// The player's default dt (docs/scene-example.toml), where the tolerances are swept.
constexpr int kToleranceRate = 240;
/// How long the spinning beam turns (5 turns at 10 rad/s would be 3 s; 0.8 turn is
/// enough for the large steps to part from the reference).
constexpr double kSpinSeconds = 0.5;

/// What is swept. Every swept rate and kToleranceRate must divide reference_sample_rate,
/// which must divide reference_rate, so every swept step has a reference state at the
/// same time (check() says so before anything runs).
struct Plan {
  /// Steps per second of the reference. 3840 = 16 × 240, so every swept rate divides it.
  int reference_rate = 3840;
  /// The reference keeps a state every 1/960 s (every 4th step): the finest swept rate,
  /// at a quarter of the memory.
  int reference_sample_rate = 960;
  std::vector<int> rates{30, 60, 120, 240, 480, 960};
  std::vector<double> tolerances{1e-2, 1e-3, 1e-4, 1e-6, 1e-8};
  double spin_reference_dt = 2.5e-4;
  std::vector<double> spin_dts{0.05, 0.02, 0.01, 0.005, 0.002};

  /// Three rates, two tolerances, two spin steps and coarser references: for CI, so the
  /// sweep cannot rot.
  static Plan quick() { return {960, 240, {30, 120, 240}, {1e-2, 1e-6}, 1e-3, {0.05, 0.01}}; }

  void check() const {
    const auto divides = [](int a, int b) { return a > 0 && b % a == 0; };
    bool ok = divides(reference_sample_rate, reference_rate) && divides(kToleranceRate, reference_sample_rate);
    for (const int rate : rates) ok = ok && divides(rate, reference_sample_rate);
    if (!ok) throw Error("the sweep's rates do not divide the reference's sample rate", "fix Plan in tradeoff_sweep.cpp");
  }
};

/// The CSV files the sweeps append to (nothing is written without --csv).
struct CsvOutput {
  testing::CsvTable dt, tolerance, spin;
  explicit CsvOutput(const std::filesystem::path& dir)
      : dt(dir, "dt", {"case", "stiffness", "dt_s", "rms_error_relative", "tip_error_m", "tip_error_relative",
                       "wall_s_per_simulated_s", "ms_per_step", "failed_steps"}),
        tolerance(dir, "tolerance", {"case", "solver", "tolerance", "cg_iterations_per_step", "steps_at_cap",
                                     "factorizations", "rms_error_relative", "error_vs_direct", "tip_error_m",
                                     "wall_s_per_simulated_s", "failed_steps"}),
        spin(dir, "spin", {"stiffness", "dt_s", "rad_per_step", "peak_energy_ratio", "final_energy_ratio",
                           "momentum_ratio", "tip_error_m", "ms_per_step", "steps"}) {}
};

const char* kUsage =
    "usage: fissure_tradeoff_sweep [--threads N] [--cases beam,bunny,spin] [--csv DIR] [--quick]\n"
    "  --threads N     worker threads (default 1, so the per-second costs compare across machines)\n"
    "  --cases LIST    comma-separated: beam (the issue's 4x1x1 m cantilever, 702 tets), bunny\n"
    "                  (bunny-5k-cage-987, lowest nodes pinned), spin (a free 2 m beam at 10 rad/s,\n"
    "                  exact against warped stiffness); default: all three\n"
    "  --csv DIR       also write the figures to DIR/dt.csv, tolerance.csv and spin.csv\n"
    "  --quick         three rates, two tolerances, two spin steps and coarser references (for CI)\n"
    "  --help          print this and exit\n";

struct Case {
  std::string key;   ///< the case's name in --cases and the CSV files
  std::string name;
  TetMesh cage;
  std::vector<NodeIndex> pinned;
  /// Nodes whose mean position is "the tip" (the free end of the beam, the bunny's ear).
  std::vector<NodeIndex> tip;
  Vec3 gravity;
  sim::Material material;
};

/// The cantilever: 4×1×1 m, 13×3×3 cubes (702 tets), x = 0 clamped, gravity −z,
/// E = 1e6 Pa, no damping (as fissure_sim_bench).
Case beam_case() {
  Case c{"beam", "beam 4×1×1 m, 13×3×3 (702 tets), x = 0 clamped, gravity −z; "
         "E = 1e6 Pa, ν = 0.3, ρ = 1000 kg/m³, no damping",
         testing::grid_cage(Vec3::Zero(), Vec3(4, 1, 1), 13, 3, 3), {}, {}, Vec3(0, 0, -9.81),
         sim::Material{.density = 1000, .youngs_modulus = 1e6, .poisson_ratio = 0.3}};
  for (Index n = 0; n < static_cast<Index>(c.cage.node_count()); ++n) {
    if (c.cage.rest_positions(0, n) <= 1e-9) c.pinned.push_back(static_cast<NodeIndex>(n));
    if (c.cage.rest_positions(0, n) >= 4.0 - 1e-9) c.tip.push_back(static_cast<NodeIndex>(n));
  }
  return c;
}

/// The sample bunny's 987-tet cage standing as in data/scenes/bunny-drop.toml (y up,
/// gravity −y, the scene's material), its lowest 5% of height pinned (16 nodes: the
/// feet), as if glued to the ground. The tip is its highest node, on an ear.
/// The scene's material and damping are kept on purpose, so the figures speak for the
/// scene users run: in a first run at E = 1e6 Pa with no damping, every dt from 1/30 to
/// 1/960 s was 14–20% off, all of it ringing of the reference that implicit Euler damps
/// out within a few steps at any real-time dt.
Case bunny_case() {
  Case c{"bunny", "bunny-5k-cage-987 (987 tets), lowest 5% of height pinned, gravity −y; bunny-drop.toml's material: "
         "E = 2e5 Pa, ν = 0.3, ρ = 1000 kg/m³, Rayleigh β = 0.002 s",
         formats::read_cage(testing::data_dir() / "cages" / "bunny-5k-cage-987.node").mesh, {}, {},
         Vec3(0, -9.81, 0),
         sim::Material{.density = 1000, .youngs_modulus = 2e5, .poisson_ratio = 0.3, .rayleigh_stiffness = 0.002}};
  const auto y = c.cage.rest_positions.row(1);
  const double y_min = y.minCoeff();
  const double height = y.maxCoeff() - y_min;
  Index top = 0;
  for (Index n = 0; n < static_cast<Index>(c.cage.node_count()); ++n) {
    if (y(n) <= y_min + 0.05 * height) c.pinned.push_back(static_cast<NodeIndex>(n));
    if (y(n) > y(top)) top = n;
  }
  c.tip.push_back(static_cast<NodeIndex>(top));
  return c;
}

struct Run {
  int rate = 0;                  ///< steps per simulated second
  int sample_every = 1;          ///< a state is kept after every this many steps
  std::vector<Matrix3Xd> states; ///< node positions after steps sample_every, 2·sample_every, …
  double wall_seconds = 0;       ///< the whole run, first step's symbolic analysis included
  double iterations = 0;         ///< mean CG iterations per step
  int capped = 0;                ///< steps that hit the CG iteration cap
  int factorizations = 0;        ///< numeric Cholesky factorizations (direct: every step)
  int failed = 0;                ///< steps that did not advance (not positive definite, non-finite)
};

/// `settings` chooses the solver, preconditioner, tolerance and stiffness model; dt and
/// gravity come from `rate` and the case.
Run simulate(const Case& c, int rate, sim::StepSettings settings, int sample_every) {
  sim::ImplicitIntegrator body(c.cage.rest_positions, c.cage.tets, c.material);
  body.pin(c.pinned);
  settings.dt = 1.0 / rate;
  settings.gravity = c.gravity;
  Run run;
  run.rate = rate;
  run.sample_every = sample_every;
  const int steps = rate * kSimulatedSeconds;
  run.states.reserve(static_cast<std::size_t>(steps / sample_every));
  long total_iterations = 0;
  // Copying the states out is inside the timed loop but costs microseconds against
  // milliseconds per step.
  const auto start = Clock::now();
  for (int step = 1; step <= steps; ++step) {
    const sim::SolveStatus status = body.step(settings);
    total_iterations += body.last_iterations();
    if (status == sim::SolveStatus::MaxIterations) ++run.capped;
    if (status == sim::SolveStatus::NotPositiveDefinite || status == sim::SolveStatus::NonFinite) ++run.failed;
    if (step % sample_every == 0) run.states.push_back(body.positions());
  }
  run.wall_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  run.iterations = static_cast<double>(total_iterations) / steps;
  run.factorizations = body.factorizations();
  return run;
}

Vec3 tip_position(const Case& c, const Matrix3Xd& positions) {
  Vec3 sum = Vec3::Zero();
  for (const NodeIndex n : c.tip) sum += positions.col(n);
  return sum / static_cast<double>(c.tip.size());
}

struct Deviation {
  double rms_error = 0;         ///< [m] over every node and every common time
  double rms_displacement = 0;  ///< [m] of the reference from rest, over the same nodes and times
  double tip_error = 0;         ///< [m] at the end of the run
  double tip_displacement = 0;  ///< [m] of the reference's tip from rest at the end of the run
  [[nodiscard]] double relative_rms() const { return rms_error / rms_displacement; }
  [[nodiscard]] double relative_tip() const { return tip_error / tip_displacement; }
};

/// `run` against `reference` at every time both kept a state. Pinned nodes add zero to
/// both sums, so the relative figure does not depend on how many there are.
Deviation deviation(const Case& c, const Run& run, const Run& reference) {
  const int ratio = reference.rate / run.rate;  // reference steps per run step
  double error2 = 0, displacement2 = 0;
  std::size_t compared = 0;
  for (std::size_t s = 0; s < run.states.size(); ++s) {
    const long reference_step = static_cast<long>(s + 1) * run.sample_every * ratio;
    if (reference_step % reference.sample_every != 0) continue;
    const Matrix3Xd& truth = reference.states[static_cast<std::size_t>(reference_step / reference.sample_every) - 1];
    error2 += (run.states[s] - truth).squaredNorm();
    displacement2 += (truth - c.cage.rest_positions).squaredNorm();
    ++compared;
  }
  const double samples = static_cast<double>(compared * c.cage.node_count());
  const Vec3 tip_rest = tip_position(c, c.cage.rest_positions);
  const Vec3 tip_truth = tip_position(c, reference.states.back());
  return {std::sqrt(error2 / samples), std::sqrt(displacement2 / samples),
          (tip_position(c, run.states.back()) - tip_truth).norm(), (tip_truth - tip_rest).norm()};
}

const char* model_name(sim::StiffnessModel m) { return m == sim::StiffnessModel::Exact ? "exact" : "warped"; }

sim::StepSettings direct_solver(sim::StiffnessModel stiffness) {
  sim::StepSettings s;
  s.solver = sim::LinearSolver::Direct;
  s.stiffness = stiffness;
  return s;
}

sim::StepSettings conjugate_gradients(sim::Preconditioner preconditioner, double tolerance) {
  sim::StepSettings s;
  s.solver = sim::LinearSolver::ConjugateGradient;
  s.preconditioner = preconditioner;
  s.tolerance = tolerance;
  s.stiffness = sim::StiffnessModel::Warped;
  return s;
}

/// Appended to a row's last cell: a failed step leaves the state where it was, which
/// the error figures would otherwise silently include.
std::string outcome(const Run& run) {
  if (run.failed > 0) return " (" + std::to_string(run.failed) + " steps failed)";
  return {};
}

void sweep(const Case& c, const Plan& plan, CsvOutput& csv) {
  std::printf("\n### %s\n\n", c.name.c_str());
  constexpr sim::StiffnessModel kModels[] = {sim::StiffnessModel::Warped, sim::StiffnessModel::Exact};
  std::vector<Run> references;
  for (const sim::StiffnessModel model : kModels) {
    sim::StepSettings settings = conjugate_gradients(sim::Preconditioner::LaggedCholesky, kReferenceTolerance);
    settings.stiffness = model;
    references.push_back(simulate(c, plan.reference_rate, settings, plan.reference_rate / plan.reference_sample_rate));
  }
  // The two references should agree to well below the swept errors; if not, the
  // reference dt is too coarse to call either of them the truth.
  const Deviation between = deviation(c, references[0], references[1]);
  // Against itself: only its displacement figures are of use here.
  const Deviation motion = deviation(c, references[0], references[0]);
  std::printf("Reference: lagged-Cholesky CG to a residual of %.0e (%d and %d steps at the iteration cap), dt = 1/%d s, "
              "%d s simulated. Tip moved %.4g m by t = %d s; RMS node "
              "displacement over the run %.4g m. Warped reference: %.3f s wall per simulated s; exact: %.3f s. "
              "Warped and exact references differ by %.2e relative RMS, tip %.3g m.\n\n",
              kReferenceTolerance, references[0].capped, references[1].capped, plan.reference_rate, kSimulatedSeconds,
              motion.tip_displacement, kSimulatedSeconds,
              motion.rms_displacement, references[0].wall_seconds / kSimulatedSeconds,
              references[1].wall_seconds / kSimulatedSeconds, between.relative_rms(), between.tip_error);
  std::fflush(stdout);

  std::printf("dt sweep, direct solver (error against the same model's reference):\n\n");
  std::printf("| stiffness | dt | RMS error / RMS displacement | tip error at %d s | wall s per simulated s | ms/step |\n"
              "|---|---|---|---|---|---|\n", kSimulatedSeconds);
  for (std::size_t m = 0; m < std::size(kModels); ++m) {
    for (const int rate : plan.rates) {
      const Run run = simulate(c, rate, direct_solver(kModels[m]), 1);
      const Deviation d = deviation(c, run, references[m]);
      csv.dt.row({c.key, model_name(kModels[m]), 1.0 / rate, d.relative_rms(), d.tip_error, d.relative_tip(),
                  run.wall_seconds / kSimulatedSeconds, 1e3 * run.wall_seconds / (rate * kSimulatedSeconds), run.failed});
      std::printf("| %s | 1/%d | %.2e | %.3g m (%.1f%%) | %.3f | %.2f%s |\n", model_name(kModels[m]), rate,
                  d.relative_rms(), d.tip_error, 100 * d.relative_tip(), run.wall_seconds / kSimulatedSeconds,
                  1e3 * run.wall_seconds / (rate * kSimulatedSeconds), outcome(run).c_str());
      std::fflush(stdout);
    }
  }

  // At a fixed dt the time-discretization error is a floor no tolerance can go under,
  // so each run is also compared with the direct solve at the same dt: that part is
  // what the tolerance alone adds. Warped only, the player's default: in a first run of
  // this sweep the exact model took the same Jacobi CG iteration counts to within 0.2.
  std::printf("\nCG tolerance sweep at dt = 1/%d s, warped stiffness (warm-started, cap 1000 iterations; lagged "
              "Cholesky refactors after a solve of more than 8 iterations):\n\n", kToleranceRate);
  std::printf("| solver | tolerance | CG iterations/step | steps at cap | factorizations | RMS error / RMS displacement vs "
              "reference | vs direct at the same dt | tip error at %d s | wall s per simulated s |\n"
              "|---|---|---|---|---|---|---|---|---|\n", kSimulatedSeconds);
  const Run direct = simulate(c, kToleranceRate, direct_solver(sim::StiffnessModel::Warped), 1);
  const Deviation dd = deviation(c, direct, references[0]);
  std::printf("| direct | — | — | — | %d | %.2e | 0 | %.3g m (%.1f%%) | %.3f%s |\n", direct.factorizations,
              dd.relative_rms(), dd.tip_error, 100 * dd.relative_tip(), direct.wall_seconds / kSimulatedSeconds,
              outcome(direct).c_str());
  csv.tolerance.row({c.key, "direct", 0, 0, 0, direct.factorizations, dd.relative_rms(), 0, dd.tip_error,
                     direct.wall_seconds / kSimulatedSeconds, direct.failed});
  constexpr std::pair<sim::Preconditioner, const char*> kPreconditioners[] = {
      {sim::Preconditioner::Jacobi, "CG, Jacobi"}, {sim::Preconditioner::LaggedCholesky, "CG, lagged Cholesky"}};
  for (const auto& [preconditioner, name] : kPreconditioners) {
    for (const double tolerance : plan.tolerances) {
      const Run run = simulate(c, kToleranceRate, conjugate_gradients(preconditioner, tolerance), 1);
      const Deviation d = deviation(c, run, references[0]);
      const Deviation own = deviation(c, run, direct);
      csv.tolerance.row({c.key, preconditioner == sim::Preconditioner::Jacobi ? "cg-jacobi" : "cg-lagged-cholesky",
                         tolerance, run.iterations, run.capped, run.factorizations, d.relative_rms(), own.relative_rms(),
                         d.tip_error, run.wall_seconds / kSimulatedSeconds, run.failed});
      std::printf("| %s | %.0e | %.1f | %d | %d | %.2e | %.2e | %.3g m (%.1f%%) | %.3f%s |\n", name, tolerance,
                  run.iterations, run.capped, run.factorizations, d.relative_rms(), own.relative_rms(), d.tip_error,
                  100 * d.relative_tip(), run.wall_seconds / kSimulatedSeconds, outcome(run).c_str());
      std::fflush(stdout);
    }
  }
}

/// Exact against warped stiffness where they part most: a free beam spinning at 10 rad/s
/// with a little bending, at steps from 0.02 to 0.5 rad. The reference is the exact model
/// at a small step (both models converge to the same motion as dt → 0).
void spin_sweep(const Plan& plan, CsvOutput& csv) {
  const testing::SpinningBeam beam;
  const testing::SpinOutcome reference = testing::spin(beam, sim::StiffnessModel::Exact, plan.spin_reference_dt, kSpinSeconds);
  std::printf("\n### Free beam 2×0.25×0.25 m (48 tets, E = 1e6 Pa) spinning at 10 rad/s for %.1f s\n\n", kSpinSeconds);
  std::printf("Reference: exact stiffness at dt = %.2g s, E/E0 %.4f, L/L0 %.4f at the end.\n\n", plan.spin_reference_dt,
              reference.energy_ratio, reference.momentum_ratio);
  std::printf("| stiffness | dt | rad/step | peak E/E0 | final E/E0 | final L/L0 | tip error | ms/step |\n"
              "|---|---|---|---|---|---|---|---|\n");
  for (const double dt : plan.spin_dts) {
    for (const sim::StiffnessModel model : {sim::StiffnessModel::Warped, sim::StiffnessModel::Exact}) {
      const auto start = Clock::now();
      const testing::SpinOutcome run = testing::spin(beam, model, dt, kSpinSeconds);
      const double ms = 1e3 * std::chrono::duration<double>(Clock::now() - start).count() / std::max(run.steps, 1);
      const double tip_error = (run.tip - reference.tip).norm();
      std::printf("| %s | %.3g | %.2f | %.3f | %.3f | %.3f | %.3g m | %.3f |\n", model_name(model), dt, 10 * dt,
                  run.peak_energy_ratio, run.energy_ratio, run.momentum_ratio, tip_error, ms);
      std::fflush(stdout);
      csv.spin.row({model_name(model), dt, 10 * dt, run.peak_energy_ratio, run.energy_ratio, run.momentum_ratio, tip_error,
                    ms, run.steps});
    }
  }
}

int parse_thread_count(const std::string& value) {
  return testing::parse_integer_option("--threads", value, 1, "pass a whole number of threads, e.g. --threads 2");
}

}  // namespace

int main(int argc, char** argv) {
  try {
    int threads = 1;
    bool beam = true, bunny = true, spinning = true;
    Plan plan;
    std::filesystem::path csv_dir;
    for (int i = 1; i < argc; ++i) {
      const std::string arg = argv[i];
      if (arg == "--help" || arg == "-h") {
        std::fputs(kUsage, stdout);
        return 0;
      }
      if ((arg == "--threads" || arg == "--cases" || arg == "--csv") && i + 1 >= argc) {
        throw Error(arg + " needs a value", "see --help");
      }
      if (arg == "--quick") {
        plan = Plan::quick();
      } else if (arg == "--csv") {
        csv_dir = argv[++i];
      } else if (arg == "--threads") {
        threads = parse_thread_count(argv[++i]);
      } else if (arg == "--cases") {
        const std::string list = argv[++i];
        beam = bunny = spinning = false;
        std::size_t from = 0;
        while (from <= list.size()) {
          const std::size_t comma = std::min(list.find(',', from), list.size());
          const std::string name = list.substr(from, comma - from);
          if (name == "beam") {
            beam = true;
          } else if (name == "bunny") {
            bunny = true;
          } else if (name == "spin") {
            spinning = true;
          } else {
            throw Error("--cases: unknown case '" + name + "'", "valid cases: beam, bunny, spin");
          }
          from = comma + 1;
        }
      } else {
        throw Error("unknown option '" + arg + "'", "options: --threads N, --cases beam,bunny,spin, --csv DIR, --quick, --help");
      }
    }
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    std::printf("threads: %d; every body released from rest, %d s simulated\n", threads, kSimulatedSeconds);
    plan.check();
    CsvOutput csv(csv_dir);
    if (beam) sweep(beam_case(), plan, csv);
    if (bunny) sweep(bunny_case(), plan, csv);
    if (spinning) spin_sweep(plan, csv);
    return 0;
  } catch (const Error& e) {
    std::fputs(format_error(e).c_str(), stderr);
    return 1;
  }
}
