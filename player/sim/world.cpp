#include "player/sim/world.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "common/assert.h"
#include "common/error.h"
#include "player/sim/stand_in_spheres.h"

namespace fissure::sim {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

std::vector<TetFace> fractured_faces(const FractureTopology& topology) {
  std::vector<TetFace> out;
  const std::vector<FaceState>& faces = topology.face_states();
  for (std::size_t k = 0; k < faces.size(); ++k) {
    if (faces[k] == FaceState::Fractured) out.push_back({static_cast<TetIndex>(k / 4), static_cast<int>(k % 4)});
  }
  return out;
}

void check_time_step(double dt) {
  if (!(dt > 0.0) || !std::isfinite(dt)) {
    throw Error("time step " + std::to_string(dt) + " s is not positive", "use dt > 0, e.g. 1/240");
  }
}

/// At most this many substeps per step, so a typo cannot make one step take hours.
constexpr double kMostSubsteps = 10000;

void check_max_substep(double dt, double max_substep) {
  if (max_substep == 0.0) return;
  if (!(max_substep > 0.0) || !std::isfinite(max_substep) || dt / max_substep > kMostSubsteps) {
    throw Error("max_substep " + std::to_string(max_substep) + " s would split a step of " + std::to_string(dt) +
                    " s into more than " + std::to_string(static_cast<int>(kMostSubsteps)) + " substeps",
                "use 0 (never substep) or a max_substep of at least dt / 10000");
  }
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
    : m_environment(std::move(environment)),
      m_projectiles(std::move(projectiles)),
      m_settings(settings),
      m_sleeping(settings.sleep) {
  check_time_step(settings.step.dt);
  check_max_substep(settings.step.dt, settings.max_substep);
  m_bodies.reserve(bodies.size());
  for (BodyDescription& d : bodies) {
    const std::string where = "body '" + d.name + "'";
    if (!(d.toughness >= 0.0)) {
      throw Error(where + ": toughness " + std::to_string(d.toughness) + " is negative", "use a toughness ≥ 0 N, or inf");
    }
    validate(d.material, where + " material");
    auto solver = std::make_unique<ImplicitIntegrator>(d.rest, d.tets, d.material, d.mass ? &*d.mass : nullptr);
    if (d.positions.size() > 0) solver->set_positions(d.positions);
    if (d.velocity.size() > 0) solver->set_velocities(d.velocity);
    solver->pin(d.pinned);
    const auto tet_count = static_cast<std::size_t>(d.tets.cols());
    EmbeddedPoints spheres = d.spheres.size() > 0 ? std::move(d.spheres) : inscribed_spheres(d.rest, d.tets);
    check_points(spheres, tet_count, where + " spheres");
    check_points(d.vertices, tet_count, where + " render vertices");
    if (settings.collisions && settings.collision_points == CollisionPoints::RenderVertices && d.vertices.size() == 0) {
      throw Error(where + " has no render vertices for the exact collision mode", "use collision_mode = \"spheres\"");
    }
    FractureTopology topology(d.tets, static_cast<Index>(d.rest.cols()));
    m_stand_ins.emplace_back(d.rest, d.tets, spheres, d.mass ? &*d.mass : nullptr);
    m_bodies.emplace_back(d.name, std::move(solver), std::move(topology),
                          FractureSettings{d.toughness, settings.max_splits_per_step}, d.contact, std::move(spheres),
                          std::move(d.vertices));
  }
  m_start_positions.resize(m_bodies.size());
  m_checkpoint.bodies.resize(m_bodies.size());
  for (const Body& b : m_bodies) m_previous_positions.push_back(b.integrator().positions());
  m_deformation.resize(m_bodies.size());
  m_deformation_step.assign(m_bodies.size(), 0);
  m_start_energy = total_energy();
}

Body::Body(std::string name_, std::unique_ptr<ImplicitIntegrator> integrator, FractureTopology topology_,
           FractureSettings fracture_, ContactMaterial contact_, EmbeddedPoints spheres_, EmbeddedPoints vertices_)
    : name(std::move(name_)),
      topology(std::move(topology_)),
      fracture(fracture_),
      contact(contact_),
      spheres(std::move(spheres_)),
      vertices(std::move(vertices_)),
      m_integrator(std::move(integrator)) {}

const char* to_string(StepOutcome outcome) {
  switch (outcome) {
    case StepOutcome::Converged: return "converged";
    case StepOutcome::Substepped: return "substepped";
    case StepOutcome::SolveFailed: return "solve failed at the smallest step";
    case StepOutcome::NonFinite: return "non-finite state";
  }
  return "unknown";
}

StepReport World::step() {
  const auto start = Clock::now();
  StepReport report;
  report.substeps = 0;
  m_checkpoint.time = m_time;
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) m_bodies[bi].integrator().save(m_checkpoint.bodies[bi]);
  m_checkpoint.projectiles = m_projectiles;
  m_checkpoint.impulses = m_contact_impulses;
  m_checkpoint.split_overlaps.resize(m_bodies.size());
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) m_checkpoint.split_overlaps[bi] = m_bodies[bi].split_overlaps;
  m_checkpoint.sphere_counts.resize(m_bodies.size());
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) m_checkpoint.sphere_counts[bi] = m_bodies[bi].spheres.size();
  m_checkpoint.energy_put_in = m_energy_put_in;
  const int substeps = planned_substeps();
  for (int i = 0; i < substeps && report.status.ok(); ++i) {
    report.status = advance(m_settings.step.dt / substeps, report, 0);
  }
  if (report.status.ok()) {
    if (const std::optional<Index> bad = first_non_finite(); bad) {
      report.status = {StepOutcome::NonFinite, *bad, SolveStatus::NonFinite, m_checkpoint.time, m_settings.step.dt};
    } else if (report.substeps > 1) {
      report.status.outcome = StepOutcome::Substepped;
    }
  }
  if (report.status.ok() && m_sleeping.wakes_pending()) {
    // Something closed on a sleeping island, which answered as an obstacle: take the
    // step again with the island awake. Each retake wakes more, so this ends.
    roll_back(report);
    const std::vector<SleepBody> sleepers = sleep_bodies();
    m_sleeping.wake(sleepers);
    StepReport again = step();
    again.retaken_to_wake += 1;
    again.total = seconds_since(start);  // both tries
    return again;
  }
  if (!report.status.ok()) {
    roll_back(report);
  } else {
    keep_previous_positions(report);
    ++m_steps;
    if (m_sleeping.enabled()) {
      const std::vector<SleepBody> sleepers = sleep_bodies();
      m_sleeping.after_step(sleepers, m_touches, m_settings.step.dt);
      report.fragments_asleep = Sleeping::asleep(sleepers);
    }
  }
  report.total = seconds_since(start);
  return report;
}

