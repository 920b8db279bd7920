#include "player/sim/corotated_elasticity.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>

#include "common/assert.h"
#include "common/error.h"
#include "common/tet_mesh.h"

namespace fissure::sim {

void validate(const Material& m, const std::string& where) {
  auto bad = [&](const std::string& what, double value, const std::string& hint) {
    throw Error(where + ": " + what + " = " + std::to_string(value) + " is out of range", hint);
  };
  if (!(m.density > 0.0) || !std::isfinite(m.density)) bad("density", m.density, "give a positive density in kg/m³");
  if (!(m.youngs_modulus > 0.0) || !std::isfinite(m.youngs_modulus)) {
    bad("youngs_modulus", m.youngs_modulus, "give a positive Young's modulus in Pa (rubber ~1e6, steel ~2e11)");
  }
  if (!(m.poisson_ratio >= 0.0 && m.poisson_ratio < 0.5)) {
    bad("poisson_ratio", m.poisson_ratio, "use 0 ≤ ν < 0.5 (0.5 is incompressible; 0.49 is nearly so)");
  }
  if (!(m.rayleigh_mass >= 0.0) || !std::isfinite(m.rayleigh_mass)) bad("rayleigh_mass", m.rayleigh_mass, "use α ≥ 0");
  if (!(m.rayleigh_stiffness >= 0.0) || !std::isfinite(m.rayleigh_stiffness)) {
    bad("rayleigh_stiffness", m.rayleigh_stiffness, "use β ≥ 0");
  }
}


namespace {

// The element loop's arithmetic on lanes, one tet per lane (entry a + 3b of a 3×3 or
// 3×4 matrix, column-major, as Eigen stores them), built for AVX2/FMA and for baseline
// x86-64 like the polar iteration. Measured on the 987-tet bunny cage, one thread: the
// per-tet Eigen 3×3 expressions were a third of the step.

/// F = Σᵢ xᵢ gᵢᵀ.
FISSURE_SIMD_KERNEL void deformation_gradient_lanes(
    const double (&x)[12][kLanes], const double (&g)[12][kLanes], double (&F)[9][kLanes]) {
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) {
      for (int l = 0; l < kLanes; ++l) {
        F[a + 3 * b][l] = x[a][l] * g[b][l] + x[3 + a][l] * g[3 + b][l] + x[6 + a][l] * g[6 + b][l] +
                          x[9 + a][l] * g[9 + b][l];
      }
    }
  }
}

/// From the rotation Q and F: the rotated gradients Q g, the forces −V Q σ g with
/// σ = 2μ ε + λ tr(ε) I, ε = sym(Qᵀ F) − I, and the world stress Q σ Qᵀ.
FISSURE_SIMD_KERNEL void element_lanes(
    const double (&Q)[9][kLanes], const double (&F)[9][kLanes], const double (&g)[12][kLanes],
    const double (&volume)[kLanes], double mu, double lambda, double (&rotated)[12][kLanes],
    double (&forces)[12][kLanes], double (&world_stress)[9][kLanes]) {
  constexpr int L = kLanes;
  double S[9][L], sigma[9][L], P[9][L];
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) {
      for (int l = 0; l < L; ++l) {  // S = Qᵀ F
        S[a + 3 * b][l] = Q[3 * a][l] * F[3 * b][l] + Q[1 + 3 * a][l] * F[1 + 3 * b][l] + Q[2 + 3 * a][l] * F[2 + 3 * b][l];
      }
    }
  }
  for (int l = 0; l < L; ++l) {
    const double trace = lambda * (S[0][l] + S[4][l] + S[8][l] - 3.0);
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) {
        const double strain = 0.5 * (S[a + 3 * b][l] + S[b + 3 * a][l]) - (a == b ? 1.0 : 0.0);
        sigma[a + 3 * b][l] = 2.0 * mu * strain + (a == b ? trace : 0.0);
      }
    }
  }
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) {
      for (int l = 0; l < L; ++l) {  // P = Q σ
        P[a + 3 * b][l] = Q[a][l] * sigma[3 * b][l] + Q[a + 3][l] * sigma[1 + 3 * b][l] + Q[a + 6][l] * sigma[2 + 3 * b][l];
      }
    }
  }
  for (int i = 0; i < 4; ++i) {
    for (int a = 0; a < 3; ++a) {
      for (int l = 0; l < L; ++l) {
        const double gx = g[3 * i][l], gy = g[3 * i + 1][l], gz = g[3 * i + 2][l];
        rotated[3 * i + a][l] = Q[a][l] * gx + Q[a + 3][l] * gy + Q[a + 6][l] * gz;
        forces[3 * i + a][l] = -volume[l] * (P[a][l] * gx + P[a + 3][l] * gy + P[a + 6][l] * gz);
      }
    }
  }
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) {
      for (int l = 0; l < L; ++l) {  // P Qᵀ
        world_stress[a + 3 * b][l] = P[a][l] * Q[b][l] + P[a + 3][l] * Q[b + 3][l] + P[a + 6][l] * Q[b + 6][l];
      }
    }
  }
}

}  // namespace

