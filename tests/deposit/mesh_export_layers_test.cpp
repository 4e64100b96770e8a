// The layered as-printed mesh (--deposit-mesh-surface layers, the default): closed and
// outward where consecutive outlines cross, touch diagonally or nest; the filled volume; the
// fall-back to the voxel surface; decimation by a coarser outline tolerance.
#include <gtest/gtest.h>
#include <set>

#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <numbers>
#include <vector>

#include "deposit/mesh_export.hpp"
#include "deposit/mesh_export_internal.hpp"
#include "deposit/mesh_test_support.hpp"
#include "printtwin/io.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

constexpr double kVoxel = 0.05;
constexpr int kLayer = 4;  // voxels per layer: 0.2 mm

double volume(const Mesh& m) {
  double six = 0;
  for (const auto& t : m.triangles)
    six += m.vertices_mm[t[0]].dot(m.vertices_mm[t[1]].cross(m.vertices_mm[t[2]]));
  return six / 6.0;
}

/// A part of `layers` layers on a 0.05 mm grid: each layer's cells where `inside(x, y,
/// layer)` holds, as stadium beads do it: the top and bottom voxel rows of a layer are one
/// voxel narrower at the outline than the middle rows. One bead per layer gives its top.
struct Part {
  VoxelGrid grid{kVoxel, Vec3(0, 0, 0), Eigen::Vector3i(160, 160, 64)};
  std::vector<SurfaceBead> beads;
};

template <class Inside>
Part make_part(int layers, Inside inside) {
  Part p;
  for (int l = 0; l < layers; ++l) {
    for (int zz = 0; zz < kLayer; ++zz) {
      const bool end_row = zz == 0 || zz == kLayer - 1;
      for (int y = 1; y < 159; ++y)
        for (int x = 1; x < 159; ++x) {
          if (!inside(x, y, l)) continue;
          // Narrower rows: the cell must have its four neighbours inside too.
          if (end_row && !(inside(x - 1, y, l) && inside(x + 1, y, l) && inside(x, y - 1, l) &&
                           inside(x, y + 1, l)))
            continue;
          p.grid.set({x, y, l * kLayer + zz}, {1, l, Feature::perimeter});
        }
    }
    SurfaceBead b;
    b.start_mm = Vec3(1, 1, (l + 1) * kLayer * kVoxel);
    b.end_mm = Vec3(2, 1, (l + 1) * kLayer * kVoxel);
    b.width_mm = 0.45F;
    b.height_mm = static_cast<float>(kLayer * kVoxel);
    p.beads.push_back(b);
  }
  return p;
}

DepositMesh build(const Part& p, const DepositMeshOptions& o = {}) {
  auto r = build_deposit_mesh(p.grid, o, p.beads);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().describe());
  return r.ok() ? *r : DepositMesh{};
}

/// `vertex_manifold` false: two outlines may touch at one point (a vertex shared by two
/// sheets; every edge still closes), as coarse outlines do.
void expect_layered_and_closed(const DepositMesh& dm, bool vertex_manifold = true) {
  EXPECT_EQ(dm.surface, DepositMeshSurface::layers) << dm.layers_fallback;
  EXPECT_TRUE(dm.layers_fallback.empty()) << dm.layers_fallback;
  if (vertex_manifold) test::expect_closed_oriented(dm.mesh);
  EXPECT_TRUE(detail::is_closed_oriented(dm.mesh));
  EXPECT_GT(dm.volume_mm3, 0.0);
}