std::vector<SleepBody> World::sleep_bodies() {
  std::vector<SleepBody> out;
  out.reserve(m_bodies.size());
  for (Body& b : m_bodies) out.push_back({&b.integrator(), &b.topology.tet_fragment(), b.topology.fragment_count()});
  return out;
}

int World::planned_substeps() const {
  const double ratio = m_settings.max_substep > 0.0 ? m_settings.step.dt / m_settings.max_substep : 1.0;
  // A dt within rounding of a whole number of substeps (1/30 s at 1/60 s) takes that many.
  return std::max(1, static_cast<int>(std::ceil(ratio * (1.0 - 1e-12))));
}

StepStatus World::advance(double dt, StepReport& report, int depth) {
  StepSettings step = m_settings.step;
  step.dt = dt;
  for (Body& b : m_bodies) {
    b.integrator().evaluate(step, m_settings.fracture && depth == 0 && std::isfinite(b.fracture.toughness));
    report.forces += b.integrator().last_phase_times().forces;
  }
  if (m_settings.fracture && depth == 0) fracture_bodies(report);
  const StepStatus solved = solve_bodies(step, report);
  if (!solved.ok()) {
    if (m_settings.min_dt > 0.0 && 0.5 * dt >= m_settings.min_dt) {
      const StepStatus first = advance(0.5 * dt, report, depth + 1);
      return first.ok() ? advance(0.5 * dt, report, depth + 1) : first;
    }
    return solved;
  }
  ++report.substeps;
  // What the bodies' checkpoint does not hold, to take the substep again as halves.
  const SubstepStart start{m_projectiles, m_energy_put_in};
  const bool resolves = m_settings.exact_when_gaining != ExactResolve::Never;
  if (resolves) save_motion(m_linear_motion);
  launch_and_move_projectiles(dt);
  if (m_settings.collisions) collide(dt, report);
  if (m_settings.exact_when_gaining == ExactResolve::SolveAndContacts) save_motion(m_contact_motion);
  if (m_settings.rotate_on_arcs) rotate_fragments_on_arcs(m_start_positions);
  const bool may_halve = halves_when_gaining(dt, depth);
  // The exact re-solve measures the substep's energy anyway; without it, only where a
  // halving may follow.
  const double energy = resolves ? solve_exactly_if_gaining(step, report) : may_halve ? total_energy() : 0.0;
  if (may_halve && energy > substep_energy_limit() && energy > run_energy_limit()) {
    // Still above its budget after every repair, and above all the run was given: the
    // substep is too long for what happens in it (WorldSettings::energy_halvings).
    return take_again_as_halves(start, dt, report, depth);
  }
  m_time += dt;
  return {};
}

StepStatus World::take_again_as_halves(const SubstepStart& start, double dt, StepReport& report, int depth) {
  // The contact warm starts stay as the substep left them: they are only guesses.
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) m_bodies[bi].integrator().restore(m_substep_checkpoint[bi]);
  m_projectiles = start.projectiles;
  m_energy_put_in = start.energy_put_in;
  --report.substeps;
  ++report.energy_halvings;
  const StepStatus first = advance(0.5 * dt, report, depth + 1);
  return first.ok() ? advance(0.5 * dt, report, depth + 1) : first;
}

