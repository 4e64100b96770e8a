// Feature names and the slicers' feature labels.
#include <algorithm>
#include <array>
#include <cctype>
#include <string>

#include "printtwin/toolpath.hpp"

namespace printtwin {

std::string_view to_string(Feature f) {
  switch (f) {
    case Feature::unknown: return "unknown";
    case Feature::outer_perimeter: return "outer_perimeter";
    case Feature::perimeter: return "perimeter";
    case Feature::overhang_perimeter: return "overhang_perimeter";
    case Feature::sparse_infill: return "sparse_infill";
    case Feature::solid_infill: return "solid_infill";
    case Feature::top_solid_infill: return "top_solid_infill";
    case Feature::bridge_infill: return "bridge_infill";
    case Feature::gap_fill: return "gap_fill";
    case Feature::skirt: return "skirt";
    case Feature::support: return "support";
    case Feature::support_interface: return "support_interface";
    case Feature::wipe_tower: return "wipe_tower";
    case Feature::custom: return "custom";
    case Feature::count_: break;
  }
  return "unknown";
}

Feature feature_from_label(std::string_view label) {
  std::string s;
  for (char c : label) {
    if (c == '\r' || c == '\n') break;
    s.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
  }
  while (!s.empty() && s.back() == ' ') s.pop_back();
  while (!s.empty() && s.front() == ' ') s.erase(0, 1);
  struct Entry {
    std::string_view label;
    Feature feature;
  };
  // PrusaSlicer / Slic3r / Orca / Cura labels, lower-cased.
  static constexpr std::array<Entry, 34> kTable = {{
      {"external perimeter", Feature::outer_perimeter},
      {"outer wall", Feature::outer_perimeter},
      {"wall-outer", Feature::outer_perimeter},
      {"perimeter", Feature::perimeter},
      {"inner wall", Feature::perimeter},
      {"wall-inner", Feature::perimeter},
      {"overhang perimeter", Feature::overhang_perimeter},
      {"overhang wall", Feature::overhang_perimeter},
      {"internal infill", Feature::sparse_infill},
      {"sparse infill", Feature::sparse_infill},
      {"fill", Feature::sparse_infill},
      {"infill", Feature::sparse_infill},
      {"solid infill", Feature::solid_infill},
      {"internal solid infill", Feature::solid_infill},
      {"skin", Feature::solid_infill},
      {"top solid infill", Feature::top_solid_infill},
      {"top surface", Feature::top_solid_infill},
      {"bottom surface", Feature::solid_infill},
      {"bridge infill", Feature::bridge_infill},
      {"internal bridge infill", Feature::bridge_infill},
      {"bridge", Feature::bridge_infill},
      {"gap fill", Feature::gap_fill},
      {"gap infill", Feature::gap_fill},
      {"skirt", Feature::skirt},
      {"skirt/brim", Feature::skirt},
      {"brim", Feature::skirt},
      {"support material", Feature::support},
      {"support", Feature::support},
      {"support material interface", Feature::support_interface},
      {"support-interface", Feature::support_interface},
      {"support interface", Feature::support_interface},
      {"wipe tower", Feature::wipe_tower},
      {"prime tower", Feature::wipe_tower},
      {"custom", Feature::custom},
  }};
  for (const auto& e : kTable)
    if (s == e.label) return e.feature;
  if (s.find("perimeter") != std::string::npos || s.find("wall") != std::string::npos)
    return Feature::perimeter;
  if (s.find("infill") != std::string::npos) return Feature::sparse_infill;
  if (s.find("support") != std::string::npos) return Feature::support;
  return Feature::unknown;
}

}  // namespace printtwin