void CorotatedElasticity::set_material(const Material& material) {
  validate(material);
  m_mu = material.mu();
  m_lambda = material.lambda();
  m_last_energy.known = false;
}

CorotatedElasticity::CorotatedElasticity(const Matrix3Xd& rest, const Matrix4Xu& tets, const Material& material)
    : m_tets(tets), m_mu(material.mu()), m_lambda(material.lambda()) {
  validate(material);
  m_gradients.resize(static_cast<std::size_t>(tets.cols()));
  m_volume.resize(static_cast<std::size_t>(tets.cols()));
  for (Eigen::Index t = 0; t < tets.cols(); ++t) {
    const Vec3 x0 = rest.col(tets(0, t));
    Mat3 edges;
    edges << rest.col(tets(1, t)) - x0, rest.col(tets(2, t)) - x0, rest.col(tets(3, t)) - x0;
    const double volume = edges.determinant() / 6.0;
    if (!(volume > 0.0)) {
      throw Error("tet " + std::to_string(t) + " has non-positive rest volume " + std::to_string(volume),
                  "the cage must be positively oriented and non-degenerate (fissure-bake verify checks this)");
    }
    const Mat3 inverse = edges.inverse();  // rows: gradients of shape functions 1..3
    auto& g = m_gradients[static_cast<std::size_t>(t)];
    g.col(1) = inverse.row(0).transpose();
    g.col(2) = inverse.row(1).transpose();
    g.col(3) = inverse.row(2).transpose();
    g.col(0) = -(g.col(1) + g.col(2) + g.col(3));
    m_volume[static_cast<std::size_t>(t)] = volume;
  }
}

Mat3 CorotatedElasticity::deformation_gradient(const Matrix3Xd& x, TetIndex t) const {
  const auto& g = m_gradients[t];
  Mat3 F = Mat3::Zero();
  for (int i = 0; i < 4; ++i) F += x.col(m_tets(i, t)) * g.col(i).transpose();
  return F;
}

bool CorotatedElasticity::knows_gradients_at(const Matrix3Xd& x) const {
  const LastEnergy& last = m_last_energy;
  const auto bytes = static_cast<std::size_t>(x.size()) * sizeof(double);
  return last.known && last.positions.cols() == x.cols() && std::memcmp(last.positions.data(), x.data(), bytes) == 0;
}

double CorotatedElasticity::energy(const Matrix3Xd& x) const {
  LastEnergy& last = m_last_energy;
  if (knows_gradients_at(x)) return last.value;
  last.value = summed_energy(x);
  last.positions = x;
  last.known = true;
  return last.value;
}

void CorotatedElasticity::gather_lanes(const Matrix3Xd& x, std::size_t first, int size, bool positions,
                                       double (&x_lanes)[12][kLanes], double (&g_lanes)[12][kLanes],
                                       double (&volume)[kLanes]) const {
  for (int l = 0; l < kLanes; ++l) {
    const auto t = static_cast<TetIndex>(first + (l < size ? l : 0));
    const Mat34& g = m_gradients[t];
    for (int i = 0; i < 4; ++i) {
      for (int a = 0; a < 3; ++a) g_lanes[3 * i + a][l] = g(a, i);
      if (!positions) continue;
      const auto node = x.col(m_tets(i, t));
      for (int a = 0; a < 3; ++a) x_lanes[3 * i + a][l] = node[a];
    }
    volume[l] = m_volume[t];
  }
}

