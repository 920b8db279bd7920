// Side by side with a peer (issue 4): the same cantilever, tet mesh, lumped masses,
// material, dt and clamp stepped by Fissure's implicit integrator and by Bullet3's
// deformable FEM in one run. Prints Markdown tables for BENCHMARKS.md: ms per step of
// each engine and the ratio, then the static tip deflection of both against
// Euler–Bernoulli.
//
//   fissure_bullet_peer_bench [--steps N] [--settle-steps N] [--levels 13x3x3,36x7x7]
//
// Built only with -DFISSURE_BUILD_BULLET_PEER=ON (Debian libbullet-dev, double precision).
// Bullet's side is btDeformableLinearElasticityForce, its corotated linear FEM with the
// rotation frozen in the stiffness: the same model as our warped stiffness. (Its
// btDeformableCorotatedForce has no stiffness term in 3.24, so it cannot step implicitly.)
#include <BulletSoftBody/btDeformableBodySolver.h>
#include <BulletSoftBody/btDeformableGravityForce.h>
#include <BulletSoftBody/btDeformableLinearElasticityForce.h>
#include <BulletSoftBody/btDeformableMultiBodyConstraintSolver.h>
#include <BulletSoftBody/btDeformableMultiBodyDynamicsWorld.h>
#include <BulletSoftBody/btSoftBody.h>
#include <BulletSoftBody/btSoftBodyHelpers.h>
#include <BulletSoftBody/btSoftBodyRigidBodyCollisionConfiguration.h>
#include <btBulletCollisionCommon.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "common/error.h"
#include "player/sim/implicit_integrator.h"
#include "tests/support/bench_args.h"
#include "tests/support/procedural.h"

#ifndef BT_USE_DOUBLE_PRECISION
#error "link the double-precision Bullet (pkg-config bullet-float64), which defines BT_USE_DOUBLE_PRECISION"
#endif
static_assert(sizeof(btScalar) == sizeof(double), "Bullet must run in double precision, as Fissure does");