TEST(LayerSurfaceClosure, EachEdgeOnceInEachDirection) {
  // A tetrahedron oriented outward: every edge once each way.
  Mesh tet;
  tet.vertices_mm = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
  tet.triangles = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}};
  EXPECT_TRUE(detail::is_closed_oriented(tet));
  Mesh flipped = tet;  // one face inward: its edges run the same way as the neighbours'
  flipped.triangles[2] = {1, 3, 2};
  EXPECT_FALSE(detail::is_closed_oriented(flipped));
  Mesh open = tet;  // a face missing: three edges once
  open.triangles.pop_back();
  EXPECT_FALSE(detail::is_closed_oriented(open));
  Mesh doubled = tet;  // a face twice, both ways: its edges twice in each direction
  doubled.triangles.push_back({0, 2, 1});
  doubled.triangles.push_back({0, 1, 2});
  EXPECT_FALSE(detail::is_closed_oriented(doubled));
  Mesh degenerate = tet;
  degenerate.triangles.push_back({1, 1, 2});
  EXPECT_FALSE(detail::is_closed_oriented(degenerate));
  Mesh outside = tet;  // a corner past the vertices
  outside.triangles[0] = {0, 2, 4};
  EXPECT_FALSE(detail::is_closed_oriented(outside));
}
TEST(LayeredMesh, ACellTouchingThePartAtACornerStaysPartOfIt) {
  // A bead's end can leave a cell that touches the rest of its layer only diagonally. The
  // deposit is one piece there, so the mesh is one piece too, not a one-cell speck beside it.
  const auto square = [](int x, int y, int) { return x >= 40 && x < 120 && y >= 40 && y < 120; };
  for (const bool rising : {true, false}) {
    Part p = make_part(4, square);
    // Cells at the square's +x,+y corner (rising diagonal) or at its +x,-y corner (falling).
    const int y = rising ? 120 : 39;
    for (int z = kLayer + 1; z < 2 * kLayer - 1; ++z)
      p.grid.set({120, y, z}, {1, 1, Feature::perimeter});
    const DepositMesh dm = build(p);
    expect_layered_and_closed(dm);
    EXPECT_EQ(dm.components, 1u) << (rising ? "rising" : "falling");
    EXPECT_NEAR(dm.volume_mm3, dm.filled_volume_mm3, 0.01 * dm.filled_volume_mm3);
  }
}

/// Parts with voxels that lie in one slab alone but touch the next slab's: the round sides of
/// both slabs would take the contact away and leave them a separate piece of the mesh.
std::vector<Part> parts_needing_a_join() {
  const auto square = [](int x, int y, int) { return x >= 40 && x < 120 && y >= 40 && y < 120; };
  // A few cells lifted one cell above the last layer, on the rim of a hole in it (face to
  // face with the layer below).
  Part lifted = make_part(4, [&](int x, int y, int l) {
    return square(x, y, l) && !(l == 3 && x >= 74 && x < 82 && y >= 74 && y < 82);
  });
  for (int y = 77; y < 80; ++y)
    for (int x = 81; x < 84; ++x)
      lifted.grid.set({x, y, 4 * kLayer}, {1, 3, Feature::top_solid_infill});
  // The sagging underside of an overhanging layer's bead: a cell in the slab below, away
  // from that slab's cells, touching the overhang's bottom row along an edge only.
  Part sagging = make_part(4, [](int x, int y, int l) {
    return x >= 40 && x < 120 && y >= 40 && y < (l == 0 ? 100 : 120);
  });
  for (int x = 60; x < 64; ++x) sagging.grid.set({x, 118, kLayer - 1}, {1, 1, Feature::perimeter});
  // A layer that is only a patch on the part's side, touching the layers below and above
  // it face to face within their round sides: its cells join the slab below (a tie).
  Part patch = make_part(
      4, [](int x, int y, int l) { return l != 2 && x >= 40 && x < 120 && y >= 40 && y < 120; });
  for (int z = 2 * kLayer; z < 3 * kLayer; ++z)
    for (int y = 78; y < 82; ++y)
      for (int x = 118; x < 122; ++x) patch.grid.set({x, y, z}, {1, 2, Feature::perimeter});
  std::vector<Part> parts;
  parts.push_back(std::move(lifted));
  parts.push_back(std::move(sagging));
  parts.push_back(std::move(patch));
  return parts;
}

TEST(LayeredMesh, CellsTouchingTheNextLayerOnlyAcrossSlabsJoinIt) {
  for (const Part& p : parts_needing_a_join()) {
    const DepositMesh dm = build(p);
    expect_layered_and_closed(dm);
    EXPECT_EQ(dm.components, 1u);
    EXPECT_EQ(dm.merged_pieces, 1u);
    EXPECT_EQ(analyze_mesh_health(dm.mesh).shells, 1u);
    EXPECT_NEAR(dm.volume_mm3, dm.filled_volume_mm3, 0.02 * dm.filled_volume_mm3);
  }
}

