// The as-printed mesh (--deposit-mesh): closed, outward, the deposit's filled volume,
// skirt and purge pieces left out, decimation within its stated bound, every format loads.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <map>
#include <random>
#include <set>

#include <tbb/global_control.h>

#include "deposit/mesh_export.hpp"
#include "deviation/outer_surface.hpp"
#include "printtwin/deviation.hpp"
#include "printtwin/io.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

constexpr double kVoxel = 0.1;

VoxelGrid make_grid(int n = 48) {
  return VoxelGrid(kVoxel, Vec3(10, 20, 0), Eigen::Vector3i(n, n, n));
}

void fill_box(VoxelGrid& g, const Eigen::Vector3i& lo, const Eigen::Vector3i& hi,
              Feature f = Feature::perimeter, int layer = -1) {
  for (int z = lo.z(); z < hi.z(); ++z)
    for (int y = lo.y(); y < hi.y(); ++y)
      for (int x = lo.x(); x < hi.x(); ++x) g.set({x, y, z}, {1, layer < 0 ? z : layer, f});
}

/// Every undirected edge in exactly two triangles, once in each direction; no degenerate
/// triangle; every vertex used.
void expect_closed_oriented(const Mesh& m) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
  std::vector<char> used(m.vertices_mm.size(), 0);
  for (const auto& t : m.triangles) {
    for (int k = 0; k < 3; ++k) {
      ++directed[{t[k], t[(k + 1) % 3]}];
      used[t[k]] = 1;
    }
    const Vec3 n = (m.vertices_mm[t[1]] - m.vertices_mm[t[0]])
                       .cross(m.vertices_mm[t[2]] - m.vertices_mm[t[0]]);
    EXPECT_GT(n.norm(), 1e-12) << "degenerate triangle";
  }
  std::size_t bad = 0;
  for (const auto& [e, n] : directed) {
    const auto rev = directed.find({e.second, e.first});
    if (n != 1 || rev == directed.end() || rev->second != 1) ++bad;
  }
  EXPECT_EQ(bad, 0u) << "edges not shared by exactly two oppositely oriented triangles";
  EXPECT_EQ(std::count(used.begin(), used.end(), 0), 0);
  // Distinct vertices (no geometric duplicates that would hide an open seam).
  std::set<std::array<double, 3>> pos;
  for (const Vec3& p : m.vertices_mm) pos.insert({p.x(), p.y(), p.z()});
  EXPECT_EQ(pos.size(), m.vertices_mm.size());
}

DepositMesh build(const VoxelGrid& g, const DepositMeshOptions& o = {}) {
  auto r = build_deposit_mesh(g, o);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().describe());
  return r.ok() ? *r : DepositMesh{};
}

TEST(DepositMesh, BoxIsTwelveTrianglesWithItsVolume) {
  VoxelGrid g = make_grid();
  fill_box(g, {3, 4, 0}, {13, 10, 4});
  const DepositMesh dm = build(g);
  expect_closed_oriented(dm.mesh);
  EXPECT_EQ(dm.mesh.triangles.size(), 12u);
  EXPECT_EQ(dm.rectangles, 6u);
  EXPECT_NEAR(dm.volume_mm3, 240 * std::pow(kVoxel, 3), 1e-9);
  EXPECT_NEAR(dm.filled_volume_mm3, dm.volume_mm3, 1e-9);
  EXPECT_EQ(dm.error_bound_mm, 0.0);
  const Box3 box = bounding_box(dm.mesh);
  EXPECT_NEAR(box.min.x(), 10.3, 1e-9);
  EXPECT_NEAR(box.max.z(), 0.4, 1e-9);
}

TEST(DepositMesh, StaircaseHasNoTJunctions) {
  // Steps of different lengths on each layer: long coplanar faces meet short ones.
  VoxelGrid g = make_grid();
  for (int z = 0; z < 6; ++z) fill_box(g, {2 + z, 2, z}, {20 - 2 * z, 5 + z, z + 1});
  const DepositMesh dm = build(g);
  expect_closed_oriented(dm.mesh);
  EXPECT_NEAR(dm.volume_mm3, dm.filled_volume_mm3, 1e-9);
  EXPECT_EQ(dm.repaired_cells, 0u);
}

