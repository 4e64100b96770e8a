#pragma once
// 3MF packages, read by printtwin itself: the zip entries, a small XML tag scanner, the
// root model found through _rels/.rels, objects' meshes and components (within one model
// file or, with the production extension's p:path, across the archive's model files, as
// Bambu Studio and OrcaSlicer save their projects) followed to any depth with their
// transforms composed, the build items placed. The slicers' own part types are honoured:
// PrusaSlicer's volumes (Metadata/Slic3r_PE_model.config) and Bambu Studio / OrcaSlicer's
// parts (Metadata/model_settings.config) that are modifiers, negative volumes or support
// blockers/enforcers are left out.
#include <string>
#include <string_view>

#include "printtwin/mesh.hpp"
#include "printtwin/result.hpp"

namespace printtwin::detail {

/// The triangles of every printed build item of the 3MF package `archive`, in millimetres
/// (the model's unit converted) times `scale`, each item's copy with its own vertices (not
/// welded). Left out: build items marked printable="0" (an object the user disabled in
/// Bambu Studio / OrcaSlicer), objects of type "support" or "other", and the slicers'
/// modifier, negative and support parts. `name` names the file in errors; each error also
/// names the archive entry.
[[nodiscard]] Result<Mesh> read_3mf(std::string_view archive, double scale,
                                    const std::string& name);

}  // namespace printtwin::detail