namespace {

using namespace fissure;
using Clock = std::chrono::steady_clock;

constexpr double kLength = 4.0, kWidth = 1.0, kHeight = 1.0;  // [m], the issue's beam
constexpr double kDt = 1.0 / 240.0;                            // [s]
constexpr double kGravity = 9.81;                              // [m/s²], along −z
/// Our conjugate-gradient stopping rule, the player's default (formats/scene.h):
/// ‖r‖ ≤ 1e-4 ‖b‖; and the stricter 1e-6 it had before.
constexpr double kOurTolerance = 1e-4;
constexpr double kOurStrictTolerance = 1e-6;
/// Bullet's btConjugateGradient stops when rᵀP⁻¹r < tol · min(1, bᵀP⁻¹b), P its
/// preconditioner (the identity in 3.24, see CountingMassPreconditioner): a squared
/// norm, so 1e-8 is our 1e-4 (and 1e-12 our 1e-6) while ‖b‖ < 1, and stricter
/// otherwise. Its default tol is machine epsilon, about 1.5e-8 relative.
constexpr double kBulletMatchedTolerance = 1e-8;
constexpr double kBulletMatchedStrictTolerance = 1e-12;
/// Young's moduli of the deflection table [Pa]. The issue's 1e6 bends the beam by about
/// half its length, far outside Euler–Bernoulli's small deflections: there the two
/// engines are compared with each other. At 1e8 the tip drops under 1% of the length
/// and Euler–Bernoulli is the reference.
constexpr double kSettleModuli[] = {1e6, 1e8};
/// Steps run before the clock starts: the first builds patterns, buffers and factors.
constexpr int kWarmupSteps = 2;
/// The timed steps of all engines are interleaved in chunks of this many, so that load
/// from other jobs on a shared machine falls on all of them alike.
constexpr int kTimingChunk = 10;

const char* kUsage =
    "usage: fissure_bullet_peer_bench [--steps N] [--settle-steps N] [--levels LIST]\n"
    "  --steps N         timed steps per engine and beam, after 2 warm-up steps (default 50)\n"
    "  --settle-steps N  damped steps at E = 1e6 Pa before the static tip deflection is read\n"
    "                    (default 1500, about 2 periods of the first bending mode); stiffer\n"
    "                    beams get as many periods, so fewer steps. 0 skips the deflection table\n"
    "  --levels LIST     comma-separated grids of the 4x1x1 m beam, NXxNYxNZ cubes of 6 tets\n"
    "                    each (default 13x3x3,36x7x7: 702 and 10,584 tets)\n"
    "  --help            print this and exit\n";

struct Beam {
  std::string name;  ///< "13×3×3"
  TetMesh cage;
  std::vector<NodeIndex> clamped;  ///< the nodes at x = 0
  std::vector<NodeIndex> tip;      ///< the nodes at x = L, whose mean z drop is "the tip deflection"
};

Beam make_beam(int nx, int ny, int nz) {
  Beam beam{std::to_string(nx) + "×" + std::to_string(ny) + "×" + std::to_string(nz),
            testing::grid_cage(Vec3::Zero(), Vec3(kLength, kWidth, kHeight), nx, ny, nz), {}, {}};
  for (Index n = 0; n < static_cast<Index>(beam.cage.node_count()); ++n) {
    if (beam.cage.rest_positions(0, n) <= 1e-9) beam.clamped.push_back(n);
    if (beam.cage.rest_positions(0, n) >= kLength - 1e-9) beam.tip.push_back(n);
  }
  return beam;
}

/// The issue's material; damping is chosen per run: none while timing, mass damping
/// while settling.
sim::Material beam_material(double youngs_modulus = 1e6, double rayleigh_mass = 0.0) {
  return sim::Material{
      .density = 1000, .youngs_modulus = youngs_modulus, .poisson_ratio = 0.3, .rayleigh_mass = rayleigh_mass};
}

/// Static tip deflection of a clamped beam under its own weight, Euler–Bernoulli:
/// δ = q L⁴ / (8 E I), q = ρ g A, I = w h³ / 12 (bending about y).
double euler_bernoulli_tip(const sim::Material& m) {
  const double q = m.density * kGravity * kWidth * kHeight;
  const double inertia = kWidth * std::pow(kHeight, 3) / 12.0;
  return q * std::pow(kLength, 4) / (8.0 * m.youngs_modulus * inertia);
}

/// The shear term Timoshenko adds to it, q L² / (2 κ G A) with κ = 5/6: not negligible
/// for a beam only 4 times as long as it is deep.
double timoshenko_shear_tip(const sim::Material& m) {
  const double q = m.density * kGravity * kWidth * kHeight;
  return q * kLength * kLength / (2.0 * (5.0 / 6.0) * m.mu() * kWidth * kHeight);
}

/// First bending mode of the cantilever, Euler–Bernoulli: ω₁ = 1.8751² √(E I / (ρ A L⁴)) [rad/s].
double first_bending_frequency(const sim::Material& m) {
  const double inertia = kWidth * std::pow(kHeight, 3) / 12.0;
  return 1.8751 * 1.8751 * std::sqrt(m.youngs_modulus * inertia / (m.density * kWidth * kHeight * std::pow(kLength, 4)));
}

/// What the timing and settling loops need from either engine.
class BeamEngine {
 public:
  virtual ~BeamEngine() = default;
  virtual void step() = 0;
  /// Mean z drop of the beam's x = L nodes [m].
  [[nodiscard]] virtual double tip_deflection() const = 0;
  /// Zeroes the per-run counters below, e.g. after the warm-up.
  virtual void reset_counters() = 0;
  /// CG iterations summed over the steps since reset_counters().
  [[nodiscard]] virtual long iterations() const = 0;
  /// Steps that did not advance.
  [[nodiscard]] virtual int failed_steps() const = 0;
};

/// Fissure's side: the implicit integrator with conjugate gradients at the player's
/// tolerance (docs/scene-example.toml), with either preconditioner.
class FissureBeam final : public BeamEngine {
 public:
  FissureBeam(const Beam& beam, const sim::Material& material,
              sim::Preconditioner preconditioner = sim::Preconditioner::LaggedCholesky,
              double tolerance = kOurTolerance)
      : m_beam(beam), m_body(beam.cage.rest_positions, beam.cage.tets, material) {
    m_body.pin(beam.clamped);
    m_settings.dt = kDt;
    m_settings.gravity = Vec3(0, 0, -kGravity);
    m_settings.solver = sim::LinearSolver::ConjugateGradient;
    m_settings.tolerance = tolerance;
    m_settings.preconditioner = preconditioner;
  }

