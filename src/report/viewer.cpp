// Data of the layer viewer in report.html: per layer, the mesh's cross-section (simplified
// polylines), the deposit's outer-surface points of that layer and the out-of-tolerance
// mesh samples near it, each point with its signed deviation.
//
// Size matters (report.html < 5 MB for a 200k-triangle part): coordinates are quantised to
// uint16 over the part's XY box, deviations to int8 over the colour scale's range, and the
// arrays travel as base64 strings inside one JSON object.
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "report/report_internal.hpp"

namespace printtwin::detail {

namespace {

struct Packer {
  double x0 = 0, y0 = 0, q = 0.001;
  std::string bytes;
  void u16(unsigned v) {
    bytes += static_cast<char>(v & 0xff);
    bytes += static_cast<char>((v >> 8) & 0xff);
  }
  void xy(const Vec2& p) {
    u16(static_cast<unsigned>(std::clamp(std::lround((p.x() - x0) / q), 0L, 65535L)));
    u16(static_cast<unsigned>(std::clamp(std::lround((p.y() - y0) / q), 0L, 65535L)));
  }
};

std::int8_t quantize_dev(double d, double range) {
  return static_cast<std::int8_t>(std::clamp(std::lround(d / range * 127.0), -127L, 127L));
}

double round_to(double v, double step) { return std::round(v / step) * step; }

/// Layers offered by the viewer (evenly subsampled when there are many).
std::vector<std::size_t> choose_layers(std::size_t layers, int max_viewer_layers) {
  std::vector<std::size_t> chosen;
  const std::size_t max_layers = static_cast<std::size_t>(std::max(max_viewer_layers, 1));
  if (layers <= max_layers) {
    for (std::size_t i = 0; i < layers; ++i) chosen.push_back(i);
  } else {
    for (std::size_t k = 0; k < max_layers; ++k)
      chosen.push_back(k * (layers - 1) / (max_layers - 1));
  }
  return chosen;
}

/// Height of layer i from the layer tops (0.2 mm when implausible).
double layer_height(const std::vector<double>& top, std::size_t i) {
  const double h = i > 0 ? top[i] - top[i - 1] : top[0];
  return (h > 1e-6 && h < 2.0) ? h : 0.2;
}

/// The samples shown per chosen layer: deposit samples by their layer, out-of-tolerance
/// mesh samples by the layer slab their height falls in.
struct LayerSamples {
  std::vector<std::vector<std::uint32_t>> deposit, mesh;
};

LayerSamples samples_by_layer(const DeviationResult& dev, const std::vector<std::size_t>& chosen,
                              const std::vector<double>& top) {
  const auto& per_layer = dev.per_layer;
  // A direct table over the layer numbers: millions of samples are looked up.
  constexpr std::size_t kNotChosen = SIZE_MAX;
  int first_layer = per_layer[chosen.front()].layer, last_layer = first_layer;
  for (std::size_t k : chosen) {
    first_layer = std::min(first_layer, per_layer[k].layer);
    last_layer = std::max(last_layer, per_layer[k].layer);
  }
  std::vector<std::size_t> chosen_at(static_cast<std::size_t>(last_layer - first_layer) + 1,
                                     kNotChosen);
  for (std::size_t k = 0; k < chosen.size(); ++k)
    chosen_at[static_cast<std::size_t>(per_layer[chosen[k]].layer - first_layer)] = k;
  auto chosen_of = [&](int layer) {
    if (layer < first_layer || layer > last_layer) return kNotChosen;
    return chosen_at[static_cast<std::size_t>(layer - first_layer)];
  };
  LayerSamples out{std::vector<std::vector<std::uint32_t>>(chosen.size()),
                   std::vector<std::vector<std::uint32_t>>(chosen.size())};
  for (std::uint32_t i = 0; i < dev.deposit_samples.size(); ++i) {
    const std::size_t k = chosen_of(dev.deposit_samples.tags[i].layer);
    if (k != kNotChosen) out.deposit[k].push_back(i);
  }
  for (std::uint32_t i = 0; i < dev.mesh_samples.size(); ++i) {
    if (!(std::abs(dev.mesh_samples.distances_mm[i]) > dev.tolerance_mm)) continue;
    const double z = dev.mesh_samples.positions_mm[i].z();
    const auto it = std::lower_bound(top.begin(), top.end(), z - 1e-9);
    if (it == top.end()) continue;
    const std::size_t li = static_cast<std::size_t>(it - top.begin());
    if (z < top[li] - layer_height(top, li) - 1e-9) continue;
    const std::size_t k = chosen_of(per_layer[li].layer);
    if (k != kNotChosen) out.mesh[k].push_back(i);
  }
  return out;
}

/// Cross-section polylines: [count, (n, x, y, x, y, ...)...] as uint16, base64.
std::string pack_sections(const Packer& frame, const std::vector<std::vector<Vec2>>& polys) {
  Packer loops = frame;
  std::size_t nloops = 0;
  for (const auto& poly : polys)
    for (std::size_t start = 0; start + 1 < poly.size(); start += 65534) nloops++;
  loops.u16(static_cast<unsigned>(std::min<std::size_t>(nloops, 65535)));
  for (const auto& poly : polys) {
    for (std::size_t start = 0; start + 1 < poly.size(); start += 65534) {
      const std::size_t end = std::min(poly.size(), start + 65535);
      loops.u16(static_cast<unsigned>(end - start));
      for (std::size_t i = start; i < end; ++i) loops.xy(poly[i]);
    }
  }
  return base64(loops.bytes);
}

/// At most `cap` of the samples `idx` (evenly strided): positions and quantised deviations.
void pack_points(const Packer& frame, const DeviationColorScale& scale, const DeviationSamples& all,
                 const std::vector<std::uint32_t>& idx, std::size_t cap, std::string& xy_b64,
                 std::string& d_b64) {
  Packer xy = frame;
  std::string d;
  const std::size_t stride = idx.size() > cap ? (idx.size() + cap - 1) / cap : 1;
  for (std::size_t i = 0; i < idx.size(); i += stride) {
    const Vec3& at = all.positions_mm[idx[i]];
    xy.xy(Vec2(at.x(), at.y()));
    d += static_cast<char>(quantize_dev(all.distances_mm[idx[i]], scale.range_mm));
  }
  xy_b64 = base64(xy.bytes);
  d_b64 = base64(d);
}

/// A layer's figures: worst excess, worst deficit, RMS of both directions, within tolerance.
nlohmann::json layer_summary(const LayerDeviation& ld) {
  double excess = 0, deficit = 0, ss = 0;
  std::size_t n = 0;
  for (const DeviationStats* s : {&ld.deposit_to_mesh, &ld.mesh_to_deposit}) {
    if (s->samples == 0) continue;
    excess = std::max(excess, s->max_mm);
    deficit = std::min(deficit, s->min_mm);
    ss += s->rms_mm * s->rms_mm * static_cast<double>(s->samples);
    n += s->samples;
  }
  return {round_to(excess, 1e-4), round_to(deficit, 1e-4),
          round_to(n > 0 ? std::sqrt(ss / static_cast<double>(n)) : 0.0, 1e-4),
          round_to(ld.deposit_to_mesh.within_tolerance_pct, 0.01)};
}

/// Colour lookup table over [-range, +range] (256 entries, RGB), the same scale as the images.
std::string colour_lut(const DeviationColorScale& scale) {
  std::string lut;
  for (int i = 0; i < 256; ++i) {
    const auto c = scale.color((i / 127.5 - 1.0) * scale.range_mm);
    lut.append(reinterpret_cast<const char*>(c.data()), 3);
  }
  return lut;
}

nlohmann::json regions_json(const DeviationResult& dev) {
  nlohmann::json regions = nlohmann::json::array();
  for (const auto& r : dev.regions) {
    regions.push_back({{"k", std::string(region_kind_name(r.kind))},
                       {"l0", r.layer_min},
                       {"l1", r.layer_max},
                       {"b",
                        {round_to(r.bbox_mm.min.x(), 1e-3), round_to(r.bbox_mm.min.y(), 1e-3),
                         round_to(r.bbox_mm.max.x(), 1e-3), round_to(r.bbox_mm.max.y(), 1e-3)}},
                       {"w", round_to(r.worst_mm, 1e-4)}});
  }
  return regions;
}

}  // namespace

std::string viewer_json(const VerifyReport& report, const DeviationColorScale& scale,
                        const ReportOptions& options) {
  const auto& dev = report.deviation;
  const auto& per_layer = dev.per_layer;
  nlohmann::json j;
  if (per_layer.empty()) {
    j["layers"] = nlohmann::json::array();
    return j.dump();
  }

  const std::vector<std::size_t> chosen =
      choose_layers(per_layer.size(), options.max_viewer_layers);
  // Layer tops (z_mm) and heights; the cut is taken at mid-layer.
  std::vector<double> top(per_layer.size()), cut_z(chosen.size());
  for (std::size_t i = 0; i < per_layer.size(); ++i) top[i] = per_layer[i].z_mm;
  for (std::size_t k = 0; k < chosen.size(); ++k)
    cut_z[k] = top[chosen[k]] - 0.5 * layer_height(top, chosen[k]);
  const auto sections = cut_mesh(report.placed_mesh, cut_z, options.section_simplify_mm);

  // XY frame of the quantisation: mesh and deposit part boxes.
  Box3 box = bounding_box(report.placed_mesh);
  box.extend(report.deposit.part_bbox_mm);
  if (box.empty()) box.extend(Vec3::Zero());
  const double pad = 1.0;
  Packer frame;
  frame.x0 = std::floor(box.min.x() - pad);
  frame.y0 = std::floor(box.min.y() - pad);
  const double extent = std::max(box.max.x() - frame.x0, box.max.y() - frame.y0) + pad;
  frame.q = std::max(extent / 65000.0, 0.0005);

  const LayerSamples samples = samples_by_layer(dev, chosen, top);
  const std::size_t per_layer_cap = std::max<std::size_t>(
      200, options.max_viewer_points / std::max<std::size_t>(chosen.size(), 1));
  const std::size_t mesh_cap = std::max<std::size_t>(100, per_layer_cap / 2);
  nlohmann::json layers = nlohmann::json::array();
  for (std::size_t k = 0; k < chosen.size(); ++k) {
    const LayerDeviation& ld = per_layer[chosen[k]];
    std::string p, pd, m, md;
    pack_points(frame, scale, dev.deposit_samples, samples.deposit[k], per_layer_cap, p, pd);
    pack_points(frame, scale, dev.mesh_samples, samples.mesh[k], mesh_cap, m, md);
    nlohmann::json l;
    l["l"] = ld.layer;
    l["z"] = round_to(ld.z_mm, 1e-4);
    l["c"] = pack_sections(frame, sections[k]);
    l["p"] = p;
    l["pd"] = pd;
    l["m"] = m;
    l["md"] = md;
    l["np"] = samples.deposit[k].size();
    l["s"] = layer_summary(ld);
    layers.push_back(std::move(l));
  }

  j["x0"] = frame.x0;
  j["y0"] = frame.y0;
  j["q"] = frame.q;
  j["ext"] = {round_to(box.min.x(), 1e-3), round_to(box.min.y(), 1e-3), round_to(box.max.x(), 1e-3),
              round_to(box.max.y(), 1e-3)};
  j["voxel"] = report.deposit.voxel_mm > 0 ? report.deposit.voxel_mm : report.settings.voxel_mm;
  j["tol"] = scale.tolerance_mm;
  j["range"] = scale.range_mm;
  j["lut"] = base64(colour_lut(scale));
  j["layers"] = std::move(layers);
  j["regions"] = regions_json(dev);
  j["total_layers"] = per_layer.size();
  return j.dump();
}

}  // namespace printtwin::detail
