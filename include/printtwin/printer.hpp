#pragma once
// The printer a G-code file was made for: the slicer's embedded settings, the built-in
// printer library, Klipper's printer.cfg, and `--printer auto` which combines them
// (docs/printer-profile.md).
//
//   auto printer = resolve_printer("auto", "part.gcode");   // or "mk4s", "my.json", "printer.cfg"
//   SimulateOptions options;
//   apply_printer_to_options(*printer, options.interpreter);  // start-macro temperatures
//   auto sim = simulate_gcode_file("part.gcode", printer->profile, options);
//
// Every value of the resolved profile carries where it came from (PrinterOrigin in
// machine.hpp): the file (with the setting's key), the library (profile id), a printer.cfg
// or JSON file, or the generic default.
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "printtwin/finding.hpp"
#include "printtwin/gcode.hpp"
#include "printtwin/machine.hpp"
#include "printtwin/result.hpp"

namespace printtwin {

// ---------------------------------------------------------------------------------------
// Slicer settings embedded in a G-code file.

/// The key/value pairs a slicer wrote into its output, in file order. Filled from a text
/// G-code's head and tail (read_slicer_settings) or from a .bgcode's metadata blocks
/// (add the pairs with `add`). Keys keep the slicer's own names ("bed_shape",
/// "machine_width", "strokeXoverride"); values are trimmed text.
struct SlicerSettings {
  /// "PrusaSlicer", "SuperSlicer", "OrcaSlicer", "BambuStudio", "Creality Print", "Cura",
  /// "ideaMaker", "KISSlicer", "Simplify3D", "Slic3r" or "" when no known header was seen.
  std::string slicer;
  std::string slicer_version;  ///< "2.8.1", "5.1.4.10249", ... ("" if not stated)
  struct Entry {
    std::string key;
    std::string value;
    long line = 0;  ///< 1-based line in the file (0 when not from a text file)
  };
  std::vector<Entry> entries;
  /// The first Klipper extended command in the head or tail ("PRINT_START"), "" if none:
  /// the file runs on Klipper whatever flavour it states (Cura has no Klipper flavour).
  std::string klipper_command;
  long klipper_command_line = 0;

