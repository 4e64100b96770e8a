// One test per finding of `check`, on meshes built in code.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <map>
#include <nlohmann/json.hpp>
#include <random>

#include "check/check_internal.hpp"
#include "printtwin/check.hpp"
#include "printtwin/mesh_query.hpp"
#include "support/bumpy_sphere.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// Appends `b` to `a` (vertices renumbered).
Mesh merged(Mesh a, const Mesh& b) {
  const auto base = static_cast<std::uint32_t>(a.vertices_mm.size());
  a.vertices_mm.insert(a.vertices_mm.end(), b.vertices_mm.begin(), b.vertices_mm.end());
  for (auto t : b.triangles) a.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
  return a;
}

Mesh flipped(Mesh m) {
  for (auto& t : m.triangles) std::swap(t[1], t[2]);
  return m;
}

/// Prism over the XZ polygon `profile` (CCW seen from -Y... any order: oriented by volume),
/// extruded from y = 0 to y = depth, then turned by `turn_deg` about z. The front and back are
/// `caps` (indices into the profile), a fan from its first corner when empty.
Mesh prism(const std::vector<Vec2>& profile, double depth,
           std::vector<std::array<std::uint32_t, 3>> caps = {}, double turn_deg = 0) {
  Mesh m;
  const auto n = static_cast<std::uint32_t>(profile.size());
  const double c = std::cos(turn_deg * kPi / 180), s = std::sin(turn_deg * kPi / 180);
  for (const double y : {0.0, depth})
    for (const auto& p : profile)
      m.vertices_mm.emplace_back(c * p.x() - s * y, s * p.x() + c * y, p.y());
  if (caps.empty())
    for (std::uint32_t i = 1; i + 1 < n; ++i) caps.push_back({0, i, i + 1});
  for (const auto& t : caps) {
    m.triangles.push_back({t[0], t[1], t[2]});
    m.triangles.push_back({n + t[0], n + t[2], n + t[1]});
  }
  for (std::uint32_t i = 0; i < n; ++i) {
    const std::uint32_t j = (i + 1) % n;
    m.triangles.push_back({i, n + i, j});
    m.triangles.push_back({j, n + i, n + j});
  }
  if (signed_volume_mm3(m) < 0) m = flipped(m);
  return m;
}

const Finding* find(const CheckReport& r, const std::string& code) {
  for (const auto& f : r.findings)
    if (f.code == code) return &f;
  return nullptr;
}

CheckReport run(const Mesh& m, CheckSettings s = {}) {
  auto r = check_printability(m, ender3_marlin2(), s);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().describe());
  return r.ok() ? *r : CheckReport{};
}

TEST(CheckHealth, ClosedCube) {
  const MeshHealth h = analyze_mesh_health(test::make_cube_mm(10));
  EXPECT_EQ(h.triangles, 12U);
  EXPECT_EQ(h.vertices, 8U);
  EXPECT_EQ(h.shells, 1U);
  EXPECT_TRUE(h.closed);
  EXPECT_EQ(h.boundary_edges + h.non_manifold_edges + h.non_manifold_vertices + h.degenerate_faces +
                h.duplicate_faces + h.inconsistent_edges + h.inverted_shells,
            0U);
  EXPECT_NEAR(h.volume_mm3, 1000.0, 1e-9);
  EXPECT_NEAR(h.area_mm2, 600.0, 1e-9);
  EXPECT_NEAR(h.bbox_mm.size().z(), 10.0, 1e-12);
}

TEST(CheckHealth, CubeIsPrintableWithNoFindings) {
  const CheckReport r = run(test::make_cube_mm(20, Vec3(-50, 30, 7)));
  EXPECT_TRUE(r.printable);
  EXPECT_TRUE(r.findings.empty()) << r.findings.front().code;
  // Placed like a slicer: centred on the 235 x 235 bed, lowest point on z = 0.
  EXPECT_NEAR(r.placement.bbox_mm.center().x(), 117.5, 1e-9);
  EXPECT_NEAR(r.placement.bbox_mm.center().y(), 117.5, 1e-9);
  EXPECT_NEAR(r.placement.bbox_mm.min.z(), 0.0, 1e-12);
  EXPECT_NEAR(r.placement.footprint_area_mm2, 400.0, 1e-9);
  EXPECT_TRUE(r.placement.fits);
  ASSERT_TRUE(r.thickness.has_value());
  EXPECT_NEAR(r.thickness->min_thickness_mm, 20.0, 1e-3);
}

TEST(CheckHealth, OpenMesh) {
  Mesh m = test::make_cube_mm(10);
  m.triangles.pop_back();
  const CheckReport r = run(m);
  EXPECT_EQ(r.health.boundary_edges, 3U);
  EXPECT_FALSE(r.health.closed);
  const Finding* f = find(r, "open_mesh");
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->severity, Severity::error);
  EXPECT_EQ(f->count, 3);
  ASSERT_TRUE(f->position_mm.has_value());
  EXPECT_NEAR(f->position_mm->x(), 117.5 + 5.0, 1e-9);  // the removed face is on x = max
  EXPECT_FALSE(r.printable);
}

TEST(CheckHealth, NonManifoldEdge) {
  Mesh m = test::make_cube_mm(10);
  m.vertices_mm.emplace_back(5, -5, -5);
  m.triangles.push_back({0, 1, 8});  // a fin on the edge (0,0,0)-(10,0,0)
  const MeshHealth h = analyze_mesh_health(m);
  EXPECT_EQ(h.non_manifold_edges, 1U);
  EXPECT_EQ(h.boundary_edges, 2U);
  EXPECT_FALSE(h.closed);
  ASSERT_TRUE(h.first_non_manifold_edge_mm.has_value());
  EXPECT_TRUE(h.first_non_manifold_edge_mm->isApprox(Vec3(5, 0, 0)));
  const CheckReport r = run(m);
  ASSERT_NE(find(r, "non_manifold_edge"), nullptr);
  EXPECT_EQ(find(r, "non_manifold_edge")->severity, Severity::error);
}

TEST(CheckHealth, NonManifoldVertexWhereTwoCubesTouch) {
  // Second cube shares only vertex 7 (10,10,10) of the first.
  Mesh a = test::make_cube_mm(10);
  Mesh m = merged(a, test::make_cube_mm(10, Vec3(10, 10, 10)));
  for (auto& t : m.triangles)
    for (auto& v : t)
      if (v == 8) v = 7;  // weld the touching corner
  const MeshHealth h = analyze_mesh_health(m);
  EXPECT_EQ(h.non_manifold_vertices, 1U);
  EXPECT_EQ(h.shells, 2U);
  EXPECT_TRUE(h.closed);
  EXPECT_TRUE(h.first_non_manifold_vertex_mm->isApprox(Vec3(10, 10, 10)));
  const CheckReport r = run(m);
  EXPECT_NE(find(r, "non_manifold_vertex"), nullptr);
  EXPECT_NE(find(r, "multiple_shells"), nullptr);
  EXPECT_EQ(r.health.self_intersections, 0U);
}

/// `m` with vertices at the same position joined (first use keeps its index order).
Mesh welded_by_position(const Mesh& m) {
  std::map<std::array<double, 3>, std::uint32_t> index;
  Mesh out;
  std::vector<std::uint32_t> to(m.vertices_mm.size());
  for (std::size_t v = 0; v < m.vertices_mm.size(); ++v) {
    const Vec3& p = m.vertices_mm[v];
    const auto [it, added] = index.try_emplace({p.x(), p.y(), p.z()},
                                               static_cast<std::uint32_t>(out.vertices_mm.size()));
    if (added) out.vertices_mm.push_back(p);
    to[v] = it->second;
  }
  for (const auto& t : m.triangles) out.triangles.push_back({to[t[0]], to[t[1]], to[t[2]]});
  return out;
}

