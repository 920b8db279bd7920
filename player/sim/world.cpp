#include "player/sim/world.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "common/error.h"
#include "common/tet_mesh.h"

namespace fissure::sim {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

/// One sphere per tet, at its centroid, as large as fits inside the tet: the stand-in
/// when a bundle has no baked spheres. Coarse (it ignores where the surface is), but
/// never empty. The centroid is a quarter of each face's height from that face, so the
/// radius is 3V / (4 · largest face area). (The inradius 3V / total area is larger
/// whenever a face exceeds a quarter of the total: it poked out of the Kuhn tets of a
/// grid by 0.03 of the edge, so face neighbours' spheres overlapped, and the moment
/// fracture put them in different fragments, self-collision threw them apart.)
EmbeddedPoints inscribed_spheres(const Matrix3Xd& rest, const Matrix4Xu& tets) {
  EmbeddedPoints points;
  for (TetIndex t = 0; t < static_cast<TetIndex>(tets.cols()); ++t) {
    Mat3 edges;
    const Vec3 x0 = rest.col(tets(0, t));
    edges << rest.col(tets(1, t)) - x0, rest.col(tets(2, t)) - x0, rest.col(tets(3, t)) - x0;
    double largest_face = 0.0;
    for (const auto& face : kTetFaceNodes) {
      const Vec3 a = rest.col(tets(face[0], t)), b = rest.col(tets(face[1], t)), c = rest.col(tets(face[2], t));
      largest_face = std::max(largest_face, 0.5 * (b - a).cross(c - a).norm());
    }
    points.tet.push_back(t);
    points.barycentric.push_back(Vec4::Constant(0.25));
    points.radius.push_back(3.0 * (edges.determinant() / 6.0) / (4.0 * largest_face));
  }
  return points;
}

void check_points(const EmbeddedPoints& points, std::size_t tet_count, const std::string& what) {
  if (points.barycentric.size() != points.size() || points.radius.size() != points.size()) {
    throw Error(what + ": tet, barycentric and radius arrays differ in length", "rebake the bundle");
  }
  for (std::size_t k = 0; k < points.size(); ++k) {
    if (points.tet[k] >= tet_count || !points.barycentric[k].allFinite() || !(points.radius[k] >= 0.0)) {
      throw Error(what + ": point " + std::to_string(k) + " has an invalid tet, barycentric or radius",
                  "rebake the bundle; `fissure-bake verify` checks collision data");
    }
  }
}

}  // namespace

World::World(std::vector<BodyDescription> bodies, Environment environment, std::vector<Projectile> projectiles,
             WorldSettings settings)
    : m_environment(std::move(environment)), m_projectiles(std::move(projectiles)), m_settings(settings) {
  if (!(settings.step.dt > 0.0) || !std::isfinite(settings.step.dt)) {
    throw Error("time step " + std::to_string(settings.step.dt) + " s is not positive", "use dt > 0, e.g. 1/240");
  }
  m_bodies.reserve(bodies.size());
  for (BodyDescription& d : bodies) {
    const std::string where = "body '" + d.name + "'";
    if (!(d.toughness >= 0.0)) {
      throw Error(where + ": toughness " + std::to_string(d.toughness) + " is negative", "use a toughness ≥ 0 N, or inf");
    }
    validate(d.material, where + " material");
    auto solver = std::make_unique<ImplicitIntegrator>(d.rest, d.tets, d.material, d.mass ? &*d.mass : nullptr);
    if (d.velocity.cols() == d.rest.cols()) solver->velocities = d.velocity;
    solver->pin(d.pinned);
    const auto tet_count = static_cast<std::size_t>(d.tets.cols());
    EmbeddedPoints spheres = d.spheres.size() > 0 ? std::move(d.spheres) : inscribed_spheres(d.rest, d.tets);
    check_points(spheres, tet_count, where + " spheres");
    check_points(d.vertices, tet_count, where + " render vertices");
    if (settings.collisions && settings.collision_points == CollisionPoints::RenderVertices && d.vertices.size() == 0) {
      throw Error(where + " has no render vertices for the exact collision mode", "use collision_mode = \"spheres\"");
    }
    FractureTopology topology(d.tets, static_cast<Index>(d.rest.cols()));
    m_bodies.push_back(Body{d.name, std::move(solver), std::move(topology),
                            FractureSettings{d.toughness, settings.max_splits_per_step}, d.contact, std::move(spheres),
                            std::move(d.vertices)});
  }
  m_start_positions.resize(m_bodies.size());
}

StepReport World::step() {
  StepReport report;
  report.substeps = 0;
  advance(m_settings.step.dt, report, 0);
  return report;
}