TEST(DepositMesh, DiagonalContactsAreRepairedIntoAManifold) {
  VoxelGrid g = make_grid();
  fill_box(g, {2, 2, 0}, {6, 6, 4});
  fill_box(g, {6, 6, 0}, {9, 9, 4});    // touches the first along an edge only
  fill_box(g, {9, 9, 4}, {12, 12, 7});  // touches the second at a corner only
  const DepositMesh dm = build(g);
  expect_closed_oriented(dm.mesh);
  EXPECT_GT(dm.repaired_cells, 0u);
  EXPECT_EQ(dm.components, 1u);
  EXPECT_NEAR(dm.volume_mm3, dm.filled_volume_mm3, 1e-9);
  const double voxels = 64 + 36 + 27;
  EXPECT_NEAR(dm.filled_volume_mm3,
              (voxels + static_cast<double>(dm.repaired_cells)) * std::pow(kVoxel, 3), 1e-9);
  EXPECT_GT(dm.error_bound_mm, 0.0);
}

TEST(DepositMesh, RandomBlobsAreClosedWithTheFilledVolume) {
  std::mt19937 rng(7);
  for (int round = 0; round < 6; ++round) {
    VoxelGrid g = make_grid(32);
    std::uniform_int_distribution<int> pos(1, 30);
    const int n = 300 + 300 * round;
    for (int i = 0; i < n; ++i)
      g.set({pos(rng), pos(rng), pos(rng) / 2}, {1, 0, Feature::sparse_infill});
    const DepositMesh dm = build(g);
    SCOPED_TRACE(round);
    expect_closed_oriented(dm.mesh);
    EXPECT_NEAR(dm.volume_mm3, dm.filled_volume_mm3, 1e-7);
    // Scattered voxels are many pieces; each keeps its own closed surface.
    EXPECT_GE(dm.components, 1u);
  }
}

TEST(DepositMesh, EnclosedCavityIsFilledAndTouchingTheGridLimitsWorks) {
  VoxelGrid g = make_grid(16);
  fill_box(g, {0, 0, 0}, {16, 16, 16});  // the whole grid, to its limits
  for (int z = 4; z < 12; ++z)
    for (int y = 4; y < 12; ++y)
      for (int x = 4; x < 12; ++x) g.clear({x, y, z});  // a closed cavity
  const DepositMesh dm = build(g);
  expect_closed_oriented(dm.mesh);
  EXPECT_EQ(dm.mesh.triangles.size(), 12u);
  EXPECT_NEAR(dm.volume_mm3, 16 * 16 * 16 * std::pow(kVoxel, 3), 1e-9);
  // The outer-surface routine agrees on the filled volume.
  const DepositSurface s = extract_outer_surface(g, Box3{Vec3(10, 20, 0), Vec3(11.6, 21.6, 1.6)});
  EXPECT_NEAR(dm.volume_mm3, static_cast<double>(s.filled_voxels) * std::pow(kVoxel, 3), 1e-9);
}

TEST(DepositMesh, SkirtSupportAndLoosePurgeLineAreLeftOut) {
  VoxelGrid g = make_grid(64);
  fill_box(g, {20, 20, 0}, {30, 30, 10}, Feature::outer_perimeter);
  fill_box(g, {30, 22, 0}, {34, 28, 6}, Feature::support);  // support against the part
  // A skirt ring on the first layer, apart from the part.
  fill_box(g, {10, 10, 0}, {40, 12, 1}, Feature::skirt, 0);
  fill_box(g, {10, 38, 0}, {40, 40, 1}, Feature::skirt, 0);
  // A purge line in start code with no feature label.
  fill_box(g, {2, 2, 0}, {50, 4, 1}, Feature::unknown, 0);
  const DepositMesh part = build(g);
  expect_closed_oriented(part.mesh);
  EXPECT_EQ(part.components, 1u);
  EXPECT_EQ(part.dropped_components, 1u);  // the purge line; skirt and support are air
  EXPECT_NEAR(part.volume_mm3, 1000 * std::pow(kVoxel, 3), 1e-9);

  DepositMeshOptions with;
  ASSERT_TRUE(parse_deposit_mesh_include("skirt,support", with).ok());
  const DepositMesh all = build(g, with);
  expect_closed_oriented(all.mesh);
  EXPECT_EQ(all.components, 3u);  // part + support, two skirt strips
  EXPECT_NEAR(all.volume_mm3, (1000 + 144 + 2 * 60) * std::pow(kVoxel, 3), 1e-9);

  DepositMeshOptions bad;
  EXPECT_EQ(parse_deposit_mesh_include("skirt,raft", bad).error().code, ErrorCode::usage);
}

