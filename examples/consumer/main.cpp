// Loads a mesh with printtwin and prints its volume: the README's library example.
#include <cstdio>

#include "printtwin/mesh.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: consumer part.stl\n");
    return 2;
  }
  auto mesh = printtwin::load_mesh(argv[1]);
  if (!mesh) {
    std::fprintf(stderr, "%s\n", mesh.error().describe().c_str());
    return 3;
  }
  std::printf("volume_mm3 %.3f\n", printtwin::signed_volume_mm3(*mesh));
  return 0;
}