double World::run_energy_limit() const {
  const double given = m_start_energy + m_energy_put_in;
  return given + 1e-9 * (std::abs(m_start_energy) + std::abs(m_energy_put_in));
}

bool World::halves_when_gaining(double dt, int depth) const {
  return depth < m_settings.energy_halvings && 0.5 * dt >= m_settings.min_dt;
}

void World::rotate_fragments_on_arcs(const std::vector<Matrix3Xd>& from) {
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    Body& b = m_bodies[bi];
    const Matrix4Xu& tets = b.integrator().elasticity().tets();
    const std::vector<Index>& tet_fragment = b.topology.tet_fragment();
    m_node_fragment.assign(b.integrator().node_count(), 0);
    for (Eigen::Index t = 0; t < tets.cols(); ++t) {
      for (int k = 0; k < 4; ++k) m_node_fragment[tets(k, t)] = tet_fragment[t];
    }
    b.integrator().rotate_rigid_parts(from[bi], m_node_fragment, b.topology.fragment_count());
  }
}

/// The linear solve (one Newton step with the forces linearised about the substep's
/// start) is what keeps ordinary steps cheap, but it can end a substep with energy the
/// substep did not have (issue 16). The energy says when, and which part gained:
///  - The solve (its answer turned on arcs already ends above the budget): parts turning
///    fast about a hinge, which the arcs cannot see. The substep is solved again to
///    convergence from that answer on arcs (so Newton starts close), its contacts
///    answered again, and only their correction turned on arcs afterwards: a converged
///    step already turns each part through atan(hω), and the arcs' linearised fit of the
///    whole displacement would shrink it by cos of that (docs/decisions/0031-fragments-turn-on-arcs.md).
///  - The contact response (ExactResolve::SolveAndContacts only): its correction moved
///    on lines (a bunny crushed under 1e4 m/s² gained 14 kJ in one substep so). Solved
///    again exactly with the response's impulses held. Not the default: a 1 mm steel
///    sliver with ν = 0.499 lying on the ground then runs away (×1e8) in every seed, from
///    the step after one such re-solve on; why is open
///    (docs/decisions/0032-exact-resolve-where-a-substep-gains.md).
double World::solve_exactly_if_gaining(const StepSettings& step, StepReport& report) {
  const double linear = total_energy();
  if (linear <= substep_energy_limit()) return linear;
  save_motion(m_linear_end_motion);
  m_linear_end_impulses = m_contact_impulses;
  m_linear_end_put_in = m_energy_put_in;
  // Which part gained: the solve (its answer on arcs, before contacts and projectiles)
  // or the contact response that followed it.
  restore_motion(m_linear_motion);
  m_energy_put_in = m_substep_put_in;
  if (m_settings.rotate_on_arcs) rotate_fragments_on_arcs(m_start_positions);
  const bool solve_gained = total_energy() > substep_energy_limit();
  if (solve_gained) {
    resolve_exactly(step, report);
  } else if (m_settings.exact_when_gaining == ExactResolve::SolveAndContacts) {
    resolve_contacts_exactly(step, report);
  } else {
    keep_linear_answer();
    return linear;
  }
  ++report.exact_substeps;
  // Both answer the substep; where the exact one still ends higher (its contacts, say,
  // answered linearly after a large exact step), the substep keeps the linear one.
  const double exact = total_energy();
  if (exact > linear) {
    keep_linear_answer();
    ++report.exact_substeps_rejected;
    return linear;
  }
  return exact;
}

void World::resolve_exactly(const StepSettings& step, StepReport& report) {
  // From the linear answer turned on arcs: the arcs take most of the lines' strain away.
  solve_bodies_exactly(step, report, nullptr);
  m_exact_positions.resize(m_bodies.size());
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) m_exact_positions[bi] = m_bodies[bi].integrator().positions();
  launch_and_move_projectiles(step.dt);
  if (m_settings.collisions) collide(step.dt, report);
  // The contacts' correction moves on lines like any linear answer; its turn goes on arcs.
  if (m_settings.rotate_on_arcs) rotate_fragments_on_arcs(m_exact_positions);
}

void World::resolve_contacts_exactly(const StepSettings& step, StepReport& report) {
  // The contact response found impulses p = A δ (δ its velocity correction, A the linear
  // solve's system, still valid: nothing was evaluated since). Moved on lines, δ can
  // strain a body far more than the impulses could (a bunny crushed under 1e4 m/s²
  // gained 14 kJ in one substep this way); held fixed through an exact solve, the
  // same impulses are answered nonlinearly.
  m_held_impulses.resize(m_bodies.size());
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    ImplicitIntegrator& body = m_bodies[bi].integrator();
    Eigen::VectorXd delta(body.system_size());
    for (Index n = 0; n < body.node_count(); ++n) {
      const Index row = body.system_row(n);
      if (row == kInvalidIndex) continue;
      delta.segment<3>(row) = m_contact_motion.bodies[bi].velocities.col(n) - m_linear_motion.bodies[bi].velocities.col(n);
    }
    m_held_impulses[bi].resize(body.system_size());
    body.multiply_system(delta, m_held_impulses[bi]);
  }
  restore_motion(m_contact_motion);
  m_energy_put_in = m_linear_end_put_in;
  m_contact_impulses = m_linear_end_impulses;
  solve_bodies_exactly(step, report, &m_held_impulses);
}