// verify hands its deviation stage's filled volume to the mesh: the same mesh as one built
// on its own, unless the options include auxiliary features (then the mesh extracts its own).
TEST(DepositMesh, TheDeviationStagesFilledVolumeIsReused) {
  VoxelGrid g = make_grid(64);
  fill_box(g, {20, 20, 0}, {30, 30, 10}, Feature::outer_perimeter);
  for (int z = 2; z < 8; ++z)  // an enclosed cavity
    for (int y = 22; y < 28; ++y)
      for (int x = 22; x < 28; ++x) g.clear({x, y, z});
  fill_box(g, {10, 10, 0}, {40, 12, 1}, Feature::skirt, 0);
  const DeviationSettings d;
  const Box3 region{Vec3(11.5, 21.5, -0.5), Vec3(13.5, 23.5, 1.5)};  // the part, 0.5 mm margin
  const DepositSurface filled = extract_outer_surface(g, region, d.seal_gap_mm, d.groove_depth_mm);
  const DepositMesh own = build(g);
  auto reused = build_deposit_mesh(g, {}, {}, &filled);
  ASSERT_TRUE(reused.ok());
  expect_closed_oriented(reused->mesh);
  EXPECT_EQ(reused->mesh.triangles, own.mesh.triangles);
  EXPECT_EQ(reused->mesh.vertices_mm, own.mesh.vertices_mm);
  EXPECT_NEAR(reused->volume_mm3, 1000 * std::pow(kVoxel, 3), 1e-9);  // cavity filled

  DepositMeshOptions with;
  ASSERT_TRUE(parse_deposit_mesh_include("skirt", with).ok());
  auto skirt = build_deposit_mesh(g, with, {}, &filled);
  ASSERT_TRUE(skirt.ok());
  EXPECT_EQ(skirt->components, 2u);  // the part and the skirt strip
}

// The mesh extracts the filled volume over the part's blocks only (plus the seal's reach): a
// skirt far across the bed changes nothing, and the filled volume is the outer surface's.
TEST(DepositMesh, AFarSkirtChangesNothingInThePart) {
  VoxelGrid g = make_grid(160);
  fill_box(g, {100, 100, 0}, {120, 120, 12}, Feature::outer_perimeter);
  for (int z = 3; z < 9; ++z)  // a cavity behind a one-voxel pinhole (sealed) ...
    for (int y = 104; y < 116; ++y)
      for (int x = 104; x < 116; ++x) g.clear({x, y, z});
  g.clear({100, 110, 5});
  g.clear({101, 110, 5});
  g.clear({102, 110, 5});
  g.clear({103, 110, 5});
  for (int x = 100; x < 120; ++x) g.clear({x, 100, 6});  // ... and a groove along a wall
  DepositMeshOptions voxel;
  voxel.surface = DepositMeshSurface::voxel;
  const DepositMesh alone = build(g, voxel);
  fill_box(g, {2, 2, 0}, {60, 4, 1}, Feature::skirt, 0);
  const DepositMesh with_skirt = build(g, voxel);
  expect_closed_oriented(with_skirt.mesh);
  EXPECT_EQ(with_skirt.mesh.triangles.size(), alone.mesh.triangles.size());
  EXPECT_DOUBLE_EQ(with_skirt.filled_volume_mm3, alone.filled_volume_mm3);
  EXPECT_NEAR(with_skirt.volume_mm3, alone.volume_mm3, 1e-9);
  // The same voxels as the deviation stage's outer surface over the whole grid.
  const DeviationSettings d;
  Box3 whole;
  whole.extend(g.center_mm({0, 0, 0}));
  whole.extend(g.center_mm({159, 159, 159}));
  const DepositSurface s = extract_outer_surface(g, whole, d.seal_gap_mm, d.groove_depth_mm);
  EXPECT_NEAR(with_skirt.filled_volume_mm3, s.filled_voxels * std::pow(kVoxel, 3), 1e-9);
  const DepositSurface f = extract_filled_volume(g, whole, d.seal_gap_mm, d.groove_depth_mm);
  EXPECT_EQ(f.filled_block_code, s.filled_block_code);
  EXPECT_EQ(f.filled_masks, s.filled_masks);
  EXPECT_EQ(f.filled_voxels, s.filled_voxels);
  EXPECT_TRUE(f.faces.empty());
}