  void step() override {
    const sim::SolveStatus status = m_body.step(m_settings);
    if (status == sim::SolveStatus::NotPositiveDefinite || status == sim::SolveStatus::NonFinite) ++m_failed_steps;
    m_iterations += m_body.last_iterations();
    const sim::ImplicitIntegrator::PhaseTimes& phases = m_body.last_phase_times();
    m_phase_seconds.forces += phases.forces;
    m_phase_seconds.assembly += phases.assembly;
    m_phase_seconds.solve += phases.solve;
  }
  [[nodiscard]] double tip_deflection() const override {
    double drop = 0;
    for (const NodeIndex n : m_beam.tip) drop += m_beam.cage.rest_positions(2, n) - m_body.positions()(2, n);
    return drop / static_cast<double>(m_beam.tip.size());
  }
  void reset_counters() override {
    m_iterations = 0;
    m_phase_seconds = {};
    m_factorizations_before = m_body.factorizations();
  }
  [[nodiscard]] long iterations() const override { return m_iterations; }
  [[nodiscard]] int failed_steps() const override { return m_failed_steps; }

  /// Seconds per phase summed over the steps since reset_counters().
  [[nodiscard]] const sim::ImplicitIntegrator::PhaseTimes& phase_seconds() const { return m_phase_seconds; }
  /// Cholesky refactorizations since reset_counters() (LaggedCholesky refreshes its factor).
  [[nodiscard]] int factorizations() const { return m_body.factorizations() - m_factorizations_before; }
  [[nodiscard]] const Eigen::VectorXd& node_masses() const { return m_body.node_masses(); }

