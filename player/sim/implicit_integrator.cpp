#include "player/sim/implicit_integrator.h"

#include <Eigen/IterativeLinearSolvers>
#include <array>
#include <chrono>

namespace fissure::sim {

ImplicitIntegrator::ImplicitIntegrator(const Matrix3Xd& rest, const Matrix4Xu& tets, const Material& material)
    : positions(rest),
      velocities(Matrix3Xd::Zero(3, rest.cols())),
      m_elasticity(rest, tets, material),
      m_material(material),
      m_mass(Eigen::VectorXd::Zero(rest.cols())),
      m_pinned(static_cast<std::size_t>(rest.cols()), 0) {
  for (TetIndex t = 0; t < m_elasticity.tet_count(); ++t) {
    for (int i = 0; i < 4; ++i) m_mass[tets(i, t)] += material.density * m_elasticity.rest_volume(t) / 4.0;
  }
  build_pattern();
}

void ImplicitIntegrator::pin(NodeIndex node) {
  m_pinned[node] = 1;
  velocities.col(node).setZero();
  build_pattern();
}

void ImplicitIntegrator::build_pattern() {
  const auto nodes = static_cast<Index>(positions.cols());
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
  // Where each tet block lives in the compressed storage, so steps refill in place.
  auto locate = [&](Index row, Index column) -> double* {
    for (Eigen::SparseMatrix<double>::InnerIterator it(m_matrix, column); it; ++it) {
      if (it.row() == row) return &it.valueRef();
    }
    return nullptr;
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
  m_last_dv = Eigen::VectorXd::Zero(rows);
  m_analyzed = false;
}

SolveStatus ImplicitIntegrator::step(const StepSettings& s) {
  using Clock = std::chrono::steady_clock;
  auto seconds_since = [](Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); };
  auto phase_start = Clock::now();
  const double h = s.dt;
  const double alpha = m_material.rayleigh_mass, beta = m_material.rayleigh_stiffness;
  std::vector<Mat3> rotations;
  m_elasticity.rotations(positions, rotations);
  Matrix3Xd forces = Matrix3Xd::Zero(3, positions.cols());
  m_elasticity.add_forces(positions, rotations, forces);
  for (Eigen::Index n = 0; n < positions.cols(); ++n) {
    forces.col(n) += m_mass[n] * s.gravity - alpha * m_mass[n] * velocities.col(n);
  }

  m_phase_times.forces = seconds_since(phase_start);
  phase_start = Clock::now();
  // A = M − h D − h² K with D = −αM + βK:  A = (1 + hα) M − (hβ + h²) K.
  // b = h (f + β K v + h K v) = h (f + (β + h) K v).
  const Index rows = static_cast<Index>(m_matrix.rows());
  std::fill(m_matrix.valuePtr(), m_matrix.valuePtr() + m_matrix.nonZeros(), 0.0);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(rows);
  const Matrix4Xu& tets = m_elasticity.tets();
  for (TetIndex t = 0; t < m_elasticity.tet_count(); ++t) {
    const Mat12 K = m_elasticity.stiffness(t, rotations[t]);
    Eigen::Matrix<double, 12, 1> v;
    for (int j = 0; j < 4; ++j) v.segment<3>(3 * j) = velocities.col(tets(j, t));
    const Eigen::Matrix<double, 12, 1> Kv = K * v;
    for (int i = 0; i < 4; ++i) {
      const Index ri = m_dof[tets(i, t)];
      if (ri == kInvalidIndex) continue;
      b.segment<3>(ri) += h * (beta + h) * Kv.segment<3>(3 * i);
      for (int j = 0; j < 4; ++j) {
        for (int c = 0; c < 3; ++c) {
          // Each block column holds the block's 3 rows contiguously (the pattern has
          // whole 3×3 blocks, and rows are sorted within a column).
          double* column = m_blocks[t][static_cast<std::size_t>(3 * (4 * i + j) + c)];
          if (column == nullptr) break;
          for (int r = 0; r < 3; ++r) column[r] -= (h * beta + h * h) * K(3 * i + r, 3 * j + c);
        }
      }
    }
  }
  for (Eigen::Index n = 0; n < positions.cols(); ++n) {
    const Index r = m_dof[static_cast<Index>(n)];
    if (r == kInvalidIndex) continue;
    b.segment<3>(r) += h * forces.col(n);
    for (int a = 0; a < 3; ++a) m_matrix.coeffRef(r + a, r + a) += (1.0 + h * alpha) * m_mass[n];
  }

  m_phase_times.assembly = seconds_since(phase_start);
  phase_start = Clock::now();
  Eigen::VectorXd dv;
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
    Eigen::ConjugateGradient<Eigen::SparseMatrix<double>, Eigen::Lower | Eigen::Upper> cg;
    cg.setTolerance(s.tolerance);
    cg.setMaxIterations(s.max_iterations);
    cg.compute(m_matrix);
    dv = cg.solveWithGuess(b, m_last_dv);
    m_iterations = static_cast<int>(cg.iterations());
    if (cg.info() == Eigen::NoConvergence) return SolveStatus::MaxIterations;
  }
  m_phase_times.solve = seconds_since(phase_start);
  if (!dv.allFinite()) return SolveStatus::NonFinite;
  m_last_dv = dv;
  for (Eigen::Index n = 0; n < positions.cols(); ++n) {
    const Index r = m_dof[static_cast<Index>(n)];
    if (r == kInvalidIndex) continue;
    velocities.col(n) += dv.segment<3>(r);
    positions.col(n) += h * velocities.col(n);
  }
  return SolveStatus::Converged;
}

double ImplicitIntegrator::energy() const {
  double kinetic = 0.0;
  for (Eigen::Index n = 0; n < positions.cols(); ++n) kinetic += 0.5 * m_mass[n] * velocities.col(n).squaredNorm();
  return kinetic + m_elasticity.energy(positions);
}

}  // namespace fissure::sim