void World::solve_bodies_exactly(const StepSettings& step, StepReport& report,
                                 const std::vector<Eigen::VectorXd>* impulses) {
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    const ImplicitIntegrator::ExactSolve exact = m_bodies[bi].integrator().solve_exactly(
        step, m_substep_checkpoint[bi], m_settings.exact_iterations, impulses ? &(*impulses)[bi] : nullptr);
    report.exact_iterations += exact.iterations;
    report.factorizations += exact.iterations;
  }
}

void World::keep_linear_answer() {
  restore_motion(m_linear_end_motion);
  m_contact_impulses = m_linear_end_impulses;
  m_energy_put_in = m_linear_end_put_in;
}

void World::fracture_bodies(StepReport& report) {
  const auto start = Clock::now();
  for (Index bi = 0; bi < m_bodies.size(); ++bi) {
    Body& b = m_bodies[bi];
    if (!std::isfinite(b.fracture.toughness)) continue;
    std::vector<NodeSplit> splits;
    std::vector<TetFace> exposed;
    const Index fragments_before = b.topology.fragment_count();
    const bool holds_overlaps = m_settings.collisions && m_settings.self_collision;
    if (holds_overlaps) m_fragment_before = b.topology.tet_fragment();
    fracture(b.integrator(), b.topology, b.fracture, splits, exposed);
    // Before the overlaps are recorded: a stand-in may overlap a sphere across the crack.
    if (m_settings.collision_points == CollisionPoints::Spheres) {
      report.stand_in_spheres += static_cast<int>(m_stand_ins[bi].add_for(exposed, b.spheres));
    }
    if (holds_overlaps && b.topology.fragment_count() > fragments_before) record_split_overlaps(b, m_fragment_before);
    for (const NodeSplit& s : splits) report.splits.emplace_back(bi, s);
    for (const TetFace& f : exposed) report.exposed.emplace_back(bi, f);
  }
  report.fracture += seconds_since(start);
}

void World::record_split_overlaps(Body& b, const std::vector<Index>& fragment_before) const {
  const ImplicitIntegrator& body = b.integrator();
  sim::record_split_overlaps(body.positions(), body.elasticity().tets(), b.collision_points(m_settings.collision_points),
                             fragment_before, b.topology.tet_fragment(), b.split_overlaps);
}

StepStatus World::solve_bodies(const StepSettings& step, StepReport& report) {
  // A failed body leaves itself unchanged; the ones solved before it are put back from
  // their checkpoints, so a retry at dt / 2 starts where this (sub)step did.
  std::vector<ImplicitIntegrator::Checkpoint>& before = m_substep_checkpoint;
  before.resize(m_bodies.size());
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    m_bodies[bi].integrator().save(before[bi]);
    m_start_positions[bi] = m_bodies[bi].integrator().positions();
  }
  m_substep_start_energy.clear();
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    ImplicitIntegrator& body = m_bodies[bi].integrator();
    const int factorizations_before = body.factorizations();
    const SolveStatus status = body.solve(step);
    report.factorizations += body.factorizations() - factorizations_before;
    report.assembly += body.last_phase_times().assembly;
    report.solve += body.last_phase_times().solve;
    report.solver_iterations += body.last_iterations();
    if (status == SolveStatus::MaxIterations) report.unconverged = true;
    if (status == SolveStatus::Converged || status == SolveStatus::MaxIterations) continue;
    for (std::size_t bj = 0; bj < bi; ++bj) m_bodies[bj].integrator().restore(before[bj]);
    return {StepOutcome::SolveFailed, static_cast<Index>(bi), status, m_time, step.dt};
  }
  return {};
}

void World::launch_and_move_projectiles(double dt) {
  // Symplectic Euler, like the bodies; a projectile enters the scene at the step
  // nearest its launch time.
  m_projectile_start.resize(m_projectiles.size());
  m_substep_put_in = m_energy_put_in;
  m_substep_projectile_energy = 0.0;
  for (const Projectile& p : m_projectiles) {
    if (p.launched) m_substep_projectile_energy += 0.5 * p.mass * p.velocity.squaredNorm() - p.mass * m_settings.step.gravity.dot(p.position);
  }
  for (std::size_t j = 0; j < m_projectiles.size(); ++j) {
    Projectile& p = m_projectiles[j];
    if (!p.launched && p.launch_time <= m_time + 0.5 * dt) {
      p.launched = true;  // it enters the world with its kinetic and gravity energy
      m_energy_put_in += 0.5 * p.mass * p.velocity.squaredNorm() - p.mass * m_settings.step.gravity.dot(p.position);
    }
    m_projectile_start[j] = p.position;
    if (!p.launched) continue;
    p.velocity += dt * m_settings.step.gravity;
    p.position += dt * p.velocity;
  }
}