TEST(DepositMesh, WithoutFeatureLabelsOneLayerPiecesAreLeftOut) {
  VoxelGrid g = make_grid(64);
  for (int z = 0; z < 8; ++z) fill_box(g, {20, 20, z}, {30, 30, z + 1}, Feature::unknown, z);
  fill_box(g, {2, 2, 0}, {50, 4, 1}, Feature::unknown, 0);
  const DepositMesh dm = build(g);
  EXPECT_EQ(dm.components, 1u);
  EXPECT_EQ(dm.dropped_components, 1u);
  EXPECT_NEAR(dm.volume_mm3, 800 * std::pow(kVoxel, 3), 1e-9);
}

/// Distance from p to the union of the squares of the mesh's triangles (brute force).
double distance_to_mesh(const Mesh& m, const Vec3& p) {
  double best = 1e30;
  for (const auto& t : m.triangles) {
    // Sample the closest point by projection onto the triangle (barycentric clamp).
    const Vec3 a = m.vertices_mm[t[0]], b = m.vertices_mm[t[1]], c = m.vertices_mm[t[2]];
    const Vec3 ab = b - a, ac = c - a, ap = p - a;
    const double d1 = ab.dot(ap), d2 = ac.dot(ap);
    Vec3 q;
    if (d1 <= 0 && d2 <= 0)
      q = a;
    else {
      const Vec3 bp = p - b;
      const double d3 = ab.dot(bp), d4 = ac.dot(bp);
      const Vec3 cp = p - c;
      const double d5 = ab.dot(cp), d6 = ac.dot(cp);
      const double vc = d1 * d4 - d3 * d2, vb = d5 * d2 - d1 * d6, va = d3 * d6 - d5 * d4;
      if (d3 >= 0 && d4 <= d3)
        q = b;
      else if (d6 >= 0 && d5 <= d6)
        q = c;
      else if (vc <= 0 && d1 >= 0 && d3 <= 0)
        q = a + ab * (d1 / (d1 - d3));
      else if (vb <= 0 && d2 >= 0 && d6 <= 0)
        q = a + ac * (d2 / (d2 - d6));
      else if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
        q = b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
      else {
        const double den = 1.0 / (va + vb + vc);
        q = a + ab * (vb * den) + ac * (vc * den);
      }
    }
    best = std::min(best, (p - q).norm());
  }
  return best;
}

