#pragma once
/// Shared scalar, index and matrix aliases. Geometry is `double` in bake and sim;
/// `float` only on the way to the GPU. Indices are 32-bit everywhere.

#include <Eigen/Core>
#include <Eigen/Geometry>  // cross products
#include <cstdint>
#include <limits>

namespace fissure {

using Index = std::uint32_t;
using NodeIndex = std::uint32_t;
using TetIndex = std::uint32_t;
using TriangleIndex = std::uint32_t;
using FaceIndex = std::uint32_t;
inline constexpr Index kInvalidIndex = std::numeric_limits<Index>::max();

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Vec4 = Eigen::Vector4d;
using Mat3 = Eigen::Matrix3d;
using Matrix2Xd = Eigen::Matrix2Xd;
using Matrix3Xd = Eigen::Matrix3Xd;
using Matrix4Xd = Eigen::Matrix4Xd;
/// Column-major index arrays: one column per element.
using Matrix3Xu = Eigen::Matrix<Index, 3, Eigen::Dynamic>;
using Matrix4Xu = Eigen::Matrix<Index, 4, Eigen::Dynamic>;
using Matrix2Xu = Eigen::Matrix<Index, 2, Eigen::Dynamic>;

/// The most worker threads a CLI option or scene may ask for. Fixed rather than tied
/// to the machine, so a scene valid on one machine is valid on every one; above the
/// cores present, more threads only cost memory (each has its own stack and scratch).
inline constexpr int kMaxThreads = 256;

}  // namespace fissure
