#pragma once
/// One deformable body of a World: its integrator, fracture topology, contact material
/// and collision points; and what World and its energy guard compute over all of them.

#include <memory>
#include <span>
#include <string>
#include <vector>

#include "player/sim/contacts/split_overlaps.h"
#include "player/sim/environment.h"
#include "player/sim/fracture.h"
#include "player/sim/implicit_integrator.h"
#include "player/sim/world_settings.h"

namespace fissure::sim {

class Body {
 public:
  Body(std::string name, std::unique_ptr<ImplicitIntegrator> integrator, FractureTopology topology,
       FractureSettings fracture, ContactMaterial contact, EmbeddedPoints spheres, EmbeddedPoints vertices);

  std::string name;
  FractureTopology topology;
  FractureSettings fracture;
  ContactMaterial contact;
  EmbeddedPoints spheres;
  EmbeddedPoints vertices;
  /// Pairs of the collision points in use that a split left overlapping (split_overlaps.h).
  SplitOverlaps split_overlaps;

  [[nodiscard]] const ImplicitIntegrator& integrator() const { return *m_integrator; }
  ImplicitIntegrator& integrator() { return *m_integrator; }
  [[nodiscard]] const EmbeddedPoints& collision_points(CollisionPoints mode) const {
    return mode == CollisionPoints::Spheres ? spheres : vertices;
  }

 private:
  std::unique_ptr<ImplicitIntegrator> m_integrator;  ///< pinned in memory (see ImplicitIntegrator)
};

/// Kinetic energy of the bodies and the launched projectiles [J].
[[nodiscard]] double kinetic_energy(std::span<const Body> bodies, std::span<const Projectile> projectiles);
/// Strain energy of the bodies [J].
[[nodiscard]] double elastic_energy(std::span<const Body> bodies);
/// Gravity's energy of the bodies and the launched projectiles, relative to the origin [J].
[[nodiscard]] double potential_energy(std::span<const Body> bodies, std::span<const Projectile> projectiles,
                                      const Vec3& gravity);
/// The three summed, in that order [J].
[[nodiscard]] double total_energy(std::span<const Body> bodies, std::span<const Projectile> projectiles,
                                  const Vec3& gravity);

/// Per node of `body`, its fragment (a node's tets all lie in one fragment).
void find_node_fragments(const Body& body, std::vector<Index>& node_fragment);

/// Each fragment's rigid rotation since `from` (per body) moved onto an arc
/// (rigid_rotation.h); fragments of fewer tets than `rigid_fragments_below` also lose
/// their deformation (ContactSettings::rigid_fragments_below). `node_fragment`: scratch.
void rotate_fragments_on_arcs(std::span<Body> bodies, const std::vector<Matrix3Xd>& from, int rigid_fragments_below,
                              std::vector<Index>& node_fragment);

}  // namespace fissure::sim