TEST(LayeredMesh, AJoinRebuildsOnlyTheSlabsItChangesWithTheSameMesh) {
  // After a join the surface is built again from the slabs and caps the moved cells leave
  // as they were; PRINTTWIN_PLAIN=mesh_rebuild builds all of it: the same mesh, bit for bit.
  for (const Part& p : parts_needing_a_join()) {
    const DepositMesh part = build(p);
    ASSERT_EQ(::setenv("PRINTTWIN_PLAIN", "mesh_rebuild", 1), 0);
    const DepositMesh whole = build(p);
    ::unsetenv("PRINTTWIN_PLAIN");
    EXPECT_EQ(part.merged_pieces, 1u);
    EXPECT_EQ(whole.merged_pieces, 1u);
    EXPECT_EQ(part.layers, whole.layers);
    EXPECT_EQ(part.outlines, whole.outlines);
    ASSERT_EQ(part.mesh.triangles, whole.mesh.triangles);
    ASSERT_EQ(part.mesh.vertices_mm.size(), whole.mesh.vertices_mm.size());
    for (std::size_t i = 0; i < part.mesh.vertices_mm.size(); ++i)
      ASSERT_EQ(part.mesh.vertices_mm[i], whole.mesh.vertices_mm[i]) << i;
  }
}

TEST(LayerSurfaceMemo, OnlyTheChangedSlabAndItsCapsAreBuiltAgain) {
  // Six slabs of a square with a hole; then one slab's cross-section changes (cells added
  // beside the square, a new outline). Built again with the memo of the first build, only
  // that slab is traced and only its two caps are made: the same surface as a fresh build.
  int extra_slab = -1;  // the slab with the added cells (-1: none)
  detail::LayerSlabs in;
  in.width = 128;
  in.height = 64;
  in.cell_mm = 0.05;
  for (int b = 0; b <= 6; ++b) in.bounds.push_back(2 + 4 * b);
  in.project = [&extra_slab](int z0, int, std::vector<std::uint64_t>& rows) {
    const int slab = (z0 - 2) / 4;
    for (int y = 8; y < 56; ++y)
      for (int x = 8 + slab; x < 100; ++x)
        if (!(x >= 30 && x < 40 && y >= 20 && y < 30))
          rows[static_cast<std::size_t>(y) * 2 + static_cast<std::size_t>(x >> 6)] |= 1ULL
                                                                                      << (x & 63);
    if (slab == extra_slab)
      for (int y = 20; y < 26; ++y)
        for (int x = 104; x < 110; ++x)
          rows[static_cast<std::size_t>(y) * 2 + static_cast<std::size_t>(x >> 6)] |= 1ULL
                                                                                      << (x & 63);
  };
  const detail::LayerSurfaceOptions o;
  detail::LayerSurfaceMemo memo;
  const detail::LayerSurface first = detail::build_layer_surface(in, o, &memo);
  EXPECT_EQ(memo.reused_slabs(), 0u);
  EXPECT_EQ(memo.reused_caps(), 0u);
  ASSERT_TRUE(detail::is_closed_oriented(first.mesh));
  extra_slab = 3;
  memo.forget(in.bounds[3], in.bounds[4]);
  const detail::LayerSurface again = detail::build_layer_surface(in, o, &memo);
  EXPECT_EQ(memo.reused_slabs(), 5u);
  EXPECT_EQ(memo.reused_caps(), 5u);  // of seven: those below and above slab 3 are made
  const detail::LayerSurface fresh = detail::build_layer_surface(in, o);
  EXPECT_EQ(again.outlines, first.outlines + 1);
  EXPECT_TRUE(detail::is_closed_oriented(again.mesh));
  EXPECT_EQ(again.mesh.vertices_mm, fresh.mesh.vertices_mm);
  EXPECT_EQ(again.mesh.triangles, fresh.mesh.triangles);
  ASSERT_EQ(again.seeds.size(), fresh.seeds.size());
  for (std::size_t i = 0; i < again.seeds.size(); ++i) {
    EXPECT_EQ(again.seeds[i].slab, fresh.seeds[i].slab);
    EXPECT_EQ(again.seeds[i].triangle, fresh.seeds[i].triangle);
  }
  // Other options: nothing is taken from the memo.
  detail::LayerSurfaceOptions coarser;
  coarser.tolerance_mm = 0.05;
  const detail::LayerSurface coarse = detail::build_layer_surface(in, coarser, &memo);
  EXPECT_EQ(memo.reused_slabs(), 0u);
  EXPECT_EQ(memo.reused_caps(), 0u);
  EXPECT_TRUE(detail::is_closed_oriented(coarse.mesh));
}

