#include "player/sim/energy_guard.h"

#include <algorithm>
#include <cmath>
#include <tuple>

#include "player/sim/rigid_rotation.h"
#include "player/sim/step_report.h"

namespace fissure::sim {

bool EnergyGuard::halves_when_gaining(const WorldSettings& settings, double dt, int depth) {
  return depth < settings.energy_halvings && 0.5 * dt >= settings.min_dt;
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
double EnergyGuard::solve_exactly_if_gaining(GuardedWorld& world, const StepSettings& step, StepReport& report,
                                             const ContactsAgain& contacts_again) {
  // The start first: it is the last substep's end, whose elastic energy is known
  // (CorotatedElasticity::energy keeps its last answer).
  measure_substep_start(world);
  const double linear = world.total_energy();
  if (linear <= m_budget.exact_resolve_limit(world.settings.exact_gain_share)) return linear;
  save_motion(world, m_linear_end_motion);
  m_linear_end_impulses = world.contact_impulses;
  m_linear_end_put_in = m_budget.put_in();
  // Which part gained: the solve (its answer on arcs, before contacts and projectiles)
  // or the contact response that followed it.
  restore_motion(world, m_linear_motion);
  m_budget.restore_put_in(m_budget.put_in_at_substep_start());
  if (world.settings.rotate_on_arcs) {
    rotate_fragments_on_arcs(world.bodies, world.start_positions, world.settings.contacts.rigid_fragments_below,
                             m_node_fragment);
  }
  const bool solve_gained = world.total_energy() > substep_limit(world);
  if (solve_gained) {
    resolve_exactly(world, step, report, contacts_again);
  } else if (world.settings.exact_when_gaining == ExactResolve::SolveAndContacts) {
    resolve_contacts_exactly(world, step, report);
  } else {
    keep_linear_answer(world);
    return linear;
  }
  ++report.exact_substeps;
  // Both answer the substep; where the exact one still ends higher (its contacts, say,
  // answered linearly after a large exact step), the substep keeps the linear one.
  const double exact = world.total_energy();
  if (exact > linear) {
    keep_linear_answer(world);
    ++report.exact_substeps_rejected;
    return linear;
  }
  return exact;
}

void EnergyGuard::resolve_exactly(GuardedWorld& world, const StepSettings& step, StepReport& report,
                                  const ContactsAgain& contacts_again) {
  // From the linear answer turned on arcs: the arcs take most of the lines' strain away.
  solve_bodies_exactly(world, step, report, nullptr);
  m_exact_positions.resize(world.bodies.size());
  for (std::size_t bi = 0; bi < world.bodies.size(); ++bi) m_exact_positions[bi] = world.bodies[bi].integrator().positions();
  contacts_again();
  // The contacts' correction moves on lines like any linear answer; its turn goes on arcs.
  if (world.settings.rotate_on_arcs) {
    rotate_fragments_on_arcs(world.bodies, m_exact_positions, world.settings.contacts.rigid_fragments_below,
                             m_node_fragment);
  }
}

void EnergyGuard::resolve_contacts_exactly(GuardedWorld& world, const StepSettings& step, StepReport& report) {
  // The contact response found impulses p = A δ (δ its velocity correction, A the linear
  // solve's system, still valid: nothing was evaluated since). Moved on lines, δ can
  // strain a body far more than the impulses could (a bunny crushed under 1e4 m/s²
  // gained 14 kJ in one substep this way); held fixed through an exact solve, the
  // same impulses are answered nonlinearly.
  m_held_impulses.resize(world.bodies.size());
  for (std::size_t bi = 0; bi < world.bodies.size(); ++bi) {
    ImplicitIntegrator& body = world.bodies[bi].integrator();
    Eigen::VectorXd delta(body.system_size());
    for (Index n = 0; n < body.node_count(); ++n) {
      const Index row = body.system_row(n);
      if (row == kInvalidIndex) continue;
      delta.segment<3>(row) = m_contact_motion.bodies[bi].velocities.col(n) - m_linear_motion.bodies[bi].velocities.col(n);
    }
    m_held_impulses[bi].resize(body.system_size());
    body.multiply_system(delta, m_held_impulses[bi]);
  }
  restore_motion(world, m_contact_motion);
  m_budget.restore_put_in(m_linear_end_put_in);
  world.contact_impulses = m_linear_end_impulses;
  solve_bodies_exactly(world, step, report, &m_held_impulses);
}

void EnergyGuard::solve_bodies_exactly(GuardedWorld& world, const StepSettings& step, StepReport& report,
                                       const std::vector<Eigen::VectorXd>* impulses) {
  for (std::size_t bi = 0; bi < world.bodies.size(); ++bi) {
    const ImplicitIntegrator::ExactSolve exact = world.bodies[bi].integrator().solve_exactly(
        step, world.substep_start[bi], world.settings.exact_iterations, impulses ? &(*impulses)[bi] : nullptr);
    report.exact_iterations += exact.iterations;
    report.factorizations += exact.factorizations;
  }
}

void EnergyGuard::keep_linear_answer(GuardedWorld& world) {
  restore_motion(world, m_linear_end_motion);
  world.contact_impulses = m_linear_end_impulses;
  m_budget.restore_put_in(m_linear_end_put_in);
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
std::vector<EnergyGuard::ChipGain> EnergyGuard::chip_gains(const GuardedWorld& world,
                                                           std::vector<std::vector<std::uint8_t>>& chips) {
  std::vector<ChipGain> gains;
  chips.assign(world.bodies.size(), {});
  for (std::size_t bi = 0; bi < world.bodies.size(); ++bi) {
    const Body& b = world.bodies[bi];
    const Index count = b.topology.fragment_count();
    const std::vector<Index>& tet_fragment = b.topology.tet_fragment();
    chips[bi] = small_fragments(tet_fragment, count, world.settings.rigid_when_gaining_below);
    if (std::none_of(chips[bi].begin(), chips[bi].end(), [](std::uint8_t c) { return c != 0; })) continue;
    const ImplicitIntegrator& body = b.integrator();
    const Matrix3Xd &x0 = world.start_positions[bi], &v0 = world.substep_start[bi].velocities;
    std::vector<double> gain(count, 0.0);
    for (TetIndex t = 0; t < tet_fragment.size(); ++t) {
      if (!chips[bi][tet_fragment[t]]) continue;
      gain[tet_fragment[t]] += body.elasticity().tet_energy(body.positions(), t) - body.elasticity().tet_energy(x0, t);
    }
    find_node_fragments(world.bodies[bi], m_node_fragment);
    for (Index n = 0; n < body.node_count(); ++n) {
      if (!chips[bi][m_node_fragment[n]]) continue;
      const double m = body.node_masses()[n];
      gain[m_node_fragment[n]] += 0.5 * m * (body.velocities().col(n).squaredNorm() - v0.col(n).squaredNorm()) -
                                  m * world.settings.step.gravity.dot(body.positions().col(n) - x0.col(n));
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

double EnergyGuard::move_gaining_chips_rigidly(GuardedWorld& world, double energy, double limit, StepReport& report) {
  std::vector<std::vector<std::uint8_t>> chips;
  const std::vector<ChipGain> gains = chip_gains(world, chips);
  // The fewest chips whose gains cover the excess; where all of them do not, the chips
  // are not what gained.
  double covered = 0.0;
  std::size_t taken = 0;
  while (taken < gains.size() && covered < energy - limit) covered += gains[taken++].joules;
  if (covered < energy - limit) return energy;
  for (std::vector<std::uint8_t>& c : chips) std::fill(c.begin(), c.end(), 0);
  for (std::size_t k = 0; k < taken; ++k) chips[gains[k].body][gains[k].fragment] = 1;
  save_motion(world, m_unrepaired_motion);
  for (std::size_t bi = 0; bi < world.bodies.size(); ++bi) {
    if (std::none_of(chips[bi].begin(), chips[bi].end(), [](std::uint8_t c) { return c != 0; })) continue;
    find_node_fragments(world.bodies[bi], m_node_fragment);
    world.bodies[bi].integrator().move_rigidly(world.start_positions[bi], m_node_fragment,
                                           world.bodies[bi].topology.fragment_count(), chips[bi]);
  }
  const double repaired = world.total_energy();
  if (!(repaired < energy)) {
    restore_motion(world, m_unrepaired_motion);
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
void EnergyGuard::keep_restitution_within_budget(GuardedWorld& world, StepContacts& contacts, bool inelastic_first,
                                                 StepReport& report) {
  const double limit = substep_limit(world);
  if (inelastic_first) {
    add_restitution_within(world, contacts, limit, report);
  } else if (world.total_energy() > limit) {
    keep_restitution_within(world, contacts, limit, report);
  } else {
    m_restitution_futile = false;
  }
}

void EnergyGuard::keep_restitution_within(GuardedWorld& world, StepContacts& contacts, double budget,
                                          StepReport& report) {
  save_motion(world, m_bounced_motion);
  const double bounced = world.total_energy();
  restore_motion(world, m_free_motion);
  report.contacts.add_response(contacts.respond(0.0));
  const double inelastic = world.total_energy();
  double kept = 0.0;
  m_restitution_futile = inelastic > budget;
  if (!m_restitution_futile) {
    save_motion(world, m_inelastic_motion);
    kept = largest_share_within(world, budget, inelastic, bounced);
    restore_blend(world, m_inelastic_motion, m_bounced_motion, kept);
  }
  report.restitution_kept = std::min(report.restitution_kept, kept);
}

void EnergyGuard::add_restitution_within(GuardedWorld& world, StepContacts& contacts, double budget,
                                         StepReport& report) {
  const double inelastic = world.total_energy();
  m_restitution_futile = inelastic > budget;
  if (m_restitution_futile) {
    report.restitution_kept = 0.0;
    return;
  }
  save_motion(world, m_inelastic_motion);
  restore_motion(world, m_free_motion);
  report.contacts.add_response(contacts.respond(1.0));
  const double bounced = world.total_energy();
  if (bounced <= budget) return;
  save_motion(world, m_bounced_motion);
  const double kept = largest_share_within(world, budget, inelastic, bounced);
  restore_blend(world, m_inelastic_motion, m_bounced_motion, kept);
  report.restitution_kept = std::min(report.restitution_kept, kept);
}

double EnergyGuard::largest_share_within(GuardedWorld& world, double budget, double inelastic, double bounced) {
  // The energy of the blend at share s: kinetic quadratic in s, gravity linear, strain
  // nearly quadratic. A parabola through s = 0, ½, 1 places the crossing; it is checked,
  // and bisection below it takes over where it misses.
  constexpr int kBisections = 6;  // to 1/64 of the guess
  const auto within = [&](double share) {
    restore_blend(world, m_inelastic_motion, m_bounced_motion, share);
    return world.total_energy() <= budget;
  };
  restore_blend(world, m_inelastic_motion, m_bounced_motion, 0.5);
  const double half = world.total_energy();
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

bool EnergyGuard::above_all(const GuardedWorld& world, double energy) {
  return energy > substep_limit(world) && energy > m_budget.run_limit();
}

double EnergyGuard::substep_limit(const GuardedWorld& world) {
  measure_substep_start(world);
  return m_budget.substep_limit();
}

void EnergyGuard::measure_substep_start(const GuardedWorld& world) {
  // The bodies at the substep's start (after its fracture, which keeps energy): the
  // positions and velocities World::solve_bodies saved.
  if (m_budget.knows_bodies_at_substep_start()) return;
  for (std::size_t bi = 0; bi < world.bodies.size(); ++bi) {
    const ImplicitIntegrator& b = world.bodies[bi].integrator();
    const Matrix3Xd& x = world.start_positions[bi];
    const double kinetic = 0.5 * world.substep_start[bi].velocities.colwise().squaredNorm().dot(b.node_masses());
    const double elastic = b.elasticity().energy(x);
    const double gravity = -world.settings.step.gravity.dot(x * b.node_masses());
    m_budget.add_body_at_substep_start(kinetic + elastic + gravity, kinetic + elastic + std::abs(gravity));
  }
  m_budget.bodies_measured();
}

void EnergyGuard::save_motion(const GuardedWorld& world, Motion& out) {
  out.bodies.resize(world.bodies.size());
  for (std::size_t bi = 0; bi < world.bodies.size(); ++bi) world.bodies[bi].integrator().save_motion(out.bodies[bi]);
  out.projectiles = world.projectiles;
}

void EnergyGuard::restore_motion(GuardedWorld& world, const Motion& motion) {
  for (std::size_t bi = 0; bi < world.bodies.size(); ++bi) world.bodies[bi].integrator().restore_motion(motion.bodies[bi]);
  world.projectiles = motion.projectiles;
}

void EnergyGuard::restore_blend(GuardedWorld& world, const Motion& a, const Motion& b, double s) {
  Motion& blend = m_blend_motion;
  blend.bodies.resize(world.bodies.size());
  for (std::size_t bi = 0; bi < world.bodies.size(); ++bi) {
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
  restore_motion(world, blend);
}

}  // namespace fissure::sim
