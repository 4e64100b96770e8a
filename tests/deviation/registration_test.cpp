// Registration that survives what slicers do to a part: parts rotated about Z, laid on a
// side, in other units, several objects on one bed, parts in several islands, and a G-code
// of another part. The G-code comes from printtwin's own slicer run on the transformed mesh.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <random>
#include <sstream>

#include "deviation/registration_internal.hpp"
#include "printtwin/deviation.hpp"
#include "printtwin/machine.hpp"
#include "printtwin/mesh_query.hpp"
#include "printtwin/planner.hpp"
#include "printtwin/simulate.hpp"
#include "printtwin/slice.hpp"

namespace printtwin {
namespace {

/// A closed prism: the polygon (counter-clockwise, star-shaped from its first vertex)
/// extruded from z0 to z1.
Mesh make_prism(const std::vector<Vec2>& poly, double z0, double z1) {
  Mesh m;
  const auto n = static_cast<std::uint32_t>(poly.size());
  for (const Vec2& p : poly) m.vertices_mm.emplace_back(p.x(), p.y(), z0);
  for (const Vec2& p : poly) m.vertices_mm.emplace_back(p.x(), p.y(), z1);
  for (std::uint32_t i = 1; i + 1 < n; ++i) {
    m.triangles.push_back({0, i + 1, i});          // bottom, facing down
    m.triangles.push_back({n, n + i, n + i + 1});  // top, facing up
  }
  for (std::uint32_t i = 0; i < n; ++i) {
    const std::uint32_t j = (i + 1) % n;
    m.triangles.push_back({i, j, n + j});
    m.triangles.push_back({i, n + j, n + i});
  }
  return m;
}

/// An L-shaped bracket 30 x 20 x 6 mm with no symmetry, origin off its centre.
Mesh bracket() { return make_prism({{0, 0}, {30, 0}, {30, 8}, {8, 8}, {8, 20}, {0, 20}}, 0, 6); }

Mesh append(Mesh a, const Mesh& b) {
  const auto base = static_cast<std::uint32_t>(a.vertices_mm.size());
  a.vertices_mm.insert(a.vertices_mm.end(), b.vertices_mm.begin(), b.vertices_mm.end());
  for (const auto& t : b.triangles) a.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
  return a;
}

class Collect final : public MoveSink {
 public:
  std::vector<Move> moves;
  void on_move(const Move& m) override { moves.push_back(m); }
};

struct Printed {
  std::vector<Move> moves;
  std::map<int, std::string> names;
  Vec3 slicer_offset = Vec3::Zero();  ///< what printtwin's slicer added to the mesh it was given
};

/// Slices `mesh` (as the slicer's user placed it) with printtwin's slicer and runs the G-code.
Printed slice_and_print(const Mesh& mesh) {
  const PrinterProfile printer = ender3_marlin2();
  auto sliced = slice_mesh(mesh, printer, SliceSettings{});
  EXPECT_TRUE(sliced.ok());
  Printed p;
  if (!sliced.ok()) return p;
  p.slicer_offset = sliced->stats.placement_offset_mm;
  std::istringstream in(sliced->gcode);
  Collect sink;
  auto sim = simulate_gcode(in, printer, SimulateOptions{}, &sink);
  EXPECT_TRUE(sim.ok());
  if (sim.ok()) p.names = sim->object_names;
  p.moves = std::move(sink.moves);
  return p;
}

/// Largest distance between where the registration puts each mesh vertex and where it is.
double worst_vertex_error(const Mesh& mesh, const RigidTransform& found, const Mesh& truth) {
  double worst = 0;
  for (std::size_t i = 0; i < mesh.vertices_mm.size(); ++i)
    worst = std::max(worst, (found.apply(mesh.vertices_mm[i]) - truth.vertices_mm[i]).norm());
  return worst;
}

struct Registered {
  Registration reg;
  double worst_mm = 0;
};

/// Registers `design` against the print of `as_sliced` (the design moved by the user) and
/// measures the vertex error against where the slicer put it.
Registered register_against(const Mesh& design, const Mesh& as_sliced,
                            RegistrationOptions options = {}) {
  const Printed printed = slice_and_print(as_sliced);
  const PartExtent part = find_part_extent(printed.moves, printed.names);
  auto query = MeshQuery::build(design);
  EXPECT_TRUE(query.ok());
  auto reg = register_mesh(design, *query, part, options);
  EXPECT_TRUE(reg.ok()) << (reg.ok() ? "" : reg.error().message);
  Registered r;
  if (!reg.ok()) return r;
  r.reg = *reg;
  r.worst_mm =
      worst_vertex_error(design, reg->transform, translated(as_sliced, printed.slicer_offset));
  return r;
}

Mesh rotate(const Mesh& m, const Vec3& xyz_deg) {
  RigidTransform t;
  t.rotation = rotation_from_xyz_deg(xyz_deg);
  return transformed(m, t);
}

TEST(Registration, HullWithoutItsInnerPointsIsTheSameHull) {
  // The footprint hull drops the points inside the octagon of extreme points before its
  // sort: the same hull as the plain path, on a disc, a square with points on its sides and
  // a thin sliver (collinear-ish points).
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<std::vector<Vec2>> clouds(3);
  for (int i = 0; i < 3000; ++i) {
    const double a = 2 * M_PI * u(rng), r = std::sqrt(std::abs(u(rng)));
    clouds[0].emplace_back(50 + 18 * r * std::cos(a), 40 + 18 * r * std::sin(a));
    clouds[1].emplace_back(std::round(20 * u(rng)) / 2, std::round(20 * u(rng)) / 2);
    clouds[2].emplace_back(100 * u(rng), 1e-7 * u(rng));
  }
  for (const auto& cloud : clouds) {
    const std::vector<Vec2> fast = detail::convex_hull(cloud);
    ASSERT_EQ(::setenv("PRINTTWIN_PLAIN", "hull_filter", 1), 0);
    const std::vector<Vec2> plain = detail::convex_hull(cloud);
    ::unsetenv("PRINTTWIN_PLAIN");
    EXPECT_GE(plain.size(), 3U);
    EXPECT_EQ(fast, plain);
  }
}

TEST(Registration, EulerAnglesRoundTrip) {
  for (const Vec3& a : {Vec3(0, 0, 30), Vec3(90, 0, 0), Vec3(10, -20, 150), Vec3(-90, 45, -135)}) {
    const Vec3 back = xyz_deg_of(rotation_from_xyz_deg(a));
    EXPECT_TRUE(rotation_from_xyz_deg(back).isApprox(rotation_from_xyz_deg(a), 1e-12))
        << a.transpose();
  }
  EXPECT_NEAR(xyz_deg_of(rotation_from_xyz_deg(Vec3(0, 0, 30))).z(), 30, 1e-9);
}

TEST(Registration, UnrotatedPartKeepsTheSlicersCentringExactly) {
  const Mesh design = bracket();
  const Registered r = register_against(design, design);
  EXPECT_TRUE(r.reg.transform.translation_only());
  EXPECT_EQ(r.reg.method, "auto (tags, slicer centring)");
  EXPECT_LT(r.worst_mm, 0.15);
  EXPECT_TRUE(r.reg.matches) << r.reg.mismatch;
  EXPECT_LT(r.reg.residual_rms_mm, 0.4);
  EXPECT_GT(r.reg.coverage_pct, 95);
}

// A cube fits every quarter turn and flip equally well: printed as designed, it is reported
// unrotated, not as a turn the slicer never made.
TEST(Registration, SymmetricPartPrintedAsDesignedIsNotReportedTurned) {
  const Mesh design = make_prism({{0, 0}, {12, 0}, {12, 12}, {0, 12}}, 0, 12);
  const Registered r = register_against(design, design);
  EXPECT_TRUE(r.reg.matches) << r.reg.mismatch;
  EXPECT_TRUE(r.reg.transform.translation_only());
  EXPECT_LT(r.worst_mm, 0.15);
}

TEST(Registration, FindsAThirtyDegreeTurnAboutZ) {
  const Mesh design = bracket();
  const Registered r = register_against(design, rotate(design, Vec3(0, 0, 30)));
  EXPECT_TRUE(r.reg.matches) << r.reg.mismatch;
  EXPECT_NEAR(xyz_deg_of(r.reg.transform.rotation).z(), 30, 0.5);
  EXPECT_NEAR(r.reg.transform.scale, 1.0, 0);
  EXPECT_LT(r.worst_mm, 0.3);
  EXPECT_LT(r.reg.residual_rms_mm, 0.4);
  // A handful of poses, not a sweep of every angle (the speed itself is benchmarked, not
  // timed here: sanitizer builds on a loaded machine run it many times slower).
  EXPECT_LE(r.reg.candidates, 24) << r.reg.candidates << " poses";
}

TEST(Registration, FindsAPartLaidOnItsSide) {
  // The bracket stood up on its 30 x 6 face (rotated 90 degrees about X), then turned 90 about Z.
  const Mesh design = bracket();
  const Registered r = register_against(design, rotate(design, Vec3(90, 0, 90)));
  EXPECT_TRUE(r.reg.matches) << r.reg.mismatch;
  EXPECT_TRUE(r.reg.transform.rotation.isApprox(rotation_from_xyz_deg(Vec3(90, 0, 90)), 1e-6))
      << r.reg.transform.rotation;
  EXPECT_LT(r.worst_mm, 0.3);
}

TEST(Registration, FindsInchUnits) {
  // The design file is in inches; the slicer was told millimetres after scaling by 25.4.
  const Mesh mm = bracket();
  RigidTransform to_inch;
  to_inch.scale = 1 / 25.4;
  const Mesh inches = transformed(mm, to_inch);
  const Printed printed = slice_and_print(mm);
  const PartExtent part = find_part_extent(printed.moves, printed.names);
  auto query = MeshQuery::build(inches);
  ASSERT_TRUE(query.ok());
  auto reg = register_mesh(inches, *query, part);
  ASSERT_TRUE(reg.ok());
  EXPECT_DOUBLE_EQ(reg->transform.scale, 25.4);
  EXPECT_TRUE(reg->matches) << reg->mismatch;
  EXPECT_LT(worst_vertex_error(inches, reg->transform, translated(mm, printed.slicer_offset)),
            0.15);
  // Given the units, the search tries no other scale and finds the same.
  RegistrationOptions given;
  given.scale = 25.4;
  auto again = register_mesh(inches, *query, part, given);
  ASSERT_TRUE(again.ok());
  EXPECT_TRUE(again->transform.translation_mm.isApprox(reg->transform.translation_mm, 1e-9));
}

TEST(Registration, PartInFourIslandsIsPlacedByAllOfThem) {
  // Four bridges side by side, each its own island on the bed, of different lengths: the
  // largest alone is not the part (its centre is 15 mm from the part's).
  Mesh design;
  const double lengths[4] = {40, 25, 15, 10};
  for (int i = 0; i < 4; ++i) {
    const double y = 8.0 * i;
    design = append(design,
                    make_prism({{0, y}, {lengths[i], y}, {lengths[i], y + 5}, {0, y + 5}}, 0, 4));
  }
  const Registered r = register_against(design, design);
  EXPECT_TRUE(r.reg.matches) << r.reg.mismatch;
  EXPECT_LT(r.worst_mm, 0.15);
  EXPECT_GT(r.reg.coverage_pct, 95);
}

/// Two objects on one bed, as a G-code with object labels: the bracket at x = 60 and a
/// 12 mm cube at x = 150, both from printtwin's slicer, labelled 0 and 1.
struct Bed {
  std::vector<Move> moves;
  std::map<int, std::string> names{{0, "bracket.stl"}, {1, "cube.stl"}};
  Vec3 bracket_offset, cube_offset;
};

Bed two_objects() {
  Bed bed;
  const Printed a = slice_and_print(bracket());
  const Printed b = slice_and_print(make_prism({{0, 0}, {12, 0}, {12, 12}, {0, 12}}, 0, 12));
  const auto add = [&](const Printed& p, int id, const Vec3& shift) {
    for (Move m : p.moves) {
      m.start_mm += shift;
      m.end_mm += shift;
      m.object_id = is_auxiliary_feature(m.feature) ? -1 : id;
      bed.moves.push_back(m);
    }
  };
  add(a, 0, Vec3(-50, 0, 0));
  add(b, 1, Vec3(40, 0, 0));
  bed.bracket_offset = a.slicer_offset + Vec3(-50, 0, 0);
  bed.cube_offset = b.slicer_offset + Vec3(40, 0, 0);
  return bed;
}

TEST(Registration, MatchesTheObjectThatFitsOnABedOfTwo) {
  const Bed bed = two_objects();
  const PartExtent part = find_part_extent(bed.moves, bed.names);
  EXPECT_EQ(part.method, "objects");
  ASSERT_EQ(part.objects.size(), 2U);
  const Mesh design = bracket();
  auto query = MeshQuery::build(design);
  ASSERT_TRUE(query.ok());
  auto reg = register_mesh(design, *query, part);
  ASSERT_TRUE(reg.ok());
  EXPECT_EQ(reg->object, "bracket.stl");
  EXPECT_EQ(reg->object_id, 0);
  EXPECT_TRUE(reg->matches) << reg->mismatch;
  EXPECT_LT(worst_vertex_error(design, reg->transform, translated(design, bed.bracket_offset)),
            0.15);

  // Told to use the cube, the bracket does not fit it: a mismatch with the figures.
  RegistrationOptions cube;
  cube.object = "cube.stl";
  auto forced = register_mesh(design, *query, part, cube);
  ASSERT_TRUE(forced.ok());
  EXPECT_EQ(forced->object, "cube.stl");
  EXPECT_FALSE(forced->matches);
  EXPECT_NE(forced->mismatch.find("does not appear to be this part"), std::string::npos)
      << forced->mismatch;
  EXPECT_NE(forced->mismatch.find("mm"), std::string::npos);
  // By id too.
  cube.object = "1";
  auto by_id = register_mesh(design, *query, part, cube);
  ASSERT_TRUE(by_id.ok());
  EXPECT_EQ(by_id->object, "cube.stl");

  RegistrationOptions missing;
  missing.object = "lid.stl";
  auto none = register_mesh(design, *query, part, missing);
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.error().message.find("'bracket.stl', 'cube.stl'"), std::string::npos)
      << none.error().message;
}

/// The registration of `design` against a printed G-code (search, default options).
Result<Registration> register_on(const Mesh& design, const Printed& printed) {
  auto query = MeshQuery::build(design);
  if (!query) return query.error();
  return register_mesh(design, *query, find_part_extent(printed.moves, printed.names));
}

TEST(Registration, SaysWhenTheGcodeIsAnotherPart) {
  // The G-code of a 20 mm cube; the mesh is the bracket.
  const Printed cube = slice_and_print(make_prism({{0, 0}, {20, 0}, {20, 20}, {0, 20}}, 0, 20));
  auto reg = register_on(bracket(), cube);
  ASSERT_TRUE(reg.ok());
  EXPECT_FALSE(reg->matches);
  EXPECT_NE(reg->mismatch.find("printed 19."), std::string::npos) << reg->mismatch;
  // A cube of nearly the same size as the print but shorter also fails, on its height.
  auto flat = register_on(make_prism({{0, 0}, {20, 0}, {20, 20}, {0, 20}}, 0, 12), cube);
  ASSERT_TRUE(flat.ok());
  EXPECT_FALSE(flat->matches);
}

TEST(Registration, SaysWhenAnotherPartHasTheSameSize) {
  // The G-code of a full 30 x 20 x 6 block; the mesh is the L bracket with the same box: the
  // sizes fit, but the block's walls across the L's notch lie up to 12 mm from the mesh.
  const Printed block = slice_and_print(make_prism({{0, 0}, {30, 0}, {30, 20}, {0, 20}}, 0, 6));
  auto reg = register_on(bracket(), block);
  ASSERT_TRUE(reg.ok());
  EXPECT_FALSE(reg->matches);
  EXPECT_GT(reg->residual_rms_mm, 1.0);
  EXPECT_NE(reg->mismatch.find("walls lie"), std::string::npos) << reg->mismatch;
}

TEST(Registration, IsDeterministic) {
  const Mesh design = bracket();
  const Printed printed = slice_and_print(rotate(design, Vec3(0, 0, 30)));
  auto a = register_on(design, printed);
  auto b = register_on(design, printed);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->transform.rotation, b->transform.rotation);
  EXPECT_EQ(a->transform.translation_mm, b->transform.translation_mm);
  EXPECT_EQ(a->residual_rms_mm, b->residual_rms_mm);
}

TEST(Registration, GivenPoseIsMeasuredNotSearched) {
  const Mesh design = bracket();
  const Printed printed = slice_and_print(design);
  const PartExtent part = find_part_extent(printed.moves, printed.names);
  auto query = MeshQuery::build(design);
  ASSERT_TRUE(query.ok());
  RigidTransform right;
  right.translation_mm = printed.slicer_offset;
  auto good = evaluate_registration(design, *query, part, right);
  ASSERT_TRUE(good.ok());
  EXPECT_EQ(good->method, "--place");
  EXPECT_TRUE(good->matches) << good->mismatch;
  RigidTransform wrong = right;
  wrong.translation_mm += Vec3(7, 0, 0);
  auto bad = evaluate_registration(design, *query, part, wrong);
  ASSERT_TRUE(bad.ok());
  EXPECT_FALSE(bad->matches);
  EXPECT_GT(bad->residual_rms_mm, 1.0);
}

}  // namespace
}  // namespace printtwin
