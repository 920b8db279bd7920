#include "player/sim/corotated_elasticity.h"

#include <Eigen/LU>
#include <Eigen/SVD>
#include <cmath>

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

Mat3 polar_rotation(const Mat3& F) {
  const Eigen::JacobiSVD<Mat3> svd(F, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 U = svd.matrixU();
  const Mat3 V = svd.matrixV();
  // A reflection (inverted tet) goes onto the smallest singular value, which Eigen
  // sorts last: Q = U diag(1, 1, −1) Vᵀ is then the closest proper rotation.
  if ((U * V.transpose()).determinant() < 0.0) U.col(2) *= -1.0;
  return U * V.transpose();
}

CorotatedElasticity::CorotatedElasticity(const Matrix3Xd& rest, const Matrix4Xu& tets, const Material& material)
    : m_tets(tets), m_rest(rest), m_mu(material.mu()), m_lambda(material.lambda()) {
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

double CorotatedElasticity::energy(const Matrix3Xd& x) const {
  double total = 0.0;
  for (TetIndex t = 0; t < tet_count(); ++t) {
    const Mat3 F = deformation_gradient(x, t);
    const Mat3 S = polar_rotation(F).transpose() * F;
    const Mat3 strain = 0.5 * (S + S.transpose()) - Mat3::Identity();
    const double trace = strain.trace();
    total += m_volume[t] * (m_mu * strain.squaredNorm() + 0.5 * m_lambda * trace * trace);
  }
  return total;
}

void CorotatedElasticity::rotations(const Matrix3Xd& x, std::vector<Mat3>& out) const {
  out.resize(tet_count());
  for (TetIndex t = 0; t < tet_count(); ++t) out[t] = polar_rotation(deformation_gradient(x, t));
}

void CorotatedElasticity::add_forces(const Matrix3Xd& x, const std::vector<Mat3>& rotations, Matrix3Xd& out) const {
  for (TetIndex t = 0; t < tet_count(); ++t) {
    const Mat3& Q = rotations[t];
    const Mat3 S = Q.transpose() * deformation_gradient(x, t);
    const Mat3 strain = 0.5 * (S + S.transpose()) - Mat3::Identity();
    const Mat3 stress = 2.0 * m_mu * strain + m_lambda * strain.trace() * Mat3::Identity();
    const Mat3 P = Q * stress;
    for (int i = 0; i < 4; ++i) out.col(m_tets(i, t)) -= m_volume[t] * P * m_gradients[t].col(i);
  }
}

Mat12 CorotatedElasticity::stiffness(TetIndex t, const Mat3& Q) const {
  // Column (3j + a) is the force change for a unit move of node j along axis a:
  // dF = e_a g_jᵀ, dε = sym(Qᵀ dF), dσ = 2μ dε + λ tr(dε) I, df_i = −V Q dσ g_i.
  const auto& g = m_gradients[t];
  Mat12 K;
  for (int j = 0; j < 4; ++j) {
    for (int a = 0; a < 3; ++a) {
      const Mat3 dS = Q.transpose() * (Vec3::Unit(a) * g.col(j).transpose());
      const Mat3 dstrain = 0.5 * (dS + dS.transpose());
      const Mat3 dstress = 2.0 * m_mu * dstrain + m_lambda * dstrain.trace() * Mat3::Identity();
      const Mat3 dP = Q * dstress;
      for (int i = 0; i < 4; ++i) K.block<3, 1>(3 * i, 3 * j + a) = -m_volume[t] * dP * g.col(i);
    }
  }
  return K;
}

}  // namespace fissure::sim
