// Klipper's printer.cfg: sections, options, [include] with globs, the SAVE_CONFIG block,
// and the PrinterProfile it describes.
#include <fnmatch.h>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>

#include "machine/printer_internal.hpp"
#include "printtwin/io.hpp"
#include "printtwin/printer.hpp"

namespace printtwin {

const KlipperSection::Option* KlipperSection::find(std::string_view key) const {
  for (auto it = options.rbegin(); it != options.rend(); ++it)
    if (it->key == key) return &*it;
  return nullptr;
}

namespace {

namespace fs = std::filesystem;

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front())) != 0) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back())) != 0) s.remove_suffix(1);
  return s;
}

/// Removes an inline comment: '#' or ';' preceded by whitespace (as Klipper's parser does).
std::string_view strip_comment(std::string_view s) {
  for (std::size_t i = 0; i < s.size(); ++i)
    if ((s[i] == '#' || s[i] == ';') &&
        (i == 0 || std::isspace(static_cast<unsigned char>(s[i - 1])) != 0))
      return s.substr(0, i);
  return s;
}

bool has_glob(std::string_view s) { return s.find_first_of("*?[") != std::string_view::npos; }

class Reader {
 public:
  Status read(const fs::path& path, int depth) {
    std::error_code ec;
    const fs::path canonical = fs::weakly_canonical(path, ec);
    if (depth > 32 || !stack_.insert(canonical.string()).second)
      return bad_input("recursive [include] of " + path.string(), path.string());
    auto text = read_file(path);
    if (!text) return text.error();
    const std::string file = path.string();
    std::istringstream in(*text);
    std::string raw;
    long line = 0;
    KlipperSection::Option* last = nullptr;
    bool in_autosave = false;
    while (std::getline(in, raw)) {
      ++line;
      if (!raw.empty() && raw.back() == '\r') raw.pop_back();
      std::string_view l = raw;
      // SAVE_CONFIG's block: "#*# [section]" / "#*# key = value" lines are config too.
      if (l.substr(0, 3) == "#*#") {
        in_autosave = true;
        l = l.substr(3);
        if (!l.empty() && l.front() == ' ') l.remove_prefix(1);
        if (trim(l).find("SAVE_CONFIG") != std::string_view::npos || trim(l).empty()) continue;
      } else if (in_autosave && !trim(l).empty()) {
        return bad_input("text after the SAVE_CONFIG block (\"#*#\" lines must come last)", file,
                         line);
      }
      const bool indented = !l.empty() && std::isspace(static_cast<unsigned char>(l.front())) != 0;
      const std::string_view body = trim(strip_comment(l));
      if (body.empty()) continue;
      // The block's own banner ("DO NOT EDIT THIS BLOCK OR BELOW...") is neither.
      if (in_autosave && body.front() != '[' && body.find_first_of(":=") == std::string_view::npos)
        continue;
      if (indented && last != nullptr) {  // continuation of a multi-line value (gcode: ...)
        last->value += "\n" + std::string(body);
        continue;
      }
      if (body.front() == '[') {
        if (body.back() != ']')
          return bad_input("expected \"[section]\", got \"" + std::string(body) + "\"", file, line);
        const std::string name(trim(body.substr(1, body.size() - 2)));
        if (name.empty()) return bad_input("empty section name", file, line);
        last = nullptr;
        if (name.rfind("include ", 0) == 0 || name == "include") {
          const std::string pattern(trim(std::string_view(name).substr(7)));
          if (pattern.empty()) return bad_input("[include] names no file", file, line);
          if (auto st = include(path.parent_path(), pattern, file, line, depth); !st)
            return st.error();
          current_ = -1;
          continue;
        }
        current_ = section_index(name);
        continue;
      }
      const auto sep = body.find_first_of(":=");
      if (sep == std::string_view::npos || sep == 0)
        return bad_input(
            "expected \"key: value\" or \"[section]\", got \"" + std::string(body) + "\"", file,
            line);
      if (current_ < 0)
        return bad_input(
            "option \"" + std::string(trim(body.substr(0, sep))) + "\" outside any [section]", file,
            line);
      auto& sec = sections_[static_cast<std::size_t>(current_)];
      std::string key(trim(body.substr(0, sep)));
      for (auto& c : key) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      sec.options.push_back({key, std::string(trim(body.substr(sep + 1))), file, line});
      last = &sec.options.back();
    }
    stack_.erase(canonical.string());
    return Ok{};
  }

