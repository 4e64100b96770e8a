// Feature names and the slicers' feature labels.
#include <algorithm>
#include <array>
#include <cctype>
#include <string>

#include "printtwin/toolpath.hpp"

namespace printtwin {

std::string_view to_string(Feature f) {
  switch (f) {
    case Feature::unknown:
      return "unknown";
    case Feature::outer_perimeter:
      return "outer_perimeter";
    case Feature::perimeter:
      return "perimeter";
    case Feature::overhang_perimeter:
      return "overhang_perimeter";
    case Feature::sparse_infill:
      return "sparse_infill";
    case Feature::solid_infill:
      return "solid_infill";
    case Feature::top_solid_infill:
      return "top_solid_infill";
    case Feature::bridge_infill:
      return "bridge_infill";
    case Feature::gap_fill:
      return "gap_fill";
    case Feature::skirt:
      return "skirt";
    case Feature::support:
      return "support";
    case Feature::support_interface:
      return "support_interface";
    case Feature::wipe_tower:
      return "wipe_tower";
    case Feature::custom:
      return "custom";
    case Feature::count_:
      break;
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
  // Labels of PrusaSlicer / SuperSlicer / Slic3r (";TYPE:"), OrcaSlicer / Bambu Studio /
  // Creality Print ("; FEATURE:" or ";TYPE:"), Cura and ideaMaker (";TYPE:WALL-OUTER"),
  // KISSlicer ("; 'Perimeter Path'") and Simplify3D ("; feature outer perimeter"), lower-cased.
  static constexpr Entry kTable[] = {
      // Outer walls.
      {"external perimeter", Feature::outer_perimeter},
      {"outer wall", Feature::outer_perimeter},
      {"wall-outer", Feature::outer_perimeter},
      {"outer perimeter", Feature::outer_perimeter},  // Simplify3D
      {"perimeter path", Feature::outer_perimeter},   // KISSlicer (its outermost loop)
      // Inner walls.
      {"perimeter", Feature::perimeter},
      {"inner wall", Feature::perimeter},
      {"wall-inner", Feature::perimeter},
      {"inner perimeter", Feature::perimeter},  // Simplify3D
      {"loop path", Feature::perimeter},        // KISSlicer
      {"thin wall", Feature::perimeter},        // SuperSlicer
      {"overhang perimeter", Feature::overhang_perimeter},
      {"overhang wall", Feature::overhang_perimeter},
      // Infill.
      {"internal infill", Feature::sparse_infill},
      {"sparse infill", Feature::sparse_infill},
      {"fill", Feature::sparse_infill},
      {"infill", Feature::sparse_infill},
      {"sparse infill path", Feature::sparse_infill},  // KISSlicer
      {"stacked sparse infill path", Feature::sparse_infill},
      {"solid infill", Feature::solid_infill},
      {"internal solid infill", Feature::solid_infill},
      {"skin", Feature::solid_infill},         // Cura top/bottom
      {"solid-fill", Feature::solid_infill},   // ideaMaker
      {"solid layer", Feature::solid_infill},  // Simplify3D
      {"solid path", Feature::solid_infill},   // KISSlicer
      {"bottom surface", Feature::solid_infill},
      {"floating vertical shell", Feature::solid_infill},  // Orca
      {"top solid infill", Feature::top_solid_infill},
      {"top surface", Feature::top_solid_infill},
      {"ironing", Feature::top_solid_infill},
      {"crown path", Feature::top_solid_infill},  // KISSlicer top
      {"bridge infill", Feature::bridge_infill},
      {"internal bridge infill", Feature::bridge_infill},
      {"internal bridge", Feature::bridge_infill},
      {"bridge", Feature::bridge_infill},
      {"gap fill", Feature::gap_fill},
      {"gap infill", Feature::gap_fill},
      // Skirt and brim.
      {"skirt", Feature::skirt},
      {"skirt/brim", Feature::skirt},
      {"brim", Feature::skirt},
      {"skirt path", Feature::skirt},  // KISSlicer
      // Support, rafts.
      {"support material", Feature::support},
      {"support", Feature::support},
      {"support-infill", Feature::support},  // Cura 5
      {"support-fill", Feature::support},
      {"support (may stack) path", Feature::support},  // KISSlicer
      {"raft", Feature::support},
      {"raft path", Feature::support},
      {"support material interface", Feature::support_interface},
      {"support-interface", Feature::support_interface},
      {"support interface", Feature::support_interface},
      {"support transition", Feature::support_interface},  // Orca
      {"support interface path", Feature::support_interface},
      {"dense support", Feature::support_interface},  // Simplify3D
      // Wipe and prime towers.
      {"wipe tower", Feature::wipe_tower},
      {"prime tower", Feature::wipe_tower},
      {"prime-tower", Feature::wipe_tower},        // Cura
      {"prime pillar", Feature::wipe_tower},       // Simplify3D
      {"prime pillar path", Feature::wipe_tower},  // KISSlicer
      {"pillar path", Feature::wipe_tower},
      {"ooze shield", Feature::wipe_tower},
      // Start/end code.
      {"custom", Feature::custom},
  };
  for (const auto& e : kTable)
    if (s == e.label) return e.feature;
  if (s.find("outer") != std::string::npos || s.find("external") != std::string::npos)
    if (s.find("perimeter") != std::string::npos || s.find("wall") != std::string::npos)
      return Feature::outer_perimeter;
  if (s.find("perimeter") != std::string::npos || s.find("wall") != std::string::npos)
    return Feature::perimeter;
  if (s.find("infill") != std::string::npos) return Feature::sparse_infill;
  if (s.find("support") != std::string::npos) return Feature::support;
  return Feature::unknown;
}

}  // namespace printtwin