void World::collide(double dt, StepReport& report) {
  const auto start = Clock::now();
  std::vector<CollisionBody> collision_bodies;
  collision_bodies.reserve(m_bodies.size());
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    Body& b = m_bodies[bi];
    const EmbeddedPoints& points = b.collision_points(m_settings.collision_points);
    if (!b.split_overlaps.empty()) {
      forget_separated(m_start_positions[bi], b.integrator().elasticity().tets(), points, b.split_overlaps);
    }
    collision_bodies.push_back({&b.integrator(), &points, &m_start_positions[bi], &b.topology.tet_fragment(),
                                b.contact, &b.split_overlaps});
  }
  CollisionSettings cs;
  cs.dt = dt;
  cs.gravity = m_settings.step.gravity;
  cs.self_collision = m_settings.self_collision;
  cs.iterations = m_settings.contact_iterations;
  cs.sparse_blocks_after = m_settings.contact_sparse_blocks_after;
  cs.sparse_blocks_from_start = m_sparse_block_substeps > 0;
  cs.impulses = &m_contact_impulses;
  // With the last substep's impulses, before the contacts are found (collision.h).
  resist_rolling(collision_bodies, m_environment, m_contact_impulses);
  StepContacts contacts(collision_bodies, m_environment, m_projectiles, m_projectile_start, cs);
  if (m_sleeping.enabled()) {
    m_touches = contacts.touches();
    // Faster than a resting contact closes (contact_targets' resting speed), or than a
    // fragment at rest moves.
    const double wake_speed = std::max(2.0 * m_settings.step.gravity.norm() * dt, m_settings.sleep.speed);
    m_sleeping.note_wakes(sleep_bodies(), m_touches, wake_speed);
  }
  const bool restitutes = m_settings.restitution_within_budget && contacts.restituting() > 0;
  if (restitutes) save_motion(m_free_motion);
  // In a pile, substep after substep ends above its budget even inelastically (the
  // push-out of overlaps: 329 of 349 limited substeps on the bunny at toughness 0.2), so
  // the restitution's answer, solved first, was thrown away each time. There, after such
  // a substep, the inelastic answer comes first and restitution is tried only if it
  // leaves room, with the usual outer iterations. (Session 29 gave it twice as many;
  // they bought a pile nothing but time: in 259 of 326 of a pile's responses the last 8
  // each left up to ~20 contacts short by up to 3 cm/s. The light bar under 10^4 m/s^2
  // that sank twice as deep when every substep answered this way, session 28, is no
  // pile. docs/decisions/0026-inelastic-first-in-piles.md.) Outside a pile (no
  // response ran long lately) the wasted answer is cheap, and the order stays:
  // restitution first.
  const bool in_pile = m_sparse_block_substeps > 0;
  const bool inelastic_first = m_settings.inelastic_first_in_piles && restitutes && m_restitution_futile && in_pile;
  const ContactCounts counts = contacts.respond(inelastic_first ? 0.0 : 1.0);
  report.contacts.contacts += counts.contacts;
  report.contacts.swept += counts.swept;
  report.contacts.pairs_tested += counts.pairs_tested;
  report.contacts.response_iterations += counts.response_iterations;
  report.contacts.responses += counts.responses;
  report.contacts.restituting += counts.restituting;
  if (restitutes) {
    const double limit = substep_energy_limit();
    if (inelastic_first) {
      add_restitution_within(contacts, limit, report);
    } else if (total_energy() > limit) {
      keep_restitution_within(contacts, limit, report);
    } else {
      m_restitution_futile = false;
    }
  }
  m_sparse_block_substeps = counts.ran_long ? m_settings.contact_sparse_block_memory
                                            : std::max(m_sparse_block_substeps - 1, 0);
  report.collisions += seconds_since(start);
}

/// Restitution on many coupled contacts is not energy-safe. Newton's rule gives each
/// contact the target "separate at e × my own approach speed"; in a pile of fragments
/// held by thousands of contacts, those targets together can ask for more energy than
/// the impact brought (issue 16: toughness 0 gained ×3 with them and kept the bound
/// without them). So restitution gives back at most what the substep would otherwise
/// lose: when the response with it ends the substep above its budget, the inelastic
/// response is solved too and the largest blend of the two within the budget kept. Both
/// meet their non-penetration targets and the targets are linear in the velocities, so
/// the blend meets targets in between: it is the response with a smaller restitution.
/// This is the energetic bound of simultaneous-impact models (Smith et al. 2012,
/// "Reflections on simultaneous impact"). When even the inelastic response ends above
/// the budget, it stays: what is left above is not restitution's (issue 16's notes).
void World::keep_restitution_within(StepContacts& contacts, double budget, StepReport& report) {
  save_motion(m_bounced_motion);
  const double bounced = total_energy();
  restore_motion(m_free_motion);
  const ContactCounts inelastic_counts = contacts.respond(0.0);
  report.contacts.response_iterations += inelastic_counts.response_iterations;
  report.contacts.responses += inelastic_counts.responses;
  const double inelastic = total_energy();
  double kept = 0.0;
  m_restitution_futile = inelastic > budget;
  if (!m_restitution_futile) {
    save_motion(m_inelastic_motion);
    kept = largest_share_within(budget, inelastic, bounced);
    restore_blend(m_inelastic_motion, m_bounced_motion, kept);
  }
  report.restitution_kept = std::min(report.restitution_kept, kept);
}

