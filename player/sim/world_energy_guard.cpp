// World's energy guard (issue 16): the substep's energy budget, restitution kept within
// it, the exact re-solve of a substep that gained, and the halving of one that still
// does. Every substep pays only for the checks it needs; ordinary ones end within the
// budget on the first test.
#include <algorithm>
#include <cmath>
#include <tuple>

#include "player/sim/rigid_rotation.h"
#include "player/sim/world.h"

namespace fissure::sim {

StepStatus World::take_again_as_halves(const SubstepStart& start, double dt, StepReport& report, int depth) {
  // The contact warm starts stay as the substep left them: they are only guesses.
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) m_bodies[bi].integrator().restore(m_substep_checkpoint[bi]);
  m_projectiles = start.projectiles;
  m_energy.restore_put_in(start.energy_put_in);
  --report.substeps;
  ++report.energy_halvings;
  const StepStatus first = advance(0.5 * dt, report, depth + 1);
  return first.ok() ? advance(0.5 * dt, report, depth + 1) : first;
}

bool World::halves_when_gaining(double dt, int depth) const {
  return depth < m_settings.energy_halvings && 0.5 * dt >= m_settings.min_dt;
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
  // The start first: it is the last substep's end, whose elastic energy is known
  // (CorotatedElasticity::energy keeps its last answer).
  measure_substep_start();
  const double linear = total_energy();
  if (linear <= m_energy.exact_resolve_limit(m_settings.exact_gain_share)) return linear;
  save_motion(m_linear_end_motion);
  m_linear_end_impulses = m_contact_impulses;
  m_linear_end_put_in = m_energy.put_in();
  // Which part gained: the solve (its answer on arcs, before contacts and projectiles)
  // or the contact response that followed it.
  restore_motion(m_linear_motion);
  m_energy.restore_put_in(m_energy.put_in_at_substep_start());
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
  m_energy.restore_put_in(m_linear_end_put_in);
  m_contact_impulses = m_linear_end_impulses;
  solve_bodies_exactly(step, report, &m_held_impulses);
}

void World::solve_bodies_exactly(const StepSettings& step, StepReport& report,
                                 const std::vector<Eigen::VectorXd>* impulses) {
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    const ImplicitIntegrator::ExactSolve exact = m_bodies[bi].integrator().solve_exactly(
        step, m_substep_checkpoint[bi], m_settings.exact_iterations, impulses ? &(*impulses)[bi] : nullptr);
    report.exact_iterations += exact.iterations;
    report.factorizations += exact.factorizations;
  }
}

void World::keep_linear_answer() {
  restore_motion(m_linear_end_motion);
  m_contact_impulses = m_linear_end_impulses;
  m_energy.restore_put_in(m_linear_end_put_in);
}