  std::vector<KlipperSection> take() { return std::move(sections_); }

 private:
  int section_index(const std::string& name) {
    for (std::size_t i = 0; i < sections_.size(); ++i)
      if (sections_[i].name == name) return static_cast<int>(i);
    sections_.push_back({name, {}});
    return static_cast<int>(sections_.size() - 1);
  }

  Status include(const fs::path& dir, const std::string& pattern, const std::string& file,
                 long line, int depth) {
    const fs::path full = fs::path(pattern).is_absolute() ? fs::path(pattern) : dir / pattern;
    std::vector<fs::path> files;
    if (!has_glob(pattern)) {
      std::error_code ec;
      if (!fs::is_regular_file(full, ec))
        return bad_input("[include " + pattern + "]: no such file " + full.string(), file, line);
      files.push_back(full);
    } else {
      // Glob in the last path component (Klipper's own configs use "macros/*.cfg").
      const fs::path parent = full.parent_path();
      const std::string leaf = full.filename().string();
      if (has_glob(parent.string()))
        return bad_input("[include " + pattern + "]: wildcards are supported in the file name only",
                         file, line);
      std::error_code ec;
      if (fs::is_directory(parent, ec))
        for (const auto& entry : fs::directory_iterator(parent, ec))
          if (entry.is_regular_file() &&
              fnmatch(leaf.c_str(), entry.path().filename().string().c_str(), 0) == 0)
            files.push_back(entry.path());
      std::sort(files.begin(), files.end());  // Klipper includes matches in sorted order
    }
    const int saved = current_;
    for (const auto& f : files) {
      current_ = -1;
      if (auto st = read(f, depth + 1); !st) return st.error();
    }
    current_ = saved;
    return Ok{};
  }

  std::vector<KlipperSection> sections_;
  std::set<std::string> stack_;
  int current_ = -1;
};

const KlipperSection* section(const std::vector<KlipperSection>& secs, std::string_view name) {
  for (const auto& s : secs)
    if (s.name == name) return &s;
  return nullptr;
}

}  // namespace

Result<std::vector<KlipperSection>> read_klipper_config(const fs::path& path) {
  Reader r;
  if (auto st = r.read(path, 0); !st) return st.error();
  return r.take();
}

