// The only file of the deviation stage that includes CGAL: reference point-to-mesh distances
// from CGAL's AABB tree, used by the tests and benchmarks to check the Embree path.
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>

#include <cmath>

#include "printtwin/deviation.hpp"

namespace printtwin {

namespace {
using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;
using Triangle = Kernel::Triangle_3;
using Iterator = std::vector<Triangle>::const_iterator;
using Primitive = CGAL::AABB_triangle_primitive<Kernel, Iterator>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;
}  // namespace

std::vector<double> reference_distances_cgal(const Mesh& mesh, std::span<const Vec3> points) {
  std::vector<Triangle> triangles;
  triangles.reserve(mesh.triangles.size());
  auto pt = [&](std::uint32_t i) {
    const Vec3& v = mesh.vertices_mm[i];
    return Point(v.x(), v.y(), v.z());
  };
  for (const auto& t : mesh.triangles) {
    const Triangle tri(pt(t[0]), pt(t[1]), pt(t[2]));
    if (!tri.is_degenerate()) triangles.push_back(tri);
  }
  std::vector<double> out(points.size(), 0.0);
  if (triangles.empty()) return out;
  Tree tree(triangles.begin(), triangles.end());
  tree.accelerate_distance_queries();
  for (std::size_t i = 0; i < points.size(); ++i)
    out[i] = std::sqrt(tree.squared_distance(Point(points[i].x(), points[i].y(), points[i].z())));
  return out;
}

}  // namespace printtwin
