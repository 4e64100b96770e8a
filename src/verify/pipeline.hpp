#pragma once
// Private to src/verify/: what the pipeline's steps (prepare.cpp, print.cpp, measure.cpp,
// verify.cpp) share: the stage clock, input provenance, settings checks and the placement.
#include <chrono>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "printtwin/deviation.hpp"
#include "printtwin/verify.hpp"

namespace printtwin::verify_detail {

/// Appends the wall time since the previous lap (or construction) as a named stage.
class StageClock {
 public:
  explicit StageClock(std::vector<StageTiming>& out) : out_(out) {}
  void lap(const char* stage) {
    const auto now = std::chrono::steady_clock::now();
    out_.push_back({stage, std::chrono::duration<double>(now - last_).count()});
    last_ = now;
  }

 private:
  std::vector<StageTiming>& out_;
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

/// Adds the findings' counts by severity to `errors`, `warnings` and `infos`.
void count_severities(const std::vector<Finding>& findings, int& errors, int& warnings, int& infos);

/// Reads a file for its provenance (path, SHA-256, size); its bytes into `content` when given.
[[nodiscard]] Result<VerifyInput> describe_input(const std::string& role,
                                                 const std::filesystem::path& path,
                                                 std::string* content = nullptr);

/// Settings every step checks first: tolerance and gate limits, voxel size (usage errors).
[[nodiscard]] Status validate_verify_settings(const VerifySettings& settings);

/// The deviation stage's settings of a verification.
[[nodiscard]] DeviationSettings deviation_settings_of(const VerifySettings& settings);

/// The printability check of `mesh` (verify's settings: the thin-wall finding, not the
/// thinnest wall) into its summary and findings; `query`: the mesh's BVH when built already.
[[nodiscard]] Status check_part(const Mesh& mesh, const PrinterProfile& printer,
                                const MeshQuery* query, CheckSummary& summary,
                                std::vector<Finding>& findings);

/// Where the mesh sits in the G-code frame: --place (with its figures), else the search.
[[nodiscard]] Result<Registration> place_part(const PreparedPart& part, const PartExtent& extent,
                                              const VerifySettings& settings);

/// The mesh moved by a registration's transform.
[[nodiscard]] Mesh placed(const Mesh& mesh, const RigidTransform& t);

/// print_gcode, calling `on_extent` with the part's extent as soon as the simulation has
/// found it, before the deposit (verify() starts the registration then).
[[nodiscard]] Result<PrintedGcode> print_gcode_with(
    const PrinterProfile& printer, const VerifySettings& settings, GcodeInput gcode,
    const std::function<void(std::string_view)>& on_stage,
    const std::function<void(const PartExtent&)>& on_extent);

/// measure_printed with the registration when already known (verify() finds it while the
/// deposit runs); null: found here.
[[nodiscard]] Result<VerifyReport> measure_with(
    const PreparedPart& part, const VerifySettings& settings, PrintedGcode printed,
    bool include_part_timings, const std::function<void(std::string_view)>& on_stage,
    const Registration* known);

/// verify(), calling `on_placed` once, on a worker thread, as soon as the mesh's place in the
/// G-code frame is known, with the mesh as the report will hold it (placed_mesh), while the
/// deposit may still be running (verify_to_folder traces the heatmaps' views meanwhile).
/// Returns after it has returned; not called when verify fails before the placement is known.
[[nodiscard]] Result<VerifyReport> verify_with(
    const VerifyOptions& options, const std::function<void(const Mesh& placed_mesh)>& on_placed);

}  // namespace printtwin::verify_detail