TEST(CheckHealth, BodiesTouchingFaceToFaceAreClosedShells) {
  // Two 10 mm cubes side by side in one file, welded where they touch at x = 10, as
  // multi-body STLs are (Voron's multibody parts): four faces meet at each edge of the
  // shared square. Once with B's contact face the exact reverse of A's (duplicate faces),
  // once triangulated across the other diagonal.
  const Mesh a = test::make_cube_mm(10);
  const Mesh b = test::make_cube_mm(10, Vec3(10, 0, 0));
  const auto on_contact = [](const Mesh& m, const std::array<std::uint32_t, 3>& t) {
    return std::all_of(t.begin(), t.end(),
                       [&](std::uint32_t v) { return m.vertices_mm[v].x() == 10.0; });
  };
  for (const bool twins : {true, false}) {
    SCOPED_TRACE(twins ? "reverse twins" : "other diagonal");
    Mesh m = welded_by_position(merged(a, b));
    std::vector<std::array<std::uint32_t, 3>> a_contact;
    std::vector<std::array<std::uint32_t, 3>> kept;
    for (std::size_t f = 0; f < m.triangles.size(); ++f) {
      const auto& t = m.triangles[f];
      if (!on_contact(m, t)) {
        kept.push_back(t);
      } else if (f < a.triangles.size()) {
        a_contact.push_back(t);
        kept.push_back(t);
      }
    }
    ASSERT_EQ(a_contact.size(), 2U);
    if (twins) {
      for (const auto& t : a_contact) kept.push_back({t[0], t[2], t[1]});
    } else {
      // The corner both of A's contact faces leave out of their shared diagonal.
      std::map<std::uint32_t, int> uses;
      for (const auto& t : a_contact)
        for (auto v : t) ++uses[v];
      std::vector<std::uint32_t> diagonal;
      std::vector<std::uint32_t> other;
      for (const auto& [v, n] : uses) (n == 2 ? diagonal : other).push_back(v);
      ASSERT_EQ(diagonal.size(), 2U);
      ASSERT_EQ(other.size(), 2U);
      for (const std::uint32_t d : diagonal) {
        std::array<std::uint32_t, 3> t = {other[0], other[1], d};
        const Vec3 n = (m.vertices_mm[t[1]] - m.vertices_mm[t[0]])
                           .cross(m.vertices_mm[t[2]] - m.vertices_mm[t[0]]);
        if (n.x() > 0) std::swap(t[1], t[2]);  // B's face points to -x
        kept.push_back(t);
      }
    }
    m.triangles = kept;
    ASSERT_EQ(m.triangles.size(), 24U);
    const MeshHealth h = analyze_mesh_health(m);
    EXPECT_TRUE(h.closed);
    EXPECT_EQ(h.shells, 2U);
    EXPECT_EQ(h.non_manifold_edges, 0U);
    // The square's four sides; with reverse twins also its diagonal (four faces there too).
    EXPECT_EQ(h.touching_edges, twins ? 5U : 4U);
    EXPECT_EQ(h.boundary_edges + h.inconsistent_edges + h.inverted_shells, 0U);
    EXPECT_EQ(h.duplicate_faces, twins ? 2U : 0U);
    EXPECT_NEAR(h.volume_mm3, 2000.0, 1e-9);
    const CheckReport r = run(m);
    EXPECT_TRUE(r.printable);
    for (const auto& f : r.findings) EXPECT_NE(f.severity, Severity::error) << f.code << f.message;
    const Finding* shells = find(r, "multiple_shells");
    ASSERT_NE(shells, nullptr);
    EXPECT_NE(shells->message.find("touch along " + std::to_string(h.touching_edges) + " edges"),
              std::string::npos)
        << shells->message;
  }
  // A third face on an edge (a fin) stays a non-manifold edge, and one reversed repeat of a
  // face of a single body stays a duplicate (CheckHealth.NonManifoldEdge, .DuplicateFace).
}

TEST(CheckHealth, DegenerateFace) {
  Mesh m = test::make_cube_mm(10);
  m.vertices_mm.emplace_back(5, 0, 0);  // on the edge 0-1
  m.triangles.push_back({0, 8, 1});     // collinear: zero area
  m.triangles.push_back({2, 2, 3});     // repeated index
  const MeshHealth h = analyze_mesh_health(m);
  EXPECT_EQ(h.degenerate_faces, 2U);
  const CheckReport r = run(m);
  const Finding* f = find(r, "degenerate_face");
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->severity, Severity::warning);
  EXPECT_EQ(f->count, 2);
}

TEST(CheckHealth, DuplicateFace) {
  Mesh m = test::make_cube_mm(10);
  m.triangles.push_back(m.triangles[4]);
  m.triangles.push_back({m.triangles[6][0], m.triangles[6][2], m.triangles[6][1]});  // reversed
  const MeshHealth h = analyze_mesh_health(m);
  EXPECT_EQ(h.duplicate_faces, 2U);
  EXPECT_TRUE(h.closed) << "a duplicate is reported once, not as non-manifold edges";
  EXPECT_NE(find(run(m), "duplicate_face"), nullptr);
}

TEST(CheckHealth, InconsistentOrientation) {
  Mesh m = test::make_cube_mm(10);
  std::swap(m.triangles[3][1], m.triangles[3][2]);
  const MeshHealth h = analyze_mesh_health(m);
  EXPECT_EQ(h.inconsistent_edges, 3U);
  const CheckReport r = run(m);
  const Finding* f = find(r, "inconsistent_orientation");
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->severity, Severity::error);
}

TEST(CheckHealth, InvertedShellButNotCavity) {
  const MeshHealth inv = analyze_mesh_health(flipped(test::make_cube_mm(10)));
  EXPECT_EQ(inv.inverted_shells, 1U);
  EXPECT_NEAR(inv.volume_mm3, -1000.0, 1e-9);
  EXPECT_EQ(inv.inconsistent_edges, 0U);
  EXPECT_NE(find(run(flipped(test::make_cube_mm(10))), "inverted_shell"), nullptr);

  // A box with an inside-out box inside it is a hollow part, not an error.
  const Mesh hollow =
      merged(test::make_cube_mm(20), flipped(test::make_cube_mm(10, Vec3(5, 5, 5))));
  const MeshHealth h = analyze_mesh_health(hollow);
  EXPECT_EQ(h.inverted_shells, 0U);
  EXPECT_EQ(h.shells, 2U);
  EXPECT_NEAR(h.volume_mm3, 8000.0 - 1000.0, 1e-9);
}

TEST(CheckSelfIntersections, OverlappingCubes) {
  const Mesh m = merged(test::make_cube_mm(10), test::make_cube_mm(10, Vec3(5, 5, 5)));
  const SelfIntersections si = find_self_intersections(m, 3);
  EXPECT_GT(si.pairs, 0U);
  ASSERT_EQ(si.locations_mm.size(), 3U);
  const Box3 overlap{Vec3(5, 5, 5), Vec3(10, 10, 10)};
  for (const auto& p : si.locations_mm) EXPECT_TRUE(overlap.contains(p, 1e-9)) << p.transpose();
  const CheckReport r = run(m);
  const Finding* f = find(r, "self_intersection");
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->count, static_cast<long>(si.pairs));
  // Slicers merge overlapping shells: the 5 mm cube enclosed twice prints once.
  ASSERT_TRUE(r.intersection_effect.has_value());
  EXPECT_TRUE(r.intersection_effect->measured);
  EXPECT_NEAR(r.intersection_effect->twice_volume_mm3, 125.0, 0.5);
  EXPECT_NEAR(r.intersection_effect->max_twice_area_mm2, 25.0, 0.01);
  EXPECT_EQ(r.intersection_effect->layers_changed, 25U);  // z 5..10 at 0.2 mm
  EXPECT_EQ(r.intersection_effect->inverted_volume_mm3, 0.0);
  EXPECT_EQ(f->severity, Severity::info);
  EXPECT_NE(f->message.find("125.00 mm3 enclosed twice"), std::string::npos) << f->message;
  const auto j = nlohmann::json::parse(check_report_to_json(r, CheckSource{}));
  EXPECT_NEAR(j["intersection_effect"]["twice_volume_mm3"].get<double>(), 125.0, 0.5);
  EXPECT_TRUE(r.printable);
}