void World::advance(double dt, StepReport& report, int depth) {
  StepSettings step = m_settings.step;
  step.dt = dt;
  auto start = Clock::now();
  for (Body& b : m_bodies) {
    b.solver->evaluate(step, m_settings.fracture && depth == 0 && std::isfinite(b.fracture.toughness));
    report.forces += b.solver->last_phase_times().forces;
  }
  if (m_settings.fracture && depth == 0) {
    start = Clock::now();
    for (Index bi = 0; bi < m_bodies.size(); ++bi) {
      Body& b = m_bodies[bi];
      if (!std::isfinite(b.fracture.toughness)) continue;
      std::vector<NodeSplit> splits;
      std::vector<TetFace> exposed;
      fracture(*b.solver, b.topology, b.fracture, splits, exposed);
      for (const NodeSplit& s : splits) report.splits.emplace_back(bi, s);
      for (const TetFace& f : exposed) report.exposed.emplace_back(bi, f);
    }
    report.fracture += seconds_since(start);
  }
  std::vector<Matrix3Xd> start_velocities(m_bodies.size());
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    m_start_positions[bi] = m_bodies[bi].solver->positions;
    start_velocities[bi] = m_bodies[bi].solver->velocities;
  }
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    Body& b = m_bodies[bi];
    const int factorizations_before = b.solver->factorizations();
    const SolveStatus status = b.solver->solve(step);
    report.factorizations += b.solver->factorizations() - factorizations_before;
    report.assembly += b.solver->last_phase_times().assembly;
    report.solve += b.solver->last_phase_times().solve;
    report.solver_iterations += b.solver->last_iterations();
    if (status == SolveStatus::MaxIterations) report.unconverged = true;
    if (status == SolveStatus::Converged || status == SolveStatus::MaxIterations) continue;
    // Undo the bodies already advanced, then retry as two half steps.
    for (std::size_t bj = 0; bj < bi; ++bj) {
      m_bodies[bj].solver->positions = m_start_positions[bj];
      m_bodies[bj].solver->velocities = start_velocities[bj];
    }
    if (m_settings.min_dt > 0.0 && 0.5 * dt >= m_settings.min_dt) {
      advance(0.5 * dt, report, depth + 1);
      advance(0.5 * dt, report, depth + 1);
      return;
    }
    throw Error("at t = " + std::to_string(m_time) + " s, body '" + b.name + "': the implicit solve failed (" +
                    to_string(status) + ") at dt = " + std::to_string(dt) + " s",
                m_settings.min_dt > 0.0 ? "lower solver.min_dt, or use a smaller solver.dt"
                                        : "set solver.min_dt to let steps halve, or use a smaller solver.dt");
  }
  ++report.substeps;
  if (m_settings.collisions) {
    start = Clock::now();
    std::vector<CollisionBody> collision_bodies;
    collision_bodies.reserve(m_bodies.size());
    for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
      Body& b = m_bodies[bi];
      collision_bodies.push_back({b.solver.get(), &b.collision_points(m_settings.collision_points), &m_start_positions[bi],
                                  &b.topology.tet_fragment(), b.contact});
    }
    CollisionSettings cs;
    cs.dt = dt;
    cs.gravity = m_settings.step.gravity;
    cs.self_collision = m_settings.self_collision;
    cs.iterations = m_settings.contact_iterations;
    cs.impulses = &m_contact_impulses;
    const ContactCounts counts = resolve_collisions(collision_bodies, m_environment, m_projectiles, m_time, cs);
    report.contacts.contacts += counts.contacts;
    report.contacts.swept += counts.swept;
    report.contacts.pairs_tested += counts.pairs_tested;
    report.contacts.response_iterations += counts.response_iterations;
    report.collisions += seconds_since(start);
  } else {
    // Projectiles still fly when nothing collides.
    for (Projectile& p : m_projectiles) {
      if (!p.launched && p.launch_time <= m_time + 0.5 * dt) p.launched = true;
      if (!p.launched) continue;
      p.velocity += dt * m_settings.step.gravity;
      p.position += dt * p.velocity;
    }
  }
  m_time += dt;
}

double World::kinetic_energy() const {
  double e = 0.0;
  for (const Body& b : m_bodies) e += b.solver->kinetic_energy();
  for (const Projectile& p : m_projectiles) {
    if (p.launched) e += 0.5 * p.mass * p.velocity.squaredNorm();
  }
  return e;
}

double World::elastic_energy() const {
  double e = 0.0;
  for (const Body& b : m_bodies) e += b.solver->elasticity().energy(b.solver->positions);
  return e;
}

double World::potential_energy() const {
  double e = 0.0;
  for (const Body& b : m_bodies) e -= m_settings.step.gravity.dot(b.solver->positions * b.solver->node_masses());
  for (const Projectile& p : m_projectiles) {
    if (p.launched) e -= p.mass * m_settings.step.gravity.dot(p.position);
  }
  return e;
}

Vec3 World::linear_momentum() const {
  Vec3 p = Vec3::Zero();
  for (const Body& b : m_bodies) p += b.solver->linear_momentum();
  for (const Projectile& q : m_projectiles) {
    if (q.launched) p += q.mass * q.velocity;
  }
  return p;
}

Vec3 World::angular_momentum() const {
  Vec3 l = Vec3::Zero();
  for (const Body& b : m_bodies) l += b.solver->angular_momentum();
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
      const Vec3 p = embedded_position(b.solver->positions, b.solver->elasticity().tets(), b.spheres, k);
      depth = std::max(depth, penetration(p, b.spheres.radius[k], m_environment, m_projectiles));
    }
  }
  return depth;
}

double World::vertex_penetration() const {
  double depth = 0.0;
  for (const Body& b : m_bodies) {
    for (std::size_t k = 0; k < b.vertices.size(); ++k) {
      const Vec3 p = embedded_position(b.solver->positions, b.solver->elasticity().tets(), b.vertices, k);
      depth = std::max(depth, penetration(p, 0.0, m_environment, m_projectiles));
    }
  }
  return depth;
}

}  // namespace fissure::sim
