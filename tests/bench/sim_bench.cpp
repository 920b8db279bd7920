// Physics step cost: ms per implicit step vs tet count, for the direct solver and
// conjugate gradients with either preconditioner. Prints a Markdown table for BENCHMARKS.md.
//
//   fissure_sim_bench [--steps N] [--threads N] [--stiffness warped|exact] [--large] [--trace]
//                     [--only TEXT]   (cases and solvers whose name contains TEXT, for profiling)
//                     [--tolerance T] (conjugate gradients' relative residual; default 1e-4, the player's)
// --large adds an 85k-tet beam (conjugate gradients only: the direct factorization
// alone takes seconds there).
#include <tbb/global_control.h>

#include <chrono>
#include <memory>
#include <cstdio>
#include <string>

#include "formats/cage_io.h"
#include "player/sim/implicit_integrator.h"
#include "tests/support/procedural.h"

namespace {

using namespace fissure;

struct Case {
  std::string name;
  TetMesh cage;
};

}  // namespace

int main(int argc, char** argv) {
  int steps = 20;
  bool large = false;
  bool trace = false;  // one line per step: iterations and solve time
  std::string only;    // run only the cases and solvers whose "cage, solver" name contains it
  double tolerance = 1e-4;  // the player's default (formats/scene.h)
  sim::StiffnessModel stiffness = sim::StiffnessModel::Warped;
  std::unique_ptr<tbb::global_control> threads;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--steps" && i + 1 < argc) {
      steps = std::stoi(argv[++i]);
    } else if (arg == "--threads" && i + 1 < argc) {
      threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                      static_cast<std::size_t>(std::stoi(argv[++i])));
    } else if (arg == "--stiffness" && i + 1 < argc) {
      stiffness = std::string(argv[++i]) == "exact" ? sim::StiffnessModel::Exact : sim::StiffnessModel::Warped;
    } else if (arg == "--trace") {
      trace = true;
    } else if (arg == "--tolerance" && i + 1 < argc) {
      tolerance = std::stod(argv[++i]);
    } else if (arg == "--only" && i + 1 < argc) {
      only = argv[++i];
    } else if (arg == "--large") {
      large = true;
    } else {
      std::fprintf(stderr, "usage: fissure_sim_bench [--steps N] [--threads N] [--stiffness warped|exact] [--large] [--trace] [--only TEXT] [--tolerance T]\n");
      return 1;
    }
  }
  std::printf("threads: %d, stiffness: %s, CG tolerance %g, %d steps per case\n\n",
              static_cast<int>(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)),
              stiffness == sim::StiffnessModel::Exact ? "exact" : "warped", tolerance, steps);
  std::vector<Case> cases;
  // The reference beam: 4×1×1 m; grids near 1k and 10k tets.
  cases.push_back({"beam 4×1×1 m, 13×3×3", testing::grid_cage(Vec3::Zero(), Vec3(4, 1, 1), 13, 3, 3)});
  cases.push_back({"beam 4×1×1 m, 36×7×7", testing::grid_cage(Vec3::Zero(), Vec3(4, 1, 1), 36, 7, 7)});
  cases.push_back({"bunny-5k-cage-987", formats::read_cage(std::string(FISSURE_BENCH_DATA_DIR) + "/cages/bunny-5k-cage-987.node").mesh});
  cases.push_back({"bunny-5k-cage-10024", formats::read_cage(std::string(FISSURE_BENCH_DATA_DIR) + "/cages/bunny-5k-cage-10024.node").mesh});
  if (large) cases.push_back({"beam 4×1×1 m, 72×14×14", testing::grid_cage(Vec3::Zero(), Vec3(4, 1, 1), 72, 14, 14)});
  struct SolverCase {
    const char* name;
    sim::LinearSolver solver;
    sim::Preconditioner preconditioner;
  };
  const SolverCase solvers[] = {
      {"direct (CHOLMOD)", sim::LinearSolver::Direct, sim::Preconditioner::Jacobi},
      {"CG, Jacobi", sim::LinearSolver::ConjugateGradient, sim::Preconditioner::Jacobi},
      {"CG, lagged Cholesky", sim::LinearSolver::ConjugateGradient, sim::Preconditioner::LaggedCholesky},
  };
  std::printf("| cage | nodes | tets | solver | ms/step | forces / assembly / solve ms | CG iterations per step | factorizations | vs CG Jacobi |\n|---|---|---|---|---|---|---|---|---|\n");
  for (const Case& c : cases) {
    double jacobi_ms = 0.0;
    for (const SolverCase& solver : solvers) {
      if (c.cage.tet_count() > 50000 && solver.solver == sim::LinearSolver::Direct) continue;
      if (!only.empty() && (c.name + ", " + solver.name).find(only) == std::string::npos) continue;
      sim::ImplicitIntegrator body(c.cage.rest_positions, c.cage.tets,
                                   sim::Material{.density = 1000, .youngs_modulus = 1e6, .poisson_ratio = 0.3});
      // Clamp the nodes at the lowest x, as the cantilever of the issue.
      const double x_min = c.cage.rest_positions.row(0).minCoeff();
      for (Index n = 0; n < c.cage.node_count(); ++n) {
        if (c.cage.rest_positions(0, n) <= x_min + 1e-9) body.pin(n);
      }
      sim::StepSettings settings;
      settings.solver = solver.solver;
      settings.preconditioner = solver.preconditioner;
      settings.tolerance = tolerance;
      settings.stiffness = stiffness;
      body.step(settings);  // first step: pattern, symbolic analysis, first factor: excluded
      const int factorizations_before = body.factorizations();
      sim::ImplicitIntegrator::PhaseTimes phases;
      int total_iterations = 0;
      const auto start = std::chrono::steady_clock::now();
      for (int i = 0; i < steps; ++i) {
        body.step(settings);
        if (trace) std::printf("  step %d: %d iterations, solve %.2f ms\n", i, body.last_iterations(), 1e3 * body.last_phase_times().solve);
        total_iterations += body.last_iterations();
        phases.forces += body.last_phase_times().forces / steps;
        phases.assembly += body.last_phase_times().assembly / steps;
        phases.solve += body.last_phase_times().solve / steps;
      }
      const double ms = 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / steps;
      if (solver.preconditioner == sim::Preconditioner::Jacobi && solver.solver != sim::LinearSolver::Direct) {
        jacobi_ms = ms;
      }
      std::printf("| %s | %zu | %zu | %s | %.2f | %.2f / %.2f / %.2f | %s | %d | %s |\n", c.name.c_str(),
                  c.cage.node_count(), c.cage.tet_count(), solver.name, ms, 1e3 * phases.forces,
                  1e3 * phases.assembly, 1e3 * phases.solve,
                  solver.solver == sim::LinearSolver::Direct
                      ? "–"
                      : std::to_string(static_cast<double>(total_iterations) / steps).substr(0, 5).c_str(),
                  body.factorizations() - factorizations_before,
                  jacobi_ms > 0 ? (std::to_string(ms / jacobi_ms).substr(0, 4) + "×").c_str() : "–");
      std::fflush(stdout);
    }
  }
  return 0;
}
