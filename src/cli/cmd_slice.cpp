// `printtwin slice part.stl -o part.gcode [settings]`: printtwin's own slicer.
// Settings come, in this order, from the PrusaSlicer Ender-3 defaults, --config file.ini,
// the flags, and --set key=value (later wins).
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli/cli_common.hpp"
#include "cli/commands.hpp"
#include "printtwin/io.hpp"
#include "printtwin/machine.hpp"
#include "printtwin/mesh.hpp"
#include "printtwin/slice.hpp"

namespace printtwin::cli {

namespace {

// Flag name -> PrusaSlicer key.
const std::vector<std::pair<std::string, std::string>>& flag_keys() {
  static const std::vector<std::pair<std::string, std::string>> flags = {
      {"layer-height", "layer_height"},
      {"first-layer-height", "first_layer_height"},
      {"nozzle", "nozzle_diameter"},
      {"filament-diameter", "filament_diameter"},
      {"line-width", "extrusion_width"},
      {"perimeters", "perimeters"},
      {"top-layers", "top_solid_layers"},
      {"bottom-layers", "bottom_solid_layers"},
      {"infill-density", "fill_density"},
      {"infill-pattern", "fill_pattern"},
      {"seam", "seam_position"},
      {"perimeter-speed", "perimeter_speed"},
      {"external-perimeter-speed", "external_perimeter_speed"},
      {"infill-speed", "infill_speed"},
      {"solid-infill-speed", "solid_infill_speed"},
      {"top-solid-infill-speed", "top_solid_infill_speed"},
      {"gap-fill-speed", "gap_fill_speed"},
      {"bridge-speed", "bridge_speed"},
      {"first-layer-speed", "first_layer_speed"},
      {"travel-speed", "travel_speed"},
      {"retract-length", "retract_length"},
      {"retract-speed", "retract_speed"},
      {"z-hop", "retract_lift"},
      {"temperature", "temperature"},
      {"first-layer-temperature", "first_layer_temperature"},
      {"bed-temperature", "bed_temperature"},
      {"first-layer-bed-temperature", "first_layer_bed_temperature"},
      {"fan-speed", "max_fan_speed"},
      {"min-fan-speed", "min_fan_speed"},
      {"skirts", "skirts"},
      {"skirt-distance", "skirt_distance"},
      {"brim", "brim_width"},
  };
  return flags;
}

struct SliceOptions {
  std::string input;
  std::string output;
  std::string printer = "ender3";
  std::vector<std::string> configs;
  std::vector<std::string> sets;
  std::map<std::string, std::string> flag_values;
  std::vector<double> center;
  std::vector<double> place;
  bool json = false;
  bool no_time = false;
};

std::optional<Error> parse_pair(const std::string& text, std::string& key, std::string& value) {
  const auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0)
    return usage_error("--set expects key=value, got '" + text + "'");
  key = text.substr(0, eq);
  value = text.substr(eq + 1);
  return std::nullopt;
}

int run_slice(const SliceOptions& o) {
  if (auto st = check_output_path(o.output, "--output", OutputKind::file); !st)
    return report_error(st.error());
  SliceSettings settings;
  std::vector<std::string> ignored;
  SettingSources sources;
  for (const auto& cfg : o.configs) {
    auto rep = load_prusa_ini(settings, cfg);
    if (!rep) return report_error(rep.error());
    ignored.insert(ignored.end(), rep->ignored_keys.begin(), rep->ignored_keys.end());
    for (auto& [key, where] : rep->sources) sources[key] = std::move(where);
  }
  for (const auto& [flag, key] : flag_keys()) {
    auto it = o.flag_values.find(flag);
    if (it == o.flag_values.end() || it->second.empty()) continue;
    if (auto st = set_slice_setting(settings, key, it->second); !st) {
      Error e = st.error();
      e.message = "--" + flag + ": " + e.message;
      return report_error(e);
    }
    sources.erase(key);
  }
  for (const auto& kv : o.sets) {
    std::string key, value;
    if (auto err = parse_pair(kv, key, value)) return report_error(*err);
    if (auto st = set_slice_setting(settings, key, value); !st) return report_error(st.error());
    sources.erase(key);
  }
  if (!o.center.empty()) settings.center_mm = Vec2(o.center[0], o.center[1]);
  if (!o.place.empty()) settings.place_offset_mm = Vec3(o.place[0], o.place[1], o.place[2]);
  settings.estimate_time = !o.no_time;
  if (auto st = validate_slice_settings(settings, sources); !st) return report_error(st.error());

  auto printer = load_printer_profile(o.printer);
  if (!printer) return report_error(printer.error());
  auto mesh = load_mesh(o.input);
  if (!mesh) return report_error(mesh.error());
  // A mesh without area has nothing to slice (check: NOT PRINTABLE).
  if (!(surface_area_mm2(*mesh) > 0))
    return report_error(bad_input("the mesh has zero area (all " +
                                      std::to_string(mesh->triangles.size()) +
                                      " triangles are degenerate): nothing to slice, not printable",
                                  o.input));

  std::string out_path = o.output;
  if (out_path.empty())
    out_path = std::filesystem::path(o.input).replace_extension(".gcode").string();
  const auto t0 = std::chrono::steady_clock::now();
  auto sliced = slice_mesh(*mesh, *printer, settings);
  if (!sliced) {
    Error e = sliced.error();
    if (e.file.empty() && e.code == ErrorCode::bad_input) e.file = o.input;
    return report_error(e);
  }
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!(sliced->stats.filament_mm > 0))
    return report_error(
        bad_input("the slice extrudes nothing (" + std::to_string(sliced->stats.layer_count) +
                      " layers, 0 mm of filament): no part of the mesh would print, not printable",
                  o.input));
  if (auto st = write_file_atomic(out_path, sliced->gcode); !st) return report_error(st.error());

