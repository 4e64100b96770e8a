// Area-uniform, seeded, deterministic sampling of a mesh surface.
#include <unistd.h>
#include <algorithm>
#include <cmath>

#include "printtwin/io.hpp"

#include "printtwin/deviation.hpp"

namespace printtwin {

namespace {

/// splitmix64 (Steele, Lea, Flood 2014): a tiny generator with a fixed output on every
/// platform, so samples are the same everywhere for a seed.
struct SplitMix64 {
  std::uint64_t state;
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
  }
  /// Uniform in [0, 1) with 53 random bits.
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
};

}  // namespace

// Bytes per sample through the deviation: the sample, its query point, its closest point,
// distance and group entries (measured arrays of verify, rounded up).
constexpr double kBytesPerSample = 128;

Status check_sample_budget(const Mesh& mesh, double spacing_mm) {
  if (!(spacing_mm > 0) || mesh.triangles.empty()) return Ok{};
  const double area = surface_area_mm2(mesh);
  const double samples = area / (spacing_mm * spacing_mm);
  const double bytes = samples * kBytesPerSample;
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGE_SIZE);
  const double limit =
      pages > 0 && page > 0 ? static_cast<double>(pages) * static_cast<double>(page) : 64.0e9;
  if (std::isfinite(bytes) && bytes <= limit) return Ok{};
  const double fitting_spacing =
      spacing_mm * std::sqrt(std::isfinite(bytes) ? bytes / (0.5 * limit) : 1e30);
  return bad_input("the mesh's surface (" + format_fixed(area, 0) +
                   " mm2) at a sample spacing of " + format_number(spacing_mm) + " mm needs " +
                   format_fixed(samples, 0) + " samples, about " + format_fixed(bytes / 1e9, 1) +
                   " GB, more than this computer's " + format_fixed(limit / 1e9, 1) +
                   " GB of memory; use a sample spacing of at least " +
                   format_fixed(fitting_spacing, 2) + " mm");
}

std::vector<SurfaceSample> sample_surface(const Mesh& mesh, double spacing_mm, std::uint64_t seed) {
  std::vector<SurfaceSample> out;
  if (!(spacing_mm > 0) || mesh.triangles.empty()) return out;
  const double per_mm2 = 1.0 / (spacing_mm * spacing_mm);
  // Clamped: a count beyond any memory (check_sample_budget refuses those first) must not
  // overflow the conversion.
  out.reserve(static_cast<std::size_t>(std::min(surface_area_mm2(mesh) * per_mm2 * 1.05, 1.0e9)) +
              16);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    const Vec3& a = mesh.vertices_mm[tri[0]];
    const Vec3& b = mesh.vertices_mm[tri[1]];
    const Vec3& c = mesh.vertices_mm[tri[2]];
    const double area = 0.5 * (b - a).cross(c - a).norm();
    if (!(area > 0)) continue;
    // One stream per triangle: the samples of a triangle do not depend on the others.
    SplitMix64 rng{seed * 0xD1B54A32D192ED03ULL + t * 0x9E3779B97F4A7C15ULL + 1};
    const double expected = std::min(area * per_mm2, 1.0e12);
    auto n = static_cast<std::size_t>(expected);
    if (rng.uniform() < expected - static_cast<double>(n)) ++n;
    for (std::size_t i = 0; i < n; ++i) {
      // Uniform point in a triangle: sqrt warp (Osada et al. 2002, "Shape distributions").
      const double r1 = std::sqrt(rng.uniform());
      const double r2 = rng.uniform();
      const Vec3 p = (1.0 - r1) * a + r1 * (1.0 - r2) * b + r1 * r2 * c;
      out.push_back({p, static_cast<std::uint32_t>(t)});
    }
  }
  return out;
}

}  // namespace printtwin