// The pattern of models built from several bodies (3DBenchy): closed shells that overlap by
// a few microns or touch face to face, cut along the seam into sliver triangles. The seam
// changes no layer outline and no wall is 0 mm thick there.
TEST(CheckSelfIntersections, ShellsOverlappingByMicronsChangeNothing) {
  Mesh hull = test::make_cube_mm(10);
  // A deck 0.005 mm into the hull, its side along the seam split into slivers.
  Mesh deck = make_box_mesh(Vec3(9.995, 2, 0), Vec3(20, 8, 10));
  Mesh slivers;
  for (int i = 0; i < 40; ++i) {
    const double y0 = 2 + 6.0 * i / 40, y1 = 2 + 6.0 * (i + 1) / 40;
    const auto b = static_cast<std::uint32_t>(slivers.vertices_mm.size());
    slivers.vertices_mm.insert(slivers.vertices_mm.end(),
                               {Vec3(10.0, y0, 4.0), Vec3(10.0, y1, 4.0), Vec3(10.0, y0, 4.0001)});
    slivers.triangles.push_back({b, b + 1, b + 2});
  }
  const Mesh m = merged(merged(hull, deck), slivers);
  const CheckReport r = run(merged(hull, deck));
  ASSERT_GT(r.health.self_intersections, 0U);
  const Finding* f = find(r, "self_intersection");
  ASSERT_NE(f, nullptr);
  EXPECT_NE(f->severity, Severity::error) << f->message;
  ASSERT_TRUE(r.intersection_effect.has_value());
  EXPECT_NEAR(r.intersection_effect->twice_volume_mm3, 0.3, 0.01);  // 0.005 x 6 x 10 mm
  EXPECT_EQ(r.intersection_effect->inverted_volume_mm3, 0.0);
  ASSERT_TRUE(r.thickness.has_value());
  EXPECT_GT(r.thickness->min_thickness_mm, 5.0);  // the deck is 6 mm, the hull 10 mm
  EXPECT_EQ(find(r, "thin_wall"), nullptr);
  EXPECT_EQ(find(r, "narrow_gap"), nullptr);
  EXPECT_TRUE(r.printable);
  // Loose slivers on the seam (open, so the mesh is no longer closed) do not hide that.
  const CheckReport with_slivers = run(m);
  EXPECT_GT(with_slivers.health.boundary_edges, 0U);
  EXPECT_GT(with_slivers.thickness->min_thickness_mm, 5.0);
}

TEST(CheckSelfIntersections, TouchingShellsChangeNoOutline) {
  const Mesh m = merged(test::make_cube_mm(10), make_box_mesh(Vec3(10, 2, 0), Vec3(20, 8, 10)));
  const CheckReport r = run(m);
  const Finding* f = find(r, "self_intersection");
  if (f != nullptr) {
    EXPECT_EQ(f->severity, Severity::info) << f->message;
    EXPECT_NE(f->message.find("without changing any layer outline"), std::string::npos)
        << f->message;
  }
  EXPECT_EQ(find(r, "narrow_gap"), nullptr);
  ASSERT_TRUE(r.thickness.has_value());
  EXPECT_GT(r.thickness->min_thickness_mm, 5.0);
  EXPECT_TRUE(r.printable);
}

TEST(CheckSelfIntersections, InsideOutFoldIsAnErrorWithItsArea) {
  // A shell turned inside out that crosses a good one: 5 x 10 x 10 mm of it lies outside the
  // good shell, with winding number -1 there: union slicers drop it, even-odd ones fill it.
  const Mesh m =
      merged(test::make_cube_mm(10), flipped(make_box_mesh(Vec3(5, 0, 0), Vec3(15, 10, 10))));
  const CheckReport r = run(m);
  ASSERT_TRUE(r.intersection_effect.has_value());
  EXPECT_NEAR(r.intersection_effect->inverted_volume_mm3, 500.0, 1.0);
  EXPECT_NEAR(r.intersection_effect->max_inverted_area_mm2, 50.0, 0.01);
  const Finding* f = find(r, "self_intersection");
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->severity, Severity::error);
  EXPECT_NE(f->message.find("inside out"), std::string::npos) << f->message;
  EXPECT_FALSE(r.printable);
}

// Known-good real parts are PRINTABLE (skipped when the shared folder is absent).
TEST(CheckRealWorld, KnownGoodPartsArePrintable) {
  const auto dir = test::realworld_dir();
  if (!dir) GTEST_SKIP() << "no realworld folder";
  for (const char* name : {"prusa_mk3s_x-end-idler.stl", "xyz_calibration_cube_20mm.stl",
                           "voron24_octopus_bracket_set_multibody.stl"}) {
    const auto path = *dir / "models" / name;
    if (!std::filesystem::exists(path)) continue;
    auto mesh = load_mesh(path.string());
    ASSERT_TRUE(mesh) << name;
    const CheckReport r = run(*mesh);
    std::string errors;
    for (const auto& f : r.findings)
      if (f.severity == Severity::error) errors += f.code + ": " + f.message + "\n";
    EXPECT_TRUE(r.printable) << name << "\n" << errors;
    if (r.thickness) {
      EXPECT_GT(r.thickness->min_thickness_mm, 0.05) << name;
    }
  }
}

TEST(CheckSelfIntersections, NoneOnClosedMeshesAndTouchingNeighbours) {
  EXPECT_EQ(find_self_intersections(test::make_cube_mm(10)).pairs, 0U);
  // Two separate cubes 1 mm apart.
  EXPECT_EQ(find_self_intersections(
                merged(test::make_cube_mm(10), test::make_cube_mm(10, Vec3(11, 0, 0))))
                .pairs,
            0U);
}

TEST(CheckSelfIntersections, FoldedFacesSharingAnEdge) {
  // Two coplanar faces on the same side of their shared edge overlap.
  Mesh m;
  m.vertices_mm = {Vec3(0, 0, 0), Vec3(10, 0, 0), Vec3(5, 8, 0), Vec3(4, 6, 0)};
  m.triangles = {{0, 1, 2}, {1, 0, 3}};
  EXPECT_EQ(find_self_intersections(m).pairs, 1U);
  m.vertices_mm[3] = Vec3(5, -8, 0);  // other side: a flat quad, no overlap
  EXPECT_EQ(find_self_intersections(m).pairs, 0U);
}

TEST(CheckSelfIntersections, FaceThroughSharedVertexFan) {
  // Faces sharing vertex 0; the second pierces the first away from it.
  Mesh m;
  m.vertices_mm = {Vec3(0, 0, 0), Vec3(10, 0, 0), Vec3(0, 10, 0), Vec3(5, 5, -3), Vec3(1, 1, 5)};
  m.triangles = {{0, 1, 2}, {0, 3, 4}};
  EXPECT_EQ(find_self_intersections(m).pairs, 1U);
  m.vertices_mm[3] = Vec3(5, 5, 3);  // both above the first face: they touch only at vertex 0
  EXPECT_EQ(find_self_intersections(m).pairs, 0U);
}

TEST(CheckPlacement, DoesNotFit) {
  const CheckReport r = run(make_box_mesh(Vec3(0, 0, 0), Vec3(240, 10, 10)));
  EXPECT_FALSE(r.placement.fits);
  const Finding* f = find(r, "does_not_fit");
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->severity, Severity::error);
  EXPECT_NE(f->message.find("240.00 x 10.00 x 10.00 mm"), std::string::npos) << f->message;
  EXPECT_FALSE(r.printable);
  const CheckReport tall = run(make_box_mesh(Vec3(0, 0, 0), Vec3(100, 100, 251)));
  EXPECT_FALSE(tall.placement.fits);
}

