// The atomic-output promise of `verify --out`: a run killed half-way leaves no report that
// looks complete, a later run removes what a killed run left, and two runs writing the same
// report at once leave one whole report. Also the empty-deposit exports (valid empty files).
#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "printtwin/deposit.hpp"
#include "printtwin/io.hpp"
#include "printtwin/mesh.hpp"
#include "support/test_support.hpp"

extern char** environ;

namespace printtwin {
namespace {

namespace fs = std::filesystem;

/// The folder holds every file of a verify report, and its report.json parses.
bool looks_complete(const fs::path& dir) {
  for (const char* f : {"report.html", "report.json", "junit.xml", "summary.md", "deviation.ply"})
    if (!fs::is_regular_file(dir / f)) return false;
  auto text = read_file(dir / "report.json");
  return text.ok() && !nlohmann::json::parse(*text, nullptr, false).is_discarded();
}

std::vector<fs::path> staging_folders(const fs::path& parent) {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(parent))
    if (e.path().filename().string().find(".staging-") != std::string::npos)
      out.push_back(e.path());
  return out;
}

/// Starts `printtwin verify` on the 10 mm cube with its PrusaSlicer G-code, writing to `out`.
pid_t start_verify(const fs::path& dir, const fs::path& out) {
  const fs::path stl = dir / "cube10.stl";
  if (!fs::exists(stl)) {
    EXPECT_TRUE(save_stl(test::make_cube_mm(10.0, Vec3(-5, -5, 0)), stl).ok());
  }
  const std::string gcode = test::source_path("samples/gcode/prusa_cube10.gcode").string();
  std::vector<std::string> args = {PRINTTWIN_CLI, "verify", stl.string(), "--gcode", gcode,
                                   "--voxel",     "0.1",    "--quiet",    "--out",   out.string()};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
  EXPECT_EQ(posix_spawn(&pid, PRINTTWIN_CLI, &actions, nullptr, argv.data(), environ), 0);
  posix_spawn_file_actions_destroy(&actions);
  return pid;
}

int wait_exit(pid_t pid) {
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
}

TEST(AtomicOutput, KilledVerifyLeavesNoCompleteLookingReportAndALaterRunCleansUp) {
  const fs::path dir = test::temp_dir("atomic_kill");
  const fs::path out = dir / "r";
  // Kill the run as soon as its staging folder appears (it is writing the report then);
  // if the run is faster than the polling, kill it at once on the next try.
  bool killed_while_staging = false;
  for (int attempt = 0; attempt < 3 && !killed_while_staging; ++attempt) {
    fs::remove_all(out);
    const pid_t pid = start_verify(dir, out);
    const auto t0 = std::chrono::steady_clock::now();
    while (std::chrono::steady_clock::now() - t0 < std::chrono::seconds(60)) {
      if (!staging_folders(dir).empty()) {
        ::kill(pid, SIGKILL);
        killed_while_staging = true;
        break;
      }
      if (fs::exists(out)) break;  // finished before we saw it
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
    const int code = wait_exit(pid);
    if (killed_while_staging) {
      EXPECT_EQ(code, -SIGKILL);
      // Whatever was written, nothing under the report's name looks complete.
      EXPECT_FALSE(fs::exists(out) && !looks_complete(out))
          << "a half report under the report's name";
      EXPECT_FALSE(fs::exists(out)) << "the killed run was still writing";
    }
  }
  ASSERT_TRUE(killed_while_staging) << "the staging folder never appeared";
  // A run killed while staging leaves its folder, named with its (now dead) process id;
  // a stale folder of unknown owner older than an hour goes too; a live run's stays.
  fs::create_directories(dir / (".r.staging-" + std::to_string(::getpid()) + "-1"));
  const fs::path anonymous = dir / ".r.staging-old";
  fs::create_directories(anonymous);
  fs::last_write_time(anonymous, fs::file_time_type::clock::now() - std::chrono::hours(2));
  ASSERT_GE(staging_folders(dir).size(), 2u);
  const pid_t again = start_verify(dir, out);
  EXPECT_EQ(wait_exit(again), 0);
  EXPECT_TRUE(looks_complete(out));
  const auto left = staging_folders(dir);
  ASSERT_EQ(left.size(), 1u);  // only the one of a live process (this test)
  EXPECT_NE(left[0].filename().string().find(std::to_string(::getpid())), std::string::npos);
}

TEST(AtomicOutput, TwoRunsToTheSameOutLeaveOneWholeReport) {
  const fs::path dir = test::temp_dir("atomic_race");
  const fs::path out = dir / "r";
  for (int round = 0; round < 2; ++round) {  // first into nothing, then over a report
    const pid_t a = start_verify(dir, out);
    const pid_t b = start_verify(dir, out);
    EXPECT_EQ(wait_exit(a), 0);
    EXPECT_EQ(wait_exit(b), 0);
    EXPECT_TRUE(looks_complete(out)) << "round " << round;
    EXPECT_TRUE(staging_folders(dir).empty()) << "round " << round;
    // Nothing else beside the report and the inputs.
    for (const auto& e : fs::directory_iterator(dir)) {
      const std::string n = e.path().filename().string();
      EXPECT_TRUE(n == "r" || n == "cube10.stl") << n;
    }
  }
}

TEST(EmptyDeposit, EveryExportWritesAValidEmptyFile) {
  const fs::path dir = test::temp_dir("empty_deposit");
  // Travel only: the deposit has no voxel.
  std::ofstream(dir / "travel.gcode") << "G28\nG1 Z0.2 F600\nG1 X50 Y50 F3000\nG1 X60\n";
  const auto run =
      test::run_cli("simulate '" + (dir / "travel.gcode").string() + "' --deposit '" +
                    (dir / "d.ot").string() + "' --json '" + (dir / "d.json").string() + "'");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto bt =
      test::run_cli("simulate '" + (dir / "travel.gcode").string() + "' --deposit '" +
                    (dir / "d.bt").string() + "' --deposit-ply '" + (dir / "d.ply").string() + "'");
  ASSERT_EQ(bt.exit_code, 0) << bt.err;
  for (const char* f : {"d.ot", "d.bt"}) {
    auto n = count_octomap_voxels(dir / f);
    ASSERT_TRUE(n.ok()) << f << ": " << n.error().describe();
    EXPECT_EQ(*n, 0u) << f;
  }
  auto ply = read_file(dir / "d.ply");
  ASSERT_TRUE(ply.ok());
  EXPECT_NE(ply->find("element vertex 0\n"), std::string::npos);
  EXPECT_TRUE(ply->ends_with("end_header\n"));
  auto json = read_file(dir / "d.json");
  ASSERT_TRUE(json.ok());
  EXPECT_EQ(nlohmann::json::parse(*json)["deposit"]["voxels"], 0);
}

}  // namespace
}  // namespace printtwin
