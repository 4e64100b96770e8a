// The slicer's G-code writer (Marlin dialect, relative E): the only place in the slicer that
// knows how G-code looks. Orders islands and infill lines (nearest next), places seams,
// retracts on travels, applies PrusaSlicer's cooling rules, writes the feature markers.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <numbers>

#include "printtwin/io.hpp"
#include "printtwin/version.hpp"
#include "slice/slice_internal.hpp"

namespace printtwin::slice_detail {

namespace {

// Appends `v` with at most `decimals` digits, trailing zeros removed, "-0" written as "0".
void put(std::string& out, double v, int decimals) {
  char buf[64];
  auto r = std::to_chars(buf, buf + sizeof(buf), v, std::chars_format::fixed, decimals);
  char* end = r.ptr;
  char* dot = std::find(buf, end, '.');
  if (dot != end) {
    while (end > dot + 1 && end[-1] == '0') --end;
    if (end == dot + 1) end = dot;
  }
  std::string_view s(buf, static_cast<std::size_t>(end - buf));
  if (s == "-0") s = "0";
  out.append(s);
}

struct P2 {
  double x = 0, y = 0;
};
P2 pt(const CPoint& p) { return {to_mm(p.X), to_mm(p.Y)}; }
double dist(const P2& a, const P2& b) { return std::hypot(a.x - b.x, a.y - b.y); }

// Does the segment a-b cross an edge of `polys`? (retraction when leaving the part)
bool crosses(const CPaths& polys, const P2& a, const P2& b) {
  const double minx = std::min(a.x, b.x), maxx = std::max(a.x, b.x);
  const double miny = std::min(a.y, b.y), maxy = std::max(a.y, b.y);
  auto orient = [](double ax, double ay, double bx, double by, double cx, double cy) {
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax);
  };
  for (const auto& poly : polys) {
    const std::size_t n = poly.size();
    for (std::size_t i = 0; i < n; ++i) {
      const P2 p = pt(poly[i]);
      const P2 q = pt(poly[(i + 1) % n]);
      if (std::max(p.x, q.x) < minx || std::min(p.x, q.x) > maxx || std::max(p.y, q.y) < miny ||
          std::min(p.y, q.y) > maxy)
        continue;
      const double d1 = orient(a.x, a.y, b.x, b.y, p.x, p.y);
      const double d2 = orient(a.x, a.y, b.x, b.y, q.x, q.y);
      const double d3 = orient(p.x, p.y, q.x, q.y, a.x, a.y);
      const double d4 = orient(p.x, p.y, q.x, q.y, b.x, b.y);
      if (((d1 > 0) != (d2 > 0)) && ((d3 > 0) != (d4 > 0))) return true;
    }
  }
  return false;
}

double path_len_mm(const ExtrusionPath& p) {
  double len = 0;
  const std::size_t n = p.points.size();
  for (std::size_t i = 1; i < n; ++i) len += dist(pt(p.points[i - 1]), pt(p.points[i]));
  if (p.closed && n > 2) len += dist(pt(p.points.back()), pt(p.points.front()));
  return len;
}

class Writer {
 public:
  Writer(const PrinterProfile& printer, const SliceSettings& s) : printer_(printer), s_(s) {
    filament_area_ = std::numbers::pi * 0.25 * s.filament_diameter_mm * s.filament_diameter_mm;
    out_.reserve(1 << 20);
  }

  std::string& out() { return out_; }
  WriterResult& result() { return res_; }

  void line(std::string_view text) {
    out_.append(text);
    out_.push_back('\n');
  }

  void set_position(double x, double y, double z) {
    pos_ = {x, y};
    z_ = z;
  }

  void layer_change(const LayerToolpaths& layer, int fan_percent) {
    line(";LAYER_CHANGE");
    out_ += ";Z:";
    put(out_, layer.print_z_mm, 3);
    out_ += "\n;HEIGHT:";
    put(out_, layer.height_mm, 3);
    out_ += '\n';
    if (s_.retract_layer_change) retract();
    layer_z_ = layer.print_z_mm;
    move_z(layer_z_ + (retracted_ ? s_.retract_lift_mm : 0.0));
    if (layer.index == 1) {
      if (s_.temperature_c != s_.first_layer_temperature_c) {
        out_ += "M104 S";
        put(out_, s_.temperature_c, 0);
        out_ += " ; nozzle temperature after the first layer\n";
      }
      if (s_.bed_temperature_c != s_.first_layer_bed_temperature_c) {
        out_ += "M140 S";
        put(out_, s_.bed_temperature_c, 0);
        out_ += " ; bed temperature after the first layer\n";
      }
    }
    set_fan(fan_percent);
    layer_fan_ = fan_percent;
    boundary_ = &layer.boundary;
    type_.clear();  // PrusaSlicer repeats the type after a layer change
  }