double CorotatedElasticity::summed_energy(const Matrix3Xd& x) const {
  // Batches of kLanes tets on the threads, each batch's sum in its own slot, the slots
  // added in order: the total does not depend on the threads. It must not: World keeps
  // restitution within an energy budget, and a rounding difference there would change
  // the trajectory.
  const std::size_t count = tet_count();
  std::vector<double> batch_energy((count + kLanes - 1) / kLanes, 0.0);
  std::vector<Mat3>& F = m_last_energy.F;
  std::vector<Mat3>& Q = m_last_energy.Q;
  F.resize(count);
  Q.resize(count);
  parallel_for_batches<std::size_t>(count, 1024, [&](std::size_t first, int size) {
    // The element loop's own kernel (evaluate()), so that F here is the bits it computes.
    double x_lanes[12][kLanes], g_lanes[12][kLanes], volume[kLanes], F_lanes[9][kLanes];
    gather_lanes(x, first, size, true, x_lanes, g_lanes, volume);
    deformation_gradient_lanes(x_lanes, g_lanes, F_lanes);
    for (int l = 0; l < size; ++l) {
      for (int k = 0; k < 9; ++k) F[first + l].data()[k] = F_lanes[k][l];
    }
    polar_rotations(&F[first], &Q[first], size);
    double sum = 0.0;
    for (int l = 0; l < size; ++l) sum += energy_at(static_cast<TetIndex>(first + l), F[first + l], Q[first + l]);
    batch_energy[first / kLanes] = sum;
  });
  return std::accumulate(batch_energy.begin(), batch_energy.end(), 0.0);
}

double CorotatedElasticity::tet_energy(const Matrix3Xd& x, TetIndex t) const {
  Mat3 F[1] = {deformation_gradient(x, t)}, Q[1];
  polar_rotations(F, Q, 1);
  return energy_at(t, F[0], Q[0]);
}

void CorotatedElasticity::deformation_gradients(const Matrix3Xd& x, std::vector<Mat3>& out) const {
  out.resize(tet_count());
  parallel_for_range<std::size_t>(tet_count(), 1024, [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t t = r.begin(); t != r.end(); ++t) out[t] = deformation_gradient(x, static_cast<TetIndex>(t));
  });
}

void CorotatedElasticity::rotations(const Matrix3Xd& x, std::vector<Mat3>& out) const {
  out.resize(tet_count());
  for (TetIndex t = 0; t < tet_count(); ++t) out[t] = polar_rotation(deformation_gradient(x, t));
}

Mat3 CorotatedElasticity::stress(const Mat3& Q, const Mat3& F) const {
  const Mat3 S = Q.transpose() * F;
  const Mat3 strain = 0.5 * (S + S.transpose()) - Mat3::Identity();
  return 2.0 * m_mu * strain + m_lambda * strain.trace() * Mat3::Identity();
}

void CorotatedElasticity::add_forces(const Matrix3Xd& x, const std::vector<Mat3>& rotations, Matrix3Xd& out) const {
  for (TetIndex t = 0; t < tet_count(); ++t) {
    const Mat3& Q = rotations[t];
    const Mat3 P = Q * stress(Q, deformation_gradient(x, t));
    for (int i = 0; i < 4; ++i) out.col(m_tets(i, t)) -= m_volume[t] * P * m_gradients[t].col(i);
  }
}

Mat12 CorotatedElasticity::stiffness(TetIndex t, const Mat3& Q) const {
  // Column (3j + a) is the force change for a unit move of node j along axis a:
  // dF = e_a gⱼᵀ, dε = sym(Qᵀ dF), dσ = 2μ dε + λ tr(dε) I, dfᵢ = −V Q dσ gᵢ, which
  // simplifies to warped_block (ĝ = Q g).
  const Mat34 rotated = Q * m_gradients[t];
  Mat12 K;
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) K.block<3, 3>(3 * i, 3 * j) = warped_block(t, rotated, i, j);
  }
  return K;
}

Mat34 CorotatedElasticity::stiffness_times(TetIndex t, const ElementBuffers& buffers, const Mat34& u) const {
  if (buffers.model == StiffnessModel::Exact) {
    const Mat12& K = buffers.stiffness[t];
    Eigen::Matrix<double, 12, 1> stacked;
    for (int j = 0; j < 4; ++j) stacked.segment<3>(3 * j) = u.col(j);
    const Eigen::Matrix<double, 12, 1> product = K * stacked;
    return Eigen::Map<const Mat34>(product.data());
  }
  const Mat34& rotated = buffers.rotated_gradients[t];
  const Mat3 W = u * rotated.transpose();
  Mat3 stress = m_mu * (W + W.transpose());
  stress.diagonal().array() += m_lambda * W.trace();
  return (-m_volume[t]) * stress * rotated;
}

