#pragma once
/// Elastic material of a body (SI units). Checked by validate(): values outside the
/// physical range are errors that say which and why.

#include <string>

namespace fissure::sim {

struct Material {
  double density = 1000.0;        ///< [kg/m³], > 0
  double youngs_modulus = 1e6;    ///< E [Pa], > 0
  double poisson_ratio = 0.3;     ///< ν, in [0, 0.5): 0.5 is incompressible, which linear FEM locks on
  double rayleigh_mass = 0.0;     ///< α [1/s]: damping force −α M v
  double rayleigh_stiffness = 0.0;  ///< β [s]: damping force β K v (K = ∂f/∂x, negative semi-definite)

  /// Lamé's second parameter μ = E / (2 (1 + ν)) [Pa].
  [[nodiscard]] double mu() const { return youngs_modulus / (2.0 * (1.0 + poisson_ratio)); }
  /// Lamé's first parameter λ = E ν / ((1 + ν)(1 − 2ν)) [Pa].
  [[nodiscard]] double lambda() const {
    return youngs_modulus * poisson_ratio / ((1.0 + poisson_ratio) * (1.0 - 2.0 * poisson_ratio));
  }
};

/// Throws fissure::Error naming the first out-of-range value; `where` prefixes the message.
void validate(const Material& material, const std::string& where = "material");

}  // namespace fissure::sim
