#pragma once
/// What a scene holds besides its deformable bodies: static obstacles, projectiles and
/// their contact materials, and the points bound to a body's tets that collide.

#include <optional>
#include <vector>

#include "common/types.h"

namespace fissure::sim {

struct ContactMaterial {
  double restitution = 0.2;  ///< in [0, 1]; pairs use the larger
  double friction = 0.5;     ///< Coulomb μ ≥ 0; pairs use √(μa μb)
  /// μ_r ≥ 0: a contact resists its sides' relative spin with a couple of at most μ_r r
  /// times its normal force (r: the sphere's radius; rolling_resistance.h says why);
  /// pairs use √(μa μb). 0.1 stops a one-tet chip spinning at 20 rad/s in about 0.5 s;
  /// off by default until the sample is measured with it
  /// (docs/decisions/0035-rolling-resistance-and-sleeping-opt-in.md).
  double rolling_resistance = 0.0;
};

struct Plane {
  Vec3 normal = Vec3::UnitZ();  ///< unit, pointing out of the solid half space
  double offset = 0;            ///< the plane is normal · x = offset
  ContactMaterial material;
};
struct Box {
  Vec3 min, max;
  ContactMaterial material;
};
struct Ball {
  Vec3 center;
  double radius = 0;
  ContactMaterial material;
};
struct Environment {
  std::optional<Plane> ground;
  std::vector<Box> boxes;
  std::vector<Ball> balls;
};

/// A rigid ball thrown into the scene (the thesis's ball that hits the armadillo).
struct Projectile {
  Vec3 position = Vec3::Zero();  ///< at launch, then current [m]
  Vec3 velocity = Vec3::Zero();  ///< at launch, then current [m/s]
  double radius = 0.1;
  double mass = 1.0;
  double launch_time = 0;        ///< [s]; absent from the scene before this
  ContactMaterial material;
  bool launched = false;
};

/// Points bound to a body's tets by barycentric coordinates.
struct EmbeddedPoints {
  std::vector<TetIndex> tet;
  std::vector<Vec4> barycentric;
  std::vector<double> radius;  ///< 0 for render vertices
  [[nodiscard]] std::size_t size() const { return tet.size(); }
};

/// World position of embedded point k.
inline Vec3 embedded_position(const Matrix3Xd& x, const Matrix4Xu& tets, const EmbeddedPoints& points, std::size_t k) {
  const TetIndex t = points.tet[k];
  const Vec4& b = points.barycentric[k];
  return b[0] * x.col(tets(0, t)) + b[1] * x.col(tets(1, t)) + b[2] * x.col(tets(2, t)) + b[3] * x.col(tets(3, t));
}

}  // namespace fissure::sim
