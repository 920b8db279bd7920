#include "player/sim/world.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "common/assert.h"
#include "common/error.h"
#include "player/sim/contacts/stand_in_spheres.h"
#include "player/sim/rigid_rotation.h"

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

/// Each reserve sphere has a cover tet or kInvalidIndex.
void check_reserve_cover(const std::vector<TetIndex>& cover, std::size_t reserve_count, std::size_t tet_count,
                         const std::string& what) {
  if (cover.size() != reserve_count) {
    throw Error(what + ": " + std::to_string(cover.size()) + " cover tets for " + std::to_string(reserve_count) + " spheres",
                "rebake the bundle");
  }
  for (std::size_t k = 0; k < cover.size(); ++k) {
    if (cover[k] != kInvalidIndex && cover[k] >= tet_count) {
      throw Error(what + ": sphere " + std::to_string(k) + " has cover tet " + std::to_string(cover[k]) + ", out of range",
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
    check_points(d.reserve_spheres, tet_count, where + " reserve spheres");
    check_reserve_cover(d.reserve_cover, d.reserve_spheres.size(), tet_count, where + " reserve spheres");
    m_stand_ins.emplace_back(d.rest, d.tets, spheres, d.mass ? &*d.mass : nullptr, d.reserve_spheres, d.reserve_cover);
    m_bodies.emplace_back(d.name, std::move(solver), std::move(topology),
                          FractureSettings{d.toughness, settings.max_splits_per_step}, d.contact, std::move(spheres),
                          std::move(d.vertices));
  }
  m_start_positions.resize(m_bodies.size());
  m_checkpoint.bodies.resize(m_bodies.size());
  for (const Body& b : m_bodies) m_previous_positions.push_back(b.integrator().positions());
  m_deformation.resize(m_bodies.size());
  m_deformation_step.assign(m_bodies.size(), 0);
  m_guard.budget().start_run(total_energy());
  // The first step's factorizations happen here, at load, not in a step.
  StepSettings first = m_settings.step;
  first.dt /= planned_substeps();
  for (Body& b : m_bodies) b.integrator().prepare(first);
}

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
  m_checkpoint.energy_put_in = m_guard.budget().put_in();
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
  const SubstepStart start{m_projectiles, m_guard.budget().put_in()};
  const bool resolves = m_settings.exact_when_gaining != ExactResolve::Never;
  if (resolves) m_guard.save_linear_answer(guarded());
  launch_and_move_projectiles(dt);
  if (m_settings.collisions) collide(dt, report);
  if (m_settings.exact_when_gaining == ExactResolve::SolveAndContacts) m_guard.save_contact_answer(guarded());
  if (m_settings.rotate_on_arcs) {
    rotate_fragments_on_arcs(m_bodies, m_start_positions, m_settings.contacts.rigid_fragments_below, m_node_fragment);
  }
  const bool may_halve = EnergyGuard::halves_when_gaining(m_settings, dt, depth);
  const bool moves_chips = m_settings.rigid_when_gaining_below > 0;
  GuardedWorld world = guarded();
  const auto guard_start = Clock::now();
  const double collisions_before = report.collisions;
  // The exact re-solve measures the substep's energy anyway; without it, only where a
  // repair may follow (the start first: see EnergyGuard::solve_exactly_if_gaining).
  double energy = 0.0;
  if (resolves) {
    energy = m_guard.solve_exactly_if_gaining(world, step, report, [&] {
      launch_and_move_projectiles(dt);
      if (m_settings.collisions) collide(dt, report);
    });
  } else if (may_halve || moves_chips) {
    m_guard.measure_substep_start(world);
    energy = total_energy();
  }
  if (moves_chips && m_guard.above_all(world, energy)) {
    const double limit = std::max(m_guard.substep_limit(world), m_guard.budget().run_limit());
    energy = m_guard.move_gaining_chips_rigidly(world, energy, limit, report);
  }
  report.guard += seconds_since(guard_start) - (report.collisions - collisions_before);
  if (may_halve && m_guard.above_all(world, energy)) {
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
  m_guard.budget().restore_put_in(start.energy_put_in);
  --report.substeps;
  ++report.energy_halvings;
  const StepStatus first = advance(0.5 * dt, report, depth + 1);
  return first.ok() ? advance(0.5 * dt, report, depth + 1) : first;
}

GuardedWorld World::guarded() {
  return {m_bodies, m_projectiles, m_contact_impulses, m_start_positions, m_substep_checkpoint, m_settings};
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
      report.stand_in_spheres += static_cast<int>(
          m_stand_ins[bi].add_for(exposed, b.integrator().elasticity().tets(), b.topology.tet_fragment(), b.spheres));
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
  m_guard.budget().forget_bodies_at_substep_start();
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
  double projectile_energy = 0.0;
  for (const Projectile& p : m_projectiles) {
    if (p.launched) projectile_energy += 0.5 * p.mass * p.velocity.squaredNorm() - p.mass * m_settings.step.gravity.dot(p.position);
  }
  m_guard.budget().start_substep(projectile_energy);
  for (std::size_t j = 0; j < m_projectiles.size(); ++j) {
    Projectile& p = m_projectiles[j];
    if (!p.launched && p.launch_time <= m_time + 0.5 * dt) {
      p.launched = true;  // it enters the world with its kinetic and gravity energy
      m_guard.budget().put_in(0.5 * p.mass * p.velocity.squaredNorm() - p.mass * m_settings.step.gravity.dot(p.position));
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
    const bool spheres = m_settings.collision_points == CollisionPoints::Spheres;
    collision_bodies.push_back({&b.integrator(), &points, &m_start_positions[bi], &b.topology.tet_fragment(),
                                b.contact, &b.split_overlaps, spheres ? &m_stand_ins[bi].obstacles_only() : nullptr});
  }
  CollisionSettings cs;
  cs.dt = dt;
  cs.gravity = m_settings.step.gravity;
  cs.self_collision = m_settings.self_collision;
  cs.contacts = m_settings.contacts;
  cs.sparse_blocks_from_start = m_pile.sparse_blocks_from_start();
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
  if (restitutes) m_guard.save_free_motion(guarded());
  // In a pile, substep after substep ends above its budget even inelastically (the
  // push-out of overlaps: 329 of 349 limited substeps on the bunny at toughness 0.2), so
  // the restitution's answer, solved first, was thrown away each time. There, after such
  // a substep, the inelastic answer comes first and restitution is tried only if it
  // leaves room, with the usual outer iterations. (Session 29 gave it twice as many;
  // they bought a pile nothing but time: in 259 of 326 of a pile's responses the last 8
  // each left up to ~20 contacts short by up to 3 cm/s. The light bar under 10^4 m/s^2
  // that sank twice as deep when every substep answered this way, session 28, is no
  // pile. docs/decisions/0026-inelastic-first-in-piles.md.) Debris whose sequential
  // impulses sweep to their cap is a pile too (pile.h): at toughness 0 it made the step
  // 0.84× as long. Outside a pile (no response ran long or swept to its cap lately)
  // the wasted answer is cheap, and the order stays: restitution first.
  const bool inelastic_first = m_settings.inelastic_first_in_piles && restitutes && m_guard.restitution_futile() && m_pile.in_pile();
  const ContactCounts counts = contacts.respond(inelastic_first ? 0.0 : 1.0);
  report.contacts.contacts += counts.contacts;
  report.contacts.swept += counts.swept;
  report.contacts.pairs_tested += counts.pairs_tested;
  report.contacts.add_response(counts);
  report.contacts.restituting += counts.restituting;
  if (restitutes) {
    GuardedWorld world = guarded();
    m_guard.keep_restitution_within_budget(world, contacts, inelastic_first, report);
  }
  m_pile.note(counts, m_settings.contacts.sparse_block_memory);
  report.collisions += seconds_since(start);
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
  m_guard.budget().restore_put_in(m_checkpoint.energy_put_in);
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
      const FractureTopology& topology = m_bodies[bi].topology;
      m_stand_ins[bi].add_for(fractured_faces(topology), m_bodies[bi].integrator().elasticity().tets(),
                              topology.tet_fragment(), m_bodies[bi].spheres);
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

void World::set_velocities(Index body, const Matrix3Xd& velocities) {
  ImplicitIntegrator& integrator = m_bodies.at(body).integrator();
  const double before = integrator.kinetic_energy();
  integrator.set_velocities(velocities);
  m_guard.budget().put_in(integrator.kinetic_energy() - before);
}

}  // namespace fissure::sim
