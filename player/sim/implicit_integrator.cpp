#include "player/sim/implicit_integrator.h"

#include <tbb/blocked_range.h>

#include <algorithm>
#include <chrono>
#include <string>

#include "common/assert.h"
#include "common/error.h"
#include "player/sim/conjugate_gradient.h"
#include "player/sim/lanes.h"
#include "player/sim/rigid_rotation.h"

namespace fissure::sim {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

/// Below this share of a tet's mass no corner goes: a node whose tets all hold their
/// solid far from it would otherwise get (almost) no mass and an ill-conditioned row.
constexpr double kMinCornerWeight = 0.05;
/// Below this solid fraction a tet counts as this much: an empty cage tet still has
/// to move with its nodes, and a massless node makes M singular.
constexpr double kMinMassFraction = 1e-3;
/// A lagged solve that has taken this many times StepSettings::refactor_iterations
/// refactors at once and goes on from its iterate, instead of refactoring only at the
/// next step. Where the factor no longer fits A (the exact re-solve left the factor of
/// its last Newton system, or fragments just broken off spin fast at ν = 0.4999),
/// conjugate gradients otherwise ran on to 300-500 iterations, 100-160 ms of a step,
/// where a factorization of the sample's cage takes about what 35 iterations do.
constexpr int kStaleFactorShare = 4;
int stale_factor_iterations(const StepSettings& s) { return kStaleFactorShare * s.refactor_iterations; }

/// LooseNodes: the largest part eliminated densely each step (record 0084: with
/// StepSettings::loose_node_slots = 4 and no limit, the sample's parts joined into ones
/// that tripled its solve phase).
constexpr int kLoosePartNodes = 64;
}  // namespace

const char* to_string(SolveStatus status) {
  switch (status) {
    case SolveStatus::Converged: return "converged";
    case SolveStatus::MaxIterations: return "iteration cap reached";
    case SolveStatus::NotPositiveDefinite: return "system not positive definite";
    case SolveStatus::NonFinite: return "non-finite solution";
  }
  return "unknown";
}

ImplicitIntegrator::ImplicitIntegrator(const Matrix3Xd& rest, const Matrix4Xu& tets, const Material& material,
                                       const MassDistribution* mass)
    : m_positions(rest),
      m_velocities(Matrix3Xd::Zero(3, rest.cols())),
      m_elasticity(rest, tets, material),
      m_material(material),
      m_rest(rest),
      m_pinned(static_cast<std::size_t>(rest.cols()), 0),
      m_last_dv(Matrix3Xd::Zero(3, rest.cols())),
      m_previous_dv(Matrix3Xd::Zero(3, rest.cols())) {
  const std::size_t tet_count = m_elasticity.tet_count();
  if (mass != nullptr && (mass->fraction.size() != tet_count || mass->center_of_mass.size() != tet_count)) {
    throw Error("mass distribution has " + std::to_string(mass->fraction.size()) + " fractions and " +
                    std::to_string(mass->center_of_mass.size()) + " centres for " + std::to_string(tet_count) +
                    " tets",
                "pass one fraction and one barycentric centre of mass per tet");
  }
  m_tet_mass.resize(tet_count);
  m_solid_fraction.assign(tet_count, 1.0);
  m_corner_weight.assign(tet_count, Vec4::Constant(0.25));
  for (TetIndex t = 0; t < tet_count; ++t) {
    double fraction = 1.0;
    if (mass != nullptr) {
      fraction = std::clamp(mass->fraction[t], kMinMassFraction, 1.0);
      Vec4 weight = mass->center_of_mass[t].cwiseMax(kMinCornerWeight);
      if (!weight.allFinite()) weight = Vec4::Constant(0.25);
      m_corner_weight[t] = weight / weight.sum();
    }
    m_solid_fraction[t] = fraction;
  }
  compute_tet_masses(material.density);
}

void ImplicitIntegrator::set_material(const Material& material) {
  m_elasticity.set_material(material);  // validates first: nothing changes on an error
  compute_tet_masses(material.density);
  m_material = material;
  m_pattern_dirty = true;  // the matrix's values change everywhere: factor afresh
}

