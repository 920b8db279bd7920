#pragma once
/// What energy a world may hold (issue 16): the physics may only lose energy, so the run
/// never ends a substep above its energy when built plus what was put in since, and a
/// substep never above its start's energy plus what was put in during it. Bookkeeping
/// only: World and its energy guard (energy_guard.h) measure the energies and tell this
/// when a run and a substep start and what was put in; this says the limits the guard
/// tests against. Each limit carries a rounding allowance of 1e-9 of the
/// magnitudes summed, so a substep that only rounds is never taken for one that gains.

#include <algorithm>
#include <cmath>
#include <vector>

namespace fissure::sim {

class EnergyBudget {
 public:
  /// The world as built holds `energy` [J]; nothing was put in yet.
  void start_run(double energy) {
    m_run_start = energy;
    m_put_in = 0.0;
  }
  /// Energy put in from outside [J]: a projectile launched, a push.
  void put_in(double energy) { m_put_in += energy; }
  /// All that was put in since the run started [J].
  [[nodiscard]] double put_in() const { return m_put_in; }
  /// Puts back a total from put_in() (a step or substep taken again).
  void restore_put_in(double total) { m_put_in = total; }
  /// put_in() when the substep started (start_substep).
  [[nodiscard]] double put_in_at_substep_start() const { return m_substep_put_in; }

  /// A substep's bodies are about to move: their energy at its start is measured anew on
  /// first use (add_body_at_substep_start).
  void forget_bodies_at_substep_start() {
    m_bodies_at_start.clear();
    m_bodies_measured = false;
  }
  [[nodiscard]] bool knows_bodies_at_substep_start() const { return m_bodies_measured; }
  /// One body's energy at the substep's start [J], and its magnitude (each term's
  /// absolute value summed) for the rounding allowance; every body, in order, then
  /// bodies_measured().
  void add_body_at_substep_start(double energy, double magnitude) { m_bodies_at_start.push_back({energy, magnitude}); }
  void bodies_measured() { m_bodies_measured = true; }
  /// The substep's projectiles start holding `projectile_energy` [J] (those launched
  /// before it); what is put in from now on counts as the substep's.
  void start_substep(double projectile_energy) {
    m_substep_put_in = m_put_in;
    m_projectiles_at_start = projectile_energy;
  }

  /// The most a substep may end with [J]: its start's energy plus what was put in during
  /// it, and rounding. Needs the bodies measured.
  [[nodiscard]] double substep_limit() const {
    double budget = m_projectiles_at_start + (m_put_in - m_substep_put_in);
    double magnitude = std::abs(m_projectiles_at_start) + std::abs(m_put_in - m_substep_put_in);
    for (const Measured& body : m_bodies_at_start) {
      budget += body.energy;
      magnitude += body.magnitude;
    }
    return budget + kRounding * magnitude;
  }
  /// The most the world may hold now [J]: its energy when built plus what was put in
  /// since, and rounding.
  [[nodiscard]] double run_limit() const {
    return m_run_start + m_put_in + kRounding * (std::abs(m_run_start) + std::abs(m_put_in));
  }
  /// Above this a substep is solved again exactly [J]: its limit plus `share` of what the
  /// run has dissipated so far (WorldSettings::exact_gain_share).
  [[nodiscard]] double exact_resolve_limit(double share) const {
    const double substep = substep_limit();
    return substep + share * std::max(0.0, run_limit() - substep);
  }

 private:
  static constexpr double kRounding = 1e-9;
  struct Measured {
    double energy = 0, magnitude = 0;
  };
  double m_run_start = 0;                    ///< the world's energy when built
  double m_put_in = 0;                       ///< see put_in()
  double m_substep_put_in = 0;               ///< put_in() at the substep's start
  double m_projectiles_at_start = 0;         ///< the launched projectiles' energy at the substep's start
  std::vector<Measured> m_bodies_at_start;   ///< per body, once measured
  bool m_bodies_measured = false;
};

}  // namespace fissure::sim
