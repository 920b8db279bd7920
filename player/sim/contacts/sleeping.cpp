#include "player/sim/contacts/sleeping.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace fissure::sim {
namespace {

enum class FragmentState : std::uint8_t { Awake, Held, Pinned };

/// One body's fragments as sleeping needs them.
struct BodyFragments {
  std::vector<Index> node_fragment;
  std::vector<FragmentState> state;
  std::vector<double> mass, speed_squared;  ///< Σ m, Σ m |v|²
};

BodyFragments fragments_of(const SleepBody& b) {
  const ImplicitIntegrator& body = *b.body;
  const Matrix4Xu& tets = body.elasticity().tets();
  BodyFragments f;
  f.node_fragment.assign(body.node_count(), 0);
  if (b.tet_fragment != nullptr) {
    for (Eigen::Index t = 0; t < tets.cols(); ++t) {
      for (int k = 0; k < 4; ++k) f.node_fragment[tets(k, t)] = (*b.tet_fragment)[t];
    }
  }
  f.state.assign(b.fragments, FragmentState::Held);
  f.mass.assign(b.fragments, 0.0);
  f.speed_squared.assign(b.fragments, 0.0);
  for (NodeIndex n = 0; n < body.node_count(); ++n) {
    const Index k = f.node_fragment[n];
    if (body.pinned(n) && !body.held(n)) {
      f.state[k] = FragmentState::Pinned;
    } else if (!body.held(n) && f.state[k] == FragmentState::Held) {
      f.state[k] = FragmentState::Awake;
    }
    f.mass[k] += body.node_masses()[n];
    f.speed_squared[k] += body.node_masses()[n] * body.velocities().col(n).squaredNorm();
  }
  return f;
}

/// Union–find over every body's fragments, numbered body by body.
class Islands {
 public:
  explicit Islands(const std::vector<BodyFragments>& bodies) {
    Index total = 0;
    for (const BodyFragments& b : bodies) {
      m_offset.push_back(total);
      total += static_cast<Index>(b.state.size());
    }
    m_parent.resize(total);
    std::iota(m_parent.begin(), m_parent.end(), Index{0});
  }
  [[nodiscard]] Index id(const SpinSide& s) const { return m_offset[s.body] + s.fragment; }
  [[nodiscard]] Index id(std::size_t body, Index fragment) const { return m_offset[body] + fragment; }
  Index root(Index i) {
    while (m_parent[i] != i) i = m_parent[i] = m_parent[m_parent[i]];
    return i;
  }
  void join(Index a, Index b) { m_parent[root(a)] = root(b); }
  [[nodiscard]] Index size() const { return static_cast<Index>(m_parent.size()); }

 private:
  std::vector<Index> m_offset, m_parent;
};

std::vector<BodyFragments> all_fragments(std::span<const SleepBody> bodies) {
  std::vector<BodyFragments> out;
  out.reserve(bodies.size());
  for (const SleepBody& b : bodies) out.push_back(fragments_of(b));
  return out;
}

FragmentState state_of(const std::vector<BodyFragments>& f, const SpinSide& s) {
  return f[s.body].state[s.fragment];
}

}  // namespace

void Sleeping::note_wakes(std::span<const SleepBody> bodies, std::span<const Touch> touches, double wake_speed) {
  if (!enabled() || asleep(bodies) == 0) return;
  const std::vector<BodyFragments> f = all_fragments(bodies);
  Islands islands(f);
  std::vector<Index> seeds;
  for (const Touch& t : touches) {
    const bool a_body = t.a.body != kInvalidIndex, b_body = t.b.body != kInvalidIndex;
    const FragmentState a = a_body ? state_of(f, t.a) : FragmentState::Pinned;
    const FragmentState b = b_body ? state_of(f, t.b) : FragmentState::Pinned;
    if (a == FragmentState::Held && b == FragmentState::Held) {
      islands.join(islands.id(t.a), islands.id(t.b));
      continue;
    }
    if (!(t.closing > wake_speed)) continue;
    const bool b_moves = b == FragmentState::Awake || t.b_is_projectile;
    if (a == FragmentState::Held && b_moves) seeds.push_back(islands.id(t.a));
    if (b == FragmentState::Held && a == FragmentState::Awake) seeds.push_back(islands.id(t.b));
  }
  if (seeds.empty()) return;
  std::vector<std::uint8_t> waking(islands.size(), 0);
  for (const Index s : seeds) waking[islands.root(s)] = 1;
  m_wake_nodes.resize(bodies.size());
  for (std::size_t bi = 0; bi < bodies.size(); ++bi) {
    for (NodeIndex n = 0; n < bodies[bi].body->node_count(); ++n) {
      const Index k = f[bi].node_fragment[n];
      if (f[bi].state[k] == FragmentState::Held && waking[islands.root(islands.id(bi, k))]) {
        m_wake_nodes[bi].push_back(n);
      }
    }
  }
  m_wake_pending = true;
}