void ImplicitIntegrator::compute_tet_masses(double density) {
  // One expression for the constructor and set_material(): a world edited to a material
  // steps bit for bit as one built with it.
  for (TetIndex t = 0; t < m_elasticity.tet_count(); ++t) {
    m_tet_mass[t] = density * m_elasticity.rest_volume(t) * m_solid_fraction[t];
  }
  lump_masses();
}

void ImplicitIntegrator::lump_masses() {
  m_mass = Eigen::VectorXd::Zero(m_positions.cols());
  const Matrix4Xu& tets = m_elasticity.tets();
  for (TetIndex t = 0; t < m_elasticity.tet_count(); ++t) {
    for (int i = 0; i < 4; ++i) m_mass[tets(i, t)] += m_tet_mass[t] * m_corner_weight[t][i];
  }
  // A node no tet uses (a cage with stray nodes) keeps a nominal mass so it stays put.
  for (Eigen::Index n = 0; n < m_mass.size(); ++n) {
    if (!(m_mass[n] > 0.0)) m_mass[n] = 1.0;
  }
}

void ImplicitIntegrator::pin(std::span<const NodeIndex> nodes) {
  for (const NodeIndex node : nodes) {
    if (node >= node_count()) {
      throw Error("pinned node " + std::to_string(node) + " does not exist (the body has " +
                      std::to_string(node_count()) + " nodes)",
                  "node indices are 0-based cage node numbers");
    }
    m_pinned[node] = 1;
    m_velocities.col(node).setZero();
  }
  m_smooth_solves = 0;
  m_pattern_dirty = true;
  m_system_form = SystemForm::None;
}

void ImplicitIntegrator::hold(std::span<const NodeIndex> nodes) {
  for (const NodeIndex node : nodes) {
    FISSURE_ASSERT(node < node_count());
    if (m_pinned[node] != 0) continue;
    m_pinned[node] = kHeld;
    m_velocities.col(node).setZero();
    m_last_dv.col(node).setZero();
    m_previous_dv.col(node).setZero();
  }
  m_smooth_solves = 0;
  m_pattern_dirty = true;
  m_system_form = SystemForm::None;
}

void ImplicitIntegrator::release(std::span<const NodeIndex> nodes) {
  for (const NodeIndex node : nodes) {
    FISSURE_ASSERT(node < node_count());
    if (m_pinned[node] == kHeld) m_pinned[node] = 0;
  }
  m_smooth_solves = 0;
  m_pattern_dirty = true;
  m_system_form = SystemForm::None;
}

NodeIndex ImplicitIntegrator::split_node(NodeIndex node, std::span<const std::pair<TetIndex, int>> slots) {
  const NodeIndex added = node_count();
  const auto grow = [&](Matrix3Xd& m) {
    m.conservativeResize(Eigen::NoChange, m.cols() + 1);
    m.col(added) = m.col(node);
  };
  grow(m_positions);
  grow(m_velocities);
  grow(m_rest);
  grow(m_last_dv);
  grow(m_previous_dv);
  m_pinned.push_back(m_pinned[node]);
  for (const auto& [t, corner] : slots) {
    FISSURE_ASSERT(m_elasticity.tets()(corner, t) == node);
    m_elasticity.replace_node(t, corner, added);
  }
  lump_masses();
  m_pattern_dirty = true;
  m_system_form = SystemForm::None;
  return added;
}

void ImplicitIntegrator::undo_split(NodeIndex node, NodeIndex added) {
  FISSURE_ASSERT(added + 1 == node_count() && node < added);
  const Matrix4Xu& tets = m_elasticity.tets();
  for (TetIndex t = 0; t < m_elasticity.tet_count(); ++t) {
    for (int corner = 0; corner < 4; ++corner) {
      if (tets(corner, t) == added) m_elasticity.replace_node(t, corner, node);
    }
  }
  const auto shrink = [](Matrix3Xd& m) { m.conservativeResize(Eigen::NoChange, m.cols() - 1); };
  shrink(m_positions);
  shrink(m_velocities);
  shrink(m_rest);
  shrink(m_last_dv);
  shrink(m_previous_dv);
  m_pinned.pop_back();
  lump_masses();
  m_pattern_dirty = true;
  m_system_form = SystemForm::None;
}