  void set_fan(int percent) {
    if (percent == fan_) return;
    fan_ = percent;
    if (percent <= 0) {
      line("M107");
    } else {
      out_ += "M106 S";
      put(out_, std::round(2.55 * percent), 0);
      out_ += '\n';
    }
  }
  int layer_fan() const { return layer_fan_; }

  void retract() {
    if (retracted_ || s_.retract_length_mm <= 0) return;
    out_ += "G1 E";
    put(out_, -s_.retract_length_mm, 5);
    out_ += " F";
    put(out_, s_.retract_speed_mm_s * 60, 0);
    out_ += '\n';
    retracted_ = true;
    f_ = s_.retract_speed_mm_s * 60;
    ++res_.retractions;
    if (s_.retract_lift_mm > 0) move_z(layer_z_ + s_.retract_lift_mm);
  }

  void unretract() {
    if (std::abs(z_ - layer_z_) > 1e-9) move_z(layer_z_);
    if (!retracted_) return;
    const double speed =
        s_.deretract_speed_mm_s > 0 ? s_.deretract_speed_mm_s : s_.retract_speed_mm_s;
    out_ += "G1 E";
    put(out_, s_.retract_length_mm, 5);
    out_ += " F";
    put(out_, speed * 60, 0);
    out_ += '\n';
    retracted_ = false;
    f_ = speed * 60;
  }

  void move_z(double z) {
    out_ += "G1 Z";
    put(out_, z, 3);
    out_ += " F";
    put(out_, s_.travel_speed_mm_s * 60, 0);
    out_ += '\n';
    z_ = z;
    f_ = s_.travel_speed_mm_s * 60;
  }

  void travel_to(const P2& p) {
    const double d = dist(pos_, p);
    if (d < 1e-4) return;
    const bool cross = boundary_ != nullptr && crosses(*boundary_, pos_, p);
    if (d > s_.retract_before_travel_mm && (cross || !s_.only_retract_when_crossing_perimeters))
      retract();
    out_ += "G1 X";
    put(out_, p.x, 3);
    out_ += " Y";
    put(out_, p.y, 3);
    const double f = s_.travel_speed_mm_s * 60;
    if (f != f_) {
      out_ += " F";
      put(out_, f, 0);
      f_ = f;
    }
    out_ += '\n';
    pos_ = p;
  }

  // Extrudes along `pts` (already in order) from its first point.
  void extrude(const ExtrusionPath& path, const std::vector<P2>& pts, double speed_mm_s) {
    if (pts.size() < 2) return;
    travel_to(pts.front());
    unretract();
    const char* label = role_label(path.role);
    if (type_ != label) {
      out_ += ";TYPE:";
      out_ += label;
      out_ += '\n';
      type_ = label;
    }
    if (std::abs(width_ - path.width_mm) > 1e-9) {
      out_ += ";WIDTH:";
      put(out_, path.width_mm, 4);
      out_ += '\n';
      width_ = path.width_mm;
    }
    const bool bridge = path.role == Role::bridge_infill;
    if (bridge && s_.cooling && s_.bridge_fan_speed > 0)
      set_fan(static_cast<int>(s_.bridge_fan_speed));
    const double f = speed_mm_s * 60;
    const double e_per_mm = path.area_mm2 / filament_area_ * s_.extrusion_multiplier;
    bool first = true;
    for (std::size_t i = 1; i < pts.size(); ++i) {
      const double len = dist(pts[i - 1], pts[i]);
      if (len < 1e-4) continue;
      const double e = e_per_mm * len;
      out_ += "G1 X";
      put(out_, pts[i].x, 3);
      out_ += " Y";
      put(out_, pts[i].y, 3);
      out_ += " E";
      put(out_, e, 5);
      if (first && f != f_) {
        out_ += " F";
        put(out_, f, 0);
        f_ = f;
      }
      first = false;
      out_ += '\n';
      res_.filament_mm += e;
      res_.extruded_mm3[static_cast<int>(path.role)] += e * filament_area_;
    }
    pos_ = pts.back();
    if (bridge && s_.cooling && s_.bridge_fan_speed > 0) set_fan(layer_fan_);
  }