TEST(CheckPlacement, CenterAndNoCenter) {
  CheckSettings s;
  s.center_x_mm = 50;
  s.center_y_mm = 60;
  const CheckReport r = run(test::make_cube_mm(10, Vec3(3, 4, 5)), s);
  EXPECT_NEAR(r.placement.bbox_mm.center().x(), 50.0, 1e-12);
  EXPECT_NEAR(r.placement.bbox_mm.center().y(), 60.0, 1e-12);
  s.center = false;
  const CheckReport k = run(test::make_cube_mm(10, Vec3(3, 4, 5)), s);
  EXPECT_TRUE(k.placement.offset_mm.isApprox(Vec3(0, 0, -5)));
  // Kept where it is, it hangs off the bed at x < 0.
  const CheckReport off = run(test::make_cube_mm(10, Vec3(-3, 4, 5)), s);
  EXPECT_FALSE(off.placement.fits);
}

TEST(CheckRisks, OverhangAreaAndAngle) {
  // Foot 5 mm wide, 10 mm tall, outer face leaning 60 deg from vertical, 5 mm deep.
  const double a = 60 * kPi / 180;
  const Mesh m = prism({Vec2(0, 0), Vec2(5, 0), Vec2(5 + 10 * std::tan(a), 10), Vec2(0, 10)}, 5);
  const CheckReport r = run(m);
  ASSERT_EQ(r.overhangs.size(), 1U);
  EXPECT_NEAR(r.overhangs[0].area_mm2, 5.0 * 10.0 / std::cos(a), 1e-9);
  EXPECT_NEAR(r.overhangs[0].max_angle_deg, 60.0, 1e-9);
  const Finding* f = find(r, "overhang");
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->severity, Severity::warning);
  EXPECT_NEAR(*f->value, 60.0, 1e-9);
  EXPECT_NEAR(f->position_mm->z(), 5.0, 1e-9);  // centroid of the leaning face
  EXPECT_TRUE(r.printable);
  // A steeper limit accepts it; the bottom face resting on the bed never counts.
  CheckSettings s;
  s.overhang_angle_deg = 61;
  EXPECT_TRUE(run(m, s).overhangs.empty());
  EXPECT_TRUE(run(test::make_cube_mm(10)).overhangs.empty());
}

TEST(CheckRisks, FloatingCeilingIsAnOverhang) {
  // A table: a plate 20 x 20 x 2 held by one leg; its underside is a 90 deg overhang.
  const Mesh table = merged(make_box_mesh(Vec3(8, 8, 0), Vec3(12, 12, 10.5)),
                            make_box_mesh(Vec3(0, 0, 10), Vec3(20, 20, 12)));
  CheckSettings s;
  s.self_intersections = false;  // the two boxes overlap on purpose
  const CheckReport r = run(table, s);
  ASSERT_FALSE(r.overhangs.empty());
  EXPECT_NEAR(r.overhangs[0].max_angle_deg, 90.0, 1e-9);
  EXPECT_NEAR(r.overhangs[0].area_mm2, 400.0, 1e-9);
  EXPECT_NEAR(r.overhangs[0].bbox_mm.min.z(), 10.0, 1e-9);
}

/// A table of two legs `leg` mm wide joined by a deck from z = 6 to 10 over a gap of `gap`
/// mm (an arch seen from the front), `depth` deep along y; turned by `turn_deg` about z.
Mesh two_legged_table(double gap, double leg, double depth, double turn_deg = 0) {
  const double w = 2 * leg + gap;
  // The front and back as six triangles inside the outline (it is not convex).
  return prism({Vec2(0, 0), Vec2(leg, 0), Vec2(leg, 6), Vec2(leg + gap, 6), Vec2(leg + gap, 0),
                Vec2(w, 0), Vec2(w, 10), Vec2(0, 10)},
               depth, {{0, 1, 2}, {0, 2, 7}, {2, 3, 7}, {3, 6, 7}, {3, 4, 5}, {3, 5, 6}}, turn_deg);
}

TEST(CheckBridges, DeckBetweenTwoLegsBridgesItsGap) {
  const Mesh table = two_legged_table(10, 5, 10);
  ASSERT_TRUE(analyze_mesh_health(table).closed);
  const CheckReport r = run(table);
  ASSERT_EQ(r.overhangs.size(), 1U);
  ASSERT_TRUE(r.overhangs[0].bridge.has_value());
  const BridgeSpan& b = *r.overhangs[0].bridge;
  EXPECT_NEAR(b.span_mm, 10.0, 1e-6);  // wall to wall, across the gap
  EXPECT_EQ(b.direction_deg, 0.0);
  EXPECT_TRUE(b.flat);
  EXPECT_FALSE(b.ledge);
  // The Ender-3's sag model: 0.8 mm at 50 mm, sag ~ span^2.
  EXPECT_NEAR(b.sag_mm, 0.8 * 0.04, 1e-9);
  EXPECT_EQ(find(r, "overhang"), nullptr);
  const Finding* f = find(r, "bridge");
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->severity, Severity::info);
  EXPECT_NEAR(*f->value, 0.032, 1e-9);
  EXPECT_NE(f->message.find("bridge of up to 10.00 mm"), std::string::npos) << f->message;
  // The direction follows the part: turned 30 deg, the lines turn with it.
  const CheckReport turned = run(two_legged_table(10, 5, 10, 30));
  ASSERT_EQ(turned.overhangs.size(), 1U);
  ASSERT_TRUE(turned.overhangs[0].bridge.has_value());
  EXPECT_EQ(turned.overhangs[0].bridge->direction_deg, 30.0);
  EXPECT_NEAR(turned.overhangs[0].bridge->span_mm, 10.0, 1e-6);
}

TEST(CheckBridges, LongSpansSagAndTooLongSpansNeedSupport) {
  const CheckReport r40 = run(two_legged_table(40, 5, 10));
  ASSERT_EQ(r40.overhangs.size(), 1U);
  ASSERT_TRUE(r40.overhangs[0].bridge.has_value());
  EXPECT_NEAR(r40.overhangs[0].bridge->sag_mm, 0.8 * 0.64, 1e-9);
  const Finding* f = find(r40, "bridge_sag");
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->severity, Severity::warning);
  EXPECT_NE(f->message.find("sag 0.51 mm"), std::string::npos) << f->message;
  // Beyond twice the reference span (100 mm) the model bridges nothing.
  const CheckReport r120 = run(two_legged_table(120, 5, 10));
  ASSERT_EQ(r120.overhangs.size(), 1U);
  EXPECT_FALSE(r120.overhangs[0].bridge.has_value());
  EXPECT_NE(find(r120, "overhang"), nullptr);
  EXPECT_EQ(find(r120, "bridge"), nullptr);
}

TEST(CheckBridges, ShelfHeldOnOneSideIsAnOverhangUnlessNarrow) {
  // One leg 5 mm wide under a deck reaching `reach` mm beyond it (a shelf). The outline
  // starts at the inner corner, so that prism's fan of triangles stays inside it.
  const auto shelf = [](double reach) {
    return prism(
        {Vec2(5, 6), Vec2(5 + reach, 6), Vec2(5 + reach, 10), Vec2(0, 10), Vec2(0, 0), Vec2(5, 0)},
        10);
  };
  const CheckReport wide = run(shelf(10));
  ASSERT_EQ(wide.overhangs.size(), 1U);
  EXPECT_FALSE(wide.overhangs[0].bridge.has_value());
  EXPECT_NE(find(wide, "overhang"), nullptr);
  // 0.2 mm beyond the leg: within half the 0.45 mm line width, a ledge that prints.
  const CheckReport narrow = run(shelf(0.2));
  ASSERT_EQ(narrow.overhangs.size(), 1U);
  ASSERT_TRUE(narrow.overhangs[0].bridge.has_value());
  EXPECT_TRUE(narrow.overhangs[0].bridge->ledge);
  EXPECT_NEAR(narrow.overhangs[0].bridge->span_mm, 0.2, 1e-9);  // reach beyond the leg
  EXPECT_EQ(find(narrow, "overhang"), nullptr);
  const Finding* f = find(narrow, "bridge");
  ASSERT_NE(f, nullptr);
  EXPECT_NE(f->message.find("ledge"), std::string::npos) << f->message;
}

