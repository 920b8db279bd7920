#pragma once
/// Fragments at rest fall asleep, as the islands of rigid-body engines do (Box2D, Bullet).
///
/// Why: a shattered pile holds hundreds of fragments and thousands of contacts, and every
/// one took its full share of every contact response long after the pile had come to rest
/// (issue 16: a pile cost ~65× the collision phase of the unbroken body).
///
/// An *island* is a set of fragments joined by contacts (obstacles and projectiles join
/// nothing; a fragment with a pinned node neither joins nor sleeps). When every awake
/// fragment of an island has moved slower than `speed` (the mass-weighted root mean
/// square of its nodes' speeds: a light tet flapping on a heavy fragment hardly counts)
/// for `time`, the whole island is held still (ImplicitIntegrator::hold): out of the
/// implicit solve, and its contacts with each other out of the contact response, where it
/// counts as an obstacle. Holding takes away at most the kinetic energy of that slow
/// motion; it adds none.
///
/// A held island wakes when anything awake (a fragment or a projectile) closes on one of
/// its fragments faster than the wake speed. The step in which that happens is taken
/// again from its start with the island awake (World::step), so a ball that hits a
/// sleeping bunny hits a bunny that answers, not a wall.

#include <span>
#include <vector>

#include "player/sim/implicit_integrator.h"
#include "player/sim/contacts/rolling_resistance.h"

namespace fissure::sim {

struct SleepSettings {
  double speed = 0.0;  ///< [m/s] below this a fragment is at rest; 0: nothing sleeps
  double time = 0.25;  ///< [s] an island rests this long before it sleeps
};

/// What sleeping sees of one body.
struct SleepBody {
  ImplicitIntegrator* body = nullptr;
  const std::vector<Index>* tet_fragment = nullptr;  ///< per tet
  Index fragments = 1;
};

/// One contact as sleeping sees it: its sides' fragments (SpinSide::body kInvalidIndex:
/// an obstacle or a projectile), whether side b moves on its own (a projectile), and how
/// fast the sides close [m/s] (> 0 closing), before the contact response.
struct Touch {
  SpinSide a, b;
  bool b_is_projectile = false;
  double closing = 0;
};

class Sleeping {
 public:
  explicit Sleeping(SleepSettings settings) : m_settings(settings) {}
  [[nodiscard]] bool enabled() const { return m_settings.speed > 0.0; }

  /// During a step: notes the held islands that an awake side closes on faster than
  /// `wake_speed` [m/s]. Their nodes existed before the step, so the note survives the
  /// step's roll-back.
  void note_wakes(std::span<const SleepBody> bodies, std::span<const Touch> touches, double wake_speed);
  [[nodiscard]] bool wakes_pending() const { return m_wake_pending; }
  /// Releases the noted islands (after the step was rolled back). Returns how many
  /// fragments woke.
  std::size_t wake(std::span<const SleepBody> bodies);

  /// After a step that stands: updates each fragment's time at rest and holds every
  /// island that has rested long enough. `touches`: the step's last contacts.
  void after_step(std::span<const SleepBody> bodies, std::span<const Touch> touches, double dt);

  /// Fragments held now, summed over bodies.
  [[nodiscard]] static std::size_t asleep(std::span<const SleepBody> bodies);

 private:
  SleepSettings m_settings;
  std::vector<std::vector<double>> m_rest_time;       ///< per body, per node [s]
  std::vector<std::vector<NodeIndex>> m_wake_nodes;  ///< per body, the noted islands' nodes
  bool m_wake_pending = false;
};

}  // namespace fissure::sim
