#include "support/test_support.hpp"

#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>
#include <array>
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

std::filesystem::path temp_dir(const std::string& name) {
  // One folder per test process: ctest runs tests in parallel, each in its own process.
  auto dir = std::filesystem::temp_directory_path() /
             ("printtwin_test_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
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

Mesh make_cube_mm(double size_mm, const Vec3& min_mm) {
  return make_box_mesh(min_mm, min_mm + Vec3::Constant(size_mm));
}

}  // namespace printtwin::test