void ImplicitIntegrator::save(Checkpoint& out) const {
  out.positions = m_positions;
  out.velocities = m_velocities;
  out.last_dv = m_last_dv;
  out.previous_dv = m_previous_dv;
  out.smooth_solves = m_smooth_solves;
  out.iterations = m_iterations;
  out.last_dt = m_last_dt;
}

void ImplicitIntegrator::restore(const Checkpoint& checkpoint) {
  FISSURE_ASSERT(checkpoint.positions.cols() == node_count());
  m_positions = checkpoint.positions;
  m_velocities = checkpoint.velocities;
  m_last_dv = checkpoint.last_dv;
  m_previous_dv = checkpoint.previous_dv;
  m_smooth_solves = checkpoint.smooth_solves;
  m_iterations = checkpoint.iterations;
  m_last_dt = checkpoint.last_dt;
  m_system_form = SystemForm::None;
}

void ImplicitIntegrator::set_positions(const Matrix3Xd& x) {
  check_state(x, "positions");
  m_positions = x;
  m_smooth_solves = 0;
  m_system_form = SystemForm::None;
}

void ImplicitIntegrator::set_velocities(const Matrix3Xd& v) {
  check_state(v, "velocities");
  m_velocities = v;
  for (Index n = 0; n < node_count(); ++n) {
    if (m_pinned[n]) m_velocities.col(n).setZero();
  }
  m_smooth_solves = 0;
}

void ImplicitIntegrator::check_state(const Matrix3Xd& m, const char* what) const {
  if (m.rows() != 3 || m.cols() != node_count()) {
    throw Error(std::string(what) + " are " + std::to_string(m.rows()) + "×" + std::to_string(m.cols()) +
                    " for a body of " + std::to_string(node_count()) + " nodes",
                "pass one column per node");
  }
  if (!m.allFinite()) throw Error(std::string(what) + " hold a non-finite value", "pass finite values");
}

void ImplicitIntegrator::set_system_scales(double h) {
  // A = M − h D − h² K with D = −αM + βK:  A = (1 + hα) M − (hβ + h²) K.
  m_system_k_scale = h * m_material.rayleigh_stiffness + h * h;
  m_system_m_scale = 1.0 + h * m_material.rayleigh_mass;
}

bool ImplicitIntegrator::prepare(const StepSettings& s) {
  const bool lagged = s.solver == LinearSolver::ConjugateGradient && s.preconditioner == Preconditioner::LaggedCholesky;
  if (!lagged) return true;
  update_pattern(s);
  if (m_system.free_count() == 0) return true;
  evaluate(s, false);
  set_system_scales(s.dt);
  m_system.assemble(m_elasticity, m_elements, m_mass, m_system_k_scale, m_system_m_scale);
  const bool factored = refactor(true);
  m_system_form = SystemForm::None;
  return factored;
}

SolveStatus ImplicitIntegrator::step(const StepSettings& settings) {
  evaluate(settings, false);
  return solve(settings);
}

void ImplicitIntegrator::evaluate(const StepSettings& settings, bool with_stress) {
  const auto start = Clock::now();
  m_elasticity.evaluate(m_positions, settings.stiffness, with_stress, m_elements);
  m_system_form = SystemForm::None;
  m_phase_times.forces = seconds_since(start);
}