  const P2& pos() const { return pos_; }

 private:
  const PrinterProfile& printer_;
  const SliceSettings& s_;
  std::string out_;
  WriterResult res_;
  double filament_area_ = 1;
  P2 pos_;
  double z_ = 0, layer_z_ = 0;
  double f_ = -1;
  double width_ = -1;
  bool retracted_ = false;
  int fan_ = -1;
  int layer_fan_ = 0;
  std::string type_;
  const CPaths* boundary_ = nullptr;
};

// Points of a closed loop starting at vertex `start`, ending before the start by the seam
// gap (PrusaSlicer clips 15 % of the nozzle diameter so the seam does not bulge).
std::vector<P2> loop_points(const CPath& loop, std::size_t start, double clip_mm) {
  const std::size_t n = loop.size();
  std::vector<P2> pts;
  pts.reserve(n + 1);
  for (std::size_t k = 0; k <= n; ++k) pts.push_back(pt(loop[(start + k) % n]));
  double rest = clip_mm;
  while (pts.size() > 2 && rest > 0) {
    const P2 a = pts[pts.size() - 2];
    const P2 b = pts.back();
    const double len = dist(a, b);
    if (len > rest) {
      const double t = (len - rest) / len;
      pts.back() = {a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)};
      break;
    }
    rest -= len;
    pts.pop_back();
  }
  return pts;
}

std::size_t seam_vertex(const CPath& loop, SeamPosition seam, const P2& pos,
                        const P2& aligned_ref) {
  std::size_t best = 0;
  double best_v = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < loop.size(); ++i) {
    const P2 p = pt(loop[i]);
    double v = 0;
    switch (seam) {
      case SeamPosition::nearest:
        v = dist(p, pos);
        break;
      case SeamPosition::aligned:
        v = dist(p, aligned_ref);
        break;
      case SeamPosition::rear:
        v = -p.y * 1000.0 + p.x;
        break;
    }
    if (v < best_v - 1e-12) {
      best_v = v;
      best = i;
    }
  }
  return best;
}

// Orders open paths nearest-next from `from` (each may be reversed). A sorted projection
// on one axis gives a lower bound on distances, so the search stops early.
std::vector<std::pair<std::size_t, bool>> order_open(const std::vector<ExtrusionPath>& paths,
                                                     const std::vector<std::size_t>& idx, P2 from) {
  std::vector<std::pair<std::size_t, bool>> order;
  const std::size_t n = idx.size();
  if (n == 0) return order;
  // Axis: perpendicular to the first path.
  const auto& f = paths[idx[0]].points;
  double ax = -(double(f.back().Y - f.front().Y)), ay = double(f.back().X - f.front().X);
  const double an = std::hypot(ax, ay);
  if (an > 0) {
    ax /= an;
    ay /= an;
  } else {
    ax = 1;
    ay = 0;
  }
  struct End {
    double key;
    std::size_t path;  // index into idx
    bool last;         // the path's last point
    P2 p;
  };
  std::vector<End> ends;
  ends.reserve(2 * n);
  for (std::size_t k = 0; k < n; ++k) {
    const auto& pts = paths[idx[k]].points;
    const P2 a = pt(pts.front()), b = pt(pts.back());
    ends.push_back({a.x * ax + a.y * ay, k, false, a});
    ends.push_back({b.x * ax + b.y * ay, k, true, b});
  }
  std::sort(ends.begin(), ends.end(), [](const End& a, const End& b) {
    return a.key < b.key ||
           (a.key == b.key && (a.path < b.path || (a.path == b.path && a.last < b.last)));
  });
  std::vector<char> used(n, 0);
  P2 cur = from;
  for (std::size_t done = 0; done < n; ++done) {
    const double ck = cur.x * ax + cur.y * ay;
    const std::size_t mid = static_cast<std::size_t>(
        std::lower_bound(ends.begin(), ends.end(), ck,
                         [](const End& e, double v) { return e.key < v; }) -
        ends.begin());
    double best = std::numeric_limits<double>::infinity();
    long best_e = -1;
    // Expand to both sides until the projection gap exceeds the best distance.
    long lo = static_cast<long>(mid) - 1, hi = static_cast<long>(mid);
    const long m = static_cast<long>(ends.size());
    while (lo >= 0 || hi < m) {
      bool progressed = false;
      if (hi < m) {
        const End& e = ends[static_cast<std::size_t>(hi)];
        if (e.key - ck <= best) {
          if (!used[e.path]) {
            const double d = dist(cur, e.p);
            if (d < best) {
              best = d;
              best_e = hi;
            }
          }
          ++hi;
          progressed = true;
        } else {
          hi = m;
        }
      }
      if (lo >= 0) {
        const End& e = ends[static_cast<std::size_t>(lo)];
        if (ck - e.key <= best) {
          if (!used[e.path]) {
            const double d = dist(cur, e.p);
            if (d < best) {
              best = d;
              best_e = lo;
            }
          }
          --lo;
          progressed = true;
        } else {
          lo = -1;
        }
      }
      if (!progressed) break;
    }
    if (best_e < 0) break;
    const End& e = ends[static_cast<std::size_t>(best_e)];
    used[e.path] = 1;
    order.emplace_back(idx[e.path], e.last);  // reversed when entering at its last point
    const auto& pts = paths[idx[e.path]].points;
    cur = e.last ? pt(pts.front()) : pt(pts.back());
    // Drop used entries lazily: compact when half are used.
    if ((done + 1) * 2 >= n && ends.size() > 64 && (done + 1) % 64 == 0) {
      std::erase_if(ends, [&](const End& x) { return used[x.path] != 0; });
    }
  }
  return order;
}