TEST(DepositMesh, DecimationFitsTheTargetWithinItsBound) {
  VoxelGrid g = make_grid(64);
  // A rough cone: many steps, so the full mesh has many triangles.
  for (int z = 0; z < 30; ++z) {
    const double r = 25 - 0.7 * z;
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 64; ++x)
        if (std::hypot(x - 31.5, y - 31.5) < r) g.set({x, y, z}, {1, z, Feature::solid_infill});
  }
  const DepositMesh full = build(g);
  expect_closed_oriented(full.mesh);
  DepositMeshOptions o;
  o.max_triangles = full.mesh.triangles.size() / 5;
  const DepositMesh small = build(g, o);
  expect_closed_oriented(small.mesh);
  EXPECT_LE(small.mesh.triangles.size(), o.max_triangles);
  EXPECT_GT(small.cell_voxels, 1);
  EXPECT_EQ(small.full_res_triangles, full.mesh.triangles.size());
  EXPECT_GE(small.volume_mm3, full.volume_mm3);  // the coarse solid contains the fine one
  // Every point of the decimated surface within the stated bound of the full surface:
  // vertices, edge midpoints and triangle centroids.
  double worst = 0;
  for (const auto& t : small.mesh.triangles) {
    const Vec3 a = small.mesh.vertices_mm[t[0]], b = small.mesh.vertices_mm[t[1]],
               c = small.mesh.vertices_mm[t[2]];
    for (const Vec3& p : std::array<Vec3, 5>{a, Vec3((a + b) / 2), Vec3((a + c) / 2),
                                             Vec3((b + c) / 2), Vec3((a + b + c) / 3)})
      worst = std::max(worst, distance_to_mesh(full.mesh, p));
  }
  EXPECT_LE(worst, small.error_bound_mm + 1e-9);
  EXPECT_GT(worst, 0.0);
  // A target below any mesh of the part is a usage error.
  o.max_triangles = 4;
  const auto none = build_deposit_mesh(g, o);
  ASSERT_FALSE(none.ok());
  EXPECT_EQ(none.error().code, ErrorCode::usage);
}

TEST(DepositMesh, EveryFormatLoadsBackWithTheSameSolid) {
  VoxelGrid g = make_grid();
  fill_box(g, {3, 4, 0}, {13, 10, 4});
  fill_box(g, {5, 5, 4}, {9, 8, 9});
  const DepositMesh dm = build(g);
  const auto dir = test::temp_dir("deposit_mesh_formats");
  std::vector<float> dev(dm.mesh.vertices_mm.size());
  for (std::size_t i = 0; i < dev.size(); ++i)
    dev[i] = static_cast<float>(dm.mesh.vertices_mm[i].z() - 0.5);
  for (const char* name : {"part.stl", "part.3mf", "part.ply", "part_dev.ply", "PART.STL"}) {
    SCOPED_TRACE(name);
    const bool with_dev = std::string(name) == "part_dev.ply";
    ASSERT_TRUE(
        write_deposit_mesh(dm, dir / name,
                           with_dev ? std::span<const float>(dev) : std::span<const float>())
            .ok());
    auto back = load_mesh(dir / name);
    ASSERT_TRUE(back.ok()) << back.error().describe();
    EXPECT_EQ(back->triangles.size(), dm.mesh.triangles.size());
    EXPECT_NEAR(signed_volume_mm3(*back), dm.volume_mm3, 1e-6);
    expect_closed_oriented(*back);
  }
  auto ply = read_file(dir / "part_dev.ply");
  ASSERT_TRUE(ply.ok());
  EXPECT_NE(ply->find("property float quality\n"), std::string::npos);
  auto plain = read_file(dir / "part.ply");
  EXPECT_EQ(plain->find("quality"), std::string::npos);
  EXPECT_NE(deposit_mesh_summary(dm, dir / "part.stl").find("closed"), std::string::npos);
}

