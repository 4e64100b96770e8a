// libFuzzer target: arbitrary bytes through load_mesh_from_memory, in every mesh format.
// The first byte picks the format (by the extension the bytes are read as); the rest is the
// file. A load must either fail with a message or give a mesh whose triangles index its
// vertices and whose coordinates are finite; anything else traps.
#include <array>
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "printtwin/mesh.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  static constexpr std::array<const char*, 6> kNames = {"f.stl", "f.obj", "f.ply",
                                                        "f.off", "f.3mf", "f.amf"};
  const char* name = kNames[data[0] % kNames.size()];
  const std::string_view bytes(reinterpret_cast<const char*>(data + 1), size - 1);
  auto mesh = printtwin::load_mesh_from_memory(bytes, name);
  if (!mesh) {
    if (mesh.error().message.empty()) __builtin_trap();
    return 0;
  }
  if (mesh->triangles.empty()) __builtin_trap();
  for (const auto& t : mesh->triangles)
    for (auto v : t)
      if (v >= mesh->vertices_mm.size()) __builtin_trap();
  for (const auto& v : mesh->vertices_mm)
    if (!v.allFinite()) __builtin_trap();
  return 0;
}