double role_speed(const SliceSettings& s, Role r) {
  switch (r) {
    case Role::external_perimeter:
      return s.external_perimeter_speed_mm_s;
    case Role::perimeter:
      return s.perimeter_speed_mm_s;
    case Role::sparse_infill:
      return s.infill_speed_mm_s;
    case Role::solid_infill:
      return s.solid_infill_speed_mm_s;
    case Role::top_solid_infill:
      return s.top_solid_infill_speed_mm_s;
    case Role::bridge_infill:
      return s.bridge_speed_mm_s;
    case Role::gap_fill:
      return s.gap_fill_speed_mm_s;
    case Role::skirt:
      return s.skirt_speed_mm_s > 0 ? s.skirt_speed_mm_s : s.perimeter_speed_mm_s;
  }
  return s.perimeter_speed_mm_s;
}

Error unknown_placeholder(const std::string& name, const std::string& which,
                          const std::string& known) {
  return bad_input("unknown placeholder {" + name + "} in the printer profile's " + which +
                   " (known: " + known + ")");
}

// Expands {name} placeholders of the printer's start / end code.
Result<std::string> expand(const std::string& text,
                           const std::vector<std::pair<std::string, std::string>>& vars,
                           const std::string& which) {
  std::string out;
  std::size_t i = 0;
  while (i < text.size()) {
    const char c = text[i];
    if (c != '{') {
      out.push_back(c);
      ++i;
      continue;
    }
    const std::size_t close = text.find('}', i);
    if (close == std::string::npos)
      return bad_input("unclosed '{' in the printer profile's " + which);
    const std::string name = text.substr(i + 1, close - i - 1);
    bool found = false;
    for (const auto& [k, v] : vars)
      if (k == name) {
        out += v;
        found = true;
      }
    if (!found) {
      std::string known;
      for (const auto& kv : vars) {
        if (!known.empty()) known += ", ";
        known += kv.first;
      }
      return unknown_placeholder(name, which, known);
    }
    i = close + 1;
  }
  if (!out.empty() && out.back() != '\n') out.push_back('\n');
  return out;
}

/// The speed of each role on one layer: the first layer's speed, or the role's, slowed for
/// PrusaSlicer's minimum layer time but not below min_print_speed.
struct LayerSpeeds {
  const SliceSettings& s;
  bool first_layer;
  double slow;
  [[nodiscard]] double operator()(Role r) const {
    const double v = first_layer ? s.first_layer_speed_mm_s : role_speed(s, r);
    return std::max(std::min(v, s.min_print_speed_mm_s), v * slow);
  }
};

