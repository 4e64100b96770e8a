#pragma once
// The parts manifest (`printtwin.json` beside the parts, or `--manifest FILE`): per-part
// settings for `check` and `verify` of a whole repository of parts (docs/ci.md).
//
//   {"version": 1,
//    "defaults": {"printer": "ender3", "units": "mm"},
//    "parts": [{"file": "bracket.stl", "orient": true},
//              {"file": "lid.stl", "units": "in", "gcode": "gcode/lid.gcode", "tolerance_mm":
//              0.15}]}
//
// A part's own keys win over "defaults", which win over the command line's options. Paths
// (file, gcode, a printer profile file) are relative to the manifest's folder. Unknown keys,
// wrong types and impossible values are bad input naming the manifest and the key.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "printtwin/result.hpp"
#include "printtwin/verify.hpp"

namespace printtwin::cli {

/// The name `check` looks for in each folder it is given and beside each file.
inline constexpr const char* kManifestName = "printtwin.json";

/// Settings of one part; unset: the command line's.
struct PartSettings {
  std::optional<std::string> printer;  ///< a library name, or a profile path (resolved)
  std::optional<std::string> units;    ///< "auto" or a `--units` value
  std::optional<double> scale;
  std::optional<bool> orient;
  std::optional<double> overhang_angle_deg;
  std::optional<double> min_thickness_mm;
  std::optional<double> line_width_mm;
  std::optional<bool> self_intersections;
  std::optional<double> weld_tolerance_mm;  ///< --repair's weld; 0: none
  // verify only
  std::optional<std::string> gcode;  ///< resolved path
  std::optional<double> tolerance_mm;
  std::optional<double> max_excess_mm;
  std::optional<double> max_deficit_mm;
  std::optional<double> max_rms_mm;
  std::optional<std::string> object;
};

struct ManifestPart {
  std::string file;       ///< resolved path (manifest folder / the entry's "file")
  PartSettings settings;  ///< "defaults" merged under the entry's own keys
};

struct Manifest {
  std::string path;
  std::vector<ManifestPart> parts;  ///< in the manifest's order
  PartSettings defaults;
};

/// Reads and validates a manifest.
[[nodiscard]] Result<Manifest> load_manifest(const std::filesystem::path& path);

/// The manifests that apply to `inputs` (command-line paths): `explicit_manifest` alone when
/// given, else printtwin.json in each folder given and beside each file given, each once.
[[nodiscard]] Result<std::vector<Manifest>> find_manifests(const std::vector<std::string>& inputs,
                                                           const std::string& explicit_manifest);

/// The entry for `file` (same file by path), or null.
[[nodiscard]] const ManifestPart* find_manifest_part(const std::vector<Manifest>& manifests,
                                                     const std::string& file);

/// True when two paths name the same file (or would, for files that do not exist).
[[nodiscard]] bool same_file(const std::string& a, const std::string& b);

/// One part of a batch run as a JUnit test case.
struct CaseOutcome {
  std::string name;  ///< the part's path
  double seconds = 0;
  bool pass = true;
  std::string failure_type;  ///< e.g. "unreadable", "not_printable", "fail"
  std::string message;       ///< one line
  std::string details;       ///< the failure's body (findings, the error)
};

/// JUnit XML with one testsuite `suite` and a test case per outcome. Deterministic.
[[nodiscard]] std::string junit_xml(const std::string& suite, const std::string& classname,
                                    const std::vector<CaseOutcome>& cases);

/// `printtwin verify --manifest FILE`: every part the manifest lists, verified against its
/// "gcode" (or sliced by printtwin when it names none), one report folder each under
/// `out_dir`/<part>, one summary table on stdout (and in `summary_out`), one JUnit file.
/// `base` holds the command line's settings; a part's keys override them. Exit code: the
/// worst part's (0 pass, 1 fail, 3 a part or its G-code unreadable).
struct VerifyBatchOptions {
  std::string manifest;
  std::string out_dir;  ///< default "reports"
  std::string summary_out;
  std::string junit_out;
  bool quiet = false;
};
[[nodiscard]] int run_verify_manifest(const VerifyBatchOptions& options,
                                      const VerifySettings& base);

}  // namespace printtwin::cli
