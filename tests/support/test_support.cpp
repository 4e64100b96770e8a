#include "support/test_support.hpp"

#include "printtwin/verify.hpp"

#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>
#include <zlib.h>
#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <vector>

namespace printtwin::test {

std::filesystem::path source_path(const std::string& relative) {
  return std::filesystem::path(PRINTTWIN_SOURCE_DIR) / relative;
}

std::optional<std::filesystem::path> realworld_dir() {
  std::vector<std::filesystem::path> candidates;
  if (const char* env = std::getenv("PRINTTWIN_REALWORLD_DIR"); env != nullptr && *env != '\0') {
    candidates.emplace_back(env);  // when set, the only place looked at (so a run can go without)
  } else {
    candidates.push_back(std::filesystem::path(PRINTTWIN_SOURCE_DIR) / ".." / "shared" /
                         "realworld");
    candidates.emplace_back("/work/shared/realworld");
  }
  for (const auto& dir : candidates)
    if (std::error_code ec; std::filesystem::is_directory(dir, ec)) return dir;
  return std::nullopt;
}

nlohmann::json read_json(const std::filesystem::path& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << path;
  if (!in.good()) return nullptr;
  return nlohmann::json::parse(in, nullptr, false);
}

namespace {
// The folders temp_dir() made, removed when the test process that made them exits (not in a
// forked child), so a suite run leaves nothing in the temporary folder. Set
// PRINTTWIN_KEEP_TEST_DIRS=1 to keep them for a look after a failure.
class MadeDirs {
 public:
  void add(const std::filesystem::path& dir) {
    if (std::find(dirs_.begin(), dirs_.end(), dir) == dirs_.end()) dirs_.push_back(dir);
  }
  MadeDirs() = default;
  MadeDirs(const MadeDirs&) = delete;
  MadeDirs& operator=(const MadeDirs&) = delete;
  MadeDirs(MadeDirs&&) = delete;
  MadeDirs& operator=(MadeDirs&&) = delete;
  ~MadeDirs() {
    const char* keep = std::getenv("PRINTTWIN_KEEP_TEST_DIRS");
    if (::getpid() != owner_ || (keep != nullptr && *keep != '\0' && *keep != '0')) return;
    for (const auto& dir : dirs_) {
      std::error_code ec;
      std::filesystem::remove_all(dir, ec);
    }
  }