/// PrusaSlicer's cooling rules from the layer's estimated time (extrusions only): the
/// slowdown factor and the fan speed.
LayerSpeeds layer_cooling(const LayerToolpaths& layer, const SliceSettings& s, int& fan) {
  const bool first_layer = layer.index == 0;
  double layer_time = 0;
  auto add_time = [&](const ExtrusionPath& p) {
    const double v = first_layer ? s.first_layer_speed_mm_s : role_speed(s, p.role);
    layer_time += path_len_mm(p) / v;
  };
  for (const auto& p : layer.skirt) add_time(p);
  for (const auto& isl : layer.islands) {
    for (const auto& p : isl.perimeters) add_time(p);
    for (const auto& p : isl.gap_fill) add_time(p);
    for (const auto& p : isl.infill) add_time(p);
  }
  double slow = 1.0;
  fan = 0;
  if (s.cooling) {
    if (layer_time < s.slowdown_below_layer_time_s && layer_time > 0)
      slow = layer_time / s.slowdown_below_layer_time_s;
    if (layer.index >= s.disable_fan_first_layers) {
      double f = s.fan_always_on ? s.min_fan_speed : 0;
      if (layer_time < s.slowdown_below_layer_time_s) {
        f = s.max_fan_speed;
      } else if (layer_time < s.fan_below_layer_time_s) {
        const double t = (layer_time - s.slowdown_below_layer_time_s) /
                         (s.fan_below_layer_time_s - s.slowdown_below_layer_time_s);
        f = s.max_fan_speed - (s.max_fan_speed - s.min_fan_speed) * t;
      }
      fan = static_cast<int>(std::lround(f));
    }
  }
  return LayerSpeeds{s, first_layer, slow};
}

/// Where the writer draws loops and open paths: seam choice and end clipping.
struct PathStyle {
  const LayerSpeeds& speed;
  double clip_mm;
  P2 aligned_ref;  ///< the aligned seam aims at this point
};

/// Open paths of one role (or all of them), ordered nearest-next; closed ones as loops with a
/// nearest seam.
void emit_open(Writer& w, const std::vector<ExtrusionPath>& paths, Role role, bool any_role,
               const PathStyle& style) {
  std::vector<std::size_t> idx;
  for (std::size_t k = 0; k < paths.size(); ++k)
    if (any_role || paths[k].role == role) idx.push_back(k);
  for (const auto& [k, reversed] : order_open(paths, idx, w.pos())) {
    const ExtrusionPath& p = paths[k];
    if (p.closed) {
      const std::size_t st =
          seam_vertex(p.points, SeamPosition::nearest, w.pos(), style.aligned_ref);
      w.extrude(p, loop_points(p.points, st, style.clip_mm), style.speed(p.role));
      continue;
    }
    std::vector<P2> pts;
    pts.reserve(p.points.size());
    for (const auto& q : p.points) pts.push_back(pt(q));
    if (reversed) std::reverse(pts.begin(), pts.end());
    w.extrude(p, pts, style.speed(p.role));
  }
}

/// One island: perimeters (loops from the seam, open ones from their nearer end), gap fill,
/// then bridges, sparse, solid and top infill.
void write_island(Writer& w, const Island& isl, SeamPosition seam, const PathStyle& style) {
  for (const auto& p : isl.perimeters) {
    if (p.closed) {
      const std::size_t st = seam_vertex(p.points, seam, w.pos(), style.aligned_ref);
      w.extrude(p, loop_points(p.points, st, style.clip_mm), style.speed(p.role));
    } else {
      std::vector<P2> pts;
      for (const auto& q : p.points) pts.push_back(pt(q));
      if (dist(w.pos(), pts.back()) < dist(w.pos(), pts.front()))
        std::reverse(pts.begin(), pts.end());
      w.extrude(p, pts, style.speed(p.role));
    }
  }
  emit_open(w, isl.gap_fill, Role::gap_fill, true, style);
  emit_open(w, isl.infill, Role::bridge_infill, false, style);
  emit_open(w, isl.infill, Role::sparse_infill, false, style);
  emit_open(w, isl.infill, Role::solid_infill, false, style);
  emit_open(w, isl.infill, Role::top_solid_infill, false, style);
}