  void add(std::string key, std::string value, long line = 0);
  /// The last value of `key` (config blocks may repeat a header key; the block wins).
  [[nodiscard]] const Entry* find(std::string_view key) const;
  [[nodiscard]] bool empty() const { return entries.empty(); }
};

/// Reads the settings of any supported slicer from the first and last `window_bytes` of a
/// G-code text (bounded work on big files). Errors only when the file cannot be read.
[[nodiscard]] Result<SlicerSettings> read_slicer_settings(const std::filesystem::path& gcode_path,
                                                          std::size_t window_bytes = 512 * 1024);
/// Same on text already in memory: `head` is the start of the file and `tail` its end
/// (they may overlap or be the same text); `tail_first_line` numbers the tail's lines.
[[nodiscard]] SlicerSettings parse_slicer_settings(std::string_view head, std::string_view tail,
                                                   long tail_first_line = 0);

/// One value the settings state, with the setting's key it came from.
/// (At namespace scope: clang 14 crashes generating code for a class template nested in
/// StatedPrinter when it holds an Eigen vector, so the fuzz build could not compile.)
template <class T>
struct StatedValue {
  T value{};
  std::string key;  ///< the setting's key, e.g. "bed_shape"
};

/// What the settings say about the machine, in profile units. Each value names the setting
/// key it came from. Unset optionals: the file does not say.
struct StatedPrinter {
  template <class T>
  using Value = StatedValue<T>;
  std::optional<Value<std::string>> model;     ///< printer_model, machine name, ...
  std::vector<std::string> names;              ///< every string that may name the printer
  std::optional<Value<std::string>> firmware;  ///< mapped flavour: marlin2, marlin1, klipper, rrf
  std::string flavour_text;                    ///< the file's own words ("marlin2", "Marlin")
  std::optional<Value<Eigen::Vector4d>> bed;   ///< min x, min y, max x, max y
  std::optional<Value<double>> max_z_mm;
  std::optional<Value<double>> nozzle_diameter_mm;
  std::optional<Value<double>> filament_diameter_mm;
  std::optional<Value<double>> max_feedrate_mm_s[4];
  std::optional<Value<double>> max_accel_mm_s2[4];
  std::optional<Value<double>> jerk_mm_s[4];
  std::optional<Value<double>> print_accel_mm_s2, retract_accel_mm_s2, travel_accel_mm_s2;
  std::optional<Value<double>> min_feedrate_mm_s, min_travel_feedrate_mm_s;
  std::optional<Value<double>> first_layer_hotend_c, first_layer_bed_c;
  /// Tools: extruders (multi-nozzle) or filaments (one nozzle, AMS / MMU) the file uses.
  std::optional<Value<int>> tool_count;
  std::optional<Value<bool>> shared_nozzle;  ///< the tools share one nozzle (AMS, MMU)
  /// Filament unload / load time at a change on a shared nozzle (s, one per tool or one for
  /// all) and the tool change time of a multi-nozzle machine (s), as the slicer states them.
  std::vector<double> filament_load_s, filament_unload_s;
  std::optional<Value<double>> tool_change_s;
};

/// Maps a slicer's settings to printer facts (bed shape and origin, height, nozzle,
/// filament, machine limits, flavour, model names, first-layer temperatures).
[[nodiscard]] StatedPrinter stated_printer(const SlicerSettings& settings);

// ---------------------------------------------------------------------------------------
// The built-in printer library (printers/*.json, embedded at build time).

struct LibraryPrinter {
  std::string id;                    ///< "prusa-mk4s", "creality-k1-max", ...
  std::string name;                  ///< display name
  std::vector<std::string> aliases;  ///< names slicers use for it (printer_model, ...)
  std::vector<std::string> sources;  ///< citations of the numbers
  PrinterProfile profile;
  PrinterOrigin origin;  ///< every key: "library" (id) or "default"
};

/// Every library printer, sorted by id. The data is compiled in: no files are read.
[[nodiscard]] const std::vector<LibraryPrinter>& printer_library();
/// Library printer by id (case-insensitive), nullptr if none.
[[nodiscard]] const LibraryPrinter* find_library_printer(std::string_view id);
/// The library printer that `name` (a printer_model, a settings id such as "Original Prusa
/// MK4S 0.4 nozzle", a machine name) denotes: the longest alias whose words appear in a row
/// in `name`. nullptr if none.
[[nodiscard]] const LibraryPrinter* match_library_printer(std::string_view name);
/// A table of the library for `printtwin printers`.
[[nodiscard]] std::string printer_library_table();

// ---------------------------------------------------------------------------------------
// Klipper printer.cfg.

/// One [section] of a Klipper config: options in order, with their file and line.
struct KlipperSection {
  std::string name;  ///< "printer", "stepper_x", "extruder", "tmc2209 stepper_x"
  struct Option {
    std::string key, value;
    std::string file;
    long line = 0;
  };
  std::vector<Option> options;
  [[nodiscard]] const Option* find(std::string_view key) const;
};

/// Parses a printer.cfg with its [include ...] files (relative paths, * ? [] globs).
/// Errors name the file and line.
[[nodiscard]] Result<std::vector<KlipperSection>> read_klipper_config(
    const std::filesystem::path& path);
/// A PrinterProfile from a printer.cfg: [printer] kinematics, max_velocity, max_accel,
/// minimum_cruise_ratio (or max_accel_to_decel), square_corner_velocity, max_z_velocity,
/// max_z_accel; [stepper_x/y/z] ranges and homing speeds; [extruder] nozzle, filament,
/// extrude-only limits, min_extrude_temp; [firmware_retraction]. Every other key stays at
/// the Klipper generic default.
[[nodiscard]] Result<PrinterProfile> load_klipper_printer_cfg(const std::filesystem::path& path);

// ---------------------------------------------------------------------------------------
// --printer auto.

/// The printer a run uses, with everything the detection learned.
struct ResolvedPrinter {
  PrinterProfile profile;   ///< profile.origin says where each value came from
  SlicerSettings settings;  ///< what the file states (empty without a G-code)
  StatedPrinter stated;
};

/// `spec` is "auto" (or empty), a library id, a built-in name, a .json profile or a Klipper
/// .cfg. With "auto" the G-code's settings pick the library printer (model, settings id,
/// machine name) and the file's own values override it; an unknown model gets the stated
/// values on top of a flavour-appropriate generic printer; a file that identifies nothing
/// gets the generic default and a finding saying so. An explicit spec wins over the file,
/// but a file made for a larger bed than the profile's still raises a finding.
/// `gcode_path` may be empty (nothing to detect from); an unreadable file identifies nothing
/// (the G-code reader reports it).
[[nodiscard]] Result<ResolvedPrinter> resolve_printer(std::string_view spec,
                                                      const std::filesystem::path& gcode_path);
/// Same with settings already read (e.g. from a .bgcode's metadata).
[[nodiscard]] Result<ResolvedPrinter> resolve_printer(std::string_view spec,
                                                      SlicerSettings settings);

/// Copies what the interpreter needs from a resolved printer: the temperatures a start
/// macro without parameters heats to (the file's first-layer temperatures).
void apply_printer_to_options(const ResolvedPrinter& printer, InterpreterOptions& options);
/// The tools the file's settings declare (PrinterOrigin::tool_count, shared nozzle, change
/// times) into `options`, unless the caller set tool_count already.
void apply_tools_to_options(const PrinterOrigin& origin, InterpreterOptions& options);

}  // namespace printtwin