void World::add_restitution_within(StepContacts& contacts, double budget, StepReport& report) {
  const double inelastic = total_energy();
  m_restitution_futile = inelastic > budget;
  if (m_restitution_futile) {
    report.restitution_kept = 0.0;
    return;
  }
  save_motion(m_inelastic_motion);
  restore_motion(m_free_motion);
  const ContactCounts bounced_counts = contacts.respond(1.0);
  report.contacts.response_iterations += bounced_counts.response_iterations;
  report.contacts.responses += bounced_counts.responses;
  const double bounced = total_energy();
  if (bounced <= budget) return;
  save_motion(m_bounced_motion);
  const double kept = largest_share_within(budget, inelastic, bounced);
  restore_blend(m_inelastic_motion, m_bounced_motion, kept);
  report.restitution_kept = std::min(report.restitution_kept, kept);
}

double World::largest_share_within(double budget, double inelastic, double bounced) {
  // The energy of the blend at share s: kinetic quadratic in s, gravity linear, strain
  // nearly quadratic. A parabola through s = 0, ½, 1 places the crossing; it is checked,
  // and bisection below it takes over where it misses.
  constexpr int kBisections = 6;  // to 1/64 of the guess
  const auto within = [&](double share) {
    restore_blend(m_inelastic_motion, m_bounced_motion, share);
    return total_energy() <= budget;
  };
  restore_blend(m_inelastic_motion, m_bounced_motion, 0.5);
  const double half = total_energy();
  // E(s) − budget = a s² + b s + c with c ≤ 0 < a + b + c.
  const double c = inelastic - budget, a = 2.0 * (bounced + inelastic) - 4.0 * half, b = bounced - inelastic - a;
  double over = 1.0;
  if (std::abs(a) > 1e-12 * std::abs(b)) {
    const double root = (-b + std::sqrt(std::max(b * b - 4.0 * a * c, 0.0))) / (2.0 * a);
    if (root > 0.0 && root < 1.0) over = root;
  } else if (b > 0.0) {
    over = std::clamp(-c / b, 0.0, 1.0);
  }
  if (within(over)) return over;
  double kept = 0.0;
  for (int i = 0; i < kBisections; ++i) {
    const double share = 0.5 * (kept + over);
    (within(share) ? kept : over) = share;
  }
  return kept;
}

std::pair<double, double> World::substep_energy_budget() const {
  // The bodies at the substep's start (after its fracture, which keeps energy): the
  // positions and velocities solve_bodies saved. Their energies are computed once per
  // substep (the elastic part is a polar decomposition per tet), on first use.
  if (m_substep_start_energy.empty()) {
    for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
      const ImplicitIntegrator& b = m_bodies[bi].integrator();
      const Matrix3Xd& x = m_start_positions[bi];
      const double kinetic = 0.5 * m_substep_checkpoint[bi].velocities.colwise().squaredNorm().dot(b.node_masses());
      const double elastic = b.elasticity().energy(x);
      const double gravity = -m_settings.step.gravity.dot(x * b.node_masses());
      m_substep_start_energy.push_back({kinetic + elastic + gravity, kinetic + elastic + std::abs(gravity)});
    }
  }
  double budget = m_substep_projectile_energy + (m_energy_put_in - m_substep_put_in);
  double magnitude = std::abs(m_substep_projectile_energy) + std::abs(m_energy_put_in - m_substep_put_in);
  for (const auto& [energy, size] : m_substep_start_energy) {
    budget += energy;
    magnitude += size;
  }
  return {budget, 1e-9 * magnitude};
}

void World::save_motion(Motion& out) const {
  out.bodies.resize(m_bodies.size());
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) m_bodies[bi].integrator().save_motion(out.bodies[bi]);
  out.projectiles = m_projectiles;
}

void World::restore_motion(const Motion& motion) {
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) m_bodies[bi].integrator().restore_motion(motion.bodies[bi]);
  m_projectiles = motion.projectiles;
}

void World::restore_blend(const Motion& a, const Motion& b, double s) {
  Motion& blend = m_blend_motion;
  blend.bodies.resize(m_bodies.size());
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    const ImplicitIntegrator::Motion &from = a.bodies[bi], &to = b.bodies[bi];
    blend.bodies[bi].positions = from.positions + s * (to.positions - from.positions);
    blend.bodies[bi].velocities = from.velocities + s * (to.velocities - from.velocities);
    blend.bodies[bi].last_dv = from.last_dv + s * (to.last_dv - from.last_dv);
  }
  blend.projectiles = a.projectiles;
  for (std::size_t j = 0; j < blend.projectiles.size(); ++j) {
    blend.projectiles[j].position += s * (b.projectiles[j].position - a.projectiles[j].position);
    blend.projectiles[j].velocity += s * (b.projectiles[j].velocity - a.projectiles[j].velocity);
  }
  restore_motion(blend);
}