/// The island not yet printed whose outline comes nearest to `from`.
std::size_t nearest_island(const LayerToolpaths& layer, const std::vector<char>& done, P2 from) {
  std::size_t best = 0;
  double bd = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < layer.islands.size(); ++k) {
    if (done[k]) continue;
    double d = std::numeric_limits<double>::infinity();
    for (const auto& q : layer.islands[k].outline) d = std::min(d, dist(pt(q), from));
    if (layer.islands[k].outline.empty()) d = 0;
    if (d < bd) {
      bd = d;
      best = k;
    }
  }
  return best;
}

/// The header comment: tool, source, printer, flavour, layer count and every setting.
void write_header(std::string& out, std::size_t layers, const PrinterProfile& printer,
                  const SliceSettings& s, const std::string& source_name) {
  out += "; generated by printtwin ";
  out += kVersion;
  out += " (printtwin slice)\n";
  out += "; source: " + source_name + "\n";
  out += "; printer: " + printer.name + "\n";
  out += "; flavor: marlin2, relative E (M83)\n";
  out += "; layers: " + std::to_string(layers) + "\n";
  for (const auto& [k, v] : slice_settings_entries(s)) {
    out += "; ";
    out += k;
    out += " = ";
    out += v;
    out += '\n';
  }
  out += "\n";
}

}  // namespace

Result<WriterResult> write_gcode(const std::vector<LayerToolpaths>& layers,
                                 const PrinterProfile& printer, const SliceSettings& s,
                                 const std::string& source_name) {
  Writer w(printer, s);
  std::string& out = w.out();
  write_header(out, layers.size(), printer, s, source_name);

  const double max_z = layers.empty() ? 0.0 : layers.back().print_z_mm;
  auto fmt = [](double v, int d) {
    std::string t;
    put(t, v, d);
    return t;
  };
  const std::vector<std::pair<std::string, std::string>> vars = {
      {"bed_temp", fmt(s.first_layer_bed_temperature_c, 0)},
      {"nozzle_temp", fmt(s.first_layer_temperature_c, 0)},
      {"bed_max_x", fmt(printer.bed_max_x_mm, 3)},
      {"bed_max_y", fmt(printer.bed_max_y_mm, 3)},
      {"max_layer_z", fmt(max_z, 3)},
      {"travel_speed_mm_min", fmt(s.travel_speed_mm_s * 60, 0)},
  };
  auto start = expand(printer.start_gcode, vars, "start_gcode");
  if (!start) return start.error();
  auto end = expand(printer.end_gcode, vars, "end_gcode");
  if (!end) return end.error();
  w.line("M107");
  out += ";TYPE:Custom\n";
  out += *start;
  w.line("G21 ; millimetres");
  w.line("G90 ; absolute XYZ");
  w.line("M83 ; relative E");
  // Where the start code leaves the nozzle is not tracked: the first travel always retracts
  // nothing and moves in XY after the first layer's Z move.
  w.set_position(-1e6, -1e6, 0);

  const double clip_mm = 0.15 * s.nozzle_diameter_mm;
  // The aligned seam aims at the rear-left corner far outside the part.
  const P2 aligned_ref{-1000.0, 1000.0};

  for (const LayerToolpaths& layer : layers) {
    int fan = 0;
    const LayerSpeeds speed = layer_cooling(layer, s, fan);
    const PathStyle style{speed, clip_mm, aligned_ref};
    w.layer_change(layer, fan);

    for (const auto& p : layer.skirt) {
      const std::size_t st = seam_vertex(p.points, SeamPosition::nearest, w.pos(), aligned_ref);
      w.extrude(p, loop_points(p.points, st, clip_mm), speed(p.role));
    }
    // Islands nearest-next by their outline.
    std::vector<char> done(layer.islands.size(), 0);
    for (std::size_t count = 0; count < layer.islands.size(); ++count) {
      const std::size_t best = nearest_island(layer, done, w.pos());
      done[best] = 1;
      write_island(w, layer.islands[best], s.seam, style);
    }
  }
  w.retract();
  out += ";TYPE:Custom\n";
  out += *end;
  WriterResult r = w.result();
  r.gcode = std::move(out);
  return r;
}

}  // namespace printtwin::slice_detail
