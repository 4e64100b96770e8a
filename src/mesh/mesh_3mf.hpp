#pragma once
// 3MF packages whose root model places objects kept in other model files of the archive
// (the 3MF production extension: <component p:path="/3D/Objects/object_1.model" .../>), as
// Bambu Studio and OrcaSlicer save their projects. assimp does not follow p:path, so such a
// package is read here: the zip entries, a small XML tag scanner, components followed to any
// depth with their transforms composed, the build items placed. Packages without p:path
// (PrusaSlicer's, Cura's) stay with assimp.
#include <optional>
#include <string>
#include <string_view>

#include "printtwin/mesh.hpp"
#include "printtwin/result.hpp"

namespace printtwin::detail {

/// The triangles of every printed build item of the 3MF package `archive`, in millimetres
/// (the model's unit converted) times `scale`, each item's copy with its own vertices (not
/// welded). nullopt when the root model references no other model file (assimp reads such
/// a package). Left out: build items marked printable="0" (an object the user disabled in
/// Bambu Studio / OrcaSlicer) and objects of type "support" or "other". `name` names the
/// file in errors; each error also names the archive entry.
[[nodiscard]] Result<std::optional<Mesh>> read_3mf_with_components(std::string_view archive,
                                                                   double scale,
                                                                   const std::string& name);

}  // namespace printtwin::detail
