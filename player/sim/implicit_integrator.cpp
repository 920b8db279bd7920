#include "player/sim/implicit_integrator.h"

#include <Eigen/IterativeLinearSolvers>
#include <algorithm>
#include <chrono>
#include <string>

#include "common/assert.h"
#include "common/error.h"

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
    : positions(rest),
      velocities(Matrix3Xd::Zero(3, rest.cols())),
      m_elasticity(rest, tets, material),
      m_material(material),
      m_rest(rest),
      m_pinned(static_cast<std::size_t>(rest.cols()), 0),
      m_last_dv(Matrix3Xd::Zero(3, rest.cols())) {
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
  m_mass = Eigen::VectorXd::Zero(positions.cols());
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
    velocities.col(node).setZero();
  }
  m_pattern_dirty = true;
}

NodeIndex ImplicitIntegrator::split_node(NodeIndex node, std::span<const std::pair<TetIndex, int>> slots) {
  const NodeIndex added = node_count();
  const auto grow = [&](Matrix3Xd& m) {
    m.conservativeResize(Eigen::NoChange, m.cols() + 1);
    m.col(added) = m.col(node);
  };
  grow(positions);
  grow(velocities);
  grow(m_rest);
  grow(m_last_dv);
  m_pinned.push_back(m_pinned[node]);
  for (const auto& [t, corner] : slots) {
    FISSURE_ASSERT(m_elasticity.tets()(corner, t) == node);
    m_elasticity.replace_node(t, corner, added);
  }
  lump_masses();
  m_pattern_dirty = true;
  return added;
}

void ImplicitIntegrator::build_pattern() {
  const Index nodes = node_count();
  m_dof.assign(nodes, kInvalidIndex);
  Index rows = 0;
  for (Index n = 0; n < nodes; ++n) {
    if (!m_pinned[n]) {
      m_dof[n] = rows;
      rows += 3;
    }
  }
  // Pattern: the diagonal (mass) plus one 3×3 block per pair of free nodes sharing a tet.
  std::vector<Eigen::Triplet<double>> entries;
  entries.reserve(static_cast<std::size_t>(rows) * 3 + m_elasticity.tet_count() * 144);
  for (Index n = 0; n < nodes; ++n) {
    if (m_dof[n] == kInvalidIndex) continue;
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) entries.emplace_back(m_dof[n] + a, m_dof[n] + b, 0.0);
    }
  }
  const Matrix4Xu& tets = m_elasticity.tets();
  for (TetIndex t = 0; t < m_elasticity.tet_count(); ++t) {
    for (int i = 0; i < 4; ++i) {
      for (int j = 0; j < 4; ++j) {
        const Index ri = m_dof[tets(i, t)], cj = m_dof[tets(j, t)];
        if (ri == kInvalidIndex || cj == kInvalidIndex) continue;
        for (int a = 0; a < 3; ++a) {
          for (int b = 0; b < 3; ++b) entries.emplace_back(ri + a, cj + b, 0.0);
        }
      }
    }
  }
  m_matrix.resize(rows, rows);
  m_matrix.setFromTriplets(entries.begin(), entries.end());
  m_matrix.makeCompressed();
  // Where each block column lives in the compressed storage, so steps refill in place.
  auto locate = [&](Index row, Index column) -> double* {
    const int* begin = m_matrix.innerIndexPtr() + m_matrix.outerIndexPtr()[column];
    const int* end = m_matrix.innerIndexPtr() + m_matrix.outerIndexPtr()[column + 1];
    const int* found = std::lower_bound(begin, end, static_cast<int>(row));
    FISSURE_ASSERT(found != end && *found == static_cast<int>(row));
    return m_matrix.valuePtr() + (found - m_matrix.innerIndexPtr());
  };
  m_blocks.assign(m_elasticity.tet_count(), {});
  for (TetIndex t = 0; t < m_elasticity.tet_count(); ++t) {
    for (int i = 0; i < 4; ++i) {
      for (int j = 0; j < 4; ++j) {
        const Index ri = m_dof[tets(i, t)], cj = m_dof[tets(j, t)];
        for (int c = 0; c < 3; ++c) {
          m_blocks[t][static_cast<std::size_t>(3 * (4 * i + j) + c)] =
              (ri == kInvalidIndex || cj == kInvalidIndex) ? nullptr : locate(ri, cj + c);
        }
      }
    }
  }
  m_diagonal.resize(rows);
  for (Index r = 0; r < rows; ++r) m_diagonal[r] = locate(r, r);
  m_analyzed = false;
  m_pattern_dirty = false;
}

SolveStatus ImplicitIntegrator::step(const StepSettings& settings) {
  evaluate(settings, false);
  return solve(settings);
}

void ImplicitIntegrator::evaluate(const StepSettings& settings, bool with_stress) {
  const auto start = Clock::now();
  m_elasticity.evaluate(positions, settings.stiffness, with_stress, m_elements);
  m_phase_times.forces = seconds_since(start);
}