 private:
  const Beam& m_beam;
  sim::ImplicitIntegrator m_body;
  sim::StepSettings m_settings;
  long m_iterations = 0;
  sim::ImplicitIntegrator::PhaseTimes m_phase_seconds;
  int m_factorizations_before = 0;
  int m_failed_steps = 0;
};

/// btDeformableBodySolver keeps its conjugate-gradient solver protected; this only
/// exposes its stopping tolerance, so the comparison can be run at ours as well.
class TunableDeformableSolver : public btDeformableBodySolver {
 public:
  void set_cg_tolerance(btScalar tolerance) { m_cg.setTolerance(tolerance); }
  [[nodiscard]] int max_newton_iterations() const { return m_maxNewtonIterations; }
  [[nodiscard]] int max_cg_iterations() const { return m_cg.m_maxIterations; }
};

/// Bullet's mass preconditioner with a counter. Bullet discards the iteration count of
/// its solves; btConjugateGradient applies the preconditioner twice before its loop and
/// once per iteration, so the count gives the iterations Bullet does not report.
/// It also records whether Bullet ever initializes it: 3.24 does not on the implicit
/// (projection) path, and an uninitialized MassPreconditioner is the identity.
class CountingMassPreconditioner : public MassPreconditioner {
 public:
  using MassPreconditioner::MassPreconditioner;
  void operator()(const TVStack& x, TVStack& b) override {
    ++applications;
    MassPreconditioner::operator()(x, b);
  }
  void reinitialize(bool nodes_changed) override {
    initialized = true;
    MassPreconditioner::reinitialize(nodes_changed);
  }
  long applications = 0;
  bool initialized = false;
};

/// Bullet's side: the same nodes, tets and lumped masses in a btDeformableMultiBodyDynamicsWorld,
/// stepped as Bullet's own volumetric demos do (implicit, no line search, CG with projection).
class BulletBeam final : public BeamEngine {
 public:
  BulletBeam(const Beam& beam, const sim::Material& material, const Eigen::VectorXd& node_masses,
             btScalar cg_tolerance)
      : m_beam(beam) {
    m_collision_configuration = std::make_unique<btSoftBodyRigidBodyCollisionConfiguration>();
    m_dispatcher = std::make_unique<btCollisionDispatcher>(m_collision_configuration.get());
    m_broadphase = std::make_unique<btDbvtBroadphase>();
    m_deformable_solver = std::make_unique<TunableDeformableSolver>();
    m_deformable_solver->set_cg_tolerance(cg_tolerance);
    m_constraint_solver = std::make_unique<btDeformableMultiBodyConstraintSolver>();
    m_constraint_solver->setDeformableSolver(m_deformable_solver.get());
    m_world = std::make_unique<btDeformableMultiBodyDynamicsWorld>(
        m_dispatcher.get(), m_broadphase.get(), m_constraint_solver.get(), m_collision_configuration.get(),
        m_deformable_solver.get());
    const btVector3 gravity(0, 0, -kGravity);
    m_world->setGravity(gravity);
    m_world->getWorldInfo().m_gravity = gravity;
    m_world->setImplicit(true);
    m_world->setLineSearch(false);
    m_world->setUseProjection(true);

    // The objective owns its preconditioners and deletes whichever one it holds; it
    // gets the counting one, and the original is ours to delete.
    btDeformableBackwardEulerObjective& objective = *m_deformable_solver->m_objective;
    m_replaced_preconditioner.reset(objective.m_massPreconditioner);
    m_preconditioner = new CountingMassPreconditioner(objective.m_softBodies);
    objective.m_massPreconditioner = m_preconditioner;

    std::vector<btVector3> positions;
    positions.reserve(beam.cage.node_count());
    for (Index n = 0; n < static_cast<Index>(beam.cage.node_count()); ++n) {
      const Vec3 p = beam.cage.rest_positions.col(n);
      positions.emplace_back(p.x(), p.y(), p.z());
    }
    m_body = new btSoftBody(&m_world->getWorldInfo(), static_cast<int>(positions.size()), positions.data(),
                            node_masses.data());
    // What btSoftBodyHelpers::CreateFromTetGenData builds (tets, their edges as links,
    // then the boundary faces), without its quadratic duplicate-link search.
    std::set<std::pair<Index, Index>> edges;
    for (Index t = 0; t < static_cast<Index>(beam.cage.tet_count()); ++t) {
      const auto tet = beam.cage.tets.col(t);
      m_body->appendTetra(static_cast<int>(tet[0]), static_cast<int>(tet[1]), static_cast<int>(tet[2]),
                          static_cast<int>(tet[3]));
      for (int a = 0; a < 4; ++a) {
        for (int b = a + 1; b < 4; ++b) edges.emplace(std::min(tet[a], tet[b]), std::max(tet[a], tet[b]));
      }
    }
    for (const auto& [a, b] : edges) m_body->appendLink(static_cast<int>(a), static_cast<int>(b));
    btSoftBodyHelpers::generateBoundaryFaces(m_body);
    m_body->initializeDmInverse();
    m_body->m_tetraScratches.resize(m_body->m_tetras.size());
    m_body->m_tetraScratchesTn.resize(m_body->m_tetras.size());
    for (const NodeIndex n : beam.clamped) m_body->setMass(static_cast<int>(n), 0);  // Bullet pins by infinite mass
    // A sleeping body would skip its steps and look fast.
    m_body->m_sleepingThreshold = 0;
    m_body->setActivationState(DISABLE_DEACTIVATION);
    m_world->addSoftBody(m_body);

    m_gravity_force = std::make_unique<btDeformableGravityForce>(gravity);
    m_elasticity = std::make_unique<btDeformableLinearElasticityForce>(material.mu(), material.lambda(),
                                                                       material.rayleigh_mass,
                                                                       material.rayleigh_stiffness);
    m_world->addForce(m_body, m_gravity_force.get());
    m_world->addForce(m_body, m_elasticity.get());
  }
  BulletBeam(const BulletBeam&) = delete;
  BulletBeam& operator=(const BulletBeam&) = delete;
  ~BulletBeam() override {
    m_world->removeSoftBody(m_body);
    delete m_body;
  }

