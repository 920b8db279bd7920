#pragma once
/// A tiny hand-made bundle: two tets sharing the face x+y+z = 1 and one render
/// triangle straddling it (two instances, one contour segment). Built without the
/// bake, so formats tests stand on their own.

#include "common/barycentric.h"
#include "formats/bundle.h"

namespace fissure::testing {

inline formats::Bundle two_tet_bundle() {
  formats::Bundle b;
  b.metadata.generator = "test";
  b.metadata.bake_options = "{}";
  b.metadata.inputs = {{"mesh", "tri.obj", std::string(64, 'a'), "../assets/tri.obj"},
                       {"cage", "two.node+two.ele", std::string(64, 'b'), "../assets/two.node"}};
  b.cage.rest_positions.resize(3, 5);
  b.cage.rest_positions << 0, 1, 0, 0, 1,  //
      0, 0, 1, 0, 1,                      //
      0, 0, 0, 1, 1;
  b.cage.tets.resize(4, 2);
  b.cage.tets << 0, 1,  //
      1, 2,             //
      2, 3,             //
      3, 4;
  b.faces = build_cage_faces(b.cage, "two-tet");
  b.render.positions.resize(3, 3);
  b.render.positions << 0.2, 0.45, 0.5,  //
      0.2, 0.5, 0.45,                    //
      0.2, 0.45, 0.45;
  b.render.triangles.resize(3, 1);
  b.render.triangles << 0, 1, 2;

  formats::Embedding& e = b.embedding;
  for (TetIndex t = 0; t < 2; ++t) {
    const auto& p = b.cage.rest_positions;
    const TetBarycentricFrame frame(p.col(b.cage.tets(0, t)), p.col(b.cage.tets(1, t)), p.col(b.cage.tets(2, t)),
                                    p.col(b.cage.tets(3, t)));
    Eigen::Matrix<double, 4, 3> beta;
    for (int j = 0; j < 3; ++j) beta.col(j) = frame.coordinates(b.render.positions.col(j));
    e.instance_triangle.push_back(0);
    e.instance_tet.push_back(t);
    e.instance_barycentric.push_back(beta);
  }
  e.node_winding.assign(5, 0.0);
  e.node_inside.assign(5, 0);
  e.tet_class.assign(2, formats::TetClass::Crossing);

  // The segment where the triangle crosses x+y+z = 1 (vertex sums 0.6, 1.4, 1.4).
  const Vec3 v0 = b.render.positions.col(0);
  const Vec3 a = v0 + 0.5 * (b.render.positions.col(1) - v0);
  const Vec3 c = v0 + 0.5 * (b.render.positions.col(2) - v0);
  const FaceIndex shared = b.faces.tet_faces(0, 0);
  e.contour_offsets.assign(b.faces.face_count() + 1, 0);
  for (std::size_t f = shared + 1; f < e.contour_offsets.size(); ++f) e.contour_offsets[f] = 1;
  Eigen::Matrix<double, 3, 2> segment;
  segment << a, c;
  e.contour_points.push_back(segment);
  e.contour_triangle.push_back(0);
  e.contour_feature.push_back({formats::kContourInterior, formats::kContourInterior});
  e.face_degenerate.assign(b.faces.face_count(), 0);
  return b;
}

}  // namespace fissure::testing