TEST(LayeredMesh, MaterialRaisedAboveTheLastLayerIsItsOwnSlab) {
  // The squeeze can lift a solid top layer's overflow one cell above the layer's top. That
  // cell is a slab of its own: the top cap stays at the last layer's top everywhere else.
  const auto square = [](int x, int y, int) { return x >= 40 && x < 120 && y >= 40 && y < 120; };
  const DepositMesh flat = build(make_part(4, square));
  Part p = make_part(4, square);
  const int top = 4 * kLayer;  // the first cell above the last layer
  for (int y = 70; y < 74; ++y)
    for (int x = 70; x < 74; ++x) p.grid.set({x, y, top}, {1, 3, Feature::top_solid_infill});
  const DepositMesh dm = build(p);
  expect_layered_and_closed(dm);
  EXPECT_EQ(flat.layers, 4u);
  EXPECT_EQ(dm.layers, 5u);  // four layers and the raised cells
  // The raised patch adds its own volume (16 cells), not a cell's height over the whole top.
  EXPECT_NEAR(volume(dm.mesh) - volume(flat.mesh), 16 * kVoxel * kVoxel * kVoxel,
              8 * kVoxel * kVoxel * kVoxel);
  // Upward faces at the last layer's top cover the square but for the raised patch.
  const double top_mm = top * kVoxel;
  double area_at_top = 0, area_above = 0;
  for (const auto& t : dm.mesh.triangles) {
    const Vec3& a = dm.mesh.vertices_mm[t[0]];
    const Vec3 n = (dm.mesh.vertices_mm[t[1]] - a).cross(dm.mesh.vertices_mm[t[2]] - a);
    if (n.z() <= 0) continue;
    const double z = (a.z() + dm.mesh.vertices_mm[t[1]].z() + dm.mesh.vertices_mm[t[2]].z()) / 3;
    if (std::abs(z - top_mm) < 1e-6) area_at_top += 0.5 * n.norm();
    if (z > top_mm + 1e-6) area_above += 0.5 * n.norm();
  }
  EXPECT_GT(area_at_top, 0.8 * 4.0 * 4.0);  // most of the 4 x 4 mm top
  EXPECT_LT(area_above, 0.1);               // the 0.2 x 0.2 mm patch, not the whole top
}

TEST(LayeredMesh, CylinderIsClosedWithTheFilledVolume) {
  const Part p =
      make_part(8, [](int x, int y, int) { return std::hypot(x - 80.0, y - 80.0) < 60.0; });
  const DepositMesh dm = build(p);
  expect_layered_and_closed(dm);
  EXPECT_EQ(dm.layers, 8u);
  EXPECT_NEAR(dm.volume_mm3, dm.filled_volume_mm3, 0.01 * dm.filled_volume_mm3);
  EXPECT_NEAR(volume(dm.mesh), dm.volume_mm3, 1e-6 * dm.volume_mm3);
  // Far smaller than the voxel surface of the same part.
  DepositMeshOptions voxel;
  voxel.surface = DepositMeshSurface::voxel;
  const DepositMesh vm = build(p, voxel);
  EXPECT_EQ(vm.surface, DepositMeshSurface::voxel);
  EXPECT_LT(dm.mesh.triangles.size() * 3, vm.mesh.triangles.size());
}

TEST(LayeredMesh, SidesFollowTheRoundBeadIntoTheGroove) {
  const Part p =
      make_part(6, [](int x, int y, int) { return x >= 40 && x < 120 && y >= 40 && y < 120; });
  const DepositMesh dm = build(p);
  expect_layered_and_closed(dm);
  // The wall x = 2.0 mm (cells from 40): at mid-layer the outline, at a layer boundary the
  // groove half a layer (0.1 mm) in.
  double mid_min_x = 1e9, groove_min_x = 1e9;
  for (const Vec3& v : dm.mesh.vertices_mm) {
    const double in_layer = std::fmod(v.z(), 0.2);
    if (std::abs(in_layer - 0.1) < 1e-6) mid_min_x = std::min(mid_min_x, v.x());
    if ((in_layer < 1e-6 || in_layer > 0.2 - 1e-6) && v.z() > 0.1 && v.z() < 1.1)
      groove_min_x = std::min(groove_min_x, v.x());
  }
  EXPECT_NEAR(mid_min_x, 2.0, 0.03);
  EXPECT_NEAR(groove_min_x, 2.1, 0.03);
}