TEST(CheckBridges, RealPartsCeilingsAreBridges) {
  // The Prusa MK3S X-end idler prints without support: its flat ceilings are bridges.
  const auto dir = test::realworld_dir();
  if (!dir) GTEST_SKIP() << "../shared/realworld is not there (a user's clone has none)";
  auto mesh = load_mesh((*dir / "models" / "prusa_mk3s_x-end-idler.stl").string());
  ASSERT_TRUE(mesh.ok()) << mesh.error().describe();
  const CheckReport r = run(*mesh);
  std::size_t bridges = 0;
  for (const auto& o : r.overhangs) {
    if (!o.bridge) continue;
    ++bridges;
    EXPECT_LT(o.bridge->span_mm, 10.0);  // the part's widest ceiling spans 5.9 mm
    EXPECT_LT(o.bridge->sag_mm, 0.1);
  }
  EXPECT_GE(bridges, 10U);
  EXPECT_TRUE(r.printable);
}

TEST(CheckRisks, ThinWall) {
  const CheckReport r = run(make_box_mesh(Vec3(0, 0, 0), Vec3(20, 0.3, 10)));
  ASSERT_TRUE(r.thickness.has_value());
  EXPECT_NEAR(r.thickness->min_thickness_mm, 0.3, 1e-4);
  const Finding* f = find(r, "thin_wall");
  ASSERT_NE(f, nullptr);
  EXPECT_NEAR(*f->value, 0.3, 1e-4);
  EXPECT_NEAR(r.thickness->thin_area_mm2, 2 * 20 * 10, 1e-6);  // the two big sides
  CheckSettings s;
  s.min_thickness_mm = 0.25;
  EXPECT_EQ(find(run(make_box_mesh(Vec3(0, 0, 0), Vec3(20, 0.3, 10)), s), "thin_wall"), nullptr);
}

TEST(CheckRisks, RaysStoppedAtTheLimitFindTheSameThinWalls) {
  // verify stops the inward rays at the limit: the same thin faces, area, box, thinnest
  // wall and findings; only the thinnest wall of a part with no thin wall is not measured.
  const Mesh thin = merged(make_box_mesh(Vec3(0, 0, 0), Vec3(20, 0.3, 10)),
                           make_box_mesh(Vec3(0, 5, 0), Vec3(20, 25, 10)));
  CheckSettings stopped;
  stopped.thickness_beyond_limit = false;
  const CheckReport full = run(thin), cut = run(thin, stopped);
  ASSERT_TRUE(full.thickness.has_value());
  ASSERT_TRUE(cut.thickness.has_value());
  EXPECT_EQ(cut.thickness->thin_faces, full.thickness->thin_faces);
  EXPECT_EQ(cut.thickness->thin_area_mm2, full.thickness->thin_area_mm2);
  EXPECT_EQ(cut.thickness->min_thickness_mm, full.thickness->min_thickness_mm);
  EXPECT_EQ(cut.thickness->min_thickness_at_mm, full.thickness->min_thickness_at_mm);
  EXPECT_EQ(cut.thickness->thin_bbox_mm.min, full.thickness->thin_bbox_mm.min);
  EXPECT_EQ(cut.thickness->thin_bbox_mm.max, full.thickness->thin_bbox_mm.max);
  EXPECT_EQ(cut.thickness->min_gap_mm, full.thickness->min_gap_mm);
  ASSERT_EQ(cut.findings.size(), full.findings.size());
  for (std::size_t i = 0; i < cut.findings.size(); ++i)
    EXPECT_EQ(cut.findings[i].message, full.findings[i].message);
  // A 20 mm cube: nothing thin; its walls (20 mm) are measured only without the stop.
  const CheckReport cube_full = run(test::make_cube_mm(20)),
                    cube_cut = run(test::make_cube_mm(20), stopped);
  EXPECT_NEAR(cube_full.thickness->min_thickness_mm, 20.0, 1e-4);
  EXPECT_TRUE(std::isinf(cube_cut.thickness->min_thickness_mm));
  EXPECT_EQ(cube_cut.thickness->thin_faces, 0U);
  EXPECT_EQ(cube_cut.findings.size(), cube_full.findings.size());
}

TEST(CheckRisks, NarrowGapBetweenFacingWalls) {
  const Mesh m = merged(make_box_mesh(Vec3(0, 0, 0), Vec3(10, 10, 10)),
                        make_box_mesh(Vec3(10.2, 0, 0), Vec3(20, 10, 10)));
  const CheckReport r = run(m);
  const Finding* f = find(r, "narrow_gap");
  ASSERT_NE(f, nullptr);
  EXPECT_NEAR(*f->value, 0.2, 1e-4);
  EXPECT_NEAR(r.thickness->narrow_gap_area_mm2, 200.0, 1e-6);
  // 1 mm apart: wider than a line.
  const Mesh wide = merged(make_box_mesh(Vec3(0, 0, 0), Vec3(10, 10, 10)),
                           make_box_mesh(Vec3(11, 0, 0), Vec3(20, 10, 10)));
  EXPECT_EQ(find(run(wide), "narrow_gap"), nullptr);
}

TEST(CheckRisks, SharedBvhMeasuresWhatItsOwnDoes) {
  // verify hands check the BVH of the mesh as loaded (before placement): the rays are cast
  // in that frame and must measure the same walls and gaps.
  const Mesh m = merged(make_box_mesh(Vec3(50, 60, 5), Vec3(70, 60.3, 15)),
                        make_box_mesh(Vec3(50, 60.5, 5), Vec3(70, 70, 15)));
  auto query = MeshQuery::build(m);
  ASSERT_TRUE(query.ok());
  CheckSettings shared;
  shared.mesh_query = &*query;
  const CheckReport own = run(m);
  const CheckReport with_shared = run(m, shared);
  ASSERT_TRUE(own.thickness.has_value());
  ASSERT_TRUE(with_shared.thickness.has_value());
  EXPECT_NEAR(own.thickness->min_thickness_mm, 0.3, 1e-4);
  EXPECT_NEAR(own.thickness->min_gap_mm, 0.2, 1e-4);
  EXPECT_NEAR(with_shared.thickness->min_thickness_mm, own.thickness->min_thickness_mm, 1e-9);
  EXPECT_NEAR(with_shared.thickness->min_gap_mm, own.thickness->min_gap_mm, 1e-9);
  EXPECT_EQ(with_shared.thickness->thin_faces, own.thickness->thin_faces);
  EXPECT_EQ(with_shared.thickness->narrow_gap_faces, own.thickness->narrow_gap_faces);
  EXPECT_EQ(with_shared.findings.size(), own.findings.size());
}

TEST(CheckRisks, SmallFeature) {
  const Mesh m = merged(test::make_cube_mm(10), make_box_mesh(Vec3(15, 0, 0), Vec3(15.3, 0.3, 3)));
  const CheckReport r = run(m);
  const Finding* f = find(r, "small_feature");
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->count, 1);
}

TEST(CheckRisks, TallSlender) {
  const CheckReport r = run(make_box_mesh(Vec3(0, 0, 0), Vec3(5, 8, 60)));
  const Finding* f = find(r, "tall_slender");
  ASSERT_NE(f, nullptr);
  EXPECT_NEAR(*f->value, 12.0, 1e-9);
  EXPECT_EQ(find(run(make_box_mesh(Vec3(0, 0, 0), Vec3(5, 8, 25))), "tall_slender"), nullptr);
}

