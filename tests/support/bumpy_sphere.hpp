#pragma once
// A closed bumpy UV sphere built in code, header-only: the check tests and check_bench both
// use it (check_bench links no test code).
#include <cmath>
#include <cstdint>

#include "printtwin/mesh.hpp"

namespace printtwin::test {

/// A closed UV sphere of radius r with 8 % bumps (outward CCW), centred at c: 2 slices
/// (stacks - 1) triangles, star-shaped about c.
inline Mesh bumpy_sphere(double r, int stacks, int slices, const Vec3& c) {
  constexpr double kPi = 3.14159265358979323846;
  Mesh m;
  m.vertices_mm.push_back(c + Vec3(0, 0, r));
  for (int i = 1; i < stacks; ++i)
    for (int j = 0; j < slices; ++j) {
      const double t = kPi * i / stacks, p = 2 * kPi * j / slices;
      const double rr = r * (1 + 0.08 * std::sin(5 * p) * std::sin(3 * t));
      m.vertices_mm.push_back(
          c + rr * Vec3(std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)));
    }
  m.vertices_mm.push_back(c + Vec3(0, 0, -r));
  const auto ring = [&](int i, int j) {
    return static_cast<std::uint32_t>(1 + (i - 1) * slices + (j % slices));
  };
  const auto south = static_cast<std::uint32_t>(m.vertices_mm.size() - 1);
  for (int j = 0; j < slices; ++j) {
    m.triangles.push_back({0, ring(1, j), ring(1, j + 1)});
    for (int i = 1; i + 1 < stacks; ++i) {
      m.triangles.push_back({ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)});
      m.triangles.push_back({ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)});
    }
    m.triangles.push_back({ring(stacks - 1, j), south, ring(stacks - 1, j + 1)});
  }
  return m;
}

}  // namespace printtwin::test
