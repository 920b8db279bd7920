#include "player/sim/implicit_integrator.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <string>

#include "common/assert.h"
#include "common/error.h"
#include "player/sim/conjugate_gradient.h"

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
/// From this many factor entries the lagged preconditioner keeps its factor in float:
/// its solves are then bound by memory traffic, which float halves. A smaller factor
/// sits in cache, and float would only cost iterations on the ill-conditioned matrices
/// of a fractured cage (measured on the bunny scene, 987 tets: 62 → 97 refactorizations
/// and a 1.2–1.3× slower solve phase).
constexpr std::size_t kSinglePrecisionMinFactorEntries = 200'000;

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
  m_corner_weight.assign(tet_count, Vec4::Constant(0.25));
  for (TetIndex t = 0; t < tet_count; ++t) {
    double fraction = 1.0;
    if (mass != nullptr) {
      fraction = std::clamp(mass->fraction[t], kMinMassFraction, 1.0);
      Vec4 weight = mass->center_of_mass[t].cwiseMax(kMinCornerWeight);
      if (!weight.allFinite()) weight = Vec4::Constant(0.25);
      m_corner_weight[t] = weight / weight.sum();
    }
    m_tet_mass[t] = material.density * m_elasticity.rest_volume(t) * fraction;
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

void ImplicitIntegrator::build_pattern() {
  const Index nodes = node_count();
  m_dof.assign(nodes, kInvalidIndex);
  m_free_nodes.clear();
  for (Index n = 0; n < nodes; ++n) {
    if (!m_pinned[n]) {
      m_dof[n] = 3 * static_cast<Index>(m_free_nodes.size());
      m_free_nodes.push_back(n);
    }
  }
  const Index free_count = m_free_nodes.size();
  const Matrix4Xu& tets = m_elasticity.tets();
  const std::size_t tet_count = m_elasticity.tet_count();

  // Every (column node, row node, tet, i, j) term, sorted: blocks come out grouped by
  // column then row, and each block's terms in tet order.
  struct Term {
    Index column, row;
    BlockTerm term;
  };
  std::vector<Term> terms;
  terms.reserve(tet_count * 16 + free_count);
  for (Index b = 0; b < free_count; ++b) terms.push_back({b, b, {kInvalidIndex, 0, 0}});  // every diagonal block
  for (TetIndex t = 0; t < tet_count; ++t) {
    for (int j = 0; j < 4; ++j) {
      const Index column = m_dof[tets(j, t)];
      if (column == kInvalidIndex) continue;
      for (int i = 0; i < 4; ++i) {
        const Index row = m_dof[tets(i, t)];
        if (row == kInvalidIndex) continue;
        terms.push_back({column / 3, row / 3, {t, static_cast<std::uint8_t>(i), static_cast<std::uint8_t>(j)}});
      }
    }
  }
  std::sort(terms.begin(), terms.end(), [](const Term& a, const Term& b) {
    if (a.column != b.column) return a.column < b.column;
    if (a.row != b.row) return a.row < b.row;
    return a.term.tet + 1 < b.term.tet + 1;  // the diagonal marker (kInvalidIndex) first
  });

  // Blocks and the compressed column storage: column 3c + k lists, per block row r,
  // rows 3r, 3r + 1, 3r + 2, so a block's three columns have the same layout.
  m_block_column_start.assign(free_count + 1, 0);
  m_block_term_start.clear();
  m_block_terms.clear();
  m_block_diagonal.clear();
  std::vector<Index> block_rows;
  for (std::size_t k = 0; k < terms.size(); ++k) {
    const bool new_block = k == 0 || terms[k].column != terms[k - 1].column || terms[k].row != terms[k - 1].row;
    if (new_block) {
      m_block_term_start.push_back(m_block_terms.size());
      m_block_diagonal.push_back(terms[k].row == terms[k].column ? 1 : 0);
      block_rows.push_back(terms[k].row);
      ++m_block_column_start[terms[k].column + 1];
    }
    if (terms[k].term.tet != kInvalidIndex) m_block_terms.push_back(terms[k].term);
  }
  m_block_term_start.push_back(m_block_terms.size());
  for (Index c = 0; c < free_count; ++c) m_block_column_start[c + 1] += m_block_column_start[c];

  const Index rows = 3 * free_count;
  m_matrix = Eigen::SparseMatrix<double>(rows, rows);
  m_matrix.resizeNonZeros(9 * static_cast<Index>(block_rows.size()));
  int* outer = m_matrix.outerIndexPtr();
  int* inner = m_matrix.innerIndexPtr();
  m_block_value.resize(block_rows.size());
  Index value = 0;
  for (Index c = 0; c < free_count; ++c) {
    const Index first = m_block_column_start[c], last = m_block_column_start[c + 1];
    for (int k = 0; k < 3; ++k) {
      outer[3 * c + k] = static_cast<int>(value);
      for (Index b = first; b < last; ++b) {
        if (k == 0) m_block_value[b] = value;
        for (int r = 0; r < 3; ++r) inner[value++] = static_cast<int>(3 * block_rows[b] + r);
      }
    }
  }
  outer[rows] = static_cast<int>(value);
  std::fill(m_matrix.valuePtr(), m_matrix.valuePtr() + value, 0.0);

  // Each tet's corner rows (system_product's gather).
  m_tet_dofs.resize(tet_count);
  for (TetIndex t = 0; t < tet_count; ++t) {
    for (int i = 0; i < 4; ++i) m_tet_dofs[t][i] = m_dof[tets(i, t)];
  }

  // The right-hand side's gather: each free node's (tet, corner) slots in tet order.
  m_incidence_start.assign(free_count + 1, 0);
  for (TetIndex t = 0; t < tet_count; ++t) {
    for (int i = 0; i < 4; ++i) {
      if (m_dof[tets(i, t)] != kInvalidIndex) ++m_incidence_start[m_dof[tets(i, t)] / 3 + 1];
    }
  }
  for (Index c = 0; c < free_count; ++c) m_incidence_start[c + 1] += m_incidence_start[c];
  m_incidence.resize(m_incidence_start[free_count]);
  std::vector<Index> fill(m_incidence_start.begin(), m_incidence_start.end() - 1);
  for (TetIndex t = 0; t < tet_count; ++t) {
    for (int i = 0; i < 4; ++i) {
      if (m_dof[tets(i, t)] != kInvalidIndex) m_incidence[fill[m_dof[tets(i, t)] / 3]++] = {t, i};
    }
  }
  m_cholesky.reset();
  m_pattern_dirty = false;
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
  if (m_pattern_dirty) build_pattern();
  if (m_free_nodes.empty()) {
    // Pinned whole: nothing moves (a factorization of the empty system would fail).
    m_iterations = 0;
    m_phase_times.assembly = m_phase_times.solve = 0.0;
    return SolveStatus::Converged;
  }
  const double h = s.dt;
  const double alpha = m_material.rayleigh_mass, beta = m_material.rayleigh_stiffness;
  // A = M − h D − h² K with D = −αM + βK:  A = (1 + hα) M − (hβ + h²) K.
  // b = h (f + β K v + h K v) = h (f + (β + h) K v), f = elastic + gravity − α M v.
  const double k_scale = h * beta + h * h;
  const double m_scale = 1.0 + h * alpha;
  const Matrix4Xu& tets = m_elasticity.tets();
  const std::size_t tet_count = m_elasticity.tet_count();
  const auto free_count = static_cast<Index>(m_free_nodes.size());
  const auto rows = static_cast<Eigen::Index>(3 * free_count);

  // Per tet f + (β + h) K v; then per free node the sum over its slots, in tet order.
  m_tet_rhs.resize(tet_count);
  parallel_for_batches<std::size_t>(tet_count, 512, [&](std::size_t first, int size) {
    Mat34 v[kLanes], kv[kLanes];
    for (int l = 0; l < size; ++l) {
      for (int j = 0; j < 4; ++j) v[l].col(j) = m_velocities.col(tets(j, first + l));
    }
    m_elasticity.stiffness_times(static_cast<TetIndex>(first), size, m_elements, v, kv);
    for (int l = 0; l < size; ++l) m_tet_rhs[first + l] = m_elements.forces[first + l] + (beta + h) * kv[l];
  });
  Eigen::VectorXd b(rows);
  tbb::parallel_for(tbb::blocked_range<Index>(0, free_count, 64), [&](const tbb::blocked_range<Index>& range) {
    for (Index c = range.begin(); c != range.end(); ++c) {
      const NodeIndex n = m_free_nodes[c];
      Vec3 sum = h * m_mass[n] * (s.gravity - alpha * m_velocities.col(n));
      for (Index k = m_incidence_start[c]; k < m_incidence_start[c + 1]; ++k) {
        const auto& [t, corner] = m_incidence[k];
        sum += h * m_tet_rhs[t].col(corner);
      }
      b.segment<3>(3 * c) = sum;
    }
  });
  // The lagged factor is refreshed when the last solve needed too many iterations, the
  // pattern changed (build_pattern drops the factor) or dt changed.
  const bool lagged = s.solver == LinearSolver::ConjugateGradient && s.preconditioner == Preconditioner::LaggedCholesky;
  const bool refactor_lagged = lagged && (!m_cholesky.factorized() || m_iterations > s.refactor_iterations ||
                                          k_scale != m_factored_k_scale || m_scale != m_factored_m_scale);
  // Only a factorization or Jacobi's product needs the assembled matrix: conjugate
  // gradients with the lagged factor multiply by A element by element (system_product),
  // which costs about what one sparse product does and saves the assembly.
  if (!lagged || refactor_lagged) assemble_matrix(k_scale, m_scale);

  m_phase_times.assembly = seconds_since(phase_start);
  phase_start = Clock::now();
  Eigen::VectorXd dv(rows);
  SolveStatus status = SolveStatus::Converged;
  const auto refactor = [&]() {
    if (!m_cholesky.analyzed()) m_cholesky.analyze(m_matrix);
    ++m_factorizations;
    m_factored_k_scale = k_scale;
    m_factored_m_scale = m_scale;
    m_factored_rotations = m_elements.rotations;
    const bool single = lagged && m_cholesky.factor_nonzeros() >= kSinglePrecisionMinFactorEntries;
    return m_cholesky.factorize(m_matrix, single ? FactorPrecision::Single : FactorPrecision::Double);
  };
  m_system_form = SystemForm::None;
  m_system_k_scale = k_scale;
  m_system_m_scale = m_scale;
  if (s.solver == LinearSolver::Direct) {
    if (!refactor()) return SolveStatus::NotPositiveDefinite;
    m_cholesky.solve(b, dv);
    m_iterations = 1;
    m_system_form = SystemForm::Assembled;
    m_system_inverse = SystemInverse::Factor;
  } else {
    // The warm start (see m_last_dv): extrapolated only across smooth solves.
    const bool extrapolate = m_smooth_solves >= 2 && h == m_last_dt;
    for (Index c = 0; c < free_count; ++c) {
      const NodeIndex n = m_free_nodes[c];
      dv.segment<3>(3 * c) = extrapolate ? Vec3(2.0 * m_last_dv.col(n) - m_previous_dv.col(n)) : Vec3(m_last_dv.col(n));
    }
    if (lagged) {
      if (refactor_lagged && !refactor()) return SolveStatus::NotPositiveDefinite;
      update_node_rotations();
      m_system_form = SystemForm::MatrixFree;
      m_system_inverse = SystemInverse::RotatedFactor;
    } else {
      m_inverse_diagonal = m_matrix.diagonal().cwiseInverse();
      m_system_form = SystemForm::Assembled;
      m_system_inverse = SystemInverse::Jacobi;
    }
    const auto product = [&](const Eigen::VectorXd& x, Eigen::VectorXd& y) { multiply_system(x, y); };
    const auto precondition = [&](const Eigen::VectorXd& r, Eigen::VectorXd& z) { precondition_system(r, z); };
    const ConjugateGradientResult cg = conjugate_gradient(product, b, dv, precondition, s.tolerance, s.max_iterations);
    m_iterations = cg.iterations;
    if (!cg.converged) status = SolveStatus::MaxIterations;
  }
  m_phase_times.solve = seconds_since(phase_start);
  if (!dv.allFinite()) return SolveStatus::NonFinite;
  for (Index c = 0; c < free_count; ++c) {
    const NodeIndex n = m_free_nodes[c];
    m_previous_dv.col(n) = m_last_dv.col(n);
    m_last_dv.col(n) = dv.segment<3>(3 * c);
    m_velocities.col(n) += dv.segment<3>(3 * c);
    m_positions.col(n) += h * m_velocities.col(n);
  }
  m_smooth_solves = h == m_last_dt ? std::min(m_smooth_solves + 1, 2) : 1;
  m_last_dt = h;
  return status;
}

Mat3 ImplicitIntegrator::stiffness_block(Index block) const {
  const bool warped = m_elements.model == StiffnessModel::Warped;
  Mat3 K = Mat3::Zero();
  for (Index k = m_block_term_start[block]; k < m_block_term_start[block + 1]; ++k) {
    const BlockTerm& term = m_block_terms[k];
    K += warped ? m_elasticity.warped_block(term.tet, m_elements.rotated_gradients[term.tet], term.i, term.j)
                : Mat3(m_elements.stiffness[term.tet].block<3, 3>(3 * term.i, 3 * term.j));
  }
  return K;
}

Mat3 ImplicitIntegrator::system_diagonal_block(NodeIndex node) const {
  FISSURE_ASSERT(m_system_form != SystemForm::None && m_dof[node] != kInvalidIndex);
  const Index c = m_dof[node] / 3;
  for (Index block = m_block_column_start[c]; block < m_block_column_start[c + 1]; ++block) {
    if (!m_block_diagonal[block]) continue;
    Mat3 A = -m_system_k_scale * stiffness_block(block);
    A.diagonal().array() += m_system_m_scale * m_mass[node];
    return A;
  }
  return m_system_m_scale * m_mass[node] * Mat3::Identity();
}

void ImplicitIntegrator::multiply_system(const Eigen::VectorXd& x, Eigen::VectorXd& y) {
  FISSURE_ASSERT(m_system_form != SystemForm::None);
  if (m_system_form == SystemForm::Assembled) {
    symmetric_product(m_matrix, x, y);
  } else {
    system_product(m_system_k_scale, m_system_m_scale, x, y);
  }
}

void ImplicitIntegrator::precondition_system(const Eigen::VectorXd& r, Eigen::VectorXd& z) {
  FISSURE_ASSERT(m_system_form != SystemForm::None);
  switch (m_system_inverse) {
    case SystemInverse::Factor: m_cholesky.solve(r, z); return;
    case SystemInverse::Jacobi: z = m_inverse_diagonal.cwiseProduct(r); return;
    case SystemInverse::RotatedFactor: {
      // z = R A_f⁻¹ Rᵀ r.
      const auto free_count = static_cast<Index>(m_free_nodes.size());
      Eigen::VectorXd rotated(r.size());
      for (Index c = 0; c < free_count; ++c) {
        rotated.segment<3>(3 * c) = m_node_rotation[c].transpose() * r.segment<3>(3 * c);
      }
      m_cholesky.solve(rotated, z);
      for (Index c = 0; c < free_count; ++c) z.segment<3>(3 * c) = m_node_rotation[c] * z.segment<3>(3 * c).eval();
      return;
    }
    case SystemInverse::None: break;
  }
  z = r;
}

void ImplicitIntegrator::correct_velocities(const Eigen::VectorXd& delta, double h) {
  FISSURE_ASSERT(delta.size() == system_size());
  m_smooth_solves = 0;  // the next Δv answers a contact: do not extrapolate across it
  const auto free_count = static_cast<Index>(m_free_nodes.size());
  for (Index c = 0; c < free_count; ++c) {
    const NodeIndex n = m_free_nodes[c];
    const Vec3 d = delta.segment<3>(3 * c);
    m_last_dv.col(n) += d;
    m_velocities.col(n) += d;
    m_positions.col(n) += h * d;
  }
}

void ImplicitIntegrator::assemble_matrix(double k_scale, double m_scale) {
  double* values = m_matrix.valuePtr();
  const auto free_count = static_cast<Index>(m_free_nodes.size());
  tbb::parallel_for(tbb::blocked_range<Index>(0, free_count, 64), [&](const tbb::blocked_range<Index>& range) {
    for (Index c = range.begin(); c != range.end(); ++c) {
      const NodeIndex n = m_free_nodes[c];
      // This node's block column: every block is one task's, so no two threads write
      // the same value, and each block sums its terms in tet order.
      const Index column_length = 3 * (m_block_column_start[c + 1] - m_block_column_start[c]);
      for (Index block = m_block_column_start[c]; block < m_block_column_start[c + 1]; ++block) {
        Mat3 A = -k_scale * stiffness_block(block);
        if (m_block_diagonal[block]) A.diagonal().array() += m_scale * m_mass[n];
        double* out = values + m_block_value[block];
        for (int col = 0; col < 3; ++col) {
          for (int row = 0; row < 3; ++row) out[col * column_length + row] = A(row, col);
        }
      }
    }
  });
}

void ImplicitIntegrator::system_product(double k_scale, double m_scale, const Eigen::VectorXd& x,
                                        Eigen::VectorXd& y) {
  // y = m_scale M x − k_scale K x. Per tet K_t x_t (pinned corners contribute 0), then
  // per free node the sum over its slots in tet order: deterministic, like assembly.
  const std::size_t tet_count = m_elasticity.tet_count();
  m_tet_product.resize(tet_count);
  parallel_for_batches<std::size_t>(tet_count, 512, [&](std::size_t first, int size) {
    Mat34 u[kLanes];
    for (int l = 0; l < size; ++l) {
      for (int j = 0; j < 4; ++j) {
        const Index dof = m_tet_dofs[first + l][j];
        u[l].col(j) = dof == kInvalidIndex ? Vec3::Zero() : Vec3(x.segment<3>(dof));
      }
    }
    m_elasticity.stiffness_times(static_cast<TetIndex>(first), size, m_elements, u, &m_tet_product[first]);
  });
  const auto free_count = static_cast<Index>(m_free_nodes.size());
  y.resize(x.size());
  tbb::parallel_for(tbb::blocked_range<Index>(0, free_count, 256), [&](const tbb::blocked_range<Index>& range) {
    for (Index c = range.begin(); c != range.end(); ++c) {
      Vec3 sum = Vec3::Zero();
      for (Index k = m_incidence_start[c]; k < m_incidence_start[c + 1]; ++k) {
        const auto& [t, corner] = m_incidence[k];
        sum += m_tet_product[t].col(corner);
      }
      y.segment<3>(3 * c) = m_scale * m_mass[m_free_nodes[c]] * x.segment<3>(3 * c) - k_scale * sum;
    }
  });
}

void ImplicitIntegrator::update_node_rotations() {
  // Each tet's rotation change once (a node has ~16 tets), then per node their sum.
  const std::size_t tet_count = m_elasticity.tet_count();
  m_tet_rotation_change.resize(tet_count);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, tet_count, 1024), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t t = r.begin(); t != r.end(); ++t) {
      m_tet_rotation_change[t].noalias() = m_elements.rotations[t] * m_factored_rotations[t].transpose();
    }
  });
  const auto free_count = static_cast<Index>(m_free_nodes.size());
  m_node_rotation.resize(free_count);
  parallel_for_batches<Index>(free_count, 256, [&](Index first, int size) {
    Mat3 sums[kLanes];
    for (int l = 0; l < size; ++l) {
      const Index c = first + l;
      sums[l].setZero();
      for (Index k = m_incidence_start[c]; k < m_incidence_start[c + 1]; ++k) {
        sums[l] += m_tet_rotation_change[m_incidence[k].first];
      }
    }
    polar_rotations(sums, &m_node_rotation[first], size);
  });
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
