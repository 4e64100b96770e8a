// The only file that includes assimp: loads any supported mesh format into a Mesh.
#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <cmath>
#include <filesystem>

#include "printtwin/io.hpp"
#include "printtwin/mesh.hpp"

namespace printtwin {

namespace fs = std::filesystem;

Result<Mesh> load_mesh(const fs::path& path, const MeshLoadOptions& options) {
  const std::string name = path.string();
  auto bytes = read_file(path);  // existence, directory and readability errors
  if (!bytes) return bytes.error();
  if (bytes->empty()) return bad_input("empty file, expected a mesh", name);

  Assimp::Importer importer;
  // Join identical vertices: without it an STL is a soup of loose triangles.
  const unsigned flags = aiProcess_JoinIdenticalVertices | aiProcess_Triangulate |
                         aiProcess_PreTransformVertices;
  const aiScene* scene = importer.ReadFileFromMemory(bytes->data(), bytes->size(), flags,
                                                     path.extension().string().c_str() + 1);
  if (scene == nullptr) return bad_input(std::string("cannot read mesh: ") + importer.GetErrorString(), name);

  double unit = 1.0;
  if (options.units == LengthUnit::cm) unit = 10.0;
  if (options.units == LengthUnit::inch) unit = 25.4;
  const double s = unit * options.scale;

  Mesh mesh;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* am = scene->mMeshes[m];
    const auto base = static_cast<std::uint32_t>(mesh.vertices_mm.size());
    for (unsigned v = 0; v < am->mNumVertices; ++v) {
      const aiVector3D& p = am->mVertices[v];
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
        return bad_input("vertex " + std::to_string(v) + " has a NaN or infinite coordinate", name);
      mesh.vertices_mm.emplace_back(s * p.x, s * p.y, s * p.z);
    }
    for (unsigned f = 0; f < am->mNumFaces; ++f) {
      const aiFace& face = am->mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines carry no volume
      mesh.triangles.push_back({base + face.mIndices[0], base + face.mIndices[1], base + face.mIndices[2]});
    }
  }
  if (mesh.triangles.empty()) return bad_input("the mesh has no triangles", name);
  return mesh;
}

}  // namespace printtwin
