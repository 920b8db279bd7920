// What World reports of its state between steps: each body's frame, energies, momenta,
// fragments and the deepest penetrations (the run's summary and diagnostics).
#include <algorithm>

#include "player/sim/world.h"

namespace fissure::sim {

BodyEnergy World::body_energy(Index body) const {
  const ImplicitIntegrator& b = m_bodies.at(body).integrator();
  return {b.kinetic_energy(), b.elasticity().energy(b.positions()),
          -m_settings.step.gravity.dot(b.positions() * b.node_masses())};
}

BodyFrame World::frame(Index body, bool with_deformation) const {
  const Body& b = m_bodies[body];
  const ImplicitIntegrator& integrator = b.integrator();
  if (with_deformation && m_deformation_step[body] != m_steps + 1) {
    integrator.elasticity().deformation_gradients(integrator.positions(), m_deformation[body]);
    m_deformation_step[body] = m_steps + 1;
  }
  const std::span<const Mat3> deformation =
      with_deformation ? std::span<const Mat3>(m_deformation[body]) : std::span<const Mat3>();
  return {integrator.positions(), m_previous_positions[body], integrator.elasticity().tets(), deformation,
          b.topology.face_states(), b.topology.tet_fragment(), b.topology.version()};
}

double World::kinetic_energy() const { return sim::kinetic_energy(m_bodies, m_projectiles); }

double World::elastic_energy() const { return sim::elastic_energy(m_bodies); }

double World::potential_energy() const { return sim::potential_energy(m_bodies, m_projectiles, m_settings.step.gravity); }

Vec3 World::linear_momentum() const {
  Vec3 p = Vec3::Zero();
  for (const Body& b : m_bodies) p += b.integrator().linear_momentum();
  for (const Projectile& q : m_projectiles) {
    if (q.launched) p += q.mass * q.velocity;
  }
  return p;
}

Vec3 World::angular_momentum() const {
  Vec3 l = Vec3::Zero();
  for (const Body& b : m_bodies) l += b.integrator().angular_momentum();
  for (const Projectile& q : m_projectiles) {
    if (q.launched) l += q.mass * q.position.cross(q.velocity);
  }
  return l;
}

Index World::fragment_count() const {
  Index n = 0;
  for (const Body& b : m_bodies) n += b.topology.fragment_count();
  return n;
}

double World::sphere_penetration() const {
  double depth = 0.0;
  for (const Body& b : m_bodies) {
    for (std::size_t k = 0; k < b.spheres.size(); ++k) {
      const Vec3 p = embedded_position(b.integrator().positions(), b.integrator().elasticity().tets(), b.spheres, k);
      depth = std::max(depth, penetration(p, b.spheres.radius[k], m_environment, m_projectiles));
    }
  }
  return depth;
}

World::DeepestVertex World::deepest_vertex() const {
  DeepestVertex deepest;
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    const Body& b = m_bodies[bi];
    for (std::size_t k = 0; k < b.vertices.size(); ++k) {
      const Vec3 p = embedded_position(b.integrator().positions(), b.integrator().elasticity().tets(), b.vertices, k);
      const ObstacleHit hit = deepest_obstacle(p, 0.0, m_environment, m_projectiles);
      if (hit.depth > deepest.hit.depth) {
        deepest = {static_cast<Index>(bi), static_cast<Index>(k), b.topology.tet_fragment()[b.vertices.tet[k]], hit};
      }
    }
  }
  return deepest;
}

}  // namespace fissure::sim
