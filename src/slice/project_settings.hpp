#pragma once
// The per-object settings of a PrusaSlicer 3MF project (Metadata/Slic3r_PE_model.config).
//
// PrusaSlicer keeps a project's print settings in Metadata/Slic3r_PE.config and each
// object's own overrides (the "settings" added to an object in the object list) in
// Metadata/Slic3r_PE_model.config, as <metadata type="object" key=".." value=".."/> rows
// inside <object>, and a part's overrides as type="volume" rows inside its <volume>.
// printtwin slices the part it is given as one body, so it can honour overrides that hold
// for the whole part and must refuse what varies inside it (modifier volumes, negative
// volumes, support blockers and enforcers, layer-range settings, objects that disagree).
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "printtwin/result.hpp"

namespace printtwin::detail {

/// Where PrusaSlicer keeps the objects' own settings and their height-range settings.
inline constexpr std::string_view kProjectModelConfigEntry = "Metadata/Slic3r_PE_model.config";
inline constexpr std::string_view kProjectLayerRangesEntry =
    "Metadata/Prusa_Slicer_layer_config_ranges.xml";

/// The settings that hold for the whole part, in file order: the object's own rows, then
/// those of its one printable part. Every object of the project must state the same
/// settings. Anything that changes settings inside the part is an error naming the object
/// and what printtwin cannot apply. `source` names the archive in errors.
[[nodiscard]] Result<std::vector<std::pair<std::string, std::string>>> project_object_settings(
    std::string_view model_config, std::string_view layer_ranges, const std::string& source);

}  // namespace printtwin::detail