SolveStatus ImplicitIntegrator::solve(const StepSettings& s) {
  auto phase_start = Clock::now();
  if (m_pattern_dirty) build_pattern();
  const double h = s.dt;
  const double alpha = m_material.rayleigh_mass, beta = m_material.rayleigh_stiffness;
  // A = M − h D − h² K with D = −αM + βK:  A = (1 + hα) M − (hβ + h²) K.
  // b = h (f + β K v + h K v) = h (f + (β + h) K v), f = elastic + gravity − α M v.
  const auto rows = static_cast<Eigen::Index>(m_matrix.rows());
  std::fill(m_matrix.valuePtr(), m_matrix.valuePtr() + m_matrix.nonZeros(), 0.0);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(rows);
  const Matrix4Xu& tets = m_elasticity.tets();
  const double k_scale = h * beta + h * h;
  for (TetIndex t = 0; t < m_elasticity.tet_count(); ++t) {
    const Mat12& K = m_elements.stiffness[t];
    Eigen::Matrix<double, 12, 1> v;
    for (int j = 0; j < 4; ++j) v.segment<3>(3 * j) = velocities.col(tets(j, t));
    const Eigen::Matrix<double, 12, 1> Kv = K * v;
    for (int i = 0; i < 4; ++i) {
      const Index ri = m_dof[tets(i, t)];
      if (ri == kInvalidIndex) continue;
      b.segment<3>(ri) += h * ((beta + h) * Kv.segment<3>(3 * i) + m_elements.forces[t].col(i));
      for (int j = 0; j < 4; ++j) {
        for (int c = 0; c < 3; ++c) {
          // Each block column holds the block's 3 rows contiguously (the pattern has
          // whole 3×3 blocks, and rows are sorted within a column).
          double* column = m_blocks[t][static_cast<std::size_t>(3 * (4 * i + j) + c)];
          if (column == nullptr) break;
          for (int r = 0; r < 3; ++r) column[r] -= k_scale * K(3 * i + r, 3 * j + c);
        }
      }
    }
  }
  for (Index n = 0; n < node_count(); ++n) {
    const Index r = m_dof[n];
    if (r == kInvalidIndex) continue;
    b.segment<3>(r) += h * m_mass[n] * (s.gravity - alpha * velocities.col(n));
    for (int a = 0; a < 3; ++a) *m_diagonal[r + a] += (1.0 + h * alpha) * m_mass[n];
  }

  m_phase_times.assembly = seconds_since(phase_start);
  phase_start = Clock::now();
  Eigen::VectorXd dv;
  SolveStatus status = SolveStatus::Converged;
  if (s.solver == LinearSolver::Direct) {
    if (!m_analyzed) {
      m_direct.analyzePattern(m_matrix);
      m_analyzed = true;
    }
    m_direct.factorize(m_matrix);
    if (m_direct.info() != Eigen::Success) return SolveStatus::NotPositiveDefinite;
    dv = m_direct.solve(b);
    m_iterations = 1;
  } else {
    Eigen::VectorXd guess(rows);
    for (Index n = 0; n < node_count(); ++n) {
      if (m_dof[n] != kInvalidIndex) guess.segment<3>(m_dof[n]) = m_last_dv.col(n);
    }
    Eigen::ConjugateGradient<Eigen::SparseMatrix<double>, Eigen::Lower | Eigen::Upper> cg;
    cg.setTolerance(s.tolerance);
    cg.setMaxIterations(s.max_iterations);
    cg.compute(m_matrix);
    dv = cg.solveWithGuess(b, guess);
    m_iterations = static_cast<int>(cg.iterations());
    if (cg.info() == Eigen::NoConvergence) status = SolveStatus::MaxIterations;
  }
  m_phase_times.solve = seconds_since(phase_start);
  if (!dv.allFinite()) return SolveStatus::NonFinite;
  for (Index n = 0; n < node_count(); ++n) {
    const Index r = m_dof[n];
    if (r == kInvalidIndex) continue;
    m_last_dv.col(n) = dv.segment<3>(r);
    velocities.col(n) += dv.segment<3>(r);
    positions.col(n) += h * velocities.col(n);
  }
  return status;
}

double ImplicitIntegrator::kinetic_energy() const {
  double kinetic = 0.0;
  for (Index n = 0; n < node_count(); ++n) kinetic += 0.5 * m_mass[n] * velocities.col(n).squaredNorm();
  return kinetic;
}

double ImplicitIntegrator::energy() const { return kinetic_energy() + m_elasticity.energy(positions); }

Vec3 ImplicitIntegrator::angular_momentum() const {
  Vec3 l = Vec3::Zero();
  for (Index n = 0; n < node_count(); ++n) l += m_mass[n] * positions.col(n).cross(velocities.col(n));
  return l;
}

}  // namespace fissure::sim