namespace {
/// Reads one number option of a section, range-checked; `out` stays empty when absent.
Status number_option(const KlipperSection* s, std::string_view key, double lo, double hi,
                     std::optional<double>& out) {
  if (s == nullptr) return Ok{};
  const auto* o = s->find(key);
  if (o == nullptr) return Ok{};
  char* end = nullptr;
  const double d = std::strtod(o->value.c_str(), &end);
  if (o->value.empty() || o->value.find_first_not_of("0123456789.-+eE") != std::string::npos ||
      end == o->value.c_str() || *end != 0 || !std::isfinite(d))
    return bad_input(
        "[" + s->name + "] " + std::string(key) + ": expected a number, got \"" + o->value + "\"",
        o->file, o->line);
  if (!(d >= lo && d <= hi))
    return bad_input("[" + s->name + "] " + std::string(key) + ": " + format_number(d) +
                         " is outside [" + format_number(lo) + ", " + format_number(hi) + "]",
                     o->file, o->line);
  out = d;
  return Ok{};
}

/// "file:line" of an option that is present.
std::string where(const KlipperSection* s, std::string_view key) {
  const auto* o = s->find(key);
  return o->file + ":" + std::to_string(o->line);
}

/// [printer]: kinematics, velocity and acceleration limits, square corner velocity,
/// minimum cruise ratio.
Status apply_printer_section(const std::vector<KlipperSection>& secs, const fs::path& path,
                             PrinterProfile& p) {
  auto num = number_option;
  const KlipperSection* printer = section(secs, "printer");
  if (printer == nullptr)
    return bad_input("no [printer] section (Klipper requires one)", path.string());
  if (const auto* k = printer->find("kinematics")) {
    static const std::set<std::string> kGantry = {
        "cartesian",         "corexy",         "corexz",        "hybrid_corexy", "hybrid_corexz",
        "limited_cartesian", "limited_corexy", "limited_corexz"};
    if (kGantry.count(k->value) == 0)
      return bad_input(
          "[printer] kinematics: " + k->value +
              " is not simulated (printtwin models cartesian and corexy/corexz gantries)",
          k->file, k->line);
    p.name = "Klipper " + k->value + " printer (" + path.filename().string() + ")";
  } else {
    return bad_input("[printer] has no kinematics", path.string());
  }
  std::optional<double> v, a, scv, mcr, atd, zv, za;
  for (const auto& st :
       {num(printer, "max_velocity", 1e-3, 1e5, v), num(printer, "max_accel", 1e-3, 1e7, a),
        num(printer, "square_corner_velocity", 0, 1e4, scv),
        num(printer, "minimum_cruise_ratio", 0, 0.99, mcr),
        num(printer, "max_accel_to_decel", 1e-3, 1e7, atd),
        num(printer, "max_z_velocity", 1e-3, 1e5, zv), num(printer, "max_z_accel", 1e-3, 1e7, za)})
    if (!st) return st.error();
  if (!v) return bad_input("[printer] has no max_velocity (Klipper requires it)", path.string());
  if (!a) return bad_input("[printer] has no max_accel (Klipper requires it)", path.string());
  p.max_feedrate_mm_s[0] = p.max_feedrate_mm_s[1] = *v;
  p.origin.set("max_feedrate_mm_s", "config", where(printer, "max_velocity"));
  p.max_accel_mm_s2[0] = p.max_accel_mm_s2[1] = *a;
  p.print_accel_mm_s2 = p.retract_accel_mm_s2 = p.travel_accel_mm_s2 = *a;
  for (const char* k :
       {"max_accel_mm_s2", "print_accel_mm_s2", "retract_accel_mm_s2", "travel_accel_mm_s2"})
    p.origin.set(k, "config", where(printer, "max_accel"));
  // Klipper's defaults: max_z_velocity = max_velocity, max_z_accel = max_accel.
  p.max_feedrate_mm_s[2] = zv.value_or(*v);
  p.max_accel_mm_s2[2] = za.value_or(*a);
  if (zv) p.origin.set("max_feedrate_mm_s", "config", where(printer, "max_z_velocity"));
  if (scv) {
    p.square_corner_velocity_mm_s = *scv;
    p.origin.set("square_corner_velocity_mm_s", "config", where(printer, "square_corner_velocity"));
  }
  if (mcr) {
    p.minimum_cruise_ratio = *mcr;
    p.origin.set("minimum_cruise_ratio", "config", where(printer, "minimum_cruise_ratio"));
  } else if (atd) {  // the older option: minimum_cruise_ratio = 1 - max_accel_to_decel / max_accel
    p.minimum_cruise_ratio = std::max(0.0, 1.0 - std::min(1.0, *atd / *a));
    p.origin.set("minimum_cruise_ratio", "config", where(printer, "max_accel_to_decel"));
  }
  p.max_accel_to_decel_ratio = std::max(0.01, 1.0 - p.minimum_cruise_ratio);

  return Ok{};
}

/// [stepper_x/y/z]: travel ranges, the printable bed, homing speeds.
Status apply_steppers(const std::vector<KlipperSection>& secs, const fs::path& path,
                      PrinterProfile& p) {
  auto num = number_option;
  static const char* kAxes[3] = {"x", "y", "z"};
  double* tmin[3] = {&p.travel_min_x_mm, &p.travel_min_y_mm, &p.travel_min_z_mm};
  double* tmax[3] = {&p.travel_max_x_mm, &p.travel_max_y_mm, &p.travel_max_z_mm};
  for (int i = 0; i < 3; ++i) {
    const std::string name = std::string("stepper_") + kAxes[i];
    const KlipperSection* s = section(secs, name);
    if (s == nullptr)
      return bad_input("no [" + name + "] section (Klipper requires one for " + p.name + ")",
                       path.string());
    std::optional<double> lo, hi, hs;
    for (const auto& st :
         {num(s, "position_min", -1e4, 1e4, lo), num(s, "position_max", -1e4, 1e4, hi),
          num(s, "homing_speed", 1e-3, 1e4, hs)})
      if (!st) return st.error();
    if (!hi)
      return bad_input("[" + name + "] has no position_max (Klipper requires it)", path.string());
    const double lo_v = lo.value_or(0);
    if (!(*hi > lo_v))
      return bad_input("[" + name + "] position_max must exceed position_min",
                       s->find("position_max")->file, s->find("position_max")->line);
    *tmin[i] = lo_v;
    *tmax[i] = *hi;
    const std::string tkey_min = std::string("travel_min_") + kAxes[i] + "_mm";
    const std::string tkey_max = std::string("travel_max_") + kAxes[i] + "_mm";
    p.origin.set(tkey_max, "config", where(s, "position_max"));
    if (lo)
      p.origin.set(tkey_min, "config", where(s, "position_min"));
    else
      p.origin.set(tkey_min, "default", "");
    if (hs) {
      p.homing_feedrate_mm_s[i] = *hs;
      p.origin.set("homing_feedrate_mm_s", "config", where(s, "homing_speed"));
    }
  }
  // The printable bed is what the toolhead reaches at Z >= 0 (Klipper knows no other bed).
  p.bed_min_x_mm = std::max(0.0, p.travel_min_x_mm);
  p.bed_min_y_mm = std::max(0.0, p.travel_min_y_mm);
  p.bed_max_x_mm = p.travel_max_x_mm;
  p.bed_max_y_mm = p.travel_max_y_mm;
  p.max_z_mm = p.travel_max_z_mm;
  if (p.bed_max_x_mm <= p.bed_min_x_mm || p.bed_max_y_mm <= p.bed_min_y_mm)
    return bad_input("the steppers' ranges leave no bed at X, Y >= 0", path.string());
  for (const char* k : {"bed_min_x_mm", "bed_max_x_mm"})
    p.origin.set(k, "config", where(section(secs, "stepper_x"), "position_max"));
  for (const char* k : {"bed_min_y_mm", "bed_max_y_mm"})
    p.origin.set(k, "config", where(section(secs, "stepper_y"), "position_max"));
  p.origin.set("max_z_mm", "config", where(section(secs, "stepper_z"), "position_max"));

  return Ok{};
}

/// [extruder]: nozzle and filament diameters, extrude-only limits, minimum temperature.
Status apply_extruder(const KlipperSection* e, PrinterProfile& p) {
  auto num = number_option;
  std::optional<double> nd, fd, ev, ea, mt;
  for (const auto& st :
       {num(e, "nozzle_diameter", 0.05, 5, nd), num(e, "filament_diameter", 0.5, 5, fd),
        num(e, "max_extrude_only_velocity", 1e-3, 1e5, ev),
        num(e, "max_extrude_only_accel", 1e-3, 1e7, ea), num(e, "min_extrude_temp", 0, 500, mt)})
    if (!st) return st.error();
  auto put = [&](const std::optional<double>& val, double& member, const char* key,
                 const char* option) {
    if (!val) return;
    member = *val;
    p.origin.set(key, "config", where(e, option));
  };
  put(nd, p.nozzle_diameter_mm, "nozzle_diameter_mm", "nozzle_diameter");
  put(fd, p.filament_diameter_mm, "filament_diameter_mm", "filament_diameter");
  put(ev, p.max_extrude_only_velocity_mm_s, "max_extrude_only_velocity_mm_s",
      "max_extrude_only_velocity");
  put(ea, p.max_extrude_only_accel_mm_s2, "max_extrude_only_accel_mm_s2", "max_extrude_only_accel");
  put(mt, p.min_extrude_temp_c, "min_extrude_temp_c", "min_extrude_temp");
  return Ok{};
}

/// [firmware_retraction]: G10/G11 lengths and speeds, with Klipper's defaults.
Status apply_firmware_retraction(const KlipperSection* r, const fs::path& path, PrinterProfile& p) {
  auto num = number_option;
  std::optional<double> len, spd, extra, uspd;
  for (const auto& st :
       {num(r, "retract_length", 0, 100, len), num(r, "retract_speed", 1e-3, 1e4, spd),
        num(r, "unretract_extra_length", 0, 100, extra),
        num(r, "unretract_speed", 1e-3, 1e4, uspd)})
    if (!st) return st.error();
  // Klipper's defaults: retract_length 0, retract_speed 20, unretract_speed 10.
  p.firmware_retraction = true;
  p.fw_retract_length_mm = len.value_or(0);
  p.fw_retract_speed_mm_s = spd.value_or(20);
  p.fw_recover_speed_mm_s = uspd.value_or(10);
  p.fw_retract_zraise_mm = 0;
  p.origin.set("firmware_retraction", "config", path.string());
  for (const char* k : {"fw_retract_length_mm", "fw_retract_speed_mm_s", "fw_recover_speed_mm_s"})
    p.origin.set(k, "config", path.string() + " [firmware_retraction]");
  return Ok{};
}

/// The options are range-checked one by one; what they make together (a bed or a height
/// from the steppers' ranges) must also be a profile printtwin simulates: the same limits as
/// a .json profile, named by the option that set the value.
Status check_simulated(const PrinterProfile& p, const fs::path& path) {
  if (auto back = parse_printer_profile(printer_profile_to_json(p), path.string()); !back) {
    const std::string message =
        "the printer this config describes is not simulated: " + back.error().message;
    const std::string& what = back.error().message;  // key "<profile key>": ...
    const auto open = what.find("key \"");
    const auto close = open == std::string::npos ? open : what.find('"', open + 5);
    const ValueOrigin* o = close == std::string::npos
                               ? nullptr
                               : p.origin.find(what.substr(open + 5, close - open - 5));
    const auto colon = o ? o->detail.rfind(':') : std::string::npos;
    if (colon != std::string::npos && colon + 1 < o->detail.size() &&
        o->detail.find_first_not_of("0123456789", colon + 1) == std::string::npos)
      return bad_input(message, o->detail.substr(0, colon), std::stol(o->detail.substr(colon + 1)));
    return bad_input(message, path.string());
  }
  return Ok{};
}
}  // namespace

Result<PrinterProfile> load_klipper_printer_cfg(const fs::path& path) {
  auto secs = read_klipper_config(path);
  if (!secs) return secs.error();
  PrinterProfile p = ender3_klipper();
  p.name = "Klipper printer (" + path.filename().string() + ")";
  p.origin = {};
  for (const auto& key : printer_profile_keys()) p.origin.set(key, "default", "");
  p.origin.how = "explicit";
  if (auto st = apply_printer_section(*secs, path, p); !st) return st.error();
  if (auto st = apply_steppers(*secs, path, p); !st) return st.error();
  if (const KlipperSection* e = section(*secs, "extruder"))
    if (auto st = apply_extruder(e, p); !st) return st.error();
  if (const KlipperSection* r = section(*secs, "firmware_retraction"))
    if (auto st = apply_firmware_retraction(r, path, p); !st) return st.error();
  p.origin.summary = p.name;
  if (auto st = check_simulated(p, path); !st) return st.error();
  return p;
}

}  // namespace printtwin