  const SliceStats& s = sliced->stats;
  if (o.json) {
    nlohmann::ordered_json j;
    j["schema"] = "printtwin.slice/1";
    j["input"] = o.input;
    j["output"] = out_path;
    j["layers"] = s.layer_count;
    j["object_height_mm"] = s.object_height_mm;
    j["part_volume_mm3"] = s.part_volume_mm3;
    j["filament_mm"] = s.filament_mm;
    j["filament_mm3"] = s.filament_volume_mm3;
    j["filament_g"] = s.filament_g;
    j["estimated_time_s"] = s.time_from_simulator ? nlohmann::ordered_json(s.estimated_time_s)
                                                  : nlohmann::ordered_json(nullptr);
    j["retractions"] = s.retractions;
    j["gcode_lines"] = s.gcode_lines;
    j["mesh_repaired"] = s.mesh_repaired;
    j["extruded_mm3"] = {{"external_perimeter", s.external_perimeter_mm3},
                         {"perimeter", s.perimeter_mm3},
                         {"internal_infill", s.sparse_infill_mm3},
                         {"solid_infill", s.solid_infill_mm3},
                         {"top_solid_infill", s.top_solid_infill_mm3},
                         {"bridge_infill", s.bridge_infill_mm3},
                         {"gap_fill", s.gap_fill_mm3},
                         {"skirt_brim", s.skirt_brim_mm3}};
    auto& fj = j["findings"] = nlohmann::ordered_json::array();
    for (const auto& f : sliced->findings) {
      nlohmann::ordered_json x;
      x["code"] = f.code;
      x["severity"] = std::string(to_string(f.severity));
      x["message"] = f.message;
      if (f.layer) x["layer"] = *f.layer;
      if (f.value) x["value"] = *f.value;
      if (f.position_mm)
        x["position_mm"] = {f.position_mm->x(), f.position_mm->y(), f.position_mm->z()};
      fj.push_back(x);
    }
    j["ignored_config_keys"] = ignored;
    std::printf("%s\n", j.dump(2).c_str());
    return kPass;
  }
  if (!ignored.empty()) {
    std::string list;
    for (const auto& k : ignored) list += (list.empty() ? "" : ", ") + k;
    std::fprintf(stderr, "printtwin: note: %zu config keys not used by printtwin's slicer: %s\n",
                 ignored.size(), list.c_str());
  }
  std::printf("%s -> %s: %d layers, filament %s mm (%s cm3, %s g)", o.input.c_str(),
              out_path.c_str(), s.layer_count, format_fixed(s.filament_mm, 1).c_str(),
              format_fixed(s.filament_volume_mm3 * 1e-3, 2).c_str(),
              format_fixed(s.filament_g, 2).c_str());
  if (s.time_from_simulator)
    std::printf(", estimated print time %s s", format_fixed(s.estimated_time_s, 0).c_str());
  std::printf(", sliced in %s s\n", format_fixed(secs, 2).c_str());
  for (const auto& f : sliced->findings)
    std::printf("%s: %s: %s\n", std::string(to_string(f.severity)).c_str(), f.code.c_str(),
                f.message.c_str());
  return kPass;
}

}  // namespace

void add_slice_command(CLI::App& app, CommandRunner& runner) {
  auto opts = std::make_shared<SliceOptions>();
  auto* cmd =
      app.add_subcommand("slice", "Slice a mesh into Marlin G-code (PrusaSlicer Ender-3 defaults)");
  cmd->add_option("mesh", opts->input, "STL, OBJ, PLY, OFF, 3MF or AMF file")->required();
  cmd->add_option("-o,--output", opts->output, "G-code file to write (default: <mesh>.gcode)");
  cmd->add_option("--printer", opts->printer,
                  "printer profile: ender3, ender3-marlin1, ender3-klipper, a library printer "
                  "(printtwin printers), a JSON file or a Klipper printer.cfg");
  cmd->add_option("--config", opts->configs,
                  "flat PrusaSlicer .ini config (supported keys used, others listed)");
  cmd->add_option("--set", opts->sets,
                  "any setting as key=value (PrusaSlicer key names, docs/slicer.md)");
  for (const auto& [flag, key] : flag_keys()) {
    cmd->add_option("--" + flag, opts->flag_values[flag], "setting " + key);
  }
  cmd->add_option("--center", opts->center, "centre the part's bounding box at X,Y (mm)")
      ->expected(2)
      ->delimiter(',');
  cmd->add_option("--place", opts->place, "translate the mesh by X,Y,Z instead of centring it")
      ->expected(3)
      ->delimiter(',');
  cmd->add_flag("--json", opts->json, "print the slice summary as JSON (schema printtwin.slice/1)");
  cmd->add_flag("--no-time-estimate", opts->no_time,
                "skip the simulator's time estimate in the footer");
  cmd->callback([opts, &runner] { runner.run = [opts]() -> int { return run_slice(*opts); }; });
}

}  // namespace printtwin::cli
