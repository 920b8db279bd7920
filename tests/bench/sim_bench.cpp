// Physics step cost: ms per implicit step vs tet count, direct vs conjugate-gradient
// solver. Prints a Markdown table for BENCHMARKS.md.
//
//   fissure_sim_bench [--steps N] [--threads N] [--stiffness warped|exact] [--large]
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
    } else if (arg == "--large") {
      large = true;
    } else {
      std::fprintf(stderr, "usage: fissure_sim_bench [--steps N] [--threads N] [--stiffness warped|exact] [--large]\n");
      return 1;
    }
  }
  std::printf("threads: %d, stiffness: %s, %d steps per case\n\n",
              static_cast<int>(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)),
              stiffness == sim::StiffnessModel::Exact ? "exact" : "warped", steps);
  std::vector<Case> cases;
  // The reference beam: 4×1×1 m; grids near 1k and 10k tets.
  cases.push_back({"beam 4×1×1 m, 13×3×3", testing::grid_cage(Vec3::Zero(), Vec3(4, 1, 1), 13, 3, 3)});
  cases.push_back({"beam 4×1×1 m, 36×7×7", testing::grid_cage(Vec3::Zero(), Vec3(4, 1, 1), 36, 7, 7)});
  cases.push_back({"bunny-5k-cage-987", formats::read_cage(std::string(FISSURE_BENCH_DATA_DIR) + "/cages/bunny-5k-cage-987.node").mesh});
  cases.push_back({"bunny-5k-cage-10024", formats::read_cage(std::string(FISSURE_BENCH_DATA_DIR) + "/cages/bunny-5k-cage-10024.node").mesh});
  if (large) cases.push_back({"beam 4×1×1 m, 72×14×14", testing::grid_cage(Vec3::Zero(), Vec3(4, 1, 1), 72, 14, 14)});
  std::printf("| cage | nodes | tets | direct ms/step | direct: forces / assembly / solve ms | CG ms/step (iterations) | CG: forces / assembly / solve ms | CG / direct |\n|---|---|---|---|---|---|---|---|\n");
  for (const Case& c : cases) {
    double ms[2] = {0, 0};
    sim::ImplicitIntegrator::PhaseTimes phases[2];
    int iterations = 0;
    const bool skip_direct = c.cage.tet_count() > 50000;
    for (int solver = skip_direct ? 1 : 0; solver < 2; ++solver) {
      sim::ImplicitIntegrator body(c.cage.rest_positions, c.cage.tets,
                                   sim::Material{.density = 1000, .youngs_modulus = 1e6, .poisson_ratio = 0.3});
      // Clamp the nodes at the lowest x, as the cantilever of the issue.
      const double x_min = c.cage.rest_positions.row(0).minCoeff();
      for (Index n = 0; n < c.cage.node_count(); ++n) {
        if (c.cage.rest_positions(0, n) <= x_min + 1e-9) body.pin(n);
      }
      sim::StepSettings settings;
      settings.solver = solver == 0 ? sim::LinearSolver::Direct : sim::LinearSolver::ConjugateGradient;
      settings.tolerance = 1e-6;
      settings.stiffness = stiffness;
      body.step(settings);  // first step: symbolic analysis, excluded
      const auto start = std::chrono::steady_clock::now();
      int total_iterations = 0;
      for (int i = 0; i < steps; ++i) {
        body.step(settings);
        total_iterations += body.last_iterations();
        phases[solver].forces += body.last_phase_times().forces / steps;
        phases[solver].assembly += body.last_phase_times().assembly / steps;
        phases[solver].solve += body.last_phase_times().solve / steps;
      }
      ms[solver] = 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / steps;
      if (solver == 1) iterations = total_iterations / steps;
    }
    std::printf("| %s | %zu | %zu | %.2f | %.2f / %.2f / %.2f | %.2f (%d) | %.2f / %.2f / %.2f | %.2f× |\n", c.name.c_str(),
                c.cage.node_count(), c.cage.tet_count(), ms[0], 1e3 * phases[0].forces, 1e3 * phases[0].assembly,
                1e3 * phases[0].solve, ms[1], iterations, 1e3 * phases[1].forces, 1e3 * phases[1].assembly,
                1e3 * phases[1].solve, skip_direct ? 0.0 : ms[1] / ms[0]);
    std::fflush(stdout);
  }
  return 0;
}