TEST(LayeredMesh, SideProfileIsAsDeepOnAverageAsTheRoundBead) {
  // Rings on the circle make a polygon inside it (0.396 r mean inset at two steps); the
  // inner rings are placed so the polygon's mean and RMS inset (lengths weighted) are the
  // round profile's: r (1 - 2 / pi) and r sqrt(3/2 - 4 / pi).
  const double mean = 1 - 2 / std::numbers::pi, rms = std::sqrt(1.5 - 4 / std::numbers::pi);
  EXPECT_GT(detail::profile_moments(2, 1, 1)[0], mean + 0.03);  // on the circle: too deep
  for (const int steps : {2, 3, 4, 6}) {
    const auto [a, b] = detail::profile_fit(steps);
    EXPECT_LT(a, 1.0);
    EXPECT_LE(b, 1.0);
    const auto m = detail::profile_moments(steps, a, b);
    EXPECT_NEAR(m[0], mean, 1e-6) << steps;
    EXPECT_NEAR(m[1], rms, 1e-6) << steps;
  }
  EXPECT_EQ(detail::profile_fit(1), (std::array<double, 2>{1, 1}));  // no inner ring
}

TEST(LayeredMesh, CrossingNestedAndDiagonalOutlinesClose) {
  // Squares that shift each layer (outlines cross), a hole that opens and closes, a second
  // piece that touches the first only diagonally from one layer to the next.
  const Part p = make_part(7, [](int x, int y, int l) {
    const int s = 30 + 6 * l;
    const bool square = x >= s && x < s + 60 && y >= 40 - l && y < 100 + 2 * l;
    const bool hole = l >= 2 && l <= 4 && std::hypot(x - (s + 30.0), y - 70.0) < 8.0 + l;
    const bool diagonal = (l % 2 == 0) ? (x >= 130 && x < 140 && y >= 130 && y < 140)
                                       : (x >= 140 && x < 150 && y >= 140 && y < 150);
    return (square && !hole) || diagonal;
  });
  const DepositMesh dm = build(p);
  expect_layered_and_closed(dm);
  // Small pieces (0.5 mm squares): four voxel rows per layer are a coarse stadium, the
  // profile's rings a finer one; the real deposits agree within 1 % (cube, benchmark part).
  EXPECT_NEAR(dm.volume_mm3, dm.filled_volume_mm3, 0.03 * dm.filled_volume_mm3);
}

TEST(LayeredMesh, ThinPinholesAndOneCellFeaturesClose) {
  // Pin holes of one cell, a one-cell-wide fin and a narrow neck (rounded sides would fold
  // there: those outlines get flatter or straight sides).
  const Part p = make_part(4, [](int x, int y, int l) {
    const bool body = x >= 20 && x < 100 && y >= 20 && y < 100 && !(x % 9 == 0 && y % 7 == 0);
    const bool fin = x == 110 + l && y >= 20 && y < 100;
    const bool neck = x >= 100 && x < 110 && y >= 58 && y < 61;
    return body || fin || neck;
  });
  const DepositMesh dm = build(p);
  expect_layered_and_closed(dm);
  EXPECT_GT(dm.straight_outlines, 0u);
}

/// A closed ring along the corners (counter-clockwise), `per_side` edges per side, each
/// vertex p moved by `wobble(i, p)` mm across its side (i counts the vertices).
template <class Wobble>
std::vector<Eigen::Vector2d> wobbly_rect(double x0, double y0, double x1, double y1, int per_side,
                                         Wobble wobble) {
  const std::array<Eigen::Vector2d, 4> c{Eigen::Vector2d(x0, y0), Eigen::Vector2d(x1, y0),
                                         Eigen::Vector2d(x1, y1), Eigen::Vector2d(x0, y1)};
  std::vector<Eigen::Vector2d> r;
  for (std::size_t s = 0; s < 4; ++s) {
    const Eigen::Vector2d a = c[s], b = c[(s + 1) % 4];
    const Eigen::Vector2d n = Eigen::Vector2d(a.y() - b.y(), b.x() - a.x()).normalized();
    for (int k = 0; k < per_side; ++k) {
      const double t = static_cast<double>(k) / per_side;
      const Eigen::Vector2d p = a + t * (b - a);
      r.push_back(p + wobble(static_cast<int>(r.size()), p) * n);
    }
  }
  return r;
}

