// repair_mesh's audit counters (measure_repair) on meshes built in code with known defects:
// each defect must show in its own counter and nowhere else.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <initializer_list>
#include <utility>

#include "printtwin/check.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

RepairCounters repaired(const Mesh& m) {
  auto r = repair_mesh(m);
  EXPECT_TRUE(r.ok()) << r.error().describe();
  if (!r.ok()) return {};
  EXPECT_TRUE(r->after.closed);
  EXPECT_EQ(r->after.inconsistent_edges, 0U);
  return r->counters;
}

void expect_counters(const RepairCounters& c, std::size_t edges_fixed, std::size_t removed,
                     std::size_t added, std::size_t reversed, std::size_t holes) {
  EXPECT_EQ(c.edges_fixed, edges_fixed);
  EXPECT_EQ(c.facets_removed, removed);
  EXPECT_EQ(c.facets_added, added);
  EXPECT_EQ(c.facets_reversed, reversed);
  EXPECT_EQ(c.holes_filled, holes);
  EXPECT_EQ(c.backwards_edges, 0U);
}

TEST(RepairCounters, NothingChangedOnAGoodCube) {
  const Mesh cube = test::make_cube_mm(10);
  const RepairCounters c = measure_repair(cube, cube);
  expect_counters(c, 0, 0, 0, 0, 0);
  EXPECT_EQ(c.parts, 1U);
  EXPECT_EQ(c.degenerate_facets, 0U);
  expect_counters(repaired(cube), 0, 0, 0, 0, 0);
}

TEST(RepairCounters, OneFlippedFacetIsReversedOnce) {
  Mesh m = test::make_cube_mm(10);
  std::swap(m.triangles[5][1], m.triangles[5][2]);
  const RepairCounters c = repaired(m);
  expect_counters(c, 0, 0, 0, 1, 0);
  EXPECT_EQ(c.parts, 1U);
}

TEST(RepairCounters, InsideOutCubeHasEveryFacetReversed) {
  Mesh m = test::make_cube_mm(10);
  for (auto& t : m.triangles) std::swap(t[1], t[2]);
  expect_counters(repaired(m), 0, 0, 0, 12, 0);
}

TEST(RepairCounters, HolesAreFilledByAddedFacets) {
  Mesh m = test::make_cube_mm(10);
  m.triangles.pop_back();  // one triangle of a side: one hole of 3 edges
  expect_counters(repaired(m), 0, 0, 1, 0, 1);

  // Two cubes apart, each missing a triangle: two holes.
  Mesh two = test::make_cube_mm(10);
  const Mesh other = test::make_cube_mm(10, Vec3(30, 0, 0));
  const auto base = static_cast<std::uint32_t>(two.vertices_mm.size());
  two.vertices_mm.insert(two.vertices_mm.end(), other.vertices_mm.begin(), other.vertices_mm.end());
  for (auto t : other.triangles) two.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
  two.triangles.erase(two.triangles.begin() + 12);
  two.triangles.erase(two.triangles.begin());
  const RepairCounters c = repaired(two);
  expect_counters(c, 0, 0, 2, 0, 2);
  EXPECT_EQ(c.parts, 2U);
}

TEST(RepairCounters, DuplicatedFacetIsRemovedAndItsEdgesBecomeManifold) {
  Mesh m = test::make_cube_mm(10);
  m.triangles.push_back(m.triangles[3]);
  // Three edges had three faces each; the two kept faces of each are now alone on it.
  expect_counters(repaired(m), 6, 1, 0, 0, 0);
}

TEST(RepairCounters, SeamOfSplitVerticesIsStitched) {
  // The +z face (triangles 2 and 3) on its own copies of the corners: 4 open edges on each
  // side of the seam, 8 facet edges closed by stitching, no face added or removed.
  Mesh m = test::make_cube_mm(10);
  for (std::uint32_t v = 4; v < 8; ++v) m.vertices_mm.push_back(m.vertices_mm[v]);
  for (std::size_t f = 2; f < 4; ++f)
    for (auto& v : m.triangles[f]) v += 4;
  ASSERT_EQ(analyze_mesh_health(m).boundary_edges, 8U);
  expect_counters(repaired(m), 8, 0, 0, 0, 0);
}

/// The 10 mm cube with its +z face on its own corners `dz` above the sides: a seam of 8
/// open facet edges.
Mesh seam_cube(double dz) { return test::make_seam_cube_mm(10, dz); }

TEST(RepairCounters, NearbyEdgesAreSeamsThatAToleranceWouldClose) {
  // The +z face on its own corners 0.001 mm above the sides (as bench/repair_vs_admesh.sh's
  // cube_seam): 4 open edges on each side of the seam, every one within 0.01 mm of a
  // partner running the other way. admesh --nearby joins them (its 8 edges fixed).
  Mesh m = seam_cube(0.001);
  EXPECT_EQ(measure_repair(m, m).nearby_edges, 8U);
  // 0.1 mm apart: beyond the tolerance.
  for (std::size_t v = 8; v < 12; ++v) m.vertices_mm[v].z() += 0.099;
  EXPECT_EQ(measure_repair(m, m).nearby_edges, 0U);
  // A hole has no partner edges; a good cube has no open edge.
  Mesh hole = test::make_cube_mm(10);
  hole.triangles.pop_back();
  EXPECT_EQ(measure_repair(hole, hole).nearby_edges, 0U);
  EXPECT_EQ(measure_repair(test::make_cube_mm(10), test::make_cube_mm(10)).nearby_edges, 0U);
}

