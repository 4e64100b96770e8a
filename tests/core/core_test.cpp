#include <gtest/gtest.h>

#include <utility>
#include <vector>

#include "core/zeroed_array.hpp"
#include "printtwin/io.hpp"
#include "printtwin/machine.hpp"
#include "printtwin/mesh.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

TEST(Io, Sha256KnownVectors) {
  EXPECT_EQ(sha256_hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(sha256_hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

TEST(Io, NumbersAreLocaleIndependent) {
  EXPECT_EQ(format_number(0.1), "0.1");
  EXPECT_EQ(format_fixed(-0.0001, 3), "0.000");
  EXPECT_EQ(format_fixed(2.5, 2), "2.50");
}

TEST(Io, AtomicWriteAndReadBack) {
  const auto dir = test::temp_dir("io");
  ASSERT_TRUE(write_file_atomic(dir / "a" / "b.txt", "hello").ok());
  auto text = read_file(dir / "a" / "b.txt");
  ASSERT_TRUE(text.ok());
  EXPECT_EQ(*text, "hello");
  auto missing = read_file(dir / "nope.txt");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().describe().find("nope.txt"), std::string::npos);
  auto directory = read_file(dir);
  ASSERT_FALSE(directory.ok());
  EXPECT_NE(directory.error().message.find("directory"), std::string::npos);
}

TEST(ZeroedArray, StartsZeroedAndKeepsWrites) {
  ZeroedArray<std::uint32_t> a(std::size_t{3} << 20);  // 12 MiB: a mapping
  EXPECT_EQ(a[5000], 0U);
  a[5001] = 7;
  EXPECT_EQ(a[5001], 7U);
  EXPECT_EQ(a[a.size() - 1], 0U);
  const ZeroedArray<std::uint32_t> copy = a;
  EXPECT_EQ(copy[5001], 7U);
  ZeroedArray<std::uint32_t> small(16);  // calloc'd
  EXPECT_EQ(small[3], 0U);
  small[3] = 2;
  ZeroedArray<std::uint32_t> moved = std::move(small);
  EXPECT_EQ(moved[3], 2U);
  EXPECT_EQ(moved.size(), 16U);
}

TEST(Mesh, CubeMeasures) {
  const Mesh cube = test::make_cube_mm(10.0, Vec3(1, 2, 3));
  EXPECT_NEAR(signed_volume_mm3(cube), 1000.0, 1e-9);
  EXPECT_NEAR(surface_area_mm2(cube), 600.0, 1e-9);
  const Mesh placed = place_on_bed(cube, 117.5, 117.5);
  const Box3 box = bounding_box(placed);
  EXPECT_NEAR(box.min.z(), 0.0, 1e-12);
  EXPECT_NEAR(box.center().x(), 117.5, 1e-12);
  EXPECT_NEAR(box.center().y(), 117.5, 1e-12);
}

TEST(Profile, BuiltinsAndOverrides) {
  const PrinterProfile p = ender3_marlin2();
  EXPECT_EQ(p.bed_max_x_mm, 235);
  EXPECT_EQ(p.max_feedrate_mm_s[2], 5);
  EXPECT_EQ(p.junction_deviation_mm, 0.08);
  auto over = parse_printer_profile(R"({"base":"ender3-marlin1","max_z_mm":300})", "x.json");
  ASSERT_TRUE(over.ok()) << over.error().describe();
  EXPECT_EQ(over->max_z_mm, 300);
  EXPECT_EQ(over->junction, JunctionModel::classic_jerk);
  auto bad = parse_printer_profile(R"({"max_feedrate_mm_s":[1,2,3]})", "bad.json");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().describe().find("max_feedrate_mm_s"), std::string::npos);
  EXPECT_NE(bad.error().describe().find("bad.json"), std::string::npos);
  auto unknown = parse_printer_profile(R"({"bed_size":3})", "u.json");
  ASSERT_FALSE(unknown.ok());
  EXPECT_NE(unknown.error().message.find("bed_size"), std::string::npos);
  // Round trip: every key written can be read back.
  auto again = parse_printer_profile(printer_profile_to_json(ender3_klipper()), "rt.json");
  ASSERT_TRUE(again.ok()) << again.error().describe();
  EXPECT_EQ(again->max_accel_mm_s2, ender3_klipper().max_accel_mm_s2);
}

}  // namespace
}  // namespace printtwin
