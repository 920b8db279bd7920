#pragma once
/// Moves the rigid rotation within a step's displacement along an arc instead of a line.
///
/// Backward Euler moves each node on a straight line, x₁ = x₀ + h v₁. For a body
/// spinning at ω that line leaves the circle: every node ends up √(1 + (hω)²) times
/// as far from the centre of mass, a strain of about (hω)²/2 that the next step's
/// elastic forces pull back. The strain is small, but its energy scales with Young's
/// modulus: the sample bunny at E = 1e12 Pa, spun by the 12 m/s ball, stored 9.7e5 J of
/// it from 37 J put in (issue 16). The linear solve cannot see it: rotations are in
/// the null space of the (warped) stiffness only to first order.
///
/// The fix keeps the step's solve and changes only how its displacement is applied.
/// Per fragment free of pins, the displacement d = x₁ − x₀ is split into its
/// mass-weighted rigid part (translation u and rotation vector θ, the least-squares
/// fit: I θ = Σ m r × (d − u)) and the rest, which is the deformation. The rotation is
/// then applied exactly, on the arc,
///   x₁ = c₀ + u + R(θ) (r + d − u − θ × r),     r = x₀ − c₀,
/// and the velocities relative to the centre of mass turn with it, v₁ ← v̄ + R(θ)(v₁ − v̄),
/// so a rigid spin stays tangent to the body. Then the rigid spin is set to carry the
/// angular momentum the step gave the fragment, scaled down where that would gain
/// energy (rigid_rotation.cpp says why). The centre of mass and the linear momentum are
/// kept exactly, the kinetic energy never rises, and a deformation is carried along
/// unchanged in the rotated frame, so no strain is made or removed. A fragment with a
/// pinned node is left as it was (it cannot turn freely).
///
/// This is not in the thesis, which steps at 1/30 s or less and never met it; it is a
/// Lie-group update of the rigid part, as rigid-body integrators do, kept apart from
/// the elastic solve so that solve stays one linear system per step.

#include <span>
#include <vector>

#include "common/types.h"

namespace fissure::sim {

/// `start` and `positions`: 3×#N before and after the step; `velocities` 3×#N after it;
/// `mass` #N; `pinned[n]` is nonzero for a pinned node; `group[n]` in [0, group_count): the
/// fragment of node n. `rigid` (empty, or one per group): a nonzero group is moved with
/// no deformation at all, its start's shape turned and moved, and its velocities made the
/// rigid field carrying their momentum and angular momentum (solver.rigid_fragments_below).
/// Returns the largest rotation applied [rad].
double rotate_rigid_parts(const Matrix3Xd& start, const Eigen::VectorXd& mass, std::span<const std::uint8_t> pinned,
                          std::span<const Index> group, Index group_count, Matrix3Xd& positions,
                          Matrix3Xd& velocities, std::span<const std::uint8_t> rigid = {});

/// Per fragment, nonzero where it has fewer tets than `below` and so moves as a rigid
/// body (solver.rigid_fragments_below); `tet_fragment[t]` is in [0, fragment_count).
/// Empty when `below` is 0.
std::vector<std::uint8_t> small_fragments(std::span<const Index> tet_fragment, Index fragment_count, int below);

}  // namespace fissure::sim
