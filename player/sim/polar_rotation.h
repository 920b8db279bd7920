#pragma once
/// The rotation of a deformation gradient's polar decomposition F = Q S, the element
/// loop's largest cost (record 0012): Higham's scaled Newton iteration, one matrix or a
/// batch on SIMD lanes, and the signed SVD where Newton does not apply.

#include "common/types.h"
#include "player/sim/lanes.h"

namespace fissure::sim {

/// F = U diag(σ) Vᵀ with U, V proper rotations; σ₂ carries the sign when F is inverted.
struct SignedSvd {
  Mat3 U, V;
  Vec3 sigma;
};
SignedSvd signed_svd(const Mat3& F);

/// The rotation of F's polar decomposition, proper (det = +1) even when F is inverted
/// or degenerate. Well-conditioned F with det F > 0 (nearly every tet, nearly every
/// step) takes Higham's scaled Newton iteration, a few 3×3 inverses; inverted, flat or
/// collapsed tets take signed_svd. Both give the same rotation where both apply.
Mat3 polar_rotation(const Mat3& F);

/// Q[i] = polar_rotation(F[i]) for up to kLanes matrices at once: the Newton
/// iterations of the batch run in lockstep, one SIMD lane per matrix, until every lane
/// has converged (a lane that converged first takes extra steps at its fixed point, so
/// the results match polar_rotation's to rounding, not bit for bit). Lanes Newton does
/// not apply to take polar_rotation's SVD path. Which matrices share a batch must not
/// depend on the thread count, for determinism: batch by absolute index (lanes.h).
void polar_rotations(const Mat3* F, Mat3* Q, int count);

/// The same on lanes (entry k of lane l's matrix, column-major, at [k][l]): Q's lanes
/// l < count are their F's rotations; the others are computed but meaningless.
void polar_rotation_lanes(const double (&F)[9][kLanes], double (&Q)[9][kLanes], int count);

}  // namespace fissure::sim
