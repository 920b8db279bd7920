// The one translation unit that includes Mesh_3 and alpha_wrap_3 (minutes and gigabytes
// to compile: keep it so).
#include "bake/wrap_cage.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Mesh_complex_3_in_triangulation_3.h>
#include <CGAL/Mesh_criteria_3.h>
#include <CGAL/Mesh_triangulation_3.h>
#include <CGAL/Polyhedral_mesh_domain_3.h>
#include <CGAL/Random.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/alpha_wrap_3.h>
#include <CGAL/make_mesh_3.h>

#include <array>
#include <unordered_map>
#include <vector>

namespace fissure::bake {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Envelope = CGAL::Surface_mesh<Point>;
using Domain = CGAL::Polyhedral_mesh_domain_3<Envelope, Kernel>;
using Triangulation = CGAL::Mesh_triangulation_3<Domain, CGAL::Default, CGAL::Sequential_tag>::type;
using Complex = CGAL::Mesh_complex_3_in_triangulation_3<Triangulation>;
using Criteria = CGAL::Mesh_criteria_3<Triangulation>;

/// The cells in the complex as a TetMesh, nodes numbered in the order the cells use them.
TetMesh to_tet_mesh(const Complex& complex) {
  std::unordered_map<Triangulation::Vertex_handle, Index> number;
  std::vector<double> xyz;
  std::vector<Index> corners;
  for (auto cell = complex.cells_in_complex_begin(); cell != complex.cells_in_complex_end(); ++cell) {
    for (int k = 0; k < 4; ++k) {
      const auto vertex = cell->vertex(k);
      const auto [it, fresh] = number.emplace(vertex, static_cast<Index>(xyz.size() / 3));
      if (fresh) {
        const auto p = complex.triangulation().point(vertex);
        xyz.insert(xyz.end(), {CGAL::to_double(p.x()), CGAL::to_double(p.y()), CGAL::to_double(p.z())});
      }
      corners.push_back(it->second);
    }
  }
  TetMesh mesh;
  mesh.rest_positions = Eigen::Map<const Matrix3Xd>(xyz.data(), 3, static_cast<Eigen::Index>(xyz.size() / 3));
  mesh.tets = Eigen::Map<const Matrix4Xu>(corners.data(), 4, static_cast<Eigen::Index>(corners.size() / 4));
  for (Eigen::Index t = 0; t < mesh.tets.cols(); ++t) {
    if (signed_volume(mesh, static_cast<TetIndex>(t)) < 0.0) std::swap(mesh.tets(2, t), mesh.tets(3, t));
  }
  return mesh;
}

}  // namespace

struct SurfaceWrap::Impl {
  Envelope envelope;
};

SurfaceWrap::SurfaceWrap(const SurfaceMesh& mesh, const WrapParameters& parameters) : m_impl(new Impl) {
  std::vector<Point> points;
  points.reserve(mesh.vertex_count());
  for (Index v = 0; v < mesh.vertex_count(); ++v) {
    points.emplace_back(mesh.positions(0, v), mesh.positions(1, v), mesh.positions(2, v));
  }
  std::vector<std::array<std::size_t, 3>> faces;
  faces.reserve(mesh.triangle_count());
  for (Index t = 0; t < mesh.triangle_count(); ++t) {
    faces.push_back({mesh.triangles(0, t), mesh.triangles(1, t), mesh.triangles(2, t)});
  }
  CGAL::alpha_wrap_3(points, faces, parameters.alpha, parameters.offset, m_impl->envelope);
}

SurfaceWrap::~SurfaceWrap() { delete m_impl; }

std::size_t SurfaceWrap::envelope_triangles() const { return m_impl->envelope.number_of_faces(); }

TetMesh SurfaceWrap::mesh_at(double cell, double facet_distance, bool polish) const {
  namespace params = CGAL::parameters;
  // Every run its own seed: the same input gives the same mesh whatever ran before.
  CGAL::Random random(0);
  Domain domain(m_impl->envelope, &random);
  const Criteria criteria(params::facet_angle = 25, params::facet_size = cell,
                          params::facet_distance = facet_distance, params::cell_radius_edge_ratio = 3,
                          params::cell_size = cell);
  CGAL::get_default_random() = CGAL::Random(0);
  Complex complex = CGAL::make_mesh_3<Complex>(domain, criteria, params::no_perturb(), params::no_exude());
  if (polish) {
    CGAL::perturb_mesh_3(complex, domain, params::sliver_bound = 10, params::time_limit = 0);
    CGAL::exude_mesh_3(complex, params::sliver_bound = 10, params::time_limit = 0);
  }
  return to_tet_mesh(complex);
}

}  // namespace fissure::bake