SolveStatus ImplicitIntegrator::solve(const StepSettings& s) {
  auto phase_start = Clock::now();
  update_pattern(s);
  if (m_system.free_count() == 0) {
    // Pinned whole: nothing moves (a factorization of the empty system would fail).
    m_iterations = 0;
    m_phase_times.assembly = m_phase_times.solve = 0.0;
    return SolveStatus::Converged;
  }
  const double h = s.dt;
  set_system_scales(h);
  const Eigen::VectorXd b = right_hand_side(s);
  // The lagged factor is refreshed when the last solve needed too many iterations, the
  // pattern changed (the factor was reset) or dt changed.
  const bool lagged = s.solver == LinearSolver::ConjugateGradient && s.preconditioner == Preconditioner::LaggedCholesky;
  const bool refactor_lagged =
      lagged && m_factor.stale(m_iterations, s.refactor_iterations, m_system_k_scale, m_system_m_scale);
  // Only a factorization or Jacobi's product needs the assembled matrix: conjugate
  // gradients with the lagged factor multiply by A element by element (BlockSystem::
  // product), which costs about what one sparse product does and saves the assembly.
  if (!lagged || refactor_lagged) {
    m_system.assemble(m_elasticity, m_elements, m_mass, m_system_k_scale, m_system_m_scale);
  }
  m_phase_times.assembly = seconds_since(phase_start);
  phase_start = Clock::now();
  Eigen::VectorXd dv(m_system.rows());
  m_system_form = SystemForm::None;
  SolveStatus status = SolveStatus::Converged;
  if (s.solver == LinearSolver::Direct) {
    if (!refactor(false)) return SolveStatus::NotPositiveDefinite;
    m_factor.solve(b, dv);
    m_iterations = 1;
    m_system_form = SystemForm::Assembled;
    m_system_inverse = SystemInverse::Factor;
  } else {
    if (refactor_lagged && !refactor(true)) return SolveStatus::NotPositiveDefinite;
    status = solve_iteratively(s, b, dv, lagged && !refactor_lagged);
    if (status == SolveStatus::NotPositiveDefinite) return status;
  }
  m_phase_times.solve = seconds_since(phase_start);
  if (!dv.allFinite()) return SolveStatus::NonFinite;
  advance(dv, h);
  return status;
}

Eigen::VectorXd ImplicitIntegrator::right_hand_side(const StepSettings& s) {
  // b = h (f + β K v + h K v) = h (f + (β + h) K v), f = elastic + gravity − α M v:
  // per tet f + (β + h) K v; then per free node the sum over its slots, in tet order.
  const double h = s.dt;
  const double alpha = m_material.rayleigh_mass, beta = m_material.rayleigh_stiffness;
  const Matrix4Xu& tets = m_elasticity.tets();
  const std::size_t tet_count = m_elasticity.tet_count();
  m_tet_rhs.resize(tet_count);
  parallel_for_batches<std::size_t>(tet_count, 512, [&](std::size_t first, int size) {
    Mat34 v[kLanes], kv[kLanes];
    for (int l = 0; l < size; ++l) {
      for (int j = 0; j < 4; ++j) v[l].col(j) = m_velocities.col(tets(j, first + l));
    }
    m_elasticity.stiffness_times(static_cast<TetIndex>(first), size, m_elements, v, kv);
    for (int l = 0; l < size; ++l) m_tet_rhs[first + l] = m_elements.forces[first + l] + (beta + h) * kv[l];
  });
  Eigen::VectorXd b(m_system.rows());
  parallel_for_range<Index>(m_system.free_count(), 64, [&](const tbb::blocked_range<Index>& range) {
    for (Index c = range.begin(); c != range.end(); ++c) {
      const NodeIndex n = m_system.free_node(c);
      Vec3 sum = h * m_mass[n] * (s.gravity - alpha * m_velocities.col(n));
      m_system.for_each_slot(c, [&](TetIndex t, int corner) { sum += h * m_tet_rhs[t].col(corner); });
      b.segment<3>(3 * c) = sum;
    }
  });
  return b;
}

void ImplicitIntegrator::update_pattern(const StepSettings& settings) {
  const bool rebuild = m_pattern_dirty;
  if (rebuild) {
    m_system.build(m_elasticity.tets(), m_pinned);
    m_factor.reset();
    m_pattern_dirty = false;
  }
  if (rebuild || settings.loose_node_slots != m_loose_node_slots) {
    m_loose_node_slots = settings.loose_node_slots;
    m_loose_nodes.find(m_elasticity.tets(), m_system, m_loose_node_slots, kLoosePartNodes);
  }
}

bool ImplicitIntegrator::refactor(bool lagged) {
  ++m_factorizations;
  return m_factor.factorize(m_system.matrix(), m_system_k_scale, m_system_m_scale, m_elements.rotations, lagged);
}

