#pragma once
// Colours of deposit exports: by layer (hues stepped by the golden angle, so neighbouring
// layers differ) and by feature (close to PrusaSlicer's preview colours).
#include <array>
#include <cmath>
#include <cstdint>

#include "printtwin/toolpath.hpp"

namespace printtwin::deposit_detail {

struct Rgb {
  std::uint8_t r = 0, g = 0, b = 0;
};

inline Rgb layer_color(int layer) {
  const double hue = std::fmod(std::max(layer, 0) * 0.618033988749895, 1.0) * 6.0;
  const int sector = static_cast<int>(hue) % 6;
  const double f = hue - std::floor(hue);
  const double v = 0.95, s = 0.75;
  const double p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
  double r = v, g = t, b = p;
  switch (sector) {
    case 0:
      r = v, g = t, b = p;
      break;
    case 1:
      r = q, g = v, b = p;
      break;
    case 2:
      r = p, g = v, b = t;
      break;
    case 3:
      r = p, g = q, b = v;
      break;
    case 4:
      r = t, g = p, b = v;
      break;
    default:
      r = v, g = p, b = q;
      break;
  }
  auto byte = [](double x) { return static_cast<std::uint8_t>(std::lround(x * 255.0)); };
  return {byte(r), byte(g), byte(b)};
}

inline Rgb feature_color(Feature f) {
  static constexpr std::array<Rgb, static_cast<std::size_t>(Feature::count_)> kColors = {{
      {128, 128, 128},  // unknown
      {255, 125, 56},   // outer_perimeter
      {255, 230, 77},   // perimeter
      {0, 0, 255},      // overhang_perimeter
      {176, 48, 41},    // sparse_infill
      {150, 84, 204},   // solid_infill
      {240, 64, 64},    // top_solid_infill
      {77, 128, 186},   // bridge_infill
      {255, 255, 255},  // gap_fill
      {0, 135, 110},    // skirt
      {0, 255, 0},      // support
      {18, 200, 18},    // support_interface
      {179, 227, 171},  // wipe_tower
      {94, 209, 148},   // custom
  }};
  const auto i = static_cast<std::size_t>(f);
  return i < kColors.size() ? kColors[i] : kColors[0];
}

}  // namespace printtwin::deposit_detail
