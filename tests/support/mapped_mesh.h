#pragma once
/// The render mesh of a bundle placed through its bindings on the CPU, as a plain mesh:
/// what the embedded render must show (tests), and the plain draw it is measured
/// against (benchmarks).

#include "common/types.h"
#include "formats/bundle.h"
#include "player/render/renderer.h"

namespace fissure::testing {

/// Each vertex from its first instance, at node positions x of the tets (after any splits),
/// with smooth area-weighted normals.
inline render::PlainMesh mapped_mesh(const formats::Bundle& bundle, const Matrix3Xd& x, const Matrix4Xu& tets) {
  const formats::Embedding& e = bundle.embedding;
  Matrix3Xd p = Matrix3Xd::Zero(3, bundle.render.positions.cols());
  std::vector<bool> placed(static_cast<std::size_t>(p.cols()), false);
  for (std::size_t i = 0; i < e.instance_count(); ++i) {
    for (int j = 0; j < 3; ++j) {
      const Index v = bundle.render.triangles(j, e.instance_triangle[i]);
      if (placed[v]) continue;
      placed[v] = true;
      const Vec4 b = e.instance_barycentric[i].col(j);
      for (int k = 0; k < 4; ++k) p.col(v) += b[k] * x.col(tets(k, e.instance_tet[i]));
    }
  }
  Matrix3Xd n = Matrix3Xd::Zero(3, p.cols());
  for (Eigen::Index t = 0; t < bundle.render.triangles.cols(); ++t) {
    const auto& tri = bundle.render.triangles.col(t);
    const Vec3 normal = (p.col(tri[1]) - p.col(tri[0])).cross(p.col(tri[2]) - p.col(tri[0]));
    for (int j = 0; j < 3; ++j) n.col(tri[j]) += normal;
  }
  render::PlainMesh mesh;
  for (Eigen::Index v = 0; v < p.cols(); ++v) {
    const Vec3 unit = n.col(v).normalized();
    for (int k = 0; k < 3; ++k) {
      mesh.positions.push_back(static_cast<float>(p(k, v)));
      mesh.normals.push_back(static_cast<float>(unit[k]));
    }
  }
  mesh.triangles.assign(bundle.render.triangles.data(), bundle.render.triangles.data() + bundle.render.triangles.size());
  mesh.color = render::EmbeddedMesh{}.color;
  return mesh;
}

}  // namespace fissure::testing
