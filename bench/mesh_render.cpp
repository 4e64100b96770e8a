// Renders a mesh (or the part of it inside a box) to a PNG with the report's renderer, for
// the pictures of docs/deposit.md (the as-printed mesh of --deposit-mesh).
//   mesh_render MESH OUT.png DX DY DZ [XMIN YMIN ZMIN XMAX YMAX ZMAX] [WIDTH_PX]
// (DX, DY, DZ): the viewing direction; the box keeps the triangles with every vertex inside.
#include <array>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "printtwin/io.hpp"
#include "printtwin/mesh.hpp"
#include "printtwin/report.hpp"

int main(int argc, char** argv) {
  using namespace printtwin;
  if (argc != 6 && argc != 12 && argc != 13) {
    std::fprintf(
        stderr,
        "usage: mesh_render MESH OUT.png DX DY DZ [XMIN YMIN ZMIN XMAX YMAX ZMAX] [WIDTH]\n");
    return 2;
  }
  auto mesh = load_mesh(argv[1]);
  if (!mesh) {
    std::fprintf(stderr, "%s\n", mesh.error().describe().c_str());
    return 1;
  }
  Mesh m = std::move(*mesh);
  if (argc >= 12) {
    const Vec3 lo(std::atof(argv[6]), std::atof(argv[7]), std::atof(argv[8]));
    const Vec3 hi(std::atof(argv[9]), std::atof(argv[10]), std::atof(argv[11]));
    Mesh crop;
    std::vector<std::uint32_t> remap(m.vertices_mm.size(), ~0U);
    for (const auto& t : m.triangles) {
      bool in = true;
      for (const auto v : t) {
        const Vec3& p = m.vertices_mm[v];
        in = in && (p.array() >= lo.array()).all() && (p.array() <= hi.array()).all();
      }
      if (!in) continue;
      std::array<std::uint32_t, 3> kept{};
      for (int k = 0; k < 3; ++k) {
        std::uint32_t& r = remap[t[static_cast<std::size_t>(k)]];
        if (r == ~0U) {
          r = static_cast<std::uint32_t>(crop.vertices_mm.size());
          crop.vertices_mm.push_back(m.vertices_mm[t[static_cast<std::size_t>(k)]]);
        }
        kept[static_cast<std::size_t>(k)] = r;
      }
      crop.triangles.push_back(kept);
    }
    m = std::move(crop);
  }
  ViewSpec view;
  view.name = "mesh";
  view.direction = Vec3(std::atof(argv[3]), std::atof(argv[4]), std::atof(argv[5])).normalized();
  view.up = std::abs(view.direction.z()) > 0.9 ? Vec3(0, 1, 0) : Vec3(0, 0, 1);
  view.width_px = view.height_px = argc == 13 ? std::atoi(argv[12]) : 480;
  const std::vector<double> zero(m.vertices_mm.size(), 0.0);
  SurfaceDeviationField field;
  field.vertex_deviation_mm = zero;
  const HeatmapView hv = render_heatmap(m, field, DeviationColorScale{}, view);
  auto png = encode_png(hv.image);
  if (!png) {
    std::fprintf(stderr, "%s\n", png.error().describe().c_str());
    return 1;
  }
  if (auto st = write_file_atomic(argv[2], *png); !st) {
    std::fprintf(stderr, "%s\n", st.error().describe().c_str());
    return 1;
  }
  std::printf("%s: %zu triangles, %d x %d px\n", argv[2], m.triangles.size(), hv.image.width,
              hv.image.height);
  return 0;
}
