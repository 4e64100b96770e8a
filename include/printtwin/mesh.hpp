#pragma once
// Mesh: the triangle mesh every stage reads. Loaded through assimp (src/mesh/mesh_io_assimp.cpp,
// the only file that includes assimp), with identical vertices joined so that closedness
// and orientation can be checked.
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "printtwin/geometry.hpp"
#include "printtwin/result.hpp"

namespace printtwin {

/// Indexed triangle mesh.
/// - `vertices_mm`: positions in millimetres.
/// - `triangles`: indices into `vertices_mm`, counter-clockwise seen from outside
///   (outward normals by the right-hand rule) for a well-formed solid.
/// Nothing is guaranteed about closedness or manifoldness: `check_mesh` reports it.
struct Mesh {
  std::vector<Vec3> vertices_mm;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  bool operator==(const Mesh&) const = default;
};

enum class LengthUnit { mm, cm, inch };

struct MeshLoadOptions {
  double scale = 1.0;                 ///< extra uniform scale applied after the unit conversion
  LengthUnit units = LengthUnit::mm;  ///< unit the file is written in
};

/// Loads STL (ASCII/binary), OBJ, PLY, OFF, 3MF or AMF. All meshes in the file are merged.
/// Errors (exit 3 in the CLI) name the file and the problem: empty, truncated, NaN/inf
/// coordinates, unknown extension, directory, unreadable, no triangles.
[[nodiscard]] Result<Mesh> load_mesh(const std::filesystem::path& path,
                                     const MeshLoadOptions& options = {});

/// The same from bytes already in memory (e.g. read once to be hashed and then parsed):
/// `name` gives the format by its extension and names the file in errors. The file is not
/// opened. Same result and the same errors as load_mesh on a file holding `bytes`, except
/// the file-system ones (missing, directory, unreadable).
[[nodiscard]] Result<Mesh> load_mesh_from_memory(std::string_view bytes,
                                                 const std::filesystem::path& name,
                                                 const MeshLoadOptions& options = {});

/// The checks of a mesh file that need only its size and first bytes (a binary STL's
/// triangle count against the file size): load_mesh runs them before reading the body, and
/// a caller that reads the file itself (to hash it) can run them first too.
[[nodiscard]] Status check_mesh_file_header(const std::filesystem::path& path);

/// Writes a binary STL (temporary file + rename).
[[nodiscard]] Status save_stl(const Mesh& mesh, const std::filesystem::path& path);

[[nodiscard]] Box3 bounding_box(const Mesh& mesh);
/// Signed volume by the divergence theorem; negative for an inside-out closed mesh.
[[nodiscard]] double signed_volume_mm3(const Mesh& mesh);
[[nodiscard]] double surface_area_mm2(const Mesh& mesh);
/// Unnormalised normal (cross product) of triangle `t`; its norm is twice the area.
[[nodiscard]] Vec3 triangle_normal(const Mesh& mesh, std::size_t t);
/// Whether triangle_normal(mesh, t) is a direction to rely on: false for slivers, whose cross
/// product of nearly parallel edges is mostly rounding (|n| < 1e-6 x the longest edge
/// squared: beyond that the direction's error, ~1e-16 L^2 / |n|, stays below 1e-10 rad), and
/// for degenerate or non-finite triangles.
[[nodiscard]] bool has_reliable_normal(const Mesh& mesh, std::size_t t);

/// Moves the mesh as a slicer places it: lowest point at z = 0, bounding-box centre at
/// (center_x_mm, center_y_mm).
[[nodiscard]] Mesh place_on_bed(Mesh mesh, double center_x_mm, double center_y_mm);
/// Translates every vertex.
[[nodiscard]] Mesh translated(Mesh mesh, const Vec3& offset_mm);

/// Axis-aligned box [min, max] as a closed, outward-oriented 12-triangle mesh.
[[nodiscard]] Mesh make_box_mesh(const Vec3& min_mm, const Vec3& max_mm);

}  // namespace printtwin