/// Signed area of the cap (facing up positive) and the smallest triangle height.
std::array<double, 2> cap_area_and_min_height(const detail::LayerCap& cap) {
  double area = 0, min_height = 1e9;
  for (const auto& t : cap.triangles) {
    const Eigen::Vector2d a = cap.vertices[t[0]], b = cap.vertices[t[1]], c = cap.vertices[t[2]];
    const Eigen::Vector2d u = b - a, v = c - a;
    const double twice = u.x() * v.y() - u.y() * v.x();
    area += 0.5 * twice;
    const double longest = std::max({u.norm(), v.norm(), (c - b).norm()});
    min_height = std::min(min_height, std::abs(twice) / longest);
  }
  return {area, min_height};
}

TEST(LayeredMesh, CapSnapsRingsAFewMicrometresApart) {
  // The slab above has the same outline, its vertices 3 um to either side (an inset limited
  // per edge puts rings this close): the rings cross near every vertex.
  const auto lower = wobbly_rect(0, 0, 2, 2, 8, [](int, const Eigen::Vector2d&) { return 0.0; });
  const auto upper = wobbly_rect(
      0, 0, 2, 2, 8, [](int i, const Eigen::Vector2d&) { return i % 2 == 0 ? 0.003 : -0.003; });
  const detail::LayerCap raw = detail::layer_cap({lower}, {upper}, 0.0);
  ASSERT_TRUE(raw.ok);
  EXPECT_LT(cap_area_and_min_height(raw)[1], 0.005);  // without snapping: slivers
  const detail::LayerCap same = detail::layer_cap({lower}, {upper}, 0.005);
  ASSERT_TRUE(same.ok);
  EXPECT_TRUE(same.triangles.empty());  // one vertical wall: no cap at all

  // Wider above (a step out on +x), the shared sides 2-3 um apart: the cap is the step only,
  // facing down, with no sliver along the shared sides, where the vertices are a few um apart
  // (bottom, top) and where they lie a few um from the other ring's edges (left: 1/6 mm
  // apart against 1/4 mm below).
  const auto wide = wobbly_rect(0, 0, 3, 2, 12, [](int i, const Eigen::Vector2d& p) {
    return p.x() > 2.0 ? 0.0 : i % 3 == 0 ? 0.003 : -0.002;
  });
  const auto lower12 = wobbly_rect(0, 0, 2, 2, 8, [](int, const Eigen::Vector2d&) { return 0.0; });
  const detail::LayerCap step = detail::layer_cap({lower12}, {wide}, 0.005);
  ASSERT_TRUE(step.ok);
  const auto [area, min_height] = cap_area_and_min_height(step);
  EXPECT_NEAR(area, -2.0, 0.01);  // 1 x 2 mm, down
  EXPECT_GT(min_height, 0.01);
  for (const auto& t : step.triangles) {  // every triangle facing down
    const Eigen::Vector2d u = step.vertices[t[1]] - step.vertices[t[0]],
                          v = step.vertices[t[2]] - step.vertices[t[0]];
    EXPECT_LT(u.x() * v.y() - u.y() * v.x(), 0.0);
  }
  // Exact constructions give the same cap.
  const detail::LayerCap exact = detail::layer_cap({lower12}, {wide}, 0.005, true);
  ASSERT_TRUE(exact.ok);
  EXPECT_NEAR(cap_area_and_min_height(exact)[0], area, 1e-9);
}