  void step() override {
    // One internal step of exactly dt per call.
    if (m_world->stepSimulation(kDt, 1, kDt) != 1) ++m_failed_steps;
    ++m_steps;
  }
  [[nodiscard]] double tip_deflection() const override {
    double drop = 0;
    for (const NodeIndex n : m_beam.tip) {
      drop += m_beam.cage.rest_positions(2, n) - m_body->m_nodes[static_cast<int>(n)].m_x.z();
    }
    return drop / static_cast<double>(m_beam.tip.size());
  }
  void reset_counters() override {
    m_preconditioner->applications = 0;
    m_steps = 0;
  }
  /// Without line search Bullet makes max_newton_iterations() solves per step (1 in
  /// 3.24: its first Newton iteration always runs), each applying the preconditioner
  /// twice before iterating.
  [[nodiscard]] long iterations() const override {
    return m_preconditioner->applications - 2L * max_newton_iterations() * m_steps;
  }
  [[nodiscard]] int failed_steps() const override { return m_failed_steps; }

  [[nodiscard]] int max_newton_iterations() const { return m_deformable_solver->max_newton_iterations(); }
  [[nodiscard]] int max_cg_iterations() const { return m_deformable_solver->max_cg_iterations(); }
  [[nodiscard]] bool mass_preconditioned() const { return m_preconditioner->initialized; }
  /// Largest distance a clamped node has moved: 0 if Bullet holds them as we do.
  [[nodiscard]] double clamp_drift() const {
    double drift = 0;
    for (const NodeIndex n : m_beam.clamped) {
      const btVector3& x = m_body->m_nodes[static_cast<int>(n)].m_x;
      drift = std::max(drift, (Vec3(x.x(), x.y(), x.z()) - m_beam.cage.rest_positions.col(n)).norm());
    }
    return drift;
  }