std::optional<Index> World::first_non_finite() const {
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    const ImplicitIntegrator& b = m_bodies[bi].integrator();
    if (!b.positions().allFinite() || !b.velocities().allFinite()) return static_cast<Index>(bi);
  }
  for (const Projectile& p : m_projectiles) {
    if (!p.position.allFinite() || !p.velocity.allFinite()) return kInvalidIndex;
  }
  return std::nullopt;
}

void World::roll_back(const StepReport& report) {
  // Splits newest first, then each body's dynamic state from before the step.
  for (auto it = report.splits.rbegin(); it != report.splits.rend(); ++it) {
    Body& b = m_bodies[it->first];
    b.integrator().undo_split(it->second.node, it->second.added);
    b.topology.undo_split(it->second.node, it->second.added, b.integrator().elasticity().tets());
  }
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) m_bodies[bi].integrator().restore(m_checkpoint.bodies[bi]);
  std::vector<std::uint8_t> split(m_bodies.size(), 0);
  for (const auto& entry : report.splits) split[entry.first] = 1;
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    if (split[bi]) m_bodies[bi].topology.update_fragments(m_bodies[bi].integrator().elasticity().tets());
  }
  m_projectiles = m_checkpoint.projectiles;
  m_contact_impulses = m_checkpoint.impulses;
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    m_bodies[bi].split_overlaps = m_checkpoint.split_overlaps[bi];
    m_stand_ins[bi].truncate(m_bodies[bi].spheres, m_checkpoint.sphere_counts[bi]);
  }
  m_energy_put_in = m_checkpoint.energy_put_in;
  m_time = m_checkpoint.time;
}

void World::keep_previous_positions(const StepReport& report) {
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) std::swap(m_previous_positions[bi], m_checkpoint.bodies[bi].positions);
  // A node split during the step started where its source did.
  for (const auto& [bi, split] : report.splits) {
    Matrix3Xd& previous = m_previous_positions[bi];
    FISSURE_ASSERT(previous.cols() == static_cast<Eigen::Index>(split.added));
    previous.conservativeResize(Eigen::NoChange, previous.cols() + 1);
    previous.col(split.added) = previous.col(split.node);
  }
}

StepFailure World::explain(const StepStatus& status) const {
  const std::string who = status.body < m_bodies.size() ? "body '" + m_bodies[status.body].name + "'" : "a projectile";
  const std::string when = "at t = " + std::to_string(status.time) + " s, " + who + ": ";
  const std::string step = " at dt = " + std::to_string(status.dt) + " s";
  switch (status.outcome) {
    case StepOutcome::Converged:
    case StepOutcome::Substepped: return {when + to_string(status.outcome), ""};
    case StepOutcome::SolveFailed:
      return {when + "the implicit solve failed (" + to_string(status.solve) + ")" + step,
              m_settings.min_dt > 0.0 ? "lower solver.min_dt, or use a smaller solver.dt"
                                      : "set solver.min_dt to let steps halve, or use a smaller solver.dt"};
    case StepOutcome::NonFinite:
      return {when + "the state became non-finite" + step,
              "use a smaller solver.dt or set solver.min_dt; please report the scene"};
  }
  return {when + "unknown outcome", ""};
}

void World::set_settings(const WorldSettings& settings) {
  check_time_step(settings.step.dt);
  check_max_substep(settings.step.dt, settings.max_substep);
  // The recorded pairs index the collision points in use.
  if (settings.collision_points != m_settings.collision_points) {
    for (Body& b : m_bodies) b.split_overlaps.clear();
  }
  // Back to spheres: the tets exposed meanwhile get theirs now.
  if (settings.collision_points == CollisionPoints::Spheres && m_settings.collision_points != CollisionPoints::Spheres) {
    for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
      m_stand_ins[bi].add_for(fractured_faces(m_bodies[bi].topology), m_bodies[bi].spheres);
    }
  }
  m_settings = settings;
  for (Body& b : m_bodies) b.fracture.max_splits_per_step = settings.max_splits_per_step;
}

void World::set_material(Index body, const Material& material, double toughness) {
  Body& b = m_bodies.at(body);
  if (!(toughness >= 0.0)) {
    throw Error("body '" + b.name + "': toughness " + std::to_string(toughness) + " is not ≥ 0",
                "give a toughness in newtons, ∞ for none");
  }
  b.integrator().set_material(material);
  b.fracture.toughness = toughness;
}

void World::add_projectile(Projectile projectile) {
  if (!projectile.position.allFinite() || !projectile.velocity.allFinite() || !(projectile.radius > 0.0) ||
      !(projectile.mass > 0.0) || !std::isfinite(projectile.radius) || !std::isfinite(projectile.mass)) {
    throw Error("a projectile needs a finite position and velocity and a positive, finite radius and mass",
                "check the shot's settings");
  }
  projectile.launch_time = m_time;
  projectile.launched = false;
  m_projectiles.push_back(projectile);
}