TEST(DepositMesh, StlNormalsAreOfTheWrittenCornersOnAnyThreadCount) {
  // Corners that float cannot hold exactly (an origin of 1/3 mm and 0.07 mm cells), a part of
  // many records: each normal is the unit normal of the float corners as written, bit for
  // bit, and the file is the same bytes on one thread as on all.
  VoxelGrid g(0.07, Vec3(1.0 / 3, 2.0 / 3, 0), Eigen::Vector3i(48, 48, 48));
  fill_box(g, {3, 4, 0}, {40, 30, 12});
  fill_box(g, {5, 5, 12}, {19, 28, 30});
  const DepositMesh dm = build(g);
  const auto dir = test::temp_dir("deposit_mesh_normals");
  ASSERT_TRUE(write_deposit_mesh(dm, dir / "all.stl", {}).ok());
  {
    const tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    ASSERT_TRUE(write_deposit_mesh(dm, dir / "one.stl", {}).ok());
  }
  const auto all = read_file(dir / "all.stl"), one = read_file(dir / "one.stl");
  ASSERT_TRUE(all.ok() && one.ok());
  EXPECT_TRUE(*all == *one) << "the STL bytes depend on the thread count";
  const std::size_t n = dm.mesh.triangles.size();
  ASSERT_EQ(all->size(), 84 + 50 * n);
  std::size_t wrong = 0;
  for (std::size_t i = 0; i < n; ++i) {
    std::array<float, 12> f{};
    std::memcpy(f.data(), all->data() + 84 + 50 * i, sizeof f);
    const Vec3 a(f[3], f[4], f[5]), b(f[6], f[7], f[8]), c(f[9], f[10], f[11]);
    const Vec3 nn = (b - a).cross(c - a).normalized();
    for (int k = 0; k < 3; ++k) {
      const float want = static_cast<float>(nn[k]);
      if (std::memcmp(&f[static_cast<std::size_t>(k)], &want, sizeof want) != 0) ++wrong;
    }
  }
  EXPECT_EQ(wrong, 0u);
}

TEST(DepositMesh, EmptyDepositWritesValidEmptyFiles) {
  const VoxelGrid g = make_grid(8);
  const DepositMesh dm = build(g);
  EXPECT_TRUE(dm.mesh.triangles.empty());
  const auto dir = test::temp_dir("deposit_mesh_empty");
  for (const char* name : {"e.stl", "e.3mf", "e.ply"}) {
    SCOPED_TRACE(name);
    ASSERT_TRUE(write_deposit_mesh(dm, dir / name).ok());
    auto bytes = read_file(dir / name);
    ASSERT_TRUE(bytes.ok());
    // load_mesh refuses a mesh without triangles, with a message, not a crash.
    auto back = load_mesh(dir / name);
    EXPECT_FALSE(back.ok());
  }
  EXPECT_EQ(read_file(dir / "e.stl")->size(), 84u);
  EXPECT_NE(read_file(dir / "e.ply")->find("element vertex 0\n"), std::string::npos);
  const std::string zip = *read_file(dir / "e.3mf");
  EXPECT_EQ(zip.rfind("PK\x03\x04", 0), 0u);
  EXPECT_NE(zip.find("3D/3dmodel.model"), std::string::npos);
  EXPECT_NE(deposit_mesh_summary(dm, dir / "e.stl").find("no part voxels"), std::string::npos);
}

// The streamed writers: a folder in the way is a clear error naming the path, and neither the
// folder nor a temporary file is left behind; a good write replaces an old file whole.
TEST(DepositMesh, StreamedWritersRefuseAFolderAndReplaceWhole) {
  VoxelGrid g = make_grid(16);
  fill_box(g, {2, 2, 2}, {9, 7, 5});
  const DepositMesh dm = build(g);
  const auto dir = test::temp_dir("deposit_mesh_streamed");
  for (const char* name : {"m.stl", "m.ply"}) {
    SCOPED_TRACE(name);
    const auto taken = dir / (std::string("taken_") + name);
    std::filesystem::create_directories(taken / name);
    const Status st = write_deposit_mesh(dm, taken / name);
    ASSERT_FALSE(st.ok());
    EXPECT_NE(st.error().describe().find(name), std::string::npos) << st.error().describe();
    std::size_t entries = 0;
    for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(taken)) ++entries;
    EXPECT_EQ(entries, 1u);  // the folder only
    ASSERT_TRUE(write_file_atomic(dir / name, std::string(1000000, 'x')).ok());
    ASSERT_TRUE(write_deposit_mesh(dm, dir / name).ok());
    auto back = load_mesh(dir / name);
    ASSERT_TRUE(back.ok());
    EXPECT_EQ(back->triangles.size(), dm.mesh.triangles.size());
  }
  EXPECT_EQ(read_file(dir / "m.stl")->size(), 84 + 50 * dm.mesh.triangles.size());
}