TEST(RepairCounters, TheWeldClosesASeamAsAdmeshNearbyDoes) {
  // admesh (default, every fix) on this seam: 8 edges fixed, nothing removed or added.
  const Mesh m = seam_cube(0.001);
  // Default: the shortest edge (10 mm) + 0.01 % of the diagonal.
  EXPECT_DOUBLE_EQ(nearby_weld_tolerance_mm(m), 10 + 1e-4 * std::sqrt(200 + 10.001 * 10.001));
  auto r = repair_mesh(m);
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(r->after.closed);
  expect_counters(r->counters, 8, 0, 0, 0, 0);
  EXPECT_EQ(r->counters.nearby_edges, 8U);
  EXPECT_EQ(r->mesh.triangles.size(), 12U);
  ASSERT_FALSE(r->changes.empty());
  EXPECT_EQ(r->changes.front().code, "welded_vertices");
  EXPECT_EQ(r->changes.front().count, 4U);
  // The lowest-numbered vertex of each joined pair stays: the sides' corners.
  for (const auto& v : r->mesh.vertices_mm) EXPECT_TRUE(v.z() == 0.0 || v.z() == 10.0);

  // Without the weld the top is a loose piece: removed, and the hole filled flat.
  RepairSettings no_weld;
  no_weld.weld_tolerance_mm = 0;
  auto plain = repair_mesh(m, no_weld);
  ASSERT_TRUE(plain.ok());
  expect_counters(plain->counters, 0, 2, 2, 0, 1);
  // A stated tolerance below the seam's width leaves it open too.
  RepairSettings tight;
  tight.weld_tolerance_mm = 0.0005;
  auto narrow = repair_mesh(m, tight);
  ASSERT_TRUE(narrow.ok());
  EXPECT_EQ(narrow->counters.nearby_edges, 0U);
  expect_counters(narrow->counters, 0, 2, 2, 0, 1);
}

TEST(RepairCounters, TheWeldNeverCollapsesAHole) {
  // The default tolerance is the shortest edge (10 mm here): the edges around a missing
  // facet are each other's nearest open edges, but joining their ends would collapse the
  // faces beside the hole. The hole is filled instead, as admesh does.
  Mesh hole = test::make_cube_mm(10);
  hole.triangles.pop_back();
  auto r = repair_mesh(hole);
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(r->after.closed);
  expect_counters(r->counters, 0, 0, 1, 0, 1);
  for (const auto& c : r->changes) EXPECT_NE(c.code, "welded_vertices");
}

TEST(RepairCounters, DegenerateAndStrayFacetsAreRemoved) {
  Mesh m = test::make_cube_mm(10);
  m.vertices_mm.emplace_back(5, 0, 0);
  m.triangles.push_back({0, 8, 1});  // zero area, on the bottom edge
  m.vertices_mm.emplace_back(50, 50, 50);
  m.vertices_mm.emplace_back(51, 50, 50);
  m.vertices_mm.emplace_back(50, 51, 50);
  m.triangles.push_back({9, 10, 11});  // a stray triangle far away
  const RepairCounters c = repaired(m);
  // The sliver lay on the cube's edge 0-1 (three faces there); without it the edge is
  // manifold again: its two cube faces count as two fixed facet edges.
  expect_counters(c, 2, 2, 0, 0, 0);
  EXPECT_EQ(c.degenerate_facets, 1U);
  EXPECT_EQ(c.parts, 1U);
}

TEST(RepairCounters, MeasuredFromTheMeshesNotFromTheSteps) {
  // measure_repair on two meshes made by hand: a face turned, a face dropped, a face added.
  Mesh before = test::make_cube_mm(10);
  Mesh after = before;
  std::swap(after.triangles[0][0], after.triangles[0][1]);
  after.triangles.erase(after.triangles.begin() + 4);
  after.triangles.push_back({0, 2, 5});
  const RepairCounters c = measure_repair(before, after);
  EXPECT_EQ(c.facets_reversed, 1U);
  EXPECT_EQ(c.facets_removed, 1U);
  EXPECT_EQ(c.facets_added, 1U);
  EXPECT_EQ(c.holes_filled, 1U);
  EXPECT_GT(c.backwards_edges, 0U) << "the turned face runs the same way as its neighbours";
  EXPECT_EQ(repair_counters_text(c).rfind(
                "edges fixed 0, facets removed 1, facets added 1, facets reversed 1", 0),
            0U)
      << repair_counters_text(c);
}

using Corner = std::array<double, 2>;

