#pragma once
/// The energy guard (issue 16): the physics may only lose energy, so a substep may end
/// with at most its start's energy plus what was put in during it (EnergyBudget). The
/// linear solve and the contact response that keep ordinary substeps cheap can end one
/// above that; the guard says when, and repairs it, cheapest first:
///  - restitution kept only as far as the budget allows (keep_restitution_within_budget);
///  - an exact re-solve of the substep where its linear solve gained
///    (solve_exactly_if_gaining);
///  - the chips (fragments of a few tets) that gained moved rigidly from the start
///    (move_gaining_chips_rigidly);
///  - and, above all the run was given, the substep taken again as two halves (World,
///    told by halves_when_gaining).
/// Every substep pays only for the checks it needs: ordinary ones end within the budget
/// on the first test. World owns the bodies and projectiles; it lends them to each call
/// (GuardedWorld), and the guard keeps only its own state: the budget, and the motions
/// it compares and blends within one substep.

#include <cstdint>
#include <functional>
#include <vector>

#include "player/sim/body.h"
#include "player/sim/contacts/collision.h"
#include "player/sim/energy_budget.h"
#include "player/sim/world_settings.h"

namespace fissure::sim {

struct StepReport;

/// What the guard reads and moves of a World, lent for one call.
struct GuardedWorld {
  std::vector<Body>& bodies;
  std::vector<Projectile>& projectiles;
  ContactImpulses& contact_impulses;                              ///< the last response's, to warm-start the next
  const std::vector<Matrix3Xd>& start_positions;                  ///< per body, at the substep's start
  const std::vector<ImplicitIntegrator::Checkpoint>& substep_start;  ///< per body, saved before its solve
  const WorldSettings& settings;
  [[nodiscard]] double total_energy() const { return sim::total_energy(bodies, projectiles, settings.step.gravity); }
};

class EnergyGuard {
 public:
  /// The accounting of what the run and the substep may hold.
  [[nodiscard]] EnergyBudget& budget() { return m_budget; }
  [[nodiscard]] const EnergyBudget& budget() const { return m_budget; }

  /// The most the substep may end with: its start's energy plus what was put in since,
  /// and rounding [J] (EnergyBudget::substep_limit). Measures the bodies' energy at the
  /// substep's start on first use: the elastic part is a polar decomposition per tet.
  [[nodiscard]] double substep_limit(const GuardedWorld& world);
  /// The bodies' energy at the substep's start into the budget, unless it is there.
  void measure_substep_start(const GuardedWorld& world);
  /// Whether `energy` [J] is above the substep's limit and above all the run was given.
  [[nodiscard]] bool above_all(const GuardedWorld& world, double energy);

  // --- Restitution within the budget (World::collide) -------------------------------
  /// Before a response with restitution: the motion both of its answers start from.
  void save_free_motion(const GuardedWorld& world) { save_motion(world, m_free_motion); }
  /// The last substep that restituted ended above its budget even inelastically.
  [[nodiscard]] bool restitution_futile() const { return m_restitution_futile; }
  /// After `contacts` were answered (inelastically where `inelastic_first`, else with
  /// full restitution; save_free_motion() before): the largest blend of the two answers
  /// within the substep's budget is kept, answering `contacts` again for the other one.
  void keep_restitution_within_budget(GuardedWorld& world, StepContacts& contacts, bool inelastic_first,
                                      StepReport& report);

  // --- After the substep's linear solve and contacts (World::advance) -----------------
  /// The bodies at the linear solve's answer, the projectiles before the substep: what
  /// an exact re-solve starts from.
  void save_linear_answer(const GuardedWorld& world) { save_motion(world, m_linear_motion); }
  /// The linear answer after contacts, before arcs (ExactResolve::SolveAndContacts).
  void save_contact_answer(const GuardedWorld& world) { save_motion(world, m_contact_motion); }
  /// Moves the projectiles and answers the contacts again over the substep, after an
  /// exact re-solve (World's launch_and_move_projectiles and collide).
  using ContactsAgain = std::function<void()>;
  /// When the substep ended above its energy budget: back to the linear solve's answer,
  /// every body solved exactly, projectiles and contacts again (`contacts_again`).
  /// Returns the energy the substep ends with [J]. Needs save_linear_answer() earlier in
  /// the substep (and save_contact_answer() for ExactResolve::SolveAndContacts).
  double solve_exactly_if_gaining(GuardedWorld& world, const StepSettings& step, StepReport& report,
                                  const ContactsAgain& contacts_again);
  /// The substep ends with `energy` above `limit` [J]: the fewest chips (fragments of
  /// fewer tets than WorldSettings::rigid_when_gaining_below), largest gain first, whose
  /// gains since the substep's start cover the excess are moved rigidly from it. Kept
  /// only where that lowers the energy. Returns the energy the substep ends with [J].
  double move_gaining_chips_rigidly(GuardedWorld& world, double energy, double limit, StepReport& report);
  /// Whether a substep of `dt` at halving depth `depth` that ends above its energy
  /// budget is taken again as two halves (WorldSettings::energy_halvings, min_dt).
  [[nodiscard]] static bool halves_when_gaining(const WorldSettings& settings, double dt, int depth);