TEST(LayeredMesh, CapSnapsKeepOneOrderAlongBothRings) {
  // Two rings of one square, their bottom sides zigzagging by a few um with 7 - 10 um edges
  // (per-vertex insets make such rings): the upper vertex (1.0143, 0.0029) lies a few um from
  // the lower edge after (1.0149, -0.0042), and that lower vertex a few um from the upper edge
  // after it. Taking both would make the rings share that short edge head-on (four triangles
  // on it); every directed edge of the cap is used once.
  using V = Eigen::Vector2d;
  const std::vector<V> lower{
      V(0, 0), V(1.0072, -0.0022), V(1.0149, -0.0042), V(1.0216, 0.0044), V(2, 0), V(2, 2),
      V(0, 2)};
  const std::vector<V> upper{
      V(0, 0), V(1.0054, 0.0053), V(1.0143, 0.0029), V(1.0238, -0.0056), V(2, 0), V(2, 2), V(0, 2)};
  for (const bool exact : {false, true}) {
    const detail::LayerCap cap = detail::layer_cap({lower}, {upper}, 0.005, exact);
    ASSERT_TRUE(cap.ok);
    ASSERT_FALSE(cap.triangles.empty());  // the slivers between the zigzags
    std::set<std::pair<std::uint32_t, std::uint32_t>> edges;
    for (const auto& t : cap.triangles)
      for (std::size_t k = 0; k < 3; ++k)
        EXPECT_TRUE(edges.insert({t[k], t[(k + 1) % 3]}).second)
            << "edge " << t[k] << " -> " << t[(k + 1) % 3] << " used twice";
    // The slivers between the zigzags and the thin wedge to (2, 0): a few 0.001 mm2.
    EXPECT_LT(std::abs(cap_area_and_min_height(cap)[0]), 0.005);
  }
}

TEST(LayeredMesh, DecimationCoarsensTheOutlinesToFit) {
  const Part p = make_part(5, [](int x, int y, int l) {
    return std::hypot(x - 80.0, y - 80.0) < 50.0 + 3 * std::sin(x * 0.7 + l);
  });
  const DepositMesh full = build(p);
  expect_layered_and_closed(full, false);
  DepositMeshOptions o;
  o.max_triangles = full.mesh.triangles.size() / 3;
  const DepositMesh small = build(p, o);
  expect_layered_and_closed(small, false);
  EXPECT_LE(small.mesh.triangles.size(), o.max_triangles);
  EXPECT_GT(small.outline_tolerance_mm, full.outline_tolerance_mm);
  EXPECT_NEAR(small.volume_mm3, full.volume_mm3, 0.02 * full.volume_mm3);
}

TEST(LayeredMesh, WithoutBeadsTheVoxelSurfaceIsBuiltAndSaysWhy) {
  const Part p =
      make_part(3, [](int x, int y, int) { return x > 50 && x < 70 && y > 50 && y < 70; });
  auto r = build_deposit_mesh(p.grid, {});
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->surface, DepositMeshSurface::voxel);
  EXPECT_NE(r->layers_fallback.find("no beads"), std::string::npos);
  EXPECT_NE(deposit_mesh_summary(*r, "x.stl").find("voxel surface instead"), std::string::npos);
}

TEST(LayeredMesh, EmptyAndSingleBeadDeposits) {
  const Part empty = make_part(0, [](int, int, int) { return false; });
  const DepositMesh e = build(empty);
  EXPECT_TRUE(e.mesh.triangles.empty());
  // One bead: a short stadium line, one layer.
  const Part one =
      make_part(1, [](int x, int y, int) { return x >= 20 && x < 80 && y >= 50 && y < 59; });
  const DepositMesh dm = build(one);
  expect_layered_and_closed(dm);
  // 0.45 mm wide, one layer: mostly rounded side (see above).
  EXPECT_NEAR(dm.volume_mm3, dm.filled_volume_mm3, 0.08 * dm.filled_volume_mm3);
}

TEST(LayeredMesh, SameInputSameMesh) {
  const Part p = make_part(6, [](int x, int y, int l) {
    return std::hypot(x - 70.0 - l, y - 80.0) < 40.0 ||
           (x > 100 && x < 130 && y > 60 + l && y < 90);
  });
  const DepositMesh a = build(p), b = build(p);
  ASSERT_EQ(a.mesh.triangles.size(), b.mesh.triangles.size());
  EXPECT_EQ(a.mesh.triangles, b.mesh.triangles);
  EXPECT_EQ(a.mesh.vertices_mm, b.mesh.vertices_mm);
}

