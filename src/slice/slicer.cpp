// slice_mesh(): placement, slicing, toolpaths, G-code, findings and the footer.
#include <algorithm>
#include <cmath>
#include <numbers>

#include <sstream>

#include "printtwin/check.hpp"
#include "printtwin/io.hpp"
#include "printtwin/simulate.hpp"
#include "slice/slice_internal.hpp"

namespace printtwin {

using namespace slice_detail;

namespace {

// Merges the per-layer dropped thin features into findings: the same feature on
// consecutive layers (overlapping footprints) is one finding with a layer range.
std::vector<Finding> dropped_findings(const std::vector<LayerToolpaths>& layers,
                                      double min_width_mm) {
  struct Group {
    DroppedFeature box;  // union of footprints
    int first = 0, last = 0;
    double min_w = 1e9, max_w = 0, area = 0;
    long count = 0;
  };
  std::vector<Group> groups;
  for (const auto& layer : layers) {
    for (const auto& d : layer.dropped) {
      Group* g = nullptr;
      for (auto& cand : groups) {
        if (cand.last + 1 < d.layer) continue;
        const bool overlap =
            d.min_x_mm <= cand.box.max_x_mm + 0.5 && d.max_x_mm >= cand.box.min_x_mm - 0.5 &&
            d.min_y_mm <= cand.box.max_y_mm + 0.5 && d.max_y_mm >= cand.box.min_y_mm - 0.5;
        if (overlap) {
          g = &cand;
          break;
        }
      }
      if (g == nullptr) {
        groups.push_back(Group{d, d.layer, d.layer, 1e9, 0, 0, 0});
        g = &groups.back();
      }
      g->box.min_x_mm = std::min(g->box.min_x_mm, d.min_x_mm);
      g->box.min_y_mm = std::min(g->box.min_y_mm, d.min_y_mm);
      g->box.max_x_mm = std::max(g->box.max_x_mm, d.max_x_mm);
      g->box.max_y_mm = std::max(g->box.max_y_mm, d.max_y_mm);
      g->last = std::max(g->last, d.layer);
      g->min_w = std::min(g->min_w, d.width_mm);
      g->max_w = std::max(g->max_w, d.width_mm);
      g->area += d.area_mm2 * layers[static_cast<std::size_t>(d.layer)].height_mm;  // mm3
      ++g->count;
    }
  }
  std::vector<Finding> out;
  for (const auto& g : groups) {
    Finding f;
    f.severity = Severity::warning;
    f.code = "thin_wall_dropped";
    const double z0 = layers[static_cast<std::size_t>(g.first)].print_z_mm -
                      layers[static_cast<std::size_t>(g.first)].height_mm;
    const double z1 = layers[static_cast<std::size_t>(g.last)].print_z_mm;
    f.message = "a feature " + format_fixed(g.min_w, 2) + " mm wide (narrower than the " +
                format_fixed(min_width_mm, 2) + " mm minimum line) is not printed on layers " +
                std::to_string(g.first) + " to " + std::to_string(g.last) + " (z " +
                format_fixed(z0, 2) + " to " + format_fixed(z1, 2) + " mm), " +
                format_fixed(g.area, 2) + " mm3 missing";
    f.position_mm =
        Vec3(0.5 * (g.box.min_x_mm + g.box.max_x_mm), 0.5 * (g.box.min_y_mm + g.box.max_y_mm), z0);
    Box3 b;
    b.extend(Vec3(g.box.min_x_mm, g.box.min_y_mm, z0));
    b.extend(Vec3(g.box.max_x_mm, g.box.max_y_mm, z1));
    f.extent_mm = b;
    f.layer = g.first;
    f.value = g.min_w;
    f.count = g.last - g.first + 1;
    out.push_back(std::move(f));
  }
  return out;
}

}  // namespace

Result<SliceOutput> slice_mesh(const Mesh& mesh, const PrinterProfile& printer,
                               const SliceSettings& settings) {
  if (auto ok = validate_slice_settings(settings); !ok) return ok.error();
  if (mesh.triangles.empty()) return bad_input("the mesh has no triangles");
  SliceOutput output;
  output.findings.clear();

  // Placement: centred on the bed (or --center), lowest point on z = 0; --place keeps the
  // mesh's own frame shifted by the given offset.
  Mesh placed;
  const Box3 in_box = bounding_box(mesh);
  if (settings.place_offset_mm) {
    placed = translated(mesh, *settings.place_offset_mm);
  } else {
    const Vec2 c =
        settings.center_mm.value_or(Vec2(printer.bed_center_x_mm(), printer.bed_center_y_mm()));
    placed = place_on_bed(mesh, c.x(), c.y());
  }
  const Box3 box = bounding_box(placed);
  output.stats.placement_offset_mm = box.min - in_box.min;
  if (box.min.z() > 1e-3)
    return bad_input("the placed part floats " + format_fixed(box.min.z(), 3) +
                     " mm above the bed (use --center or a --place offset that puts it on z = 0)");
  const double eps = 1e-6;
  if (box.min.x() < printer.bed_min_x_mm - eps || box.min.y() < printer.bed_min_y_mm - eps ||
      box.max.x() > printer.bed_max_x_mm + eps || box.max.y() > printer.bed_max_y_mm + eps ||
      box.max.z() > printer.max_z_mm + eps) {
    return bad_input("the part (" + format_fixed(box.size().x(), 2) + " x " +
                     format_fixed(box.size().y(), 2) + " x " + format_fixed(box.size().z(), 2) +
                     " mm, placed at x " + format_fixed(box.min.x(), 2) + ".." +
                     format_fixed(box.max.x(), 2) + ", y " + format_fixed(box.min.y(), 2) + ".." +
                     format_fixed(box.max.y(), 2) + ") does not fit the build volume of " +
                     printer.name);
  }

  auto gaps_of = [](const std::vector<LayerOutline>& layers) {
    long g = 0;
    for (const auto& l : layers) g += l.closed_gaps;
    return g;
  };
  auto outlines = slice_layers(placed, settings);
  const long gaps = outlines ? gaps_of(*outlines) : -1;
  if (!outlines || gaps > 0) {
    // Not closed: try CGAL's repair (check.hpp) and keep whichever slices cleaner.
    auto repaired = repair_mesh(placed);
    bool use_repaired = false;
    if (repaired && repaired->after.closed) {
      auto again = slice_layers(repaired->mesh, settings);
      if (again && (!outlines || gaps_of(*again) <= gaps)) {
        outlines = std::move(again);
        use_repaired = true;
      }
    }
    if (use_repaired) {
      output.stats.mesh_repaired = true;
      Finding f;
      f.severity = Severity::warning;
      f.code = "mesh_repaired";
      std::string what;
      for (const auto& c : repaired->changes)
        what += (what.empty() ? "" : ", ") + c.code + " " + std::to_string(c.count);
      f.message = "the mesh was not closed (" + std::to_string(repaired->before.boundary_edges) +
                  " open edges, " + std::to_string(repaired->before.non_manifold_edges) +
                  " non-manifold edges) and was repaired before slicing: " + what;
      f.count =
          static_cast<long>(repaired->before.boundary_edges + repaired->before.non_manifold_edges);
      output.findings.push_back(std::move(f));
    } else if (!outlines) {
      Error e = outlines.error();
      if (repaired) {
        e.message += "; CGAL repair left " + std::to_string(repaired->after.boundary_edges) +
                     " open and " + std::to_string(repaired->after.non_manifold_edges) +
                     " non-manifold edges";
      } else {
        e.message += "; CGAL repair failed: " + repaired.error().message;
      }
      return e;
    }
    if (const long left = gaps_of(*outlines); left > 0) {
      Finding f;
      f.severity = Severity::warning;
      f.code = "open_outline_closed";
      int first = -1;
      for (const auto& l : *outlines)
        if (l.closed_gaps > 0 && first < 0) first = l.index;
      f.message = std::to_string(left) +
                  " gaps of at most 2 mm in the layer outlines (an open mesh) were bridged "
                  "with straight lines, first on layer " +
                  std::to_string(first);
      f.layer = first;
      f.count = left;
      output.findings.push_back(std::move(f));
    }
  }
  RegionResult regions = plan_layers(*outlines, settings);
  auto written = write_gcode(regions.layers, printer, settings, "mesh");
  if (!written) return written.error();

  SliceStats& st = output.stats;
  st.layer_count = static_cast<int>(outlines->size());
  st.object_height_mm = box.max.z();
  st.part_volume_mm3 = std::abs(signed_volume_mm3(mesh));
  st.filament_mm = written->filament_mm;
  const double fa =
      std::numbers::pi * 0.25 * settings.filament_diameter_mm * settings.filament_diameter_mm;
  st.filament_volume_mm3 = st.filament_mm * fa;
  st.filament_g = st.filament_volume_mm3 * 1e-3 * settings.filament_density_g_cm3;
  const double* v = written->extruded_mm3;
  st.external_perimeter_mm3 = v[static_cast<int>(Role::external_perimeter)];
  st.perimeter_mm3 = v[static_cast<int>(Role::perimeter)];
  st.sparse_infill_mm3 = v[static_cast<int>(Role::sparse_infill)];
  st.solid_infill_mm3 = v[static_cast<int>(Role::solid_infill)];
  st.top_solid_infill_mm3 = v[static_cast<int>(Role::top_solid_infill)];
  st.bridge_infill_mm3 = v[static_cast<int>(Role::bridge_infill)];
  st.gap_fill_mm3 = v[static_cast<int>(Role::gap_fill)];
  st.skirt_brim_mm3 = v[static_cast<int>(Role::skirt)];
  st.retractions = written->retractions;

  const double min_thin = min_thin_wall_width_mm(settings);
  for (auto& f : dropped_findings(regions.layers, min_thin))
    output.findings.push_back(std::move(f));

  std::string gcode = std::move(written->gcode);
  if (settings.estimate_time) {
    // printtwin's own estimate: the G-code text through the simulator (the only link
    // between slicer and simulator), with the slice's nozzle and filament.
    PrinterProfile sim_printer = printer;
    sim_printer.nozzle_diameter_mm = settings.nozzle_diameter_mm;
    sim_printer.filament_diameter_mm = settings.filament_diameter_mm;
    std::istringstream in(gcode);
    SimulateOptions opts;
    opts.source_name = "printtwin slice output";
    auto sim = simulate_gcode(in, sim_printer, opts);
    if (!sim) {
      return internal_error("the simulator rejected the slicer's own G-code: " +
                            sim.error().describe());
    }
    st.estimated_time_s = sim->print_time_s;
    st.time_from_simulator = true;
  }
  // Footer: printtwin's own figures.
  gcode += "\n; printtwin slice summary\n";
  gcode += "; filament used [mm] = " + format_fixed(st.filament_mm, 2) + "\n";
  gcode += "; filament used [cm3] = " + format_fixed(st.filament_volume_mm3 * 1e-3, 2) + "\n";
  gcode += "; filament used [g] = " + format_fixed(st.filament_g, 2) + "\n";
  if (st.time_from_simulator) {
    gcode += "; estimated printing time (normal mode) = " +
             format_duration_compact(st.estimated_time_s) + "\n";
    gcode +=
        "; printtwin estimated printing time [s] = " + format_fixed(st.estimated_time_s, 1) + "\n";
  }
  gcode += "; layer count = " + std::to_string(st.layer_count) + "\n";
  st.gcode_lines = static_cast<long>(std::count(gcode.begin(), gcode.end(), '\n'));
  output.gcode = std::move(gcode);
  return output;
}

}  // namespace printtwin
