#pragma once
/// Collision points that a split left overlapping across a new fragment boundary.
///
/// A body's collision spheres overlap their neighbours at rest: they cover the surface.
/// The moment fracture cuts a fragment off, the spheres on the two sides of the crack
/// belong to different pieces while still overlapping, and self-collision read that
/// overlap as a penetration to push out (at up to 1 m/s per contact): energy from
/// nowhere, every time a piece came off (issue 16). Such a pair is recorded when it is
/// born and, until it separates, it is no contact while the step's free motion does not
/// bring it closer, and otherwise a contact at its distance at the start of the step
/// instead of the sum of the radii: the two sides may move apart freely, or slide, but
/// not further into each other, and are never pushed apart. Once the pair no longer
/// overlaps it is forgotten and collides like any other. (Held as a contact every step,
/// the pairs of a pile of fragments doubled the contacts and cost 40 % more.)
///
/// The thesis (IV.H) collides fragments' spheres from the moment they part and does not
/// discuss the overlap; this is our deviation (docs/decisions/0028-split-overlaps-held.md).

#include <span>
#include <utility>
#include <vector>

#include "player/sim/environment.h"

namespace fissure::sim {

/// Pairs of one body's collision points (first < second), sorted.
using SplitOverlaps = std::vector<std::pair<Index, Index>>;

/// Adds the pairs of `points` that overlap at `positions` (3×#N) and lie in different
/// fragments after a split (`fragment_after`, per tet) but were in one before it
/// (`fragment_before`, per tet). Keeps `overlaps` sorted and free of duplicates.
void record_split_overlaps(const Matrix3Xd& positions, const Matrix4Xu& tets, const EmbeddedPoints& points,
                           std::span<const Index> fragment_before, std::span<const Index> fragment_after,
                           SplitOverlaps& overlaps);

/// Removes the pairs that no longer overlap at `positions`.
void forget_separated(const Matrix3Xd& positions, const Matrix4Xu& tets, const EmbeddedPoints& points,
                      SplitOverlaps& overlaps);

/// Whether (a, b), in either order, is one of `overlaps`.
[[nodiscard]] bool is_split_overlap(const SplitOverlaps& overlaps, Index a, Index b);

}  // namespace fissure::sim
