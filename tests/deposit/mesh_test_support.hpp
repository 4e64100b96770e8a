#pragma once
// Checks shared by the as-printed mesh tests.
#include <gtest/gtest.h>

#include <cstdint>
#include <map>
#include <utility>

#include "printtwin/check.hpp"
#include "printtwin/mesh.hpp"

namespace printtwin::test {

/// Every undirected edge in exactly two triangles, once in each direction; closed, no
/// degenerate face, no non-manifold vertex, no two triangles that cross.
inline void expect_closed_oriented(const Mesh& m) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) ++directed[{t[k], t[(k + 1) % 3]}];
  std::size_t bad = 0;
  for (const auto& [e, n] : directed) {
    const auto rev = directed.find({e.second, e.first});
    if (n != 1 || rev == directed.end() || rev->second != 1) ++bad;
  }
  EXPECT_EQ(bad, 0u);
  const MeshHealth h = analyze_mesh_health(m);
  EXPECT_TRUE(h.closed);
  EXPECT_EQ(h.degenerate_faces, 0u);
  EXPECT_EQ(h.inconsistent_edges, 0u);
  EXPECT_EQ(h.non_manifold_vertices, 0u);
  EXPECT_EQ(find_self_intersections(m).pairs, 0u);
}

}  // namespace printtwin::test
