#include "player/sim/body.h"

#include <utility>

#include "player/sim/rigid_rotation.h"

namespace fissure::sim {

Body::Body(std::string name_, std::unique_ptr<ImplicitIntegrator> integrator, FractureTopology topology_,
           FractureSettings fracture_, ContactMaterial contact_, EmbeddedPoints spheres_, EmbeddedPoints vertices_)
    : name(std::move(name_)),
      topology(std::move(topology_)),
      fracture(fracture_),
      contact(contact_),
      spheres(std::move(spheres_)),
      vertices(std::move(vertices_)),
      m_integrator(std::move(integrator)) {}

double kinetic_energy(std::span<const Body> bodies, std::span<const Projectile> projectiles) {
  double e = 0.0;
  for (const Body& b : bodies) e += b.integrator().kinetic_energy();
  for (const Projectile& p : projectiles) {
    if (p.launched) e += 0.5 * p.mass * p.velocity.squaredNorm();
  }
  return e;
}

double elastic_energy(std::span<const Body> bodies) {
  double e = 0.0;
  for (const Body& b : bodies) e += b.integrator().elasticity().energy(b.integrator().positions());
  return e;
}

double potential_energy(std::span<const Body> bodies, std::span<const Projectile> projectiles, const Vec3& gravity) {
  double e = 0.0;
  for (const Body& b : bodies) e -= gravity.dot(b.integrator().positions() * b.integrator().node_masses());
  for (const Projectile& p : projectiles) {
    if (p.launched) e -= p.mass * gravity.dot(p.position);
  }
  return e;
}

double total_energy(std::span<const Body> bodies, std::span<const Projectile> projectiles, const Vec3& gravity) {
  return kinetic_energy(bodies, projectiles) + elastic_energy(bodies) + potential_energy(bodies, projectiles, gravity);
}

void find_node_fragments(const Body& body, std::vector<Index>& node_fragment) {
  const Matrix4Xu& tets = body.integrator().elasticity().tets();
  const std::vector<Index>& tet_fragment = body.topology.tet_fragment();
  node_fragment.assign(body.integrator().node_count(), 0);
  for (Eigen::Index t = 0; t < tets.cols(); ++t) {
    for (int k = 0; k < 4; ++k) node_fragment[tets(k, t)] = tet_fragment[t];
  }
}

void rotate_fragments_on_arcs(std::span<Body> bodies, const std::vector<Matrix3Xd>& from, int rigid_fragments_below,
                              std::vector<Index>& node_fragment) {
  for (std::size_t bi = 0; bi < bodies.size(); ++bi) {
    Body& b = bodies[bi];
    find_node_fragments(b, node_fragment);
    const std::vector<std::uint8_t> small =
        small_fragments(b.topology.tet_fragment(), b.topology.fragment_count(), rigid_fragments_below);
    b.integrator().rotate_rigid_parts(from[bi], node_fragment, b.topology.fragment_count(), small);
  }
}

}  // namespace fissure::sim