TEST(LayeredMeshCli, SimulateCubeIsLayeredClosedWithItsVolume) {
  const auto dir = test::temp_dir("deposit_mesh_layers_cli");
  const auto gcode = test::source_path("samples/gcode/prusa_cube10.gcode");
  const auto run = test::run_cli("simulate '" + gcode.string() + "' --deposit-mesh '" +
                                 (dir / "cube.stl").string() + "' --json '" +
                                 (dir / "cube.json").string() + "'");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  // 50 printed layers, and the top layer's overflow the squeeze raised one cell above it.
  EXPECT_NE(run.out.find("51 slabs"), std::string::npos) << run.out;
  const auto j = test::read_json(dir / "cube.json");
  const auto& m = j["deposit"]["mesh"];
  EXPECT_EQ(m["surface"].get<std::string>(), "layers");
  const double v = m["volume_mm3"].get<double>(), filled = m["filled_volume_mm3"].get<double>();
  EXPECT_NEAR(v, filled, 0.01 * filled);
  auto back = load_mesh(dir / "cube.stl");
  ASSERT_TRUE(back.ok()) << back.error().describe();
  EXPECT_NEAR(signed_volume_mm3(*back), v, 0.001 * v);
  const auto voxel =
      test::run_cli("simulate '" + gcode.string() + "' --deposit-mesh '" +
                    (dir / "cube_voxel.stl").string() + "' --deposit-mesh-surface voxel");
  ASSERT_EQ(voxel.exit_code, 0) << voxel.err;
  EXPECT_EQ(voxel.out.find("slabs,"), std::string::npos) << voxel.out;
  const auto bad = test::run_cli("simulate '" + gcode.string() + "' --deposit-mesh '" +
                                 (dir / "c.stl").string() + "' --deposit-mesh-surface mesh");
  EXPECT_EQ(bad.exit_code, 2);
}

}  // namespace
}  // namespace printtwin

namespace printtwin {
namespace {

/// The signed volume of each connected piece of `m` (over shared vertices).
std::vector<double> piece_volumes(const Mesh& m) {
  std::vector<std::uint32_t> parent(m.vertices_mm.size());
  for (std::uint32_t i = 0; i < parent.size(); ++i) parent[i] = i;
  const auto root = [&parent](std::uint32_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  for (const auto& t : m.triangles) {
    const std::uint32_t a = root(t[0]);
    parent[root(t[1])] = a;
    parent[root(t[2])] = a;
  }
  std::map<std::uint32_t, double> vol;
  for (const auto& t : m.triangles)
    vol[root(t[0])] +=
        m.vertices_mm[t[0]].dot(m.vertices_mm[t[1]].cross(m.vertices_mm[t[2]])) / 6.0;
  std::vector<double> out;
  for (const auto& [r, v] : vol) out.push_back(v);
  return out;
}

TEST(LayeredMeshCli, RealSlicerFilesGiveOuterShellsWithTheFilledVolume) {
  // The layered mesh of real slicers' prints: closed, every piece an outer shell (the small
  // cavities the slabs close are filled), its volume the filled volume's. Files up to 1 MB
  // keep the test short.
  const auto dir = test::realworld_dir();
  if (!dir) GTEST_SKIP() << "no realworld folder";
  const auto out = test::temp_dir("deposit_mesh_layers_real");
  int tested = 0;
  for (const auto& entry : std::filesystem::directory_iterator(*dir / "gcode")) {
    if (entry.path().extension() != ".gcode" || entry.file_size() > 1000000) continue;
    const std::string name = entry.path().stem().string();
    const auto run = test::run_cli("simulate '" + entry.path().string() + "' --deposit-mesh '" +
                                   (out / (name + ".stl")).string() + "' --json '" +
                                   (out / (name + ".json")).string() + "'");
    if (run.exit_code != 0) continue;  // the interpreter's tests cover its errors
    const auto j = test::read_json(out / (name + ".json"));
    if (!j["deposit"].contains("mesh")) continue;
    const auto& m = j["deposit"]["mesh"];
    auto mesh = load_mesh(out / (name + ".stl"));
    ASSERT_TRUE(mesh.ok()) << mesh.error().describe();
    EXPECT_TRUE(detail::is_closed_oriented(*mesh)) << name;
    const auto pieces = piece_volumes(*mesh);
    EXPECT_EQ(pieces.size(), m["components"].get<std::size_t>()) << name;
    for (const double v : pieces) EXPECT_GT(v, 0.0) << name;
    const double filled = m["filled_volume_mm3"].get<double>();
    EXPECT_NEAR(m["volume_mm3"].get<double>(), filled, 0.01 * filled) << name;
    ++tested;
  }
  if (tested == 0) GTEST_SKIP() << "no G-code with a deposit mesh";
}

}  // namespace
}  // namespace printtwin
