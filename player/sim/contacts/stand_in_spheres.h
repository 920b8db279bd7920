#pragma once
/// Collision spheres the player makes where a bundle's collision points leave a tet
/// bare.
///
/// The bake culls every sphere whose 26 grid neighbours are all present: such a sphere
/// cannot touch anything while the body is whole (collision_proxies.h). Fracture ends
/// that: a crack through the culled interior exposes tets with no collision point at
/// all, and a fragment made only of them falls through the ground (issue 16: with
/// toughness 0, 197 of the sample bunny's 987 tets had none, and their one-tet fragments
/// fell 0.9 m below the ground in 110 steps; the exact collision mode has the same hole
/// wherever the render surface does not pass; World covers the sphere mode only). So each tet that holds solid but no
/// collision point keeps one sphere in reserve, and gets it the moment one of its faces
/// is exposed: the scene pays nothing while the body is whole and the bundle stays as
/// it was baked.
///
/// The bake's reserve spheres (formats::Collision::reserve_tet) are held too: each
/// covers a render vertex that a sphere of another tet, its cover tet, covers while the
/// two are joined (issue 42: a one-tet chip rested with a corner 14 mm in the ground,
/// 18 mm from its tet's spheres). One is given the moment a split parts its tet from
/// its cover tet: they share fewer nodes than at rest, or lie in different fragments.
/// Where the two share no node (or there is no cover tet), a crack can part them
/// without passing between them, so it comes with its tet's exposure instead. Given on
/// exposure alone, a body whose cracks opened without breaking it carried every
/// exposed tet's reserve (docs/decisions/0076).

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "player/sim/environment.h"
#include "player/sim/fracture.h"
#include "player/sim/implicit_integrator.h"

namespace fissure::sim {

/// One sphere per tet, at its centroid, as large as fits inside the tet: World's
/// stand-in when a bundle has no baked spheres.
EmbeddedPoints inscribed_spheres(const Matrix3Xd& rest, const Matrix4Xu& tets);

class StandInSpheres {
 public:
  StandInSpheres() = default;
  /// The stand-in of every tet that has no point in `points` and holds solid (`mass`'s
  /// fraction above 0; every tet without `mass`): a sphere at the solid's centre of mass
  /// (the centroid without `mass`), as large as fits in the tet there, scaled by the
  /// cube root of the solid fraction. And the bake's `reserve` spheres, with each one's
  /// cover tet (`reserve_cover`, as many; kInvalidIndex: none).
  StandInSpheres(const Matrix3Xd& rest, const Matrix4Xu& tets, const EmbeddedPoints& points,
                 const MassDistribution* mass, const EmbeddedPoints& reserve = {},
                 std::span<const TetIndex> reserve_cover = {});

  /// Appends to `points`, and spends, each tet of `exposed`'s stand-in and the reserve
  /// spheres that come with its exposure, then every reserve sphere a split has parted
  /// from its cover tet: fewer shared nodes in `tets` (the current ones) than at rest,
  /// or another fragment in `tet_fragment`. Returns how many it added.
  std::size_t add_for(std::span<const TetFace> exposed, const Matrix4Xu& tets, std::span<const Index> tet_fragment,
                      EmbeddedPoints& points);
  /// Removes the points from index `count` on (those added by a step rolled back),
  /// putting their tets' reserves back.
  void truncate(EmbeddedPoints& points, std::size_t count);
  /// Per point of the points this appends to: whether it is a reserve sphere, which
  /// meets obstacles and projectiles only (CollisionBody::obstacles_only). Between
  /// fragments the solid's spheres already hold them apart; the reserve's pairs made
  /// a pile of one-tet fragments 1.3× as slow (docs/decisions/0076).
  [[nodiscard]] const std::vector<std::uint8_t>& obstacles_only() const { return m_obstacles_only; }
  /// Stand-ins and reserve spheres not yet given.
  [[nodiscard]] std::size_t reserved() const;

 private:
  /// A point this class appended: a stand-in (index: its tet) or a reserve sphere.
  struct Given {
    std::size_t point;
    bool stand_in;
    std::size_t index;
  };
  /// m_reserve…, and m_exposed by tet, from the rest connectivity `tets`.
  void hold_reserve(const Matrix4Xu& tets, const EmbeddedPoints& reserve, std::span<const TetIndex> cover);
  /// Appends reserve sphere `reserve` unless it was given.
  void give(std::size_t reserve, EmbeddedPoints& points);

  std::vector<Vec4> m_barycentric;  ///< per tet
  std::vector<double> m_radius;     ///< per tet; 0: no reserve (it has points or holds no solid)
  std::vector<std::uint8_t> m_given;  ///< per tet: its stand-in is in the points now
  EmbeddedPoints m_reserve;           ///< the bake's reserve spheres
  std::vector<TetIndex> m_reserve_cover;      ///< per reserve sphere: its cover tet, or kInvalidIndex
  std::vector<std::uint8_t> m_reserve_given;  ///< per reserve sphere: in the points now
  std::vector<std::uint8_t> m_reserve_shared; ///< per reserve sphere: nodes its tet shares with its cover tet at rest
  std::vector<std::size_t> m_exposed_start;   ///< per tet and one more: its range in m_exposed
  std::vector<std::size_t> m_exposed;         ///< by tet, the reserve spheres that come with its exposure
  std::vector<Given> m_log;                   ///< what is in the points, in order
  std::vector<std::uint8_t> m_obstacles_only; ///< per point: a reserve sphere (up to the last one given)
};

}  // namespace fissure::sim
