// verify(): check -> (slice) -> simulate -> deposit -> deviation, aggregated into a
// VerifyReport with gates and a verdict.
// The part's side (prepare.cpp) and the G-code's side (print.cpp) run side by side; the
// measurement (measure.cpp) joins them.
#include <chrono>
#include <mutex>
#include <optional>

#include <tbb/task_group.h>

#include "printtwin/printer.hpp"
#include "verify/pipeline.hpp"

namespace printtwin {

using verify_detail::measure_with;
using verify_detail::place_part;
using verify_detail::placed;
using verify_detail::print_gcode_with;
using verify_detail::validate_verify_settings;

namespace {

/// verify() without its clock.
Result<VerifyReport> verify_pipeline(
    const VerifyOptions& options, const std::function<void(const Mesh& placed_mesh)>& on_placed) {
  const VerifySettings& settings = options.settings;
  if (auto st = validate_verify_settings(settings); !st) return st.error();
  if (!options.gcode_path.empty() &&
      (!settings.slice_config_ini.empty() || !settings.slice_overrides.empty()))
    return usage_error(
        "slicer settings (--set, --config) apply only when printtwin slices the part; "
        "drop --gcode or the settings");
  if (options.gcode_path.empty() && settings.mesh_scale && *settings.mesh_scale != 1.0)
    return usage_error(
        "--units applies to a G-code from another slicer (--gcode); printtwin's slicer "
        "slices the mesh in millimetres as it is");
  // --printer auto (the default) reads the printer from the G-code's embedded settings.
  auto resolved = resolve_printer(settings.printer, options.gcode_path);
  if (!resolved) return resolved.error();
  std::optional<PrinterProfile> printer(std::move(resolved->profile));
  if (!options.gcode_path.empty()) {
    // The part's side (load, index, check) and the G-code's side (read, simulate, deposit)
    // need nothing from each other: they run side by side. A bad mesh is reported before a
    // bad G-code, as when they ran one after the other.
    std::optional<Result<PreparedPart>> part;
    std::optional<Result<PrintedGcode>> printed;
    tbb::task_group both;
    // The registration (and on_placed) runs as a third task once both the mesh and the
    // part's extent are known, started by whichever of the two sides finishes its share last.
    std::mutex placing;
    std::optional<PartExtent> extent;
    std::optional<Result<Registration>> registration;
    const auto place_when_ready = [&] {  // under `placing`
      if (!part || !*part || !extent) return;
      both.run([&] {
        registration.emplace(place_part(**part, *extent, settings));
        if (on_placed && *registration)
          on_placed(placed((*part)->mesh, (*registration)->transform));
      });
    };
    both.run([&] {
      auto prepared = prepare_part(options.mesh_path, *printer, settings);
      const std::lock_guard lock(placing);
      part.emplace(std::move(prepared));
      place_when_ready();
    });
    both.run([&] {
      auto gcode = read_gcode_input(options.gcode_path);
      if (!gcode) {
        printed.emplace(gcode.error());
        return;
      }
      printed.emplace(
          print_gcode_with(*printer, settings, std::move(*gcode), {}, [&](const PartExtent& e) {
            const std::lock_guard lock(placing);
            extent = e;
            place_when_ready();
          }));
    });
    both.wait();
    if (!*part) return part->error();
    if (!*printed) return printed->error();
    const Registration* known = registration && *registration ? &**registration : nullptr;
    return measure_with(**part, settings, std::move(**printed), true, {}, known);
  }
  auto part = prepare_part(options.mesh_path, *printer, settings);
  if (!part) return part.error();
  std::vector<VerifyInput> ini_inputs;
  auto slice_settings = verify_slice_settings(settings, &ini_inputs);
  if (!slice_settings) return slice_settings.error();
  auto gcode = slice_for_verify(*part, *printer, *slice_settings);
  if (!gcode) return gcode.error();
  gcode->inputs.insert(gcode->inputs.begin(), ini_inputs.begin(), ini_inputs.end());
  return verify_gcode(*part, *printer, settings, std::move(*gcode));
}

}  // namespace

Result<VerifyReport> verify_detail::verify_with(
    const VerifyOptions& options, const std::function<void(const Mesh& placed_mesh)>& on_placed) {
  const auto start = std::chrono::steady_clock::now();
  auto report = verify_pipeline(options, on_placed);
  if (report)
    report->elapsed_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

Result<VerifyReport> verify(const VerifyOptions& options) {
  return verify_detail::verify_with(options, {});
}

}  // namespace printtwin