namespace {

/// The warped product on lanes (entry k = 3j + a of a 3×4 matrix, column-major):
/// W = u ĝᵀ, σ = μ (W + Wᵀ) + λ tr(W) I, out = scale σ ĝ with scale = −V.
FISSURE_SIMD_KERNEL void warped_product_lanes(
    const double (&u)[12][kLanes], const double (&g)[12][kLanes], const double (&scale)[kLanes],
    double mu, double lambda, double (&out)[12][kLanes]) {
  constexpr int L = kLanes;
  double W[3][3][L];
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) {
      for (int l = 0; l < L; ++l) {
        W[a][b][l] = u[a][l] * g[b][l] + u[3 + a][l] * g[3 + b][l] + u[6 + a][l] * g[6 + b][l] + u[9 + a][l] * g[9 + b][l];
      }
    }
  }
  double S[3][3][L];
  for (int l = 0; l < L; ++l) {
    const double trace = lambda * (W[0][0][l] + W[1][1][l] + W[2][2][l]);
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) S[a][b][l] = scale[l] * (mu * (W[a][b][l] + W[b][a][l]) + (a == b ? trace : 0.0));
    }
  }
  for (int i = 0; i < 4; ++i) {
    for (int a = 0; a < 3; ++a) {
      for (int l = 0; l < L; ++l) {
        out[3 * i + a][l] = S[a][0][l] * g[3 * i][l] + S[a][1][l] * g[3 * i + 1][l] + S[a][2][l] * g[3 * i + 2][l];
      }
    }
  }
}

}  // namespace

void CorotatedElasticity::stiffness_times(TetIndex first, int count, const ElementBuffers& buffers, const Mat34* u,
                                          Mat34* out) const {
  FISSURE_ASSERT(count >= 0 && count <= kLanes);
  if (buffers.model == StiffnessModel::Exact) {
    for (int l = 0; l < count; ++l) out[l] = stiffness_times(first + l, buffers, u[l]);
    return;
  }
  double u_lanes[12][kLanes], g_lanes[12][kLanes], scale[kLanes], out_lanes[12][kLanes];
  for (int l = 0; l < kLanes; ++l) {
    const int lane = l < count ? l : 0;  // a short batch repeats its first tet
    const Mat34& g = buffers.rotated_gradients[first + lane];
    for (int k = 0; k < 12; ++k) {
      u_lanes[k][l] = u[lane].data()[k];
      g_lanes[k][l] = g.data()[k];
    }
    scale[l] = -m_volume[first + lane];
  }
  warped_product_lanes(u_lanes, g_lanes, scale, m_mu, m_lambda, out_lanes);
  for (int l = 0; l < count; ++l) {
    for (int k = 0; k < 12; ++k) out[l].data()[k] = out_lanes[k][l];
  }
}

Mat12 CorotatedElasticity::exact_stiffness(TetIndex t, const Matrix3Xd& x, bool project) const {
  const Mat3 F = deformation_gradient(x, t);
  return exact_stiffness(t, F, signed_svd(F), project);
}

Mat12 CorotatedElasticity::exact_stiffness(TetIndex t, const Mat3& F, const SignedSvd& svd, bool project) const {
  // ∂P/∂F as a 9×9 matrix on column-major vec(F) (index a + 3b):
  //   H = 2μ I + λ r rᵀ + (λ (I₁ − 3) − 2μ) ∂vec(R)/∂vec(F),   r = vec(R), I₁ = tr S = Σσ,
  // and ∂R/∂F = Σ_k 2/(σᵢ + σⱼ) q_k q_kᵀ over the twists q_k = U T_k Vᵀ/√2 ({i, j, k}
  // a permutation). The twists are orthogonal to r and to each other, so H's eigenvalues
  // are 2μ (five), 2μ + 3λ (along r) and e_k = 2μ + (λ(I₁ − 3) − 2μ) 2/(σᵢ + σⱼ):
  // projecting H to semi-definite only clamps the e_k.
  (void)F;
  const Mat3 R = svd.U * svd.V.transpose();
  const Vec3& s = svd.sigma;
  const double i1 = s.sum();
  const Eigen::Map<const Eigen::Matrix<double, 9, 1>> r(R.data());
  Eigen::Matrix<double, 9, 9> H = 2.0 * m_mu * Eigen::Matrix<double, 9, 9>::Identity() + m_lambda * r * r.transpose();
  const double inv_sqrt2 = 1.0 / std::sqrt(2.0);
  for (int k = 0; k < 3; ++k) {
    const int i = (k + 1) % 3, j = (k + 2) % 3;
    Mat3 twist = Mat3::Zero();
    twist(i, j) = inv_sqrt2;
    twist(j, i) = -inv_sqrt2;
    const Mat3 q = svd.U * twist * svd.V.transpose();
    const Eigen::Map<const Eigen::Matrix<double, 9, 1>> qv(q.data());
    // σᵢ + σⱼ → 0 only for a tet collapsed onto a line: the rotation is undefined there,
    // and a floor keeps the (then clamped) eigenvalue finite.
    const double rotation_gain = 2.0 / std::max(s[i] + s[j], 1e-6);
    double eigenvalue = 2.0 * m_mu + (m_lambda * (i1 - 3.0) - 2.0 * m_mu) * rotation_gain;
    if (project) eigenvalue = std::max(eigenvalue, 0.0);
    H += (eigenvalue - 2.0 * m_mu) * qv * qv.transpose();
  }
  // vec(dF) = G dx with dF = Σⱼ dxⱼ gⱼᵀ: G(a + 3b, 3j + a) = gⱼ(b).
  const Mat34& g = m_gradients[t];
  Eigen::Matrix<double, 9, 12> G = Eigen::Matrix<double, 9, 12>::Zero();
  for (int node = 0; node < 4; ++node) {
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) G(a + 3 * b, 3 * node + a) = g(b, node);
    }
  }
  return -m_volume[t] * (G.transpose() * (H * G));
}

