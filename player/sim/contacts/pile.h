#pragma once
/// Whether the world is in a pile: many fragments coupled mostly through their contacts,
/// as the last substeps' contact responses saw it. Two solvers see a pile, each its own
/// way, and each sighting lasts ContactSettings::sparse_block_memory substeps:
/// - the augmented Lagrangian ran long on a large fragment (a solve took more than
///   ContactSettings::sparse_blocks_after conjugate-gradient iterations): its next
///   responses make their sparse blocks before the first solve;
/// - the sequential impulses swept to their cap on the debris (a shattered body's
///   small fragments lying on each other).
/// In either, after a substep whose restitution was futile the next answers
/// inelastically first (World::collide, docs/decisions/0026-inelastic-first-in-piles.md).

#include <algorithm>

#include "player/sim/contacts/collision.h"

namespace fissure::sim {

class Pile {
 public:
  /// After a substep's contact response (its first answer); a sighting lasts `memory`
  /// substeps (ContactSettings::sparse_block_memory).
  void note(const ContactCounts& counts, int memory) {
    m_long_solve_left = counts.ran_long ? memory : std::max(m_long_solve_left - 1, 0);
    m_capped_sweeps_left = counts.swept_to_cap ? memory : std::max(m_capped_sweeps_left - 1, 0);
  }

  [[nodiscard]] bool in_pile() const { return m_long_solve_left > 0 || m_capped_sweeps_left > 0; }
  /// Whether the augmented Lagrangian should make its sparse blocks before its first solve.
  [[nodiscard]] bool sparse_blocks_from_start() const { return m_long_solve_left > 0; }

 private:
  int m_long_solve_left = 0;     ///< substeps since a long solve, counted down
  int m_capped_sweeps_left = 0;  ///< substeps since sweeps to the cap, counted down
};

}  // namespace fissure::sim