 private:
  pid_t owner_ = ::getpid();
  std::vector<std::filesystem::path> dirs_;
};

MadeDirs& made_dirs() {
  static MadeDirs dirs;
  return dirs;
}
}  // namespace

std::filesystem::path temp_dir(const std::string& name) {
  // One folder per test process: ctest runs tests in parallel, each in its own process.
  auto dir = std::filesystem::temp_directory_path() /
             ("printtwin_test_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  made_dirs().add(dir);
  return dir;
}

CliRun run_cli(const std::string& args) {
  static int counter = 0;
  const auto dir = std::filesystem::temp_directory_path();
  const auto err_path =
      dir / ("printtwin_cli_err_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
  const std::string cmd =
      std::string("CI=true ") + PRINTTWIN_CLI + " " + args + " 2>" + err_path.string();
  CliRun run;
  FILE* pipe = ::popen(cmd.c_str(), "r");
  if (pipe == nullptr) return run;
  std::array<char, 4096> buf{};
  std::size_t n = 0;
  while ((n = std::fread(buf.data(), 1, buf.size(), pipe)) > 0) run.out.append(buf.data(), n);
  const int status = ::pclose(pipe);
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream err(err_path);
  std::stringstream ss;
  ss << err.rdbuf();
  run.err = ss.str();
  std::filesystem::remove(err_path);
  return run;
}

void expect_same_cube10_verify(const std::filesystem::path& a, const std::filesystem::path& b,
                               const std::filesystem::path& dir) {
  ASSERT_TRUE(save_stl(make_cube_mm(10.0, Vec3(-5, -5, 0)), dir / "cube10.stl").ok());
  VerifyOptions options;
  options.mesh_path = dir / "cube10.stl";
  options.settings.voxel_mm = 0.2;
  options.gcode_path = a;
  auto ra = verify(options);
  options.gcode_path = b;
  auto rb = verify(options);
  ASSERT_TRUE(ra.ok()) << ra.error().describe();
  ASSERT_TRUE(rb.ok()) << rb.error().describe();
  EXPECT_EQ(ra->pass, rb->pass);
  EXPECT_EQ(ra->simulation.moves, rb->simulation.moves);
  EXPECT_EQ(ra->simulation.layers, rb->simulation.layers);
  EXPECT_DOUBLE_EQ(ra->simulation.print_time_s, rb->simulation.print_time_s);
  EXPECT_DOUBLE_EQ(ra->simulation.filament_mm, rb->simulation.filament_mm);
  EXPECT_DOUBLE_EQ(ra->deviation.deposit_to_mesh.rms_mm, rb->deviation.deposit_to_mesh.rms_mm);
}

Mesh make_cube_mm(double size_mm, const Vec3& min_mm) {
  return make_box_mesh(min_mm, min_mm + Vec3::Constant(size_mm));
}

Mesh make_seam_cube_mm(double size_mm, double dz_mm) {
  Mesh m = make_cube_mm(size_mm);
  for (std::uint32_t v = 4; v < 8; ++v)
    m.vertices_mm.push_back(m.vertices_mm[v] + Vec3(0, 0, dz_mm));
  for (std::size_t f = 2; f < 4; ++f)
    for (auto& v : m.triangles[f]) v += 4;
  return m;
}

namespace {
void put_le(std::string& out, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) out += static_cast<char>((v >> (8 * i)) & 0xff);
}
std::string raw_deflate(const std::string& in) {
  z_stream zs{};
  deflateInit2(&zs, Z_BEST_COMPRESSION, Z_DEFLATED, -MAX_WBITS, 8, Z_DEFAULT_STRATEGY);
  std::string out(deflateBound(&zs, static_cast<uLong>(in.size())), '\0');
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in.data()));
  zs.avail_in = static_cast<uInt>(in.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = static_cast<uInt>(out.size());
  deflate(&zs, Z_FINISH);
  out.resize(zs.total_out);
  deflateEnd(&zs);
  return out;
}
}  // namespace

std::string make_zip(const std::vector<std::pair<std::string, std::string>>& entries,
                     bool deflate) {
  std::string zip, central;
  for (const auto& [name, bytes] : entries) {
    const std::string data = deflate ? raw_deflate(bytes) : bytes;
    const auto crc =
        crc32(0L, reinterpret_cast<const Bytef*>(bytes.data()), static_cast<uInt>(bytes.size()));
    const std::size_t offset = zip.size();
    std::string common;  // version needed .. extra length, shared by both headers
    put_le(common, 20, 2);
    put_le(common, 0, 2);
    put_le(common, deflate ? 8 : 0, 2);
    put_le(common, 0, 4);  // time, date
    put_le(common, crc, 4);
    put_le(common, data.size(), 4);
    put_le(common, bytes.size(), 4);
    put_le(common, name.size(), 2);
    put_le(common, 0, 2);
    put_le(zip, 0x04034b50, 4);
    zip += common + name + data;
    put_le(central, 0x02014b50, 4);
    put_le(central, 20, 2);  // version made by
    central += common;
    central.append(10, '\0');  // comment length, disk, internal and external attributes
    put_le(central, offset, 4);
    central += name;
  }
  const std::size_t cd_offset = zip.size();
  zip += central;
  put_le(zip, 0x06054b50, 4);
  put_le(zip, 0, 4);
  put_le(zip, entries.size(), 2);
  put_le(zip, entries.size(), 2);
  put_le(zip, central.size(), 4);
  put_le(zip, cd_offset, 4);
  put_le(zip, 0, 2);
  return zip;
}

}  // namespace printtwin::test
