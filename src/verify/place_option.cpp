// The registration's command-line options: --place with a rotation, --units.
#include <charconv>
#include <cmath>
#include <string>
#include <vector>

#include "printtwin/verify.hpp"

namespace printtwin {

namespace {

/// "a,b,c" -> numbers; false unless every item is a finite number.
bool parse_numbers(std::string_view text, std::vector<double>& out) {
  out.clear();
  while (true) {
    const auto comma = text.find(',');
    std::string item(text.substr(0, comma));
    const auto b = item.find_first_not_of(" \t"), e = item.find_last_not_of(" \t");
    if (b == std::string::npos) return false;
    item = item.substr(b, e - b + 1);
    double v = 0;
    const auto [ptr, ec] = std::from_chars(item.data(), item.data() + item.size(), v);
    if (ec != std::errc() || ptr != item.data() + item.size() || !std::isfinite(v)) return false;
    out.push_back(v);
    if (comma == std::string_view::npos) return true;
    text.remove_prefix(comma + 1);
  }
}

}  // namespace

Status parse_place_option(std::string_view text, VerifySettings& settings) {
  const auto bad = [&](const std::string& why) {
    return usage_error("--place " + why + ", got '" + std::string(text) +
                       "' (expected x,y,z or x,y,z,rz or \"x,y,z;rx,ry,rz\": mm and degrees)");
  };
  const auto semi = text.find(';');
  std::vector<double> t, r;
  if (!parse_numbers(text.substr(0, semi), t)) return bad("needs numbers separated by commas");
  if (semi != std::string_view::npos) {
    if (t.size() != 3) return bad("needs 3 numbers before ';'");
    if (!parse_numbers(text.substr(semi + 1), r) || r.size() != 3)
      return bad("needs 3 angles after ';'");
  } else if (t.size() == 4) {
    r = {0, 0, t[3]};
    t.pop_back();
  } else if (t.size() != 3) {
    return bad("needs 3 or 4 numbers");
  }
  settings.place_mm = Vec3(t[0], t[1], t[2]);
  if (!r.empty())
    settings.place_rotation_deg = Vec3(r[0], r[1], r[2]);
  else
    settings.place_rotation_deg.reset();
  return Ok{};
}

Status parse_units_option(std::string_view text, VerifySettings& settings) {
  static const std::vector<std::pair<std::string_view, double>> kUnits = {
      {"mm", 1.0}, {"cm", 10.0}, {"m", 1000.0}, {"in", 25.4}, {"inch", 25.4}, {"um", 0.001}};
  for (const auto& [name, scale] : kUnits)
    if (text == name) {
      settings.mesh_scale = scale;
      return Ok{};
    }
  double v = 0;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec == std::errc() && ptr == text.data() + text.size() && std::isfinite(v) && v > 0) {
    settings.mesh_scale = v;
    return Ok{};
  }
  return usage_error("--units expects mm, cm, m, in, um or the mesh unit's length in mm, got '" +
                     std::string(text) + "'");
}

}  // namespace printtwin