 private:
  const Beam& m_beam;
  // Declared so that dependents are destroyed first: the world before the solvers it
  // steps with, the solvers before the forces they point to. The world owns none of them.
  std::unique_ptr<btSoftBodyRigidBodyCollisionConfiguration> m_collision_configuration;
  std::unique_ptr<btCollisionDispatcher> m_dispatcher;
  std::unique_ptr<btDbvtBroadphase> m_broadphase;
  std::unique_ptr<btDeformableGravityForce> m_gravity_force;
  std::unique_ptr<btDeformableLinearElasticityForce> m_elasticity;
  std::unique_ptr<TunableDeformableSolver> m_deformable_solver;
  std::unique_ptr<MassPreconditioner> m_replaced_preconditioner;
  std::unique_ptr<btDeformableMultiBodyConstraintSolver> m_constraint_solver;
  std::unique_ptr<btDeformableMultiBodyDynamicsWorld> m_world;
  btSoftBody* m_body = nullptr;                            ///< owned; removed from the world first
  CountingMassPreconditioner* m_preconditioner = nullptr;  ///< owned by the solver's objective
  long m_steps = 0;
  int m_failed_steps = 0;
};

struct Timing {
  double ms_per_step = 0;
  double iterations_per_step = 0;
  int failed_steps = 0;
};

/// Mean wall time and CG iterations per step of each engine over `steps` steps after
/// the warm-up, released from rest. The engines take turns every kTimingChunk steps;
/// their counters then cover the timed steps only.
std::vector<Timing> time_interleaved(const std::vector<BeamEngine*>& engines, int steps) {
  for (BeamEngine* engine : engines) {
    for (int i = 0; i < kWarmupSteps; ++i) engine->step();
    engine->reset_counters();
  }
  std::vector<double> seconds(engines.size(), 0.0);
  for (int done = 0; done < steps; done += kTimingChunk) {
    const int chunk = std::min(kTimingChunk, steps - done);
    for (std::size_t e = 0; e < engines.size(); ++e) {
      const auto start = Clock::now();
      for (int i = 0; i < chunk; ++i) engines[e]->step();
      seconds[e] += std::chrono::duration<double>(Clock::now() - start).count();
    }
  }
  std::vector<Timing> timings;
  for (std::size_t e = 0; e < engines.size(); ++e) {
    timings.push_back({1e3 * seconds[e] / steps, static_cast<double>(engines[e]->iterations()) / steps,
                       engines[e]->failed_steps()});
  }
  return timings;
}

struct Settled {
  double tip = 0;          ///< mean z drop of the x = L nodes after all steps [m]
  double last_change = 0;  ///< how much it changed over the last tenth of the steps [m]
  int failed_steps = 0;
};

Settled settle(BeamEngine& engine, int steps) {
  const int check_from = steps - std::max(1, steps / 10);
  double tip_at_check = 0;
  for (int i = 0; i < steps; ++i) {
    if (i == check_from) tip_at_check = engine.tip_deflection();
    engine.step();
  }
  const double tip = engine.tip_deflection();
  return {tip, std::abs(tip - tip_at_check), engine.failed_steps()};
}

std::string failures(int failed_steps) {
  return failed_steps == 0 ? "" : " (" + std::to_string(failed_steps) + " steps failed)";
}

void print_timing_table(const std::vector<Beam>& beams, int steps) {
  const sim::Material undamped = beam_material();
  bool header_printed = false;  // Bullet's solver setup is known once a body has stepped
  for (const Beam& beam : beams) {
    FissureBeam ours(beam, undamped);
    FissureBeam ours_strict(beam, undamped, sim::Preconditioner::LaggedCholesky, kOurStrictTolerance);
    FissureBeam ours_jacobi(beam, undamped, sim::Preconditioner::Jacobi);
    BulletBeam bullet_default(beam, undamped, ours.node_masses(), SIMD_EPSILON);
    BulletBeam bullet_matched(beam, undamped, ours.node_masses(), kBulletMatchedTolerance);
    BulletBeam bullet_matched_strict(beam, undamped, ours.node_masses(), kBulletMatchedStrictTolerance);
    const std::vector<Timing> t = time_interleaved(
        {&ours, &ours_strict, &ours_jacobi, &bullet_default, &bullet_matched, &bullet_matched_strict}, steps);
    if (!header_printed) {
      std::printf("Bullet %d.%02d: btDeformableLinearElasticityForce, implicit, %d Newton iteration(s) per step, CG with %s\n"
                  "(at most %d iterations).\n\n",
                  BT_BULLET_VERSION / 100, BT_BULLET_VERSION % 100, bullet_default.max_newton_iterations(),
                  bullet_default.mass_preconditioned() ? "the mass preconditioner"
                                                       : "no preconditioner (its mass preconditioner is never initialized)",
                  bullet_default.max_cg_iterations());
      std::printf("E = %g Pa, undamped, released from rest: mean over %d steps after %d warm-up steps, the engines\n"
                  "taking turns every %d steps.\n\n",
                  undamped.youngs_modulus, steps, kWarmupSteps, kTimingChunk);
      std::printf("| beam | nodes | tets | engine: CG preconditioner, tolerance | ms/step | CG iterations/step | "
                  "forces / assembly / solve ms | ÷ Fissure (player default) |\n"
                  "|---|---|---|---|---|---|---|---|\n");
      header_printed = true;
    }
    const auto fissure_row = [&](const char* solver, const Timing& timing, const FissureBeam& engine) {
      const sim::ImplicitIntegrator::PhaseTimes& phases = engine.phase_seconds();
      const int refactors = engine.factorizations();
      std::printf("| %s | %zu | %zu | Fissure: %s | %.2f%s | %.1f%s | %.2f / %.2f / %.2f | %.2f× |\n", beam.name.c_str(),
                  beam.cage.node_count(), beam.cage.tet_count(), solver, timing.ms_per_step,
                  failures(timing.failed_steps).c_str(), timing.iterations_per_step,
                  refactors > 0 ? (" (" + std::to_string(refactors) + " refactorizations)").c_str() : "",
                  1e3 * phases.forces / steps, 1e3 * phases.assembly / steps, 1e3 * phases.solve / steps,
                  timing.ms_per_step / t[0].ms_per_step);
    };
    const auto bullet_row = [&](const char* solver, const Timing& timing) {
      std::printf("| %s | %zu | %zu | Bullet: %s | %.2f%s | %.1f | – | %.2f× |\n", beam.name.c_str(),
                  beam.cage.node_count(), beam.cage.tet_count(), solver, timing.ms_per_step,
                  failures(timing.failed_steps).c_str(), timing.iterations_per_step, timing.ms_per_step / t[0].ms_per_step);
    };
    fissure_row("lagged Cholesky, 1e-4 (player default)", t[0], ours);
    fissure_row("lagged Cholesky, 1e-6", t[1], ours_strict);
    fissure_row("Jacobi, 1e-4", t[2], ours_jacobi);
    bullet_row("none, its default ε (≈ 1.5e-8 relative)", t[3]);
    bullet_row("none, 1e-8 (≈ our 1e-4)", t[4]);
    bullet_row("none, 1e-12 (≈ our 1e-6)", t[5]);
    std::fflush(stdout);
  }
}

void print_deflection_table(const std::vector<Beam>& beams, int settle_steps) {
  const sim::Material issue_material = beam_material();
  std::printf("\nStatic tip deflection (mean z drop of the x = L nodes) after %d steps (%g s) at E = %g Pa, as many\n"
              "periods of the first bending mode (so fewer steps) at higher E; mass damping on both (Rayleigh −αMv,\n"
              "α = 2ω₁: critical for the first mode; no stiffness damping). Fissure at the player default, Bullet at\n"
              "its default tolerance. \"last change\": how far the tip moved over the last tenth of the steps.\n\n",
              settle_steps, settle_steps * kDt, issue_material.youngs_modulus);
  std::printf("| beam | E Pa | steps | α 1/s | Euler–Bernoulli m (+ Timoshenko shear) | Fissure tip m (vs E–B) | "
              "last change m | Bullet tip m (vs E–B) | last change m | Bullet − Fissure m |\n"
              "|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Beam& beam : beams) {
    for (const double youngs_modulus : kSettleModuli) {
      const double omega = first_bending_frequency(beam_material(youngs_modulus));
      const int steps = static_cast<int>(std::ceil(settle_steps * first_bending_frequency(issue_material) / omega));
      // Implicit Euler's own numerical damping takes care of the higher modes.
      const sim::Material damped = beam_material(youngs_modulus, 2.0 * omega);
      const double reference = euler_bernoulli_tip(damped);
      FissureBeam ours(beam, damped);
      const Settled fissure = settle(ours, steps);
      BulletBeam bullet(beam, damped, ours.node_masses(), SIMD_EPSILON);
      const Settled peer = settle(bullet, steps);
      std::printf("| %s | %.0e | %d | %.1f | %.4g (+%.2g) | %.4g (%+.1f%%)%s | %.1e | %.4g (%+.1f%%)%s | %.1e | %+.1e |\n",
                  beam.name.c_str(), youngs_modulus, steps, damped.rayleigh_mass, reference,
                  timoshenko_shear_tip(damped), fissure.tip, 100 * (fissure.tip / reference - 1),
                  failures(fissure.failed_steps).c_str(), fissure.last_change, peer.tip, 100 * (peer.tip / reference - 1),
                  failures(peer.failed_steps).c_str(), peer.last_change, peer.tip - fissure.tip);
      if (bullet.clamp_drift() > 0) std::printf("note: Bullet's clamped nodes moved up to %.1e m\n", bullet.clamp_drift());
      std::fflush(stdout);
    }
  }
}

int parse_count(const std::string& flag, const std::string& value, int minimum) {
  return testing::parse_integer_option(flag, value, minimum, kUsage);
}

/// "13x3x3,36x7x7" → {{13, 3, 3}, {36, 7, 7}}.
std::vector<std::array<int, 3>> parse_levels(const std::string& list) {
  std::vector<std::array<int, 3>> levels;
  std::size_t from = 0;
  while (from <= list.size()) {
    const std::size_t comma = std::min(list.find(',', from), list.size());
    const std::string level = list.substr(from, comma - from);
    std::array<int, 3> n{};
    char x1 = 0, x2 = 0, extra = 0;
    if (std::sscanf(level.c_str(), "%d%c%d%c%d%c", &n[0], &x1, &n[1], &x2, &n[2], &extra) != 5 || x1 != 'x' ||
        x2 != 'x' || n[0] < 1 || n[1] < 1 || n[2] < 1) {
      throw Error("--levels: '" + level + "' is not NXxNYxNZ with positive counts", "for example --levels 13x3x3,36x7x7");
    }
    levels.push_back(n);
    from = comma + 1;
  }
  return levels;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    int steps = 50;
    int settle_steps = 1500;
    std::vector<std::array<int, 3>> levels = {{13, 3, 3}, {36, 7, 7}};
    for (int i = 1; i < argc; ++i) {
      const std::string arg = argv[i];
      if (arg == "--help" || arg == "-h") {
        std::fputs(kUsage, stdout);
        return 0;
      }
      if ((arg == "--steps" || arg == "--settle-steps" || arg == "--levels") && i + 1 >= argc) {
        throw Error(arg + " needs a value", kUsage);
      }
      if (arg == "--steps") {
        steps = parse_count(arg, argv[++i], 1);
      } else if (arg == "--settle-steps") {
        settle_steps = parse_count(arg, argv[++i], 0);
      } else if (arg == "--levels") {
        levels = parse_levels(argv[++i]);
      } else {
        throw Error("unknown option '" + arg + "'", kUsage);
      }
    }
    // Bullet's deformable solver is serial; ours gets one thread too.
    const tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
    std::vector<Beam> beams;
    for (const auto& [nx, ny, nz] : levels) beams.push_back(make_beam(nx, ny, nz));

    const sim::Material material = beam_material();
    std::printf("beam %g×%g×%g m, x = 0 clamped, gravity −z; ρ = %g kg/m³, ν = %g; dt = 1/%g s; one thread\n", kLength,
                kWidth, kHeight, material.density, material.poisson_ratio, 1.0 / kDt);
    std::printf("Fissure: warped stiffness, one linear solve per step, CG to ‖r‖ ≤ %g‖b‖.\n", kOurTolerance);
    print_timing_table(beams, steps);
    if (settle_steps > 0) print_deflection_table(beams, settle_steps);
    return 0;
  } catch (const Error& e) {
    std::fputs(format_error(e).c_str(), stderr);
    return 1;
  }
}