/// What no exact re-solve or halving repairs: a chip of a nearly incompressible material
/// whose linear solve runs away. At ν = 0.4999 a 3-tet fragment a split had just made
/// took 14.3 J of strain into one tet in one substep, and the next solves 1.4 MJ; the
/// halvings cannot stop it, and every later substep then halves to the floor (steps of
/// 13 s). The repair blames the chips that gained: each fragment of few tets is measured
/// at the substep's start and now (kinetic, strain and gravity), and the fewest of them,
/// largest gain first, whose gains cover the excess move rigidly from the start instead
/// (rigid_rotation.h): the start's shape moved and turned, so their strain is the start's,
/// and their velocities projected onto the rigid field, so their kinetic energy does not
/// rise. Kept only where the world then holds less. A chip answered so loses its flex
/// for one substep; the next substep solves it again.
std::vector<World::ChipGain> World::chip_gains(std::vector<std::vector<std::uint8_t>>& chips) {
  std::vector<ChipGain> gains;
  chips.assign(m_bodies.size(), {});
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    const Body& b = m_bodies[bi];
    const Index count = b.topology.fragment_count();
    const std::vector<Index>& tet_fragment = b.topology.tet_fragment();
    chips[bi] = small_fragments(tet_fragment, count, m_settings.rigid_when_gaining_below);
    if (std::none_of(chips[bi].begin(), chips[bi].end(), [](std::uint8_t c) { return c != 0; })) continue;
    const ImplicitIntegrator& body = b.integrator();
    const Matrix3Xd &x0 = m_start_positions[bi], &v0 = m_substep_checkpoint[bi].velocities;
    std::vector<double> gain(count, 0.0);
    for (TetIndex t = 0; t < tet_fragment.size(); ++t) {
      if (!chips[bi][tet_fragment[t]]) continue;
      gain[tet_fragment[t]] += body.elasticity().tet_energy(body.positions(), t) - body.elasticity().tet_energy(x0, t);
    }
    find_node_fragments(bi);
    for (Index n = 0; n < body.node_count(); ++n) {
      if (!chips[bi][m_node_fragment[n]]) continue;
      const double m = body.node_masses()[n];
      gain[m_node_fragment[n]] += 0.5 * m * (body.velocities().col(n).squaredNorm() - v0.col(n).squaredNorm()) -
                                  m * m_settings.step.gravity.dot(body.positions().col(n) - x0.col(n));
    }
    for (Index f = 0; f < count; ++f) {
      if (chips[bi][f] && gain[f] > 0.0) gains.push_back({gain[f], bi, f});
    }
  }
  std::sort(gains.begin(), gains.end(), [](const ChipGain& a, const ChipGain& b) {
    return a.joules != b.joules ? a.joules > b.joules : std::tie(a.body, a.fragment) < std::tie(b.body, b.fragment);
  });
  return gains;
}

double World::move_gaining_chips_rigidly(double energy, double limit, StepReport& report) {
  std::vector<std::vector<std::uint8_t>> chips;
  const std::vector<ChipGain> gains = chip_gains(chips);
  // The fewest chips whose gains cover the excess; where all of them do not, the chips
  // are not what gained.
  double covered = 0.0;
  std::size_t taken = 0;
  while (taken < gains.size() && covered < energy - limit) covered += gains[taken++].joules;
  if (covered < energy - limit) return energy;
  for (std::vector<std::uint8_t>& c : chips) std::fill(c.begin(), c.end(), 0);
  for (std::size_t k = 0; k < taken; ++k) chips[gains[k].body][gains[k].fragment] = 1;
  save_motion(m_unrepaired_motion);
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    if (std::none_of(chips[bi].begin(), chips[bi].end(), [](std::uint8_t c) { return c != 0; })) continue;
    find_node_fragments(bi);
    m_bodies[bi].integrator().move_rigidly(m_start_positions[bi], m_node_fragment,
                                           m_bodies[bi].topology.fragment_count(), chips[bi]);
  }
  const double repaired = total_energy();
  if (!(repaired < energy)) {
    restore_motion(m_unrepaired_motion);
    return energy;
  }
  report.chips_moved_rigidly += static_cast<int>(taken);
  return repaired;
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
  report.contacts.response_sweeps += inelastic_counts.response_sweeps;
  report.contacts.rigid_answers += inelastic_counts.rigid_answers;
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
  report.contacts.response_sweeps += bounced_counts.response_sweeps;
  report.contacts.rigid_answers += bounced_counts.rigid_answers;
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

double World::substep_energy_limit() {
  measure_substep_start();
  return m_energy.substep_limit();
}

void World::measure_substep_start() {
  // The bodies at the substep's start (after its fracture, which keeps energy): the
  // positions and velocities solve_bodies saved.
  if (m_energy.knows_bodies_at_substep_start()) return;
  for (std::size_t bi = 0; bi < m_bodies.size(); ++bi) {
    const ImplicitIntegrator& b = m_bodies[bi].integrator();
    const Matrix3Xd& x = m_start_positions[bi];
    const double kinetic = 0.5 * m_substep_checkpoint[bi].velocities.colwise().squaredNorm().dot(b.node_masses());
    const double elastic = b.elasticity().energy(x);
    const double gravity = -m_settings.step.gravity.dot(x * b.node_masses());
    m_energy.add_body_at_substep_start(kinetic + elastic + gravity, kinetic + elastic + std::abs(gravity));
  }
  m_energy.bodies_measured();
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

}  // namespace fissure::sim