SolveStatus ImplicitIntegrator::solve_iteratively(const StepSettings& s, const Eigen::VectorXd& b, Eigen::VectorXd& dv,
                                                  bool may_refactor) {
  // The warm start (see m_last_dv): extrapolated only across smooth solves.
  const bool extrapolate = m_smooth_solves >= 2 && s.dt == m_last_dt;
  for (Index c = 0; c < m_system.free_count(); ++c) {
    const NodeIndex n = m_system.free_node(c);
    dv.segment<3>(3 * c) = extrapolate ? Vec3(2.0 * m_last_dv.col(n) - m_previous_dv.col(n)) : Vec3(m_last_dv.col(n));
  }
  if (s.preconditioner == Preconditioner::LaggedCholesky) {
    m_factor.follow_rotations(m_elements.rotations, m_system);
    if (!m_loose_nodes.empty()) {
      m_loose_nodes.update(m_elasticity, m_elements, m_mass, m_system, m_system_k_scale, m_system_m_scale);
    }
    m_system_form = SystemForm::MatrixFree;
    m_system_inverse = SystemInverse::RotatedFactor;
  } else {
    m_inverse_diagonal = m_system.matrix().diagonal().cwiseInverse();
    m_system_form = SystemForm::Assembled;
    m_system_inverse = SystemInverse::Jacobi;
  }
  const auto product = [&](const Eigen::VectorXd& x, Eigen::VectorXd& y) { multiply_system(x, y); };
  const auto precondition = [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) { precondition_system(r, z); };
  const int lagged_cap = may_refactor ? std::min(s.max_iterations, stale_factor_iterations(s)) : s.max_iterations;
  ConjugateGradientResult cg = conjugate_gradient(product, b, dv, precondition, s.tolerance, lagged_cap);
  m_iterations = cg.iterations;
  if (!cg.converged && lagged_cap < s.max_iterations) {
    // The lagged factor has stopped fitting A (kStaleFactorShare): refactor now and go
    // on from the iterate reached. m_iterations keeps the whole count, so the next step
    // refactors too, as it would have after the long solve.
    m_system.assemble(m_elasticity, m_elements, m_mass, m_system_k_scale, m_system_m_scale);
    if (!refactor(true)) return SolveStatus::NotPositiveDefinite;
    m_factor.follow_rotations(m_elements.rotations, m_system);
    cg = conjugate_gradient(product, b, dv, precondition, s.tolerance, s.max_iterations - lagged_cap);
    m_iterations += cg.iterations;
  }
  return cg.converged ? SolveStatus::Converged : SolveStatus::MaxIterations;
}

void ImplicitIntegrator::advance(const Eigen::VectorXd& dv, double h) {
  for (Index c = 0; c < m_system.free_count(); ++c) {
    const NodeIndex n = m_system.free_node(c);
    m_previous_dv.col(n) = m_last_dv.col(n);
    m_last_dv.col(n) = dv.segment<3>(3 * c);
    m_velocities.col(n) += dv.segment<3>(3 * c);
    m_positions.col(n) += h * m_velocities.col(n);
  }
  m_smooth_solves = h == m_last_dt ? std::min(m_smooth_solves + 1, 2) : 1;
  m_last_dt = h;
}

Mat3 ImplicitIntegrator::system_diagonal_block(NodeIndex node) const {
  FISSURE_ASSERT(m_system_form != SystemForm::None);
  return m_system.diagonal_block(node, m_elasticity, m_elements, m_mass[node], m_system_k_scale, m_system_m_scale);
}

Mat3 ImplicitIntegrator::system_tet_block(TetIndex t, int i, int j) const {
  FISSURE_ASSERT(m_system_form != SystemForm::None);
  return -m_system_k_scale * BlockSystem::tet_stiffness_block(t, i, j, m_elasticity, m_elements);
}

void ImplicitIntegrator::multiply_system(const Eigen::VectorXd& x, Eigen::VectorXd& y) {
  FISSURE_ASSERT(m_system_form != SystemForm::None);
  if (m_system_form == SystemForm::Assembled) {
    symmetric_product(m_system.matrix(), x, y);
  } else {
    m_system.product(m_elasticity, m_elements, m_mass, m_system_k_scale, m_system_m_scale, x, y);
  }
}