void CorotatedElasticity::evaluate(const Matrix3Xd& x, StiffnessModel model, bool with_stress,
                                   ElementBuffers& out) const {
  const std::size_t count = tet_count();
  out.model = model;
  out.rotations.resize(count);
  out.rotated_gradients.resize(count);
  out.forces.resize(count);
  out.stiffness.resize(model == StiffnessModel::Exact ? count : 0);
  out.stress.resize(with_stress ? count : 0);
  // In batches of kLanes consecutive tets (by index, whatever the threads): the
  // deformation gradients, polar rotations, stresses and forces run a batch per SIMD
  // register (deformation_gradient_lanes, polar_rotation_lanes, element_lanes). Where the
  // last energy() was at these positions, its F and Q are these bits already.
  const bool known = model == StiffnessModel::Warped && knows_gradients_at(x);
  parallel_for_batches<std::size_t>(count, 256, [&](std::size_t first, int size) {
    constexpr int L = kLanes;
    double x_lanes[12][L], g_lanes[12][L], volume[L], F_lanes[9][L], q[9][L];
    gather_lanes(x, first, size, !known, x_lanes, g_lanes, volume);
    if (known) {
      for (int l = 0; l < L; ++l) {
        const std::size_t t = first + (l < size ? l : 0);
        for (int k = 0; k < 9; ++k) {
          F_lanes[k][l] = m_last_energy.F[t].data()[k];
          q[k][l] = m_last_energy.Q[t].data()[k];
        }
      }
    } else {
      deformation_gradient_lanes(x_lanes, g_lanes, F_lanes);
    }
    const auto lane_matrix = [](const double (&lanes)[9][L], int l) {
      Mat3 m;
      for (int k = 0; k < 9; ++k) m.data()[k] = lanes[k][l];
      return m;
    };
    if (model == StiffnessModel::Exact) {
      for (int l = 0; l < size; ++l) {
        const Mat3 F = lane_matrix(F_lanes, l);
        const SignedSvd svd = signed_svd(F);  // the exact Hessian needs the singular values
        const Mat3 Q = svd.U * svd.V.transpose();
        out.stiffness[first + l] = exact_stiffness(static_cast<TetIndex>(first + l), F, svd, true);
        for (int k = 0; k < 9; ++k) q[k][l] = Q.data()[k];
      }
      for (int l = size; l < L; ++l) {
        for (int k = 0; k < 9; ++k) q[k][l] = q[k][0];
      }
    } else if (!known) {
      polar_rotation_lanes(F_lanes, q, size);  // padding lanes' rotations are never read
    }
    double rotated[12][L], forces[12][L], world_stress[9][L];
    element_lanes(q, F_lanes, g_lanes, volume, m_mu, m_lambda, rotated, forces, world_stress);
    for (int l = 0; l < size; ++l) {
      const std::size_t index = first + l;
      for (int k = 0; k < 9; ++k) out.rotations[index].data()[k] = q[k][l];
      for (int k = 0; k < 12; ++k) {
        out.rotated_gradients[index].data()[k] = rotated[k][l];
        out.forces[index].data()[k] = forces[k][l];
      }
      if (with_stress) {
        for (int k = 0; k < 9; ++k) out.stress[index].data()[k] = world_stress[k][l];
      }
    }
  });
}

}  // namespace fissure::sim