TEST(DepositMesh, BadExtensionIsAUsageError) {
  const auto st = check_deposit_mesh_path("part.obj");
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::usage);
  EXPECT_NE(st.error().message.find(".stl, .3mf or .ply"), std::string::npos);
  EXPECT_FALSE(check_deposit_mesh_path("part").ok());
}

}  // namespace
}  // namespace printtwin

namespace printtwin {
namespace {

TEST(DepositMeshCli, SimulateWritesEachFormatAndReportsIt) {
  const auto dir = test::temp_dir("deposit_mesh_cli");
  const auto gcode = test::source_path("samples/gcode/prusa_cube10.gcode");
  const auto run = test::run_cli("simulate '" + gcode.string() + "' --voxel 0.2 --deposit-mesh '" +
                                 (dir / "cube.3mf").string() + "' --json '" +
                                 (dir / "cube.json").string() + "'");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("deposit mesh: "), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("closed and oriented outward"), std::string::npos) << run.out;
  auto back = load_mesh(dir / "cube.3mf");
  ASSERT_TRUE(back.ok()) << back.error().describe();
  const auto j = test::read_json(dir / "cube.json");
  ASSERT_TRUE(j["deposit"].contains("mesh"));
  EXPECT_EQ(j["deposit"]["mesh"]["triangles"].get<std::size_t>(), back->triangles.size());
  // The 10 mm cube's filled volume: about 1000 mm3 at this coarse voxel.
  EXPECT_NEAR(signed_volume_mm3(*back), 1000.0, 150.0);

  const auto bad = test::run_cli("simulate '" + gcode.string() + "' --deposit-mesh '" +
                                 (dir / "cube.obj").string() + "'");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find(".stl, .3mf or .ply"), std::string::npos) << bad.err;
  const auto folder =
      test::run_cli("simulate '" + gcode.string() + "' --deposit-mesh '" + dir.string() + "'");
  EXPECT_EQ(folder.exit_code, 2);
}

TEST(DepositMeshCli, EmptyDepositGivesAClearMessageAndValidFiles) {
  const auto dir = test::temp_dir("deposit_mesh_cli_empty");
  ASSERT_TRUE(
      write_file_atomic(dir / "travel.gcode", "G28\nG90\nG1 X10 Y10 Z5 F3000\nG1 X20 Y20\n").ok());
  for (const char* name : {"e.stl", "e.3mf", "e.ply"}) {
    SCOPED_TRACE(name);
    const auto run = test::run_cli("simulate '" + (dir / "travel.gcode").string() +
                                   "' --deposit-mesh '" + (dir / name).string() + "'");
    EXPECT_EQ(run.exit_code, 0) << run.err;
    EXPECT_NE(run.out.find("no part voxels"), std::string::npos) << run.out;
    EXPECT_TRUE(std::filesystem::exists(dir / name));
  }
}

TEST(DepositMeshCli, VerifyWritesTheDeviationAndLinksIt) {
  const auto dir = test::temp_dir("deposit_mesh_verify");
  const auto run = test::run_cli(
      "verify '" + test::source_path("samples/models/curved_part.stl").string() + "' --gcode '" +
      test::source_path("samples/gcode/prusa_curved_part.gcode").string() +
      "' --voxel 0.2 --out '" + (dir / "rep").string() + "' --deposit-mesh '" +
      (dir / "part.ply").string() + "'");
  ASSERT_LE(run.exit_code, 1) << run.err;
  auto ply = read_file(dir / "part.ply");
  ASSERT_TRUE(ply.ok());
  EXPECT_NE(ply->find("property float quality\n"), std::string::npos);
  auto html = read_file(dir / "rep" / "report.html");
  ASSERT_TRUE(html.ok());
  EXPECT_NE(html->find("href=\"../part.ply\""), std::string::npos);
  auto back = load_mesh(dir / "part.ply");
  ASSERT_TRUE(back.ok()) << back.error().describe();
}

}  // namespace
}  // namespace printtwin