void World::redo_splits(Index body, std::span<const RecordedSplit> splits) {
  Body& b = m_bodies.at(body);
  const Matrix4Xu& tets = b.integrator().elasticity().tets();
  // Check the whole batch first: the table after the earlier splits of the batch.
  Matrix4Xu after = tets;
  NodeIndex next = b.integrator().node_count();
  for (const RecordedSplit& s : splits) {
    const bool fits = s.node < next && s.added == next && !s.moved.empty();
    if (!fits) {
      throw Error("body '" + b.name + "': the recorded split of node " + std::to_string(s.node) + " into " +
                      std::to_string(s.added) + " does not fit its " + std::to_string(next) + " nodes",
                  "replay a trajectory with the scene that recorded it");
    }
    for (const TetIndex t : s.moved) {
      Index* corner = static_cast<Eigen::Index>(t) < after.cols() ? std::find(after.col(t).data(), after.col(t).data() + 4, s.node) : nullptr;
      if (corner == nullptr || corner == after.col(t).data() + 4) {
        throw Error("body '" + b.name + "': the recorded split of node " + std::to_string(s.node) + " moves tet " +
                        std::to_string(t) + ", which does not hold it",
                    "replay a trajectory with the scene that recorded it");
      }
      *corner = s.added;
    }
    ++next;
  }
  std::vector<std::pair<TetIndex, int>> slots;
  std::vector<TetFace> exposed;
  for (const RecordedSplit& s : splits) {
    slots.clear();
    for (const TetIndex t : s.moved) {
      const auto column = tets.col(t);
      slots.emplace_back(t, static_cast<int>(std::find(column.data(), column.data() + 4, s.node) - column.data()));
    }
    const NodeIndex added = b.integrator().split_node(s.node, slots);
    b.topology.on_split(s.node, added, slots, tets, exposed);
    m_previous_positions[body].conservativeResize(Eigen::NoChange, added + 1);
    m_previous_positions[body].col(added) = m_previous_positions[body].col(s.node);
  }
  if (!splits.empty()) b.topology.update_fragments(tets);
  m_deformation_step[body] = 0;
}

void World::undo_splits(Index body, std::span<const RecordedSplit> splits) {
  Body& b = m_bodies.at(body);
  for (auto s = splits.rbegin(); s != splits.rend(); ++s) {
    FISSURE_ASSERT(s->added + 1 == b.integrator().node_count());
    b.integrator().undo_split(s->node, s->added);
    b.topology.undo_split(s->node, s->added, b.integrator().elasticity().tets());
    m_previous_positions[body].conservativeResize(Eigen::NoChange, s->added);
  }
  if (!splits.empty()) b.topology.update_fragments(b.integrator().elasticity().tets());
  m_deformation_step[body] = 0;
}

void World::pose(Index body, const Matrix3Xd& positions) {
  ImplicitIntegrator& integrator = m_bodies.at(body).integrator();
  integrator.set_positions(positions);
  integrator.set_velocities(Matrix3Xd::Zero(3, integrator.node_count()));
  m_previous_positions[body] = positions;
  m_deformation_step[body] = 0;
}

void World::pose(double time, std::span<const Projectile> projectiles) {
  FISSURE_ASSERT(projectiles.size() == m_projectiles.size());
  m_time = time;
  std::copy(projectiles.begin(), projectiles.end(), m_projectiles.begin());
}

void World::set_velocities(Index body, const Matrix3Xd& velocities) {
  ImplicitIntegrator& integrator = m_bodies.at(body).integrator();
  const double before = integrator.kinetic_energy();
  integrator.set_velocities(velocities);
  m_energy_put_in += integrator.kinetic_energy() - before;
}

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

double World::kinetic_energy() const {
  double e = 0.0;
  for (const Body& b : m_bodies) e += b.integrator().kinetic_energy();
  for (const Projectile& p : m_projectiles) {
    if (p.launched) e += 0.5 * p.mass * p.velocity.squaredNorm();
  }
  return e;
}

double World::elastic_energy() const {
  double e = 0.0;
  for (const Body& b : m_bodies) e += b.integrator().elasticity().energy(b.integrator().positions());
  return e;
}

double World::potential_energy() const {
  double e = 0.0;
  for (const Body& b : m_bodies) e -= m_settings.step.gravity.dot(b.integrator().positions() * b.integrator().node_masses());
  for (const Projectile& p : m_projectiles) {
    if (p.launched) e -= p.mass * m_settings.step.gravity.dot(p.position);
  }
  return e;
}

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

double World::vertex_penetration() const {
  double depth = 0.0;
  for (const Body& b : m_bodies) {
    for (std::size_t k = 0; k < b.vertices.size(); ++k) {
      const Vec3 p = embedded_position(b.integrator().positions(), b.integrator().elasticity().tets(), b.vertices, k);
      depth = std::max(depth, penetration(p, 0.0, m_environment, m_projectiles));
    }
  }
  return depth;
}

}  // namespace fissure::sim