/// The 10 mm cube with its top (+z) face replaced by `facets`, each given by the (x, y) of its
/// corners at z = 10 (the cube's corners reused, other points added).
Mesh cube_with_top(std::initializer_list<std::array<Corner, 3>> facets) {
  Mesh m = test::make_cube_mm(10);
  std::erase_if(m.triangles, [&](const auto& t) {
    return m.vertices_mm[t[0]].z() == 10 && m.vertices_mm[t[1]].z() == 10 &&
           m.vertices_mm[t[2]].z() == 10;
  });
  const auto at = [&](const Corner& c) {
    const Vec3 p(c[0], c[1], 10);
    for (std::uint32_t v = 0; v < m.vertices_mm.size(); ++v)
      if (m.vertices_mm[v] == p) return v;
    m.vertices_mm.push_back(p);
    return static_cast<std::uint32_t>(m.vertices_mm.size() - 1);
  };
  for (const auto& f : facets) m.triangles.push_back({at(f[0]), at(f[1]), at(f[2])});
  return m;
}

/// The top a fan from a vertex in the middle of its edge with the +x face: the +x face's top
/// edge is one open facet edge, the top's two halves of it two others (a T-junction, as CAD
/// exports leave where faces were meshed apart).
Mesh t_junction_cube() {
  return cube_with_top(
      {{{{10, 5}, {10, 10}, {0, 10}}}, {{{10, 5}, {0, 10}, {0, 0}}}, {{{10, 5}, {0, 0}, {10, 0}}}});
}

/// Repairs `m`, a 10 mm cube with one T-junction edge carrying `pieces` - 1 vertices, and
/// expects its face split in `pieces`: closed, 1000 mm3, 1 facet removed and `pieces`
/// added, the other side's `pieces` facet edges fixed, no hole filled.
RepairResult expect_split_in(const Mesh& m, std::size_t pieces) {
  auto r = repair_mesh(m);
  EXPECT_TRUE(r.ok()) << r.error().describe();
  if (!r.ok()) return {};
  EXPECT_TRUE(r->after.closed);
  EXPECT_NEAR(signed_volume_mm3(r->mesh), 1000.0, 1e-9);
  EXPECT_EQ(r->mesh.triangles.size(), m.triangles.size() + pieces - 1);
  EXPECT_EQ(r->counters.t_junction_edges, 1U);
  EXPECT_EQ(r->counters.facets_removed, 1U);
  EXPECT_EQ(r->counters.facets_added, pieces);
  EXPECT_EQ(r->counters.edges_fixed, pieces);
  EXPECT_EQ(r->counters.holes_filled, 0U);
  return *r;
}

TEST(RepairCounters, TJunctionIsSplitAndJoined) {
  const Mesh m = t_junction_cube();
  ASSERT_EQ(analyze_mesh_health(m).boundary_edges, 3U);
  EXPECT_EQ(measure_repair(m, m).t_junction_edges, 1U);
  // The +x face's triangle is replaced by two (no face added to fill a hole, nothing
  // removed but it): one T-junction edge.
  const RepairResult r = expect_split_in(m, 2);
  bool reported = false;
  for (const auto& c : r.changes)
    reported = reported || (c.code == "split_t_junctions" && c.count == 1);
  EXPECT_TRUE(reported);
  // Without the weld (tolerance 0) nothing is split: the sliver hole is filled instead.
  RepairSettings no_weld;
  no_weld.weld_tolerance_mm = 0;
  auto plain = repair_mesh(m, no_weld);
  ASSERT_TRUE(plain.ok());
  for (const auto& c : plain->changes) EXPECT_NE(c.code, "split_t_junctions");
}

TEST(RepairCounters, TJunctionWithTwoVerticesOnTheEdgeIsSplitInThree) {
  // The top as four facets with two vertices on its edge with the +x side (at y = 4 and 7).
  const Mesh m = cube_with_top({{{{0, 0}, {10, 0}, {10, 4}}},
                                {{{0, 0}, {10, 4}, {10, 7}}},
                                {{{0, 0}, {10, 7}, {10, 10}}},
                                {{{0, 0}, {10, 10}, {0, 10}}}});
  ASSERT_EQ(analyze_mesh_health(m).boundary_edges, 4U);
  expect_split_in(m, 3);
}

TEST(RepairCounters, AHoleIsNoTJunction) {
  // The corners around a missing facet lie near each other's edges at the default tolerance
  // (the shortest edge, 10 mm), but off their lines: no split, the hole is filled.
  Mesh hole = test::make_cube_mm(10);
  hole.triangles.pop_back();
  EXPECT_EQ(measure_repair(hole, hole, 10.0).t_junction_edges, 0U);
  auto r = repair_mesh(hole);
  ASSERT_TRUE(r.ok());
  for (const auto& c : r->changes) EXPECT_NE(c.code, "split_t_junctions");
  // A vertex on the edge's line but with no open edge of its own along it: no split.
  Mesh lone = test::make_cube_mm(10);
  lone.vertices_mm.emplace_back(10, 5, 10);
  EXPECT_EQ(measure_repair(lone, lone, 10.0).t_junction_edges, 0U);
}

}  // namespace
}  // namespace printtwin