std::size_t Sleeping::wake(std::span<const SleepBody> bodies) {
  const std::size_t before = asleep(bodies);
  for (std::size_t bi = 0; bi < m_wake_nodes.size() && bi < bodies.size(); ++bi) {
    bodies[bi].body->release(m_wake_nodes[bi]);
    m_wake_nodes[bi].clear();
  }
  m_wake_pending = false;
  return before - asleep(bodies);
}

void Sleeping::after_step(std::span<const SleepBody> bodies, std::span<const Touch> touches, double dt) {
  if (!enabled()) return;
  const std::vector<BodyFragments> f = all_fragments(bodies);
  m_rest_time.resize(bodies.size());
  // Each fragment's time at rest: the shortest of its nodes' (kept per node, so that a
  // split, which renumbers fragments, keeps it; a node a split adds starts at 0).
  std::vector<std::vector<double>> rest(bodies.size());
  for (std::size_t bi = 0; bi < bodies.size(); ++bi) {
    const BodyFragments& b = f[bi];
    std::vector<double>& node_rest = m_rest_time[bi];
    node_rest.resize(bodies[bi].body->node_count(), 0.0);
    rest[bi].assign(b.state.size(), std::numeric_limits<double>::infinity());
    for (NodeIndex n = 0; n < node_rest.size(); ++n) {
      const Index k = b.node_fragment[n];
      if (b.state[k] != FragmentState::Awake) continue;
      const bool still = b.speed_squared[k] < m_settings.speed * m_settings.speed * b.mass[k];
      node_rest[n] = still ? node_rest[n] + dt : 0.0;
      rest[bi][k] = std::min(rest[bi][k], node_rest[n]);
    }
  }
  Islands islands(f);
  for (const Touch& t : touches) {
    if (t.a.body == kInvalidIndex || t.b.body == kInvalidIndex) continue;
    if (state_of(f, t.a) == FragmentState::Pinned || state_of(f, t.b) == FragmentState::Pinned) continue;
    islands.join(islands.id(t.a), islands.id(t.b));
  }
  // An island sleeps when every awake fragment in it has rested long enough.
  std::vector<std::uint8_t> restless(islands.size(), 0), has_awake(islands.size(), 0);
  for (std::size_t bi = 0; bi < bodies.size(); ++bi) {
    for (Index k = 0; k < f[bi].state.size(); ++k) {
      if (f[bi].state[k] != FragmentState::Awake) continue;
      const Index r = islands.root(islands.id(bi, k));
      has_awake[r] = 1;
      if (rest[bi][k] < m_settings.time) restless[r] = 1;
    }
  }
  for (std::size_t bi = 0; bi < bodies.size(); ++bi) {
    std::vector<NodeIndex> hold;
    for (NodeIndex n = 0; n < bodies[bi].body->node_count(); ++n) {
      const Index k = f[bi].node_fragment[n];
      const Index r = islands.root(islands.id(bi, k));
      if (f[bi].state[k] == FragmentState::Awake && has_awake[r] && !restless[r]) hold.push_back(n);
    }
    if (!hold.empty()) bodies[bi].body->hold(hold);
  }
}

std::size_t Sleeping::asleep(std::span<const SleepBody> bodies) {
  std::size_t count = 0;
  for (const SleepBody& b : bodies) {
    const BodyFragments f = fragments_of(b);
    count += static_cast<std::size_t>(std::count(f.state.begin(), f.state.end(), FragmentState::Held));
  }
  return count;
}

}  // namespace fissure::sim
