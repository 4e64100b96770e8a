// The G-code to verify: read from a file, or sliced by printtwin's slicer.
#include <chrono>

#include "printtwin/io.hpp"
#include "verify/pipeline.hpp"

namespace printtwin {

using verify_detail::describe_input;

Result<GcodeInput> read_gcode_input(const std::filesystem::path& gcode_path) {
  GcodeInput g;
  auto in = describe_input("gcode", gcode_path, &g.text);
  if (!in) return in.error();
  g.inputs.push_back(*in);
  g.name = gcode_path.string();
  g.source = "file";
  return g;
}

Result<SliceSettings> verify_slice_settings(const VerifySettings& settings,
                                            std::vector<VerifyInput>* inputs) {
  SliceSettings slice_settings;
  SettingSources sources;
  if (!settings.slice_config_ini.empty()) {
    std::string ini_text;
    auto ini_in = describe_input("slice_config", settings.slice_config_ini, &ini_text);
    if (!ini_in) return ini_in.error();
    if (inputs != nullptr) inputs->push_back(*ini_in);
    auto config = prusa_config_text(std::move(ini_text), settings.slice_config_ini);
    if (!config) return config.error();
    auto applied = apply_prusa_ini(slice_settings, *config, settings.slice_config_ini);
    if (!applied) return applied.error();
    sources = std::move(applied->sources);
  }
  for (const auto& [key, value] : settings.slice_overrides) {
    if (auto st = set_slice_setting(slice_settings, key, value); !st) return st.error();
    sources.erase(key);
  }
  if (auto st = validate_slice_settings(slice_settings, sources); !st) return st.error();
  return slice_settings;
}

Result<GcodeInput> slice_for_verify(const PreparedPart& part, const PrinterProfile& printer,
                                    const SliceSettings& settings, std::string label) {
  const auto t0 = std::chrono::steady_clock::now();
  auto sliced = slice_mesh(part.mesh, printer, settings);
  if (!sliced) return sliced.error();
  GcodeInput g;
  g.text = std::move(sliced->gcode);
  g.name = label.empty() ? part.name + ".gcode (printtwin slice)" : std::move(label);
  g.source = "printtwin slice";
  g.inputs.push_back({"gcode", g.name, sha256_hex(g.text), g.text.size()});
  g.findings = std::move(sliced->findings);
  g.slice_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return g;
}

}  // namespace printtwin
