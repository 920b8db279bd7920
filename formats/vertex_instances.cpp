#include "formats/vertex_instances.h"

namespace fissure::formats {

std::vector<VertexInstance> vertex_instances(const Bundle& bundle) {
  const Embedding& e = bundle.embedding;
  std::vector<VertexInstance> held(bundle.render.vertex_count());
  std::vector<double> depth(held.size(), 0.0);
  for (std::size_t i = 0; i < e.instance_count(); ++i) {
    for (int corner = 0; corner < 3; ++corner) {
      const Index v = bundle.render.triangles(corner, e.instance_triangle[i]);
      const double least = e.instance_barycentric[i].col(corner).minCoeff();
      if (held[v].instance != kNoInstance && !(least > depth[v])) continue;
      held[v] = {i, corner};
      depth[v] = least;
    }
  }
  return held;
}

}  // namespace fissure::formats
