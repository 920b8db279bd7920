#pragma once
/// The types that contact detection (collision.h) and the contact response
/// (contact_response.h) share: what collisions see of a body, the two sides of a
/// contact, its constraint, and its name from one step to the next. Both import this;
/// neither imports the other's header for them.

#include <cmath>
#include <compare>
#include <cstdint>
#include <map>
#include <vector>

#include "common/types.h"
#include "player/sim/contacts/split_overlaps.h"
#include "player/sim/environment.h"

namespace fissure::sim {

class ImplicitIntegrator;

/// What collisions see of one deformable body.
struct CollisionBody {
  ImplicitIntegrator* body = nullptr;
  const EmbeddedPoints* points = nullptr;
  const Matrix3Xd* start_positions = nullptr;  ///< node positions at the start of the step
  const std::vector<Index>* tet_fragment = nullptr;  ///< fragment of each tet (self-collision)
  ContactMaterial material;
  /// Pairs of `points` a split left overlapping (split_overlaps.h): held, never pushed apart.
  const SplitOverlaps* split_overlaps = nullptr;
  /// Per point (shorter or null: the rest are not): meets obstacles and projectiles but
  /// not other fragments. The bake's reserve spheres (stand_in_spheres.h).
  const std::vector<std::uint8_t>* obstacles_only = nullptr;
};

/// One side of a contact: a point embedded in a body's tet, a projectile, or a static
/// obstacle. (owner, point) names it from one step to the next (ContactKey).
struct ContactSide {
  enum class Kind : std::uint8_t { Static, Embedded, Projectile } kind = Kind::Static;
  Index owner = 0;             ///< body or projectile index; Static: which obstacle (ContactKey)
  Index point = 0;             ///< Embedded: the point's index in its body's collision points
  TetIndex tet = 0;            ///< Embedded: the tet holding the point
  Vec4 weight = Vec4::Zero();  ///< Embedded: the point's barycentric coordinates
};

/// Which contact this is, from one step to the next: each side's kind (static,
/// embedded, projectile), owner (body, projectile, or obstacle: 0 the ground, then the
/// boxes, then the balls) and embedded point.
struct ContactKey {
  std::uint8_t kind_a = 0, kind_b = 0;
  Index owner_a = 0, point_a = 0, owner_b = 0, point_b = 0;
  auto operator<=>(const ContactKey&) const = default;
};
/// The normal impulses of the last step's contacts: resting contacts carry nearly the
/// same impulse step after step, so they warm-start the response.
using ContactImpulses = std::map<ContactKey, double>;

struct ContactConstraint {
  ContactSide a, b;
  Vec3 normal = Vec3::UnitZ();  ///< unit, from b towards a
  double target = 0;            ///< the step must end with n · (v_a − v_b) ≥ target [m/s]
  double friction = 0;          ///< Coulomb μ
  double impulse = 0;           ///< in: a guess (the last step's); out: the normal impulse it carried [N s]
  /// [m] where the two sides touch: a sphere's radius against an obstacle, the radii
  /// summed between two spheres (less for a pair a split left overlapping); 0 for points.
  /// Bounds what the contact may be left missing (ContactSettings::reach_share).
  double reach = 0;
};

/// A contact's frame: columns the unit normal, then two unit tangents (any pair).
inline Mat3 contact_frame(const Vec3& normal) {
  const Vec3 helper = std::abs(normal.x()) < 0.6 ? Vec3::UnitX() : Vec3::UnitY();
  const Vec3 first = normal.cross(helper).normalized();
  Mat3 frame;
  frame << normal, first, normal.cross(first);
  return frame;
}

}  // namespace fissure::sim