 private:
  /// Every body's and projectile's motion, to try the contact response twice in a substep.
  struct Motion {
    std::vector<ImplicitIntegrator::Motion> bodies;
    std::vector<Projectile> projectiles;
  };
  static void save_motion(const GuardedWorld& world, Motion& out);
  static void restore_motion(GuardedWorld& world, const Motion& motion);
  /// Restores a + s (b − a).
  void restore_blend(GuardedWorld& world, const Motion& a, const Motion& b, double s);

  /// Answers `contacts` again inelastically and keeps the largest blend of the two
  /// answers within `budget` [J] (the bodies hold the full restitution's answer).
  void keep_restitution_within(GuardedWorld& world, StepContacts& contacts, double budget, StepReport& report);
  /// The same, the other way round: the bodies hold the inelastic answer. Over `budget`,
  /// it stays and restitution is not tried; within it, `contacts` are answered again
  /// with full restitution and the largest blend within `budget` kept.
  void add_restitution_within(GuardedWorld& world, StepContacts& contacts, double budget, StepReport& report);
  /// The largest share s ∈ [0, 1] for which the blend of m_inelastic_motion and
  /// m_bounced_motion (energies `inelastic` ≤ budget < `bounced`) keeps `budget`.
  double largest_share_within(GuardedWorld& world, double budget, double inelastic, double bounced);

  /// The solve gained: every body solved exactly, then projectiles and contacts again.
  void resolve_exactly(GuardedWorld& world, const StepSettings& step, StepReport& report,
                       const ContactsAgain& contacts_again);
  /// The contacts gained: every body solved exactly with the contacts' impulses held.
  void resolve_contacts_exactly(GuardedWorld& world, const StepSettings& step, StepReport& report);
  void solve_bodies_exactly(GuardedWorld& world, const StepSettings& step, StepReport& report,
                            const std::vector<Eigen::VectorXd>* impulses);
  /// Back to the substep's linear answer after contacts and arcs (m_linear_end_motion).
  void keep_linear_answer(GuardedWorld& world);

  /// A chip's gain since the substep's start [J] (kinetic, strain and gravity).
  struct ChipGain {
    double joules = 0;
    std::size_t body = 0;
    Index fragment = 0;
  };
  /// The chips that gained, largest gain first; `chips` gets, per body and fragment,
  /// nonzero for each chip.
  std::vector<ChipGain> chip_gains(const GuardedWorld& world, std::vector<std::vector<std::uint8_t>>& chips);

  EnergyBudget m_budget;
  Motion m_free_motion, m_bounced_motion, m_inelastic_motion, m_blend_motion;  ///< the restitution's
  /// The last substep that restituted ended above its budget even inelastically: the
  /// next answers inelastically first (World::collide).
  bool m_restitution_futile = false;
  Motion m_linear_motion;  ///< the bodies at the linear solve's answer, the projectiles before the substep
  std::vector<Matrix3Xd> m_exact_positions;      ///< per body, the exact solve's answer before contacts
  Motion m_linear_end_motion;                    ///< the substep's linear answer after contacts and arcs
  Motion m_contact_motion;                       ///< the substep's linear answer after contacts, before arcs
  std::vector<Eigen::VectorXd> m_held_impulses;  ///< per body, the contact response's impulses (system rows)
  ContactImpulses m_linear_end_impulses;         ///< and the contact impulses it left
  double m_linear_end_put_in = 0;                ///< and the budget's put_in() after it
  Motion m_unrepaired_motion;                    ///< move_gaining_chips_rigidly's scratch
  std::vector<Index> m_node_fragment;            ///< scratch for the arcs and the chips
};

}  // namespace fissure::sim
