// Basic mesh measures and placement (no third-party code).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>

#include "printtwin/io.hpp"
#include "printtwin/mesh.hpp"

namespace printtwin {

Box3 bounding_box(const Mesh& mesh) {
  Box3 box;
  for (const auto& v : mesh.vertices_mm) box.extend(v);
  return box;
}

Vec3 triangle_normal(const Mesh& mesh, std::size_t t) {
  const auto& tri = mesh.triangles[t];
  const Vec3& a = mesh.vertices_mm[tri[0]];
  return (mesh.vertices_mm[tri[1]] - a).cross(mesh.vertices_mm[tri[2]] - a);
}

bool has_reliable_normal(const Mesh& mesh, std::size_t t) {
  const auto& tri = mesh.triangles[t];
  const Vec3& a = mesh.vertices_mm[tri[0]];
  const Vec3& b = mesh.vertices_mm[tri[1]];
  const Vec3& c = mesh.vertices_mm[tri[2]];
  const double longest2 =
      std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()});
  const double len = triangle_normal(mesh, t).norm();
  return std::isfinite(len) && len > 0 && len >= 1e-6 * longest2;
}

double signed_volume_mm3(const Mesh& mesh) {
  // Sum of signed tetrahedra against a reference point near the mesh (better conditioned
  // than the origin when the part sits far from it).
  const Vec3 ref = bounding_box(mesh).center();
  double six_v = 0;
  for (const auto& tri : mesh.triangles) {
    const Vec3 a = mesh.vertices_mm[tri[0]] - ref;
    const Vec3 b = mesh.vertices_mm[tri[1]] - ref;
    const Vec3 c = mesh.vertices_mm[tri[2]] - ref;
    six_v += a.dot(b.cross(c));
  }
  return six_v / 6.0;
}

double surface_area_mm2(const Mesh& mesh) {
  double twice = 0;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) twice += triangle_normal(mesh, t).norm();
  return 0.5 * twice;
}

Mesh translated(Mesh mesh, const Vec3& offset_mm) {
  for (auto& v : mesh.vertices_mm) v += offset_mm;
  return mesh;
}

Mesh place_on_bed(Mesh mesh, double center_x_mm, double center_y_mm) {
  const Box3 box = bounding_box(mesh);
  if (box.empty()) return mesh;
  const Vec3 c = box.center();
  return translated(std::move(mesh), Vec3(center_x_mm - c.x(), center_y_mm - c.y(), -box.min.z()));
}

Mesh make_box_mesh(const Vec3& lo, const Vec3& hi) {
  Mesh m;
  for (int i = 0; i < 8; ++i)
    m.vertices_mm.emplace_back((i & 1) ? hi.x() : lo.x(), (i & 2) ? hi.y() : lo.y(),
                               (i & 4) ? hi.z() : lo.z());
  // Outward CCW faces: -z, +z, -y, +y, -x, +x.
  m.triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                 {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  return m;
}

Status save_stl(const Mesh& mesh, const std::filesystem::path& path) {
  std::string out(80, '\0');
  const char header[] = "printtwin binary STL";
  std::memcpy(out.data(), header, sizeof(header) - 1);
  const auto n = static_cast<std::uint32_t>(mesh.triangles.size());
  out.append(reinterpret_cast<const char*>(&n), 4);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    Vec3 nrm = triangle_normal(mesh, t);
    const double len = nrm.norm();
    if (len > 0) nrm /= len;
    float f[12];
    for (int i = 0; i < 3; ++i) f[i] = static_cast<float>(nrm[i]);
    for (int v = 0; v < 3; ++v)
      for (int i = 0; i < 3; ++i)
        f[3 + 3 * v + i] = static_cast<float>(mesh.vertices_mm[mesh.triangles[t][v]][i]);
    out.append(reinterpret_cast<const char*>(f), sizeof(f));
    out.append(2, '\0');
  }
  return write_file_atomic(path, out);
}

}  // namespace printtwin
