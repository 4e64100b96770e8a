// Unit guess from a mesh's size (`--units auto`) and how a part too big for the printer fits.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "check/check_internal.hpp"
#include "printtwin/check.hpp"
#include "printtwin/io.hpp"

namespace printtwin {

std::optional<UnitGuess> guess_mesh_units(const Mesh& mesh) {
  if (mesh.triangles.empty()) return std::nullopt;
  // Pieces = faces connected through shared vertices (cheaper than the edge-based shells of
  // analyze_mesh_health, and the same for sizing: stray facets share no vertex with the part).
  const std::size_t nv = mesh.vertices_mm.size();
  detail::UnionFind pieces(nv);
  std::vector<char> used(nv, 0);
  for (const auto& t : mesh.triangles) {
    pieces.unite(t[0], t[1]);
    pieces.unite(t[0], t[2]);
    used[t[0]] = used[t[1]] = used[t[2]] = 1;
  }
  // Each piece's box over its vertices (each once, not once per corner).
  std::vector<Box3> boxes(nv);
  for (std::uint32_t v = 0; v < nv; ++v)
    if (used[v] != 0) boxes[pieces.find(v)].extend(mesh.vertices_mm[v]);
  double size = 0;
  for (const Box3& b : boxes)
    if (!b.empty()) size = std::max(size, b.size().maxCoeff());
  if (!(size > 0)) return std::nullopt;
  UnitGuess g;
  g.size_units = size;
  if (size < 0.3) {
    g.unit = "m";
    g.mm_per_unit = 1000.0;
  } else if (size < 3.0) {
    g.unit = "in";
    g.mm_per_unit = 25.4;
  } else {
    return std::nullopt;
  }
  return g;
}

Finding units_guessed_finding(const UnitGuess& g, const Vec3& size_mm) {
  const std::string name = g.unit == "m" ? "metres" : "inches";
  const std::string why = "too small";
  std::string msg = "the largest part is " + format_fixed(g.size_units, 4) + " units across, " +
                    why + " for millimetres: read as " + name + " (x" +
                    format_fixed(g.mm_per_unit, 3) + "), " + format_fixed(size_mm.x(), 2) + " x " +
                    format_fixed(size_mm.y(), 2) + " x " + format_fixed(size_mm.z(), 2) + " mm; ";
  if (g.unit == "in") msg += "if it is in centimetres give --units cm, ";
  msg += "--units mm keeps the file's numbers";
  Finding f;
  f.severity = Severity::warning;
  f.code = "units_guessed";
  f.message = std::move(msg);
  f.value = g.mm_per_unit;
  return f;
}

FitAdvice advise_fit(const Vec3& s, const PrinterProfile& printer) {
  const Vec3 bed(printer.bed_max_x_mm - printer.bed_min_x_mm,
                 printer.bed_max_y_mm - printer.bed_min_y_mm, printer.max_z_mm);
  // The six ways the axes can point (each with its quarter turns; z-turns swap x and y).
  struct Way {
    const char* rotation;
    Vec3 size;
  };
  const std::array<Way, 6> ways = {
      {{"", s},
       {"rotated 90 deg about Z", Vec3(s.y(), s.x(), s.z())},
       {"rotated 90 deg about X", Vec3(s.x(), s.z(), s.y())},
       {"rotated 90 deg about Y", Vec3(s.z(), s.y(), s.x())},
       {"rotated 90 deg about X, then 90 deg about Z", Vec3(s.z(), s.x(), s.y())},
       {"rotated 90 deg about Y, then 90 deg about Z", Vec3(s.y(), s.z(), s.x())}}};
  FitAdvice best;
  best.scale = -1;
  for (const Way& w : ways) {
    double scale = 1.0;
    for (int i = 0; i < 3; ++i)
      if (w.size[i] > 0) scale = std::min(scale, bed[i] / w.size[i]);
    scale = std::floor(scale * 1000.0) / 1000.0;  // rounded down: the scaled part fits
    // Prefer a lower part when the scale ties (steadier, shorter print).
    if (scale > best.scale + 1e-12 ||
        (std::abs(scale - best.scale) <= 1e-12 && w.size.z() < best.size_mm.z() / best.scale)) {
      best.scale = scale;
      best.rotation = w.rotation;
      best.size_mm = scale * w.size;
    }
  }
  best.fits_as_is = best.scale >= 1.0 && best.rotation.empty();
  return best;
}

}  // namespace printtwin