TEST(CheckRisks, SmallBedContact) {
  // A flat octahedron (|x|/5 + |y|/5 + |z|/2 <= 1) standing on a vertex touches the bed at
  // one point, and its lower faces lean asin(0.5 / sqrt(0.33)) = 60.5 deg from vertical.
  Mesh m;
  m.vertices_mm = {Vec3(0, 0, -2), Vec3(5, 0, 0),  Vec3(0, 5, 0),
                   Vec3(-5, 0, 0), Vec3(0, -5, 0), Vec3(0, 0, 2)};
  m.triangles = {{0, 2, 1}, {0, 3, 2}, {0, 4, 3}, {0, 1, 4},
                 {5, 1, 2}, {5, 2, 3}, {5, 3, 4}, {5, 4, 1}};
  const CheckReport r = run(m);
  EXPECT_NEAR(r.health.volume_mm3, 4.0 / 3.0 * 5 * 5 * 2, 1e-9);
  EXPECT_NEAR(r.placement.footprint_area_mm2, 0.0, 1e-12);
  EXPECT_NE(find(r, "small_bed_contact"), nullptr);
  ASSERT_EQ(r.overhangs.size(), 1U);  // the four lower faces, joined over their edges
  EXPECT_EQ(r.overhangs[0].faces, 4U);
  EXPECT_NEAR(r.overhangs[0].max_angle_deg, std::asin(0.5 / std::sqrt(0.33)) * 180 / kPi, 1e-6);
}

TEST(CheckRisks, FindingsAreSortedErrorsFirst) {
  Mesh m = make_box_mesh(Vec3(0, 0, 0), Vec3(20, 0.3, 10));
  m.triangles.pop_back();
  const CheckReport r = run(m);
  ASSERT_GE(r.findings.size(), 2U);
  for (std::size_t i = 1; i < r.findings.size(); ++i)
    EXPECT_GE(static_cast<int>(r.findings[i - 1].severity),
              static_cast<int>(r.findings[i].severity));
}

TEST(CheckRepair, FillsHoleAndReportsIt) {
  Mesh m = test::make_cube_mm(10);
  m.triangles.pop_back();
  auto r = repair_mesh(m);
  ASSERT_TRUE(r.ok()) << r.error().describe();
  EXPECT_FALSE(r->before.closed);
  EXPECT_TRUE(r->after.closed);
  EXPECT_NEAR(r->after.volume_mm3, 1000.0, 1e-9);
  const auto has = [&](const std::string& code, std::size_t n) {
    for (const auto& c : r->changes)
      if (c.code == code) return c.count == n;
    return false;
  };
  EXPECT_TRUE(has("filled_holes", 1));
  EXPECT_TRUE(has("added_faces", 1));
}

TEST(CheckRepair, RemovesDuplicatesAndDegeneratesAndOrients) {
  Mesh m = test::make_cube_mm(10);
  m.triangles.push_back(m.triangles[0]);  // duplicate
  m.vertices_mm.emplace_back(5, 0, 0);
  m.triangles.push_back({0, 8, 1});                 // degenerate
  std::swap(m.triangles[5][1], m.triangles[5][2]);  // one face flipped
  auto r = repair_mesh(m);
  ASSERT_TRUE(r.ok());
  std::map<std::string, std::size_t> changes;
  for (const auto& c : r->changes) changes[c.code] = c.count;
  EXPECT_EQ(changes["removed_duplicate_faces"], 1U);
  EXPECT_EQ(changes["removed_degenerate_faces"], 1U);
  EXPECT_EQ(changes["reoriented_faces"], 1U);
  EXPECT_TRUE(r->after.closed);
  EXPECT_EQ(r->after.inconsistent_edges, 0U);
  EXPECT_EQ(r->after.triangles, 12U);
  EXPECT_NEAR(r->after.volume_mm3, 1000.0, 1e-9);
}

TEST(CheckRepair, FlipsInvertedShellAndStitchesSplitSeams) {
  // An inside-out cube whose top face uses its own copies of the corner vertices.
  Mesh m = flipped(test::make_cube_mm(10));
  for (std::uint32_t v = 4; v < 8; ++v) m.vertices_mm.push_back(m.vertices_mm[v]);
  for (std::size_t f = 2; f < 4; ++f)
    for (auto& v : m.triangles[f]) v += 4;  // faces 2, 3: the +z face
  ASSERT_FALSE(analyze_mesh_health(m).closed);
  auto r = repair_mesh(m);
  ASSERT_TRUE(r.ok());
  EXPECT_TRUE(r->after.closed);
  EXPECT_EQ(r->after.inverted_shells, 0U);
  EXPECT_NEAR(r->after.volume_mm3, 1000.0, 1e-9);
  EXPECT_FALSE(r->changes.empty());
}

TEST(CheckJson, SchemaKeys) {
  Mesh m = make_box_mesh(Vec3(0, 0, 0), Vec3(20, 0.3, 10));
  const CheckReport r = run(m);
  CheckSource src;
  src.file = "wall.stl";
  src.printer = "Ender-3";
  const auto doc = nlohmann::json::parse(check_report_to_json(r, src));
  EXPECT_EQ(doc["schema"], "printtwin.check");
  EXPECT_EQ(doc["schema_version"], kCheckJsonVersion);
  EXPECT_EQ(doc["mesh"]["triangles"], 12);
  EXPECT_EQ(doc["mesh"]["closed"], true);
  EXPECT_NEAR(doc["mesh"]["volume_mm3"].get<double>(), 60.0, 1e-4);
  EXPECT_NEAR(doc["mesh"]["bbox_mm"]["max"][1].get<double>(), 0.3, 1e-9);
  ASSERT_FALSE(doc["findings"].empty());
  bool thin = false;
  for (const auto& f : doc["findings"]) {
    for (const char* key : {"severity", "code", "message", "position_mm", "count"})
      EXPECT_TRUE(f.contains(key)) << key;
    if (f["code"] == "thin_wall") {
      thin = true;
      EXPECT_EQ(f["severity"], "warning");
      EXPECT_NEAR(f["value"].get<double>(), 0.3, 1e-4);
      EXPECT_EQ(f["position_mm"].size(), 3U);
    }
  }
  EXPECT_TRUE(thin);
  EXPECT_EQ(doc["printable"], true);
  EXPECT_EQ(check_report_to_json(r, src), check_report_to_json(run(m), src)) << "deterministic";
}

using test::bumpy_sphere;

std::vector<std::array<std::uint32_t, 2>> all_pairs(const Mesh& m) {
  return find_self_intersections(m, m.triangles.size() * m.triangles.size()).first_pairs;
}

TEST(CheckSelfIntersections, GridAndFilterFindExactlyTheExhaustivePairs) {
  // Overlapping bumpy spheres: pairs crossing between shells, none within one.
  Mesh spheres = bumpy_sphere(5, 12, 24, Vec3(0, 0, 0));
  spheres = merged(spheres, bumpy_sphere(4, 10, 20, Vec3(6, 1, 0.5)));
  spheres = merged(spheres, bumpy_sphere(3, 9, 18, Vec3(2, 5, -1)));
  const auto expected = detail::self_intersecting_pairs_exhaustive(spheres);
  EXPECT_GT(expected.size(), 50U);
  EXPECT_EQ(all_pairs(spheres), expected);

  // A soup over a small lattice: many faces share vertices and edges, many lie in one plane
  // (z = 0) or touch exactly, so the filter must hand the undecided ones to CGAL.
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> coord(0, 3), pick(0, 63);
  Mesh soup;
  for (int k = 0; k < 64; ++k)
    soup.vertices_mm.emplace_back(coord(rng), coord(rng), k % 3 == 0 ? 0.0 : 0.5 * coord(rng));
  for (int t = 0; t < 400; ++t)
    soup.triangles.push_back({static_cast<std::uint32_t>(pick(rng)),
                              static_cast<std::uint32_t>(pick(rng)),
                              static_cast<std::uint32_t>(pick(rng))});
  const auto soup_expected = detail::self_intersecting_pairs_exhaustive(soup);
  EXPECT_GT(soup_expected.size(), 100U);
  EXPECT_EQ(all_pairs(soup), soup_expected);
  // Every pair gets a finite location, even nearly coplanar slivers.
  for (const Vec3& p : find_self_intersections(soup, soup_expected.size()).locations_mm)
    EXPECT_TRUE(p.allFinite()) << p.transpose();

  // Tiny faces far apart: the cell grid (cells of ~2 x 0.02 mm over a 100 mm box) would be
  // sparse beyond the counting sort's limit, so the faces are sorted by cell instead; the
  // same pairs either way.
  Mesh sparse = merged(test::make_cube_mm(0.02), test::make_cube_mm(0.02, Vec3(0.01, 0.01, 0.01)));
  sparse = merged(sparse, test::make_cube_mm(0.02, Vec3(100, 100, 100)));
  const auto sparse_expected = detail::self_intersecting_pairs_exhaustive(sparse);
  EXPECT_GT(sparse_expected.size(), 0U);
  EXPECT_EQ(all_pairs(sparse), sparse_expected);

  // A closed bumpy sphere alone: no pair at all.
  EXPECT_EQ(find_self_intersections(bumpy_sphere(10, 60, 120, Vec3(1, 2, 3))).pairs, 0U);
}

