// ImplicitIntegrator::solve_exactly (declared in implicit_integrator.h): backward Euler
// solved to convergence by Newton iterations on the step's incremental potential.
#include <tbb/blocked_range.h>

#include <cmath>

#include "common/assert.h"
#include "player/sim/conjugate_gradient.h"
#include "player/sim/implicit_integrator.h"
#include "player/sim/lanes.h"

namespace fissure::sim {

namespace {
/// Armijo's condition: a step must lower E by at least this share of what the
/// quadratic model promises for it.
constexpr double kSufficientDecrease = 1e-4;
/// The line search halves Newton's step at most this often (to 2⁻³⁰ of it): below, E
/// differs from its start by rounding only, and the iterations stop.
constexpr int kMostHalvings = 30;
/// The conjugate gradients that take A's Newton step to the Hessian's stop at this
/// relative residual, or after this many iterations.
constexpr double kHessianStepTolerance = 1e-3;
constexpr int kMostHessianStepIterations = 20;
/// An iteration whose conjugate gradients took more than this many iterations on an
/// earlier iteration's factor makes the next iteration factor its own A.
constexpr int kRefactorAfterIterations = 8;
/// Converged when the Newton decrement −∇Eᵀδ (twice the decrease the quadratic model
/// promises) is below this share of E's terms' magnitudes: the energy is then right to
/// far below the 1 % the energy check allows.
constexpr double kDecrementTolerance = 1e-10;
}  // namespace

ImplicitIntegrator::ExactSolve ImplicitIntegrator::solve_exactly(const StepSettings& s, const Checkpoint& start,
                                                                 int max_iterations, const Eigen::VectorXd* impulses) {
  FISSURE_ASSERT(start.positions.cols() == node_count() && !m_pattern_dirty);
  FISSURE_ASSERT(impulses == nullptr || impulses->size() == m_system.rows());
  ExactSolve out;
  if (m_system.free_count() == 0) {
    out.converged = true;
    return out;
  }
  const double h = s.dt;
  // β damps with the stiffness at the step's start, as in solve(): keep it before the
  // iterations evaluate elsewhere.
  if (m_material.rayleigh_stiffness != 0.0) m_start_elements = m_elements;
  StepSettings exact = s;
  exact.stiffness = StiffnessModel::Exact;
  set_system_scales(h);
  // Newton starts from the lower in E of solve()'s answer and the start's own velocities
  // (the inertial guess x₀ + h v₀). The guard solves again where solve()'s answer gained
  // energy, so that answer is often far off: in the ν = 0.4999 bunny's later re-solves
  // its decrement was 2–30× E's scale (13.1 → 11.3 Newton iterations per re-solve on the
  // same states with this rule, record 0082).
  Eigen::VectorXd v(m_system.rows()), inertial(m_system.rows());
  for (Index c = 0; c < m_system.free_count(); ++c) {
    const NodeIndex n = m_system.free_node(c);
    v.segment<3>(3 * c) = (m_positions.col(n) - start.positions.col(n)) / h;
    inertial.segment<3>(3 * c) = start.velocities.col(n);
  }
  place(start, inertial, h);
  const double inertial_energy = incremental_potential(s, start, inertial, impulses);
  place(start, v, h);
  double energy = incremental_potential(s, start, v, impulses);
  if (inertial_energy < energy) {
    v.swap(inertial);
    energy = inertial_energy;
    place(start, v, h);
    out.from_inertial_guess = true;
  }
  const double scale = std::abs(energy) + kinetic_energy() + 0.5 * start.velocities.colwise().squaredNorm().dot(m_mass);
  Eigen::VectorXd dv(m_system.rows());
  bool factor_next = true;  // the first iteration factors its A; later ones while the old factor serves
  while (out.iterations < max_iterations) {
    evaluate(exact, false);
    const Eigen::VectorXd b = incremental_residual(s, start, v, impulses);
    m_system.assemble(m_elasticity, m_elements, m_mass, m_system_k_scale, m_system_m_scale);
    ++out.iterations;
    const bool fresh = factor_next;
    bool solved = !fresh || refactor(false);
    out.factorizations += fresh ? 1 : 0;
    if (solved) {
      m_factor.solve(b, dv);
      const HessianStep step = refine_toward_hessian(h * m_material.rayleigh_stiffness, fresh, b, dv);
      factor_next = !fresh && (!step.converged || step.iterations > kRefactorAfterIterations);
      solved = dv.allFinite();
    }
    if (!solved) {
      // The projected stiffness keeps A positive definite, so only a non-finite state
      // gets here: fall back to solve()'s answer, with its system.
      restore(start);
      evaluate(s, false);
      solve(s);
      out.status = SolveStatus::NotPositiveDefinite;
      return out;
    }
    m_system_form = SystemForm::Assembled;
    m_system_inverse = SystemInverse::Factor;
    const double decrement = b.dot(dv);
    if (!(decrement > kDecrementTolerance * scale)) {
      out.converged = true;
      break;
    }
    if (!backtrack(s, start, impulses, dv, decrement, v, energy)) {
      out.converged = true;  // E no longer falls above rounding: v is as good as it gets
      break;
    }
  }
  for (Index c = 0; c < m_system.free_count(); ++c) {
    const NodeIndex n = m_system.free_node(c);
    m_last_dv.col(n) = m_velocities.col(n) - start.velocities.col(n);
  }
  m_smooth_solves = 0;  // as after a contact correction: the next Δv does not extrapolate this one
  m_iterations = 0;     // the factor is of this re-solve's A: a lagged preconditioner may keep it
  return out;
}

void ImplicitIntegrator::multiply_hessian(double damping, const Eigen::VectorXd& x, Eigen::VectorXd& y) {
  symmetric_product(m_system.matrix(), x, y);
  if (damping == 0.0) return;
  // Per tet (K(x) − K₀) x_t, then per free node its sum over its slots in tet order, as
  // BlockSystem::product sums: the result does not depend on the thread count.
  const Matrix4Xu& tets = m_elasticity.tets();
  const std::size_t tet_count = m_elasticity.tet_count();
  m_tet_damping_change.resize(tet_count);
  parallel_for_batches<std::size_t>(tet_count, 512, [&](std::size_t first, int size) {
    Mat34 u[kLanes], now[kLanes], start[kLanes];
    for (int l = 0; l < size; ++l) {
      for (int j = 0; j < 4; ++j) {
        const Index row = m_system.row(tets(j, first + l));
        u[l].col(j) = row == kInvalidIndex ? Vec3::Zero() : Vec3(x.segment<3>(row));
      }
    }
    for (int l = size; l < kLanes; ++l) u[l].setZero();  // never read; for the compiler's uninitialized check
    m_elasticity.stiffness_times(static_cast<TetIndex>(first), size, m_elements, u, now);
    m_elasticity.stiffness_times(static_cast<TetIndex>(first), size, m_start_elements, u, start);
    for (int l = 0; l < size; ++l) m_tet_damping_change[first + l] = now[l] - start[l];
  });
  parallel_for_range<Index>(m_system.free_count(), 256, [&](const tbb::blocked_range<Index>& range) {
    for (Index c = range.begin(); c != range.end(); ++c) y.segment<3>(3 * c) += damping * m_system.gather(c, m_tet_damping_change);
  });
}

ImplicitIntegrator::HessianStep ImplicitIntegrator::refine_toward_hessian(double damping, bool fresh,
                                                                         const Eigen::VectorXd& b, Eigen::VectorXd& dv) {
  // Rayleigh damping's term of E is −½ h β vᵀ K₀ v, with the stiffness at the step's
  // start, as solve() damps; A, assembled from the iteration's own stiffness, has
  // −h β K(x) in its place. Where the two differ (a body turned or crushed within the
  // step) A's Newton steps fell short by the same share every iteration: on the bunny at
  // ν = 0.4999 the decrement halved per iteration, 24–27 factorizations per exact
  // substep. Conjugate gradients on ∇²E itself, preconditioned by a factor of A (this
  // iteration's, or an earlier one's), take the step the rest of the way. They stop at a
  // direction of non-positive curvature (Steihaug), where the step so far still lowers
  // the quadratic model; the step is kept only while it is a descent direction.
  HessianStep out;
  if (damping == 0.0 && fresh) {
    out.converged = true;  // A is ∇²E and dv its exact step
    return out;
  }
  Eigen::VectorXd refined = dv;
  const ConjugateGradientResult cg = conjugate_gradient(
      [&](const Eigen::VectorXd& x, Eigen::VectorXd& y) { multiply_hessian(damping, x, y); }, b, refined,
      [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) { m_factor.solve(r, z); }, kHessianStepTolerance,
      kMostHessianStepIterations);
  if (refined.allFinite() && b.dot(refined) > 0.0) dv.swap(refined);
  out.iterations = cg.iterations;
  out.converged = cg.converged;
  return out;
}

bool ImplicitIntegrator::backtrack(const StepSettings& s, const Checkpoint& start, const Eigen::VectorXd* impulses,
                                   const Eigen::VectorXd& dv, double decrement, Eigen::VectorXd& v, double& energy) {
  Eigen::VectorXd trial(v.size());
  double step = 1.0;
  for (int k = 0; k <= kMostHalvings; ++k, step *= 0.5) {
    trial = v + step * dv;
    place(start, trial, s.dt);
    const double e = incremental_potential(s, start, trial, impulses);
    if (e <= energy - kSufficientDecrease * step * decrement) {
      v.swap(trial);
      energy = e;
      return true;
    }
  }
  place(start, v, s.dt);
  return false;
}

void ImplicitIntegrator::place(const Checkpoint& start, const Eigen::VectorXd& v, double h) {
  for (Index c = 0; c < m_system.free_count(); ++c) {
    const NodeIndex n = m_system.free_node(c);
    m_velocities.col(n) = v.segment<3>(3 * c);
    m_positions.col(n) = start.positions.col(n) + h * m_velocities.col(n);
  }
}

double ImplicitIntegrator::incremental_potential(const StepSettings& s, const Checkpoint& start,
                                                 const Eigen::VectorXd& v, const Eigen::VectorXd* impulses) {
  const double h = s.dt, alpha = m_material.rayleigh_mass, beta = m_material.rayleigh_stiffness;
  double nodal = 0.0;
  for (Index c = 0; c < m_system.free_count(); ++c) {
    const NodeIndex n = m_system.free_node(c);
    const Vec3 vn = v.segment<3>(3 * c);
    nodal += m_mass[n] * (0.5 * (vn - start.velocities.col(n)).squaredNorm() - h * s.gravity.dot(vn) +
                          0.5 * h * alpha * vn.squaredNorm());
  }
  double damping = 0.0;  // −½ h β vᵀ K₀ v, summed in tet order
  if (beta != 0.0) {
    start_stiffness_times(v);
    const Matrix4Xu& tets = m_elasticity.tets();
    for (std::size_t t = 0; t < m_tet_rhs.size(); ++t) {
      for (int j = 0; j < 4; ++j) damping -= 0.5 * h * beta * m_velocities.col(tets(j, t)).dot(m_tet_rhs[t].col(j));
    }
  }
  const double held = impulses != nullptr ? -v.dot(*impulses) : 0.0;
  return nodal + damping + held + m_elasticity.energy(m_positions);
}

Eigen::VectorXd ImplicitIntegrator::incremental_residual(const StepSettings& s, const Checkpoint& start,
                                                         const Eigen::VectorXd& v, const Eigen::VectorXd* impulses) {
  // −∇E = h (f(x) + β K₀ v) + h M (g − α v) − M (v − v₀) (+ p): per tet the first term, then
  // per free node the sum over its slots, in tet order.
  const double h = s.dt, alpha = m_material.rayleigh_mass, beta = m_material.rayleigh_stiffness;
  start_stiffness_times(v);
  for (std::size_t t = 0; t < m_tet_rhs.size(); ++t) m_tet_rhs[t] = m_elements.forces[t] + beta * m_tet_rhs[t];
  Eigen::VectorXd b(m_system.rows());
  parallel_for_range<Index>(m_system.free_count(), 64, [&](const tbb::blocked_range<Index>& range) {
    for (Index c = range.begin(); c != range.end(); ++c) {
      const NodeIndex n = m_system.free_node(c);
      const Vec3 vn = v.segment<3>(3 * c);
      Vec3 sum = m_mass[n] * (h * (s.gravity - alpha * vn) - (vn - start.velocities.col(n)));
      m_system.for_each_slot(c, [&](TetIndex t, int corner) { sum += h * m_tet_rhs[t].col(corner); });
      b.segment<3>(3 * c) = sum;
    }
  });
  if (impulses != nullptr) b += *impulses;
  return b;
}

void ImplicitIntegrator::start_stiffness_times(const Eigen::VectorXd& v) {
  // m_velocities hold v (place()); pinned nodes' are zero.
  FISSURE_ASSERT(v.size() == m_system.rows());
  const std::size_t tet_count = m_elasticity.tet_count();
  m_tet_rhs.resize(tet_count);
  if (m_material.rayleigh_stiffness == 0.0) {
    for (Mat34& m : m_tet_rhs) m.setZero();
    return;
  }
  const Matrix4Xu& tets = m_elasticity.tets();
  parallel_for_batches<std::size_t>(tet_count, 512, [&](std::size_t first, int size) {
    Mat34 u[kLanes], ku[kLanes];
    for (int l = 0; l < size; ++l) {
      for (int j = 0; j < 4; ++j) u[l].col(j) = m_velocities.col(tets(j, first + l));
    }
    for (int l = size; l < kLanes; ++l) u[l].setZero();  // never read; for the compiler's uninitialized check
    m_elasticity.stiffness_times(static_cast<TetIndex>(first), size, m_start_elements, u, ku);
    for (int l = 0; l < size; ++l) m_tet_rhs[first + l] = ku[l];
  });
}

}  // namespace fissure::sim
