// PLY writers of the deviation stage (binary little endian; read by CloudCompare, MeshLab).
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

#include "printtwin/deviation.hpp"

namespace printtwin {

namespace {

template <class T>
void put(std::string& out, T value) {
  static_assert(std::endian::native == std::endian::little, "PLY writer assumes little endian");
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  out.append(bytes, sizeof(T));
}

/// Colour of a signed deviation: green within tolerance, towards blue (deficit) or red
/// (excess) outside it, saturated at 2x the tolerance.
std::array<std::uint8_t, 3> colour(double d, double tol) {
  if (!std::isfinite(d)) return {128, 128, 128};
  const double a = std::abs(d);
  if (a <= tol) return {40, 200, 60};
  const double t = std::clamp((a - tol) / tol, 0.0, 1.0);
  const auto mix = [&](double from, double to) {
    return static_cast<std::uint8_t>(std::lround(from + (to - from) * (0.5 + 0.5 * t)));
  };
  if (d > 0) return {mix(200, 255), mix(200, 0), mix(60, 0)};
  return {mix(60, 0), mix(200, 0), mix(200, 255)};
}

}  // namespace

std::string deviation_ply(const Mesh& mesh, std::span<const double> vertex_mm,
                          double tolerance_mm) {
  std::string out;
  out += "ply\nformat binary_little_endian 1.0\n";
  out += "comment printtwin deviation: signed mm, + excess, - deficit, tolerance " +
         std::to_string(tolerance_mm) + "\n";
  out += "element vertex " + std::to_string(mesh.vertices_mm.size()) + "\n";
  out += "property float x\nproperty float y\nproperty float z\n";
  out += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  out += "property float quality\nproperty float deviation\n";
  out += "element face " + std::to_string(mesh.triangles.size()) + "\n";
  out += "property list uchar int vertex_indices\nend_header\n";
  out.reserve(out.size() + mesh.vertices_mm.size() * 23 + mesh.triangles.size() * 13);
  for (std::size_t i = 0; i < mesh.vertices_mm.size(); ++i) {
    const Vec3& p = mesh.vertices_mm[i];
    const double d = i < vertex_mm.size() ? vertex_mm[i] : 0.0;
    for (int a = 0; a < 3; ++a) put(out, static_cast<float>(p[a]));
    for (const auto c : colour(d, tolerance_mm)) put(out, c);
    put(out, static_cast<float>(d));
    put(out, static_cast<float>(d));
  }
  for (const auto& t : mesh.triangles) {
    put(out, std::uint8_t{3});
    for (const auto i : t) put(out, static_cast<std::int32_t>(i));
  }
  return out;
}

std::string points_ply(std::span<const Vec3> points, std::span<const double> scalar) {
  std::string out;
  out += "ply\nformat binary_little_endian 1.0\n";
  out += "element vertex " + std::to_string(points.size()) + "\n";
  out += "property double x\nproperty double y\nproperty double z\n";
  if (!scalar.empty()) out += "property double deviation\n";
  out += "end_header\n";
  out.reserve(out.size() + points.size() * 32);
  for (std::size_t i = 0; i < points.size(); ++i) {
    for (int a = 0; a < 3; ++a) put(out, points[i][a]);
    if (!scalar.empty()) put(out, i < scalar.size() ? scalar[i] : 0.0);
  }
  return out;
}

}  // namespace printtwin