TEST(CheckThickness, BoundedInwardRaysGiveTheUnboundedResult) {
  // Two thick bumpy spheres (no wall under 5 mm: only the thinnest is reported), then with
  // a 0.3 mm plate beside them (thin faces): the inward rays stop past the thinnest sampled
  // wall, the unbounded ones (PRINTTWIN_PLAIN=check_ray_bound) do not; the figures agree.
  Mesh plate = test::make_cube_mm(10, Vec3(20, 0, 0));
  for (auto& v : plate.vertices_mm) v.z() = v.z() > 5 ? 0.3 : 0.0;
  const Mesh spheres =
      merged(bumpy_sphere(5, 30, 60, Vec3(0, 0, 0)), bumpy_sphere(3, 20, 40, Vec3(0, 12, 0)));
  for (const Mesh& m : {spheres, merged(spheres, plate)}) {
    ASSERT_EQ(::setenv("PRINTTWIN_PLAIN", "check_ray_bound", 1), 0);
    const auto plain = measure_thickness(m, 0.4, 0.45);
    ::unsetenv("PRINTTWIN_PLAIN");
    const auto bounded = measure_thickness(m, 0.4, 0.45);
    ASSERT_TRUE(plain && bounded);
    EXPECT_TRUE(std::isfinite(plain->min_thickness_mm));
    EXPECT_EQ(bounded->min_thickness_mm, plain->min_thickness_mm);
    EXPECT_EQ(bounded->min_thickness_at_mm, plain->min_thickness_at_mm);
    EXPECT_EQ(bounded->thin_faces, plain->thin_faces);
    EXPECT_EQ(bounded->thin_area_mm2, plain->thin_area_mm2);
    EXPECT_EQ(bounded->min_gap_mm, plain->min_gap_mm);
    EXPECT_EQ(bounded->narrow_gap_faces, plain->narrow_gap_faces);
  }
}

/// find_self_intersections with the mesh's health: the pairs around vertices whose fans are
/// certified are settled without a test.
std::vector<std::array<std::uint32_t, 2>> all_pairs_with_health(const Mesh& m) {
  const MeshHealth h = analyze_mesh_health(m);
  return find_self_intersections(m, m.triangles.size() * m.triangles.size(), &h).first_pairs;
}

TEST(CheckSelfIntersections, CertifiedFansGiveTheExhaustivePairs) {
  // Closed, manifold shells crossing each other: the fans are certified, the pairs between
  // the shells are still found.
  Mesh spheres = bumpy_sphere(5, 12, 24, Vec3(0, 0, 0));
  spheres = merged(spheres, bumpy_sphere(4, 10, 20, Vec3(6, 1, 0.5)));
  ASSERT_TRUE(analyze_mesh_health(spheres).closed);
  const auto expected = detail::self_intersecting_pairs_exhaustive(spheres);
  EXPECT_GT(expected.size(), 50U);
  EXPECT_EQ(all_pairs_with_health(spheres), expected);

  // Folds inside one closed shell: a vertex pushed through the far side of the sphere (its
  // fan crosses other faces), one pulled across its neighbours (its own faces overlap
  // each other), one pushed exactly into the plane of a neighbour.
  for (const Vec3& moved : {Vec3(0, 0, -7.0), Vec3(0.0, 1.5, 4.2), Vec3(0.3, 0.2, 4.98)}) {
    Mesh folded = bumpy_sphere(5, 12, 24, Vec3(0, 0, 0));
    folded.vertices_mm[0] = moved;  // the north pole
    const auto fold_expected = detail::self_intersecting_pairs_exhaustive(folded);
    EXPECT_EQ(all_pairs_with_health(folded), fold_expected) << moved.transpose();
  }
  Mesh pulled = bumpy_sphere(5, 12, 24, Vec3(0, 0, 0));
  pulled.vertices_mm[40] =
      pulled.vertices_mm[41] + 0.8 * (pulled.vertices_mm[41] - pulled.vertices_mm[40]);
  const auto pulled_expected = detail::self_intersecting_pairs_exhaustive(pulled);
  EXPECT_GT(pulled_expected.size(), 0U);
  EXPECT_EQ(all_pairs_with_health(pulled), pulled_expected);
}

/// A closed torus (genus 1) about the z axis: never star-shaped about a point.
Mesh torus(double big, double small, int nu, int nv) {
  Mesh m;
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const double u = 2 * kPi * i / nu, w = 2 * kPi * j / nv;
      const double r = big + small * std::cos(w);
      m.vertices_mm.emplace_back(r * std::cos(u), r * std::sin(u), small * std::sin(w));
    }
  const auto id = [&](int i, int j) { return static_cast<std::uint32_t>((i % nu) * nv + j % nv); };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      m.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      m.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return m;
}

TEST(CheckSelfIntersections, StarShapedSurfacesNeedNoPairTest) {
  // Star-shaped about the mean of their vertices and wound once: a cube, a bumpy sphere.
  EXPECT_TRUE(detail::star_shaped_surface(test::make_cube_mm(20)));
  const Mesh sphere = bumpy_sphere(5, 12, 24, Vec3(1, 2, 3));
  EXPECT_TRUE(detail::star_shaped_surface(sphere));
  EXPECT_TRUE(detail::self_intersecting_pairs_exhaustive(sphere).empty());
  EXPECT_TRUE(all_pairs_with_health(sphere).empty());
  // Not certified, so every pair is tested (and the pairs found are the exhaustive ones): a
  // torus (faces turned away from any point), two overlapping spheres (the point wrapped
  // twice), a sphere holding a smaller one as its cavity (the inner faces turned away), a
  // sphere with a vertex pushed through its far side (a fold).
  const Mesh ring = torus(10, 3, 24, 12);
  ASSERT_TRUE(analyze_mesh_health(ring).closed);
  EXPECT_FALSE(detail::star_shaped_surface(ring));
  EXPECT_TRUE(all_pairs_with_health(ring).empty());
  const Mesh twice = merged(sphere, bumpy_sphere(4, 10, 20, Vec3(2, 2, 3)));
  EXPECT_FALSE(detail::star_shaped_surface(twice));
  const auto twice_expected = detail::self_intersecting_pairs_exhaustive(twice);
  EXPECT_GT(twice_expected.size(), 10U);
  EXPECT_EQ(all_pairs_with_health(twice), twice_expected);
  Mesh cavity = bumpy_sphere(2, 8, 16, Vec3(1, 2, 3));
  for (auto& t : cavity.triangles) std::swap(t[1], t[2]);
  EXPECT_FALSE(detail::star_shaped_surface(merged(sphere, cavity)));
  Mesh folded = sphere;
  folded.vertices_mm[0] = Vec3(1, 2, -4);  // the north pole pushed out through the south
  EXPECT_FALSE(detail::star_shaped_surface(folded));
  const auto fold_expected = detail::self_intersecting_pairs_exhaustive(folded);
  EXPECT_GT(fold_expected.size(), 0U);
  EXPECT_EQ(all_pairs_with_health(folded), fold_expected);
  // The plain path (PRINTTWIN_PLAIN=check_star) tests the pairs and finds none either.
  ASSERT_EQ(::setenv("PRINTTWIN_PLAIN", "check_star", 1), 0);
  EXPECT_TRUE(all_pairs_with_health(sphere).empty());
  ::unsetenv("PRINTTWIN_PLAIN");
}

}  // namespace
}  // namespace printtwin