void ImplicitIntegrator::precondition_system(const Eigen::VectorXd& r, Eigen::VectorXd& z) {
  FISSURE_ASSERT(m_system_form != SystemForm::None);
  switch (m_system_inverse) {
    case SystemInverse::Factor: m_factor.solve(r, z); return;
    case SystemInverse::Jacobi: z = m_inverse_diagonal.cwiseProduct(r); return;
    case SystemInverse::RotatedFactor:
      if (m_loose_nodes.empty()) {
        m_factor.rotated_solve(r, z);
      } else {
        m_loose_nodes.precondition(r, z, [&](const Eigen::VectorXd& core, Eigen::VectorXd& out) { m_factor.rotated_solve(core, out); });
      }
      return;
    case SystemInverse::None: break;
  }
  z = r;
}

void ImplicitIntegrator::correct_velocities(const Eigen::VectorXd& delta, double h) {
  FISSURE_ASSERT(delta.size() == system_size());
  m_smooth_solves = 0;  // the next Δv answers a contact: do not extrapolate across it
  for (Index c = 0; c < m_system.free_count(); ++c) {
    const NodeIndex n = m_system.free_node(c);
    const Vec3 d = delta.segment<3>(3 * c);
    m_last_dv.col(n) += d;
    m_velocities.col(n) += d;
    m_positions.col(n) += h * d;
  }
}

void ImplicitIntegrator::save_motion(Motion& out) const {
  out.positions = m_positions;
  out.velocities = m_velocities;
  out.last_dv = m_last_dv;
}

void ImplicitIntegrator::restore_motion(const Motion& motion) {
  FISSURE_ASSERT(motion.positions.cols() == node_count() && motion.velocities.cols() == node_count());
  m_positions = motion.positions;
  m_velocities = motion.velocities;
  m_last_dv = motion.last_dv;
  m_smooth_solves = 0;  // as after correct_velocities: the next Δv answers a contact
}

double ImplicitIntegrator::rotate_rigid_parts(const Matrix3Xd& start, std::span<const Index> node_fragment,
                                              Index fragments, std::span<const std::uint8_t> rigid_fragments) {
  FISSURE_ASSERT(start.cols() == m_positions.cols() && node_fragment.size() == m_pinned.size());
  return sim::rotate_rigid_parts(start, m_mass, m_pinned, node_fragment, fragments, m_positions, m_velocities,
                                 rigid_fragments);
}

void ImplicitIntegrator::move_rigidly(const Matrix3Xd& start, std::span<const Index> node_fragment, Index fragments,
                                      std::span<const std::uint8_t> chosen) {
  FISSURE_ASSERT(start.cols() == m_positions.cols() && node_fragment.size() == m_pinned.size() &&
                 chosen.size() == static_cast<std::size_t>(fragments));
  // rotate_rigid_parts leaves a fragment with a pinned node as it is: the others are
  // passed as pinned.
  std::vector<std::uint8_t> left(m_pinned.size());
  for (std::size_t n = 0; n < left.size(); ++n) left[n] = m_pinned[n] != 0 || !chosen[node_fragment[n]];
  sim::rotate_rigid_parts(start, m_mass, left, node_fragment, fragments, m_positions, m_velocities, chosen);
}

double ImplicitIntegrator::kinetic_energy() const {
  double kinetic = 0.0;
  for (Index n = 0; n < node_count(); ++n) kinetic += 0.5 * m_mass[n] * m_velocities.col(n).squaredNorm();
  return kinetic;
}

double ImplicitIntegrator::energy() const { return kinetic_energy() + m_elasticity.energy(m_positions); }

Vec3 ImplicitIntegrator::angular_momentum() const {
  Vec3 l = Vec3::Zero();
  for (Index n = 0; n < node_count(); ++n) l += m_mass[n] * m_positions.col(n).cross(m_velocities.col(n));
  return l;
}

}  // namespace fissure::sim