namespace printtwin {
namespace {

TEST(CheckUnits, GuessedFromTheSizeOfTheLargestShell) {
  auto g = guess_mesh_units(test::make_cube_mm(0.02));
  ASSERT_TRUE(g.has_value());
  EXPECT_EQ(g->unit, "m");
  EXPECT_EQ(g->mm_per_unit, 1000.0);
  g = guess_mesh_units(test::make_cube_mm(0.75));
  ASSERT_TRUE(g.has_value());
  EXPECT_EQ(g->unit, "in");
  EXPECT_FALSE(guess_mesh_units(test::make_cube_mm(20000)).has_value());  // fit advice instead
  EXPECT_FALSE(guess_mesh_units(test::make_cube_mm(20)).has_value());
  EXPECT_FALSE(guess_mesh_units(test::make_cube_mm(495)).has_value());
  // A stray facet kilometres away does not make a 20 mm part look like microns.
  Mesh stray = test::make_cube_mm(20);
  const auto b = static_cast<std::uint32_t>(stray.vertices_mm.size());
  stray.vertices_mm.insert(stray.vertices_mm.end(),
                           {Vec3(1e6, 0, 0), Vec3(1e6 + 1, 0, 0), Vec3(1e6, 1, 0)});
  stray.triangles.push_back({b, b + 1, b + 2});
  EXPECT_FALSE(guess_mesh_units(stray).has_value());
  const Finding f =
      units_guessed_finding(*guess_mesh_units(test::make_cube_mm(0.02)), Vec3(20, 20, 20));
  EXPECT_EQ(f.code, "units_guessed");
  EXPECT_NE(f.message.find("read as metres"), std::string::npos) << f.message;
  EXPECT_NE(f.message.find("20.00 x 20.00 x 20.00 mm"), std::string::npos) << f.message;
}

TEST(CheckPlacement, FitAdviceRotatesOrScales) {
  const PrinterProfile p = ender3_marlin2();  // 235 x 235 x 250 mm
  FitAdvice a = advise_fit(Vec3(240, 100, 50), p);
  EXPECT_EQ(a.scale, 1.0);
  EXPECT_EQ(a.rotation, "rotated 90 deg about Y");
  EXPECT_TRUE(a.size_mm.isApprox(Vec3(50, 100, 240)));
  a = advise_fit(Vec3(238.69, 362.53, 494.61), p);  // the 495 mm scan
  EXPECT_NEAR(a.scale, 0.505, 1e-9);
  EXPECT_LE(a.size_mm.x(), 235.0);
  EXPECT_LE(a.size_mm.y(), 235.0);
  EXPECT_LE(a.size_mm.z(), 250.0);
  // In the report: does_not_fit says how it would fit.
  const CheckReport r = run(make_box_mesh(Vec3(0, 0, 0), Vec3(240, 100, 50)));
  const Finding* f = find(r, "does_not_fit");
  ASSERT_NE(f, nullptr);
  EXPECT_NE(f->message.find("it fits rotated 90 deg about Y (50.00 x 100.00 x 240.00 mm)"),
            std::string::npos)
      << f->message;
}

TEST(CheckOrientation, APlateStandingOnEdgeIsLaidFlat) {
  // 40 x 2 x 30 mm plate standing on its 40 x 2 edge: no overhang, 80 mm2 on the bed.
  const Mesh plate = make_box_mesh(Vec3(0, 0, 0), Vec3(40, 2, 30));
  const OrientationAdvice a = advise_orientation(plate);
  EXPECT_NEAR(a.current.contact_mm2, 80.0, 1e-9);
  EXPECT_NEAR(a.best.contact_mm2, 1200.0, 1e-9);
  EXPECT_NEAR(a.best.overhang_mm2, 0.0, 1e-9);
  EXPECT_NEAR(std::abs(a.best.down.y()), 1.0, 1e-12);
  EXPECT_NEAR(a.best.height_mm, 2.0, 1e-9);
  EXPECT_TRUE(a.better);
  // Rotating as advised lays it flat.
  const Box3 b = bounding_box(rotated_mesh(plate, a.best.rotation_xyz_deg));
  EXPECT_NEAR(b.size().z(), 2.0, 1e-9);
  const CheckReport report = run(plate);
  const Finding* f = find(report, "orientation");
  ASSERT_NE(f, nullptr);
  EXPECT_NE(f->message.find("1200.0 mm2 on the bed"), std::string::npos) << f->message;
  const auto j = nlohmann::json::parse(check_report_to_json(run(plate), CheckSource{}));
  EXPECT_EQ(j["orientation"]["better"], true);
  EXPECT_NEAR(j["orientation"]["best"]["contact_mm2"].get<double>(), 1200.0, 1e-6);
}

TEST(CheckOrientation, AnOverhangingArmGoesOnTheBedFace) {
  // A "7": a 5 mm post with a 25 mm arm on top; its underside (20 x 10 mm2) needs support
  // as modelled. Laid on its back (the post's 30 x 10 mm outer face) it needs none and rests
  // on more than on its 7-shaped side (250 mm2).
  const Mesh seven =
      prism({Vec2(0, 0), Vec2(5, 0), Vec2(5, 25), Vec2(25, 25), Vec2(25, 30), Vec2(0, 30)}, 10);
  const OrientationAdvice a = advise_orientation(seven);
  EXPECT_NEAR(a.current.overhang_mm2, 200.0, 1e-6);
  EXPECT_NEAR(a.best.overhang_mm2, 0.0, 1e-9);
  EXPECT_NEAR(a.best.contact_mm2, 300.0, 1e-6);
  EXPECT_NEAR(a.best.down.x(), -1.0, 1e-12);
  EXPECT_TRUE(a.better);
  // A cube is best as it stands: no advice.
  EXPECT_FALSE(advise_orientation(test::make_cube_mm(10)).better);
  EXPECT_EQ(find(run(test::make_cube_mm(10)), "orientation"), nullptr);
}

TEST(CheckHealth, StrayFacetFarAwayIsAnError) {
  // A 20 mm cube and one facet 5 m away.
  Mesh m = test::make_cube_mm(20);
  const auto b = static_cast<std::uint32_t>(m.vertices_mm.size());
  m.vertices_mm.insert(m.vertices_mm.end(),
                       {Vec3(5000, 0, 0), Vec3(5010, 0, 0), Vec3(5000, 10, 5)});
  m.triangles.push_back({b, b + 1, b + 2});
  // 1 face against 12 is more than 1 %: a second body, not a stray facet.
  EXPECT_EQ(find(run(m), "stray_shell"), nullptr);
  std::vector<Vec2> circle;
  for (int i = 0; i < 60; ++i)
    circle.emplace_back(10 + 10 * std::cos(i * kPi / 30), 10 + 10 * std::sin(i * kPi / 30));
  Mesh big = prism(circle, 20);  // 236 faces
  big = merged(big, Mesh{{Vec3(5000, 0, 0), Vec3(5010, 0, 0), Vec3(5000, 10, 5)}, {{0, 1, 2}}});
  const CheckReport r = run(big);
  const Finding* f = find(r, "stray_shell");
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->severity, Severity::error);
  EXPECT_NE(f->message.find("instead of 20.0 x 20.0 x 20.0 mm"), std::string::npos) << f->message;
  const Finding* fit = find(r, "does_not_fit");
  ASSERT_NE(fit, nullptr);
  EXPECT_NE(fit->message.find("without the stray shells it fits"), std::string::npos)
      << fit->message;
  // Two bodies side by side are no stray shells.
  EXPECT_EQ(find(run(merged(test::make_cube_mm(20), test::make_cube_mm(1, Vec3(25, 0, 0)))),
                 "stray_shell"),
            nullptr);
}

}  // namespace
}  // namespace printtwin
