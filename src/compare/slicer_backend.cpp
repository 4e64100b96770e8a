// External slicer back-ends: PrusaSlicer, CuraEngine and Slic3r run as child processes that
// write the G-code a compare or verify variant then measures (docs/compare.md).
#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <thread>

#include <nlohmann/json.hpp>

#include "printtwin/compare.hpp"
#include "printtwin/io.hpp"
#include "printtwin/printer.hpp"
#include "printtwin/slice.hpp"

namespace printtwin {

namespace {

// "key=value" in one allocation (a setting on a command line, an environment entry).
std::string key_value(std::string_view key, std::string_view value) {
  std::string out;
  out.reserve(key.size() + 1 + value.size());
  out.append(key).append(1, '=').append(value);
  return out;
}

Error slicer_path_without_slicer(const std::string& value, bool no_external_slicer) {
  return usage_error("--slicer-path " + value +
                     ": say which slicer it is for (name=path, e.g. prusa-slicer=" + value + ")" +
                     (no_external_slicer ? ", and give that --slicer" : ""));
}

namespace fs = std::filesystem;

struct SlicerInfo {
  std::string_view name;
  std::array<std::string_view, 2> programs;  // names looked up on the PATH, in order
  std::string_view package;                  // Debian package(s) that provide it
  std::string_view version_flag;             // argument that prints the version
};

constexpr std::array<SlicerInfo, 3> kSlicers{{
    {"prusa-slicer", {"prusa-slicer", "PrusaSlicer"}, "prusa-slicer", "--help"},
    {"cura", {"CuraEngine", ""}, "cura-engine (and cura for the printer definitions)", "help"},
    {"slic3r", {"slic3r", ""}, "slic3r", "--version"},
}};

const SlicerInfo* info_of(std::string_view name) {
  for (const auto& s : kSlicers)
    if (s.name == name) return &s;
  return nullptr;
}

bool is_executable(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec) && ::access(p.c_str(), X_OK) == 0;
}

std::string on_path(std::string_view program) {
  const char* path = std::getenv("PATH");
  std::string_view rest = path ? path : "/usr/local/bin:/usr/bin:/bin";
  while (!rest.empty()) {
    const auto colon = rest.find(':');
    const std::string dir(rest.substr(0, colon));
    if (!dir.empty() && is_executable(fs::path(dir) / program))
      return (fs::path(dir) / program).string();
    if (colon == std::string_view::npos) break;
    rest.remove_prefix(colon + 1);
  }
  return {};
}

// "PrusaSlicer-2.5.0+UNKNOWN based on ..." -> "PrusaSlicer 2.5.0"; "Cura_SteamEngine version
// 4.13.0" -> "CuraEngine 4.13.0"; "1.3.0" -> "Slic3r 1.3.0".
std::string version_from_output(std::string_view name, std::string_view out) {
  auto token_after = [&](std::string_view marker) -> std::string {
    const auto at = out.find(marker);
    if (at == std::string_view::npos) return {};
    std::size_t b = at + marker.size(), e = b;
    while (e < out.size() && (std::isdigit(static_cast<unsigned char>(out[e])) || out[e] == '.'))
      ++e;
    return std::string(out.substr(b, e - b));
  };
  if (name == "prusa-slicer") {
    const auto v = token_after("PrusaSlicer-");
    return v.empty() ? std::string() : "PrusaSlicer " + v;
  }
  if (name == "cura") {
    const auto v = token_after("version ");
    return v.empty() ? std::string() : "CuraEngine " + v;
  }
  // Slic3r prints its bare version; skip log lines.
  for (std::size_t b = 0; b < out.size();) {
    auto e = out.find('\n', b);
    if (e == std::string_view::npos) e = out.size();
    std::string_view line = out.substr(b, e - b);
    if (!line.empty() && std::isdigit(static_cast<unsigned char>(line[0]))) {
      std::size_t k = 0;
      while (k < line.size() &&
             (std::isdigit(static_cast<unsigned char>(line[k])) || line[k] == '.'))
        ++k;
      return "Slic3r " + std::string(line.substr(0, k));
    }
    b = e + 1;
  }
  return {};
}

// The last `limit` bytes of a file.
std::string read_tail(const fs::path& p, std::size_t limit) {
  std::ifstream in(p, std::ios::binary);
  if (!in) return {};
  in.seekg(0, std::ios::end);
  const auto size = static_cast<std::size_t>(std::max<std::streamoff>(in.tellg(), 0));
  const std::size_t start = size > limit ? size - limit : 0;
  in.seekg(static_cast<std::streamoff>(start));
  std::string s(size - start, '\0');
  in.read(s.data(), static_cast<std::streamsize>(s.size()));
  return s;
}

// The slicer's message: the last few lines that are not progress or trace chatter.
std::string last_lines(std::string_view text, int count) {
  std::vector<std::string_view> lines;
  for (std::size_t b = 0; b < text.size();) {
    auto e = text.find('\n', b);
    if (e == std::string_view::npos) e = text.size();
    std::string_view line = text.substr(b, e - b);
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.remove_suffix(1);
    const bool chatter = line.find("[trace]") != std::string_view::npos ||
                         line.find("[debug]") != std::string_view::npos ||
                         line.find("Progress:") != std::string_view::npos || line.empty();
    if (!chatter) lines.push_back(line);
    b = e + 1;
  }
  // Lines that say what went wrong beat the last lines (a slicer may print its whole help
  // after "Unknown option ...").
  std::vector<std::string_view> errors;
  for (auto line : lines) {
    std::string lower(line);
    std::transform(lower.begin(), lower.end(), lower.begin(),
                   [](unsigned char c) { return std::tolower(c); });
    for (std::string_view word : {"error", "unknown", "invalid", "failed", "cannot", "could not"})
      if (lower.find(word) != std::string::npos) {
        errors.push_back(line);
        break;
      }
  }
  // The first such line: what follows it is often a consequence or the help text.
  if (!errors.empty()) lines.assign(1, errors.front());
  std::string out;
  const std::size_t from =
      lines.size() > static_cast<std::size_t>(count) ? lines.size() - count : 0;
  for (std::size_t i = from; i < lines.size(); ++i) {
    if (!out.empty()) out += " | ";
    out += std::string(lines[i].substr(0, 300));
  }
  return out;
}

// Cura: key=value lines of a settings file ('#' and ';' comments, blank lines skipped).
Result<std::vector<SettingKV>> read_cura_settings(const std::string& path) {
  auto text = read_file(path);
  if (!text) return text.error();
  std::vector<SettingKV> out;
  long line_no = 0;
  std::string_view rest = *text;
  while (!rest.empty()) {
    const auto nl = rest.find('\n');
    std::string_view line = rest.substr(0, nl);
    rest = nl == std::string_view::npos ? std::string_view() : rest.substr(nl + 1);
    ++line_no;
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t'))
      line.remove_suffix(1);
    while (!line.empty() && (line.front() == ' ' || line.front() == '\t')) line.remove_prefix(1);
    if (line.empty() || line.front() == '#' || line.front() == ';' || line.front() == '[') continue;
    auto kv = parse_setting_kv(line);
    if (!kv)
      return bad_input("a Cura settings file holds key=value lines: " + kv.error().message, path,
                       line_no);
    out.push_back(std::move(*kv));
  }
  return out;
}

// CuraEngine reads no formula of the definitions: a parent setting given with -s does not
// reach the children the engine uses. The children of the settings people vary are filled
// in here with Cura's own rules; a child the config file or the command line sets is kept,
// as Cura keeps a value the user set.
void add_cura_children(std::map<std::string, std::string>& s,
                       const std::set<std::string>& from_file,
                       const std::set<std::string>& from_command) {
  auto number = [&](const std::string& key, double fallback) {
    auto it = s.find(key);
    if (it == s.end()) return fallback;
    char* end = nullptr;
    const double v = std::strtod(it->second.c_str(), &end);
    return end != it->second.c_str() ? v : fallback;
  };
  auto derive = [&](const std::string& key, std::string value) {
    if (from_command.count(key) || from_file.count(key))
      return;  // set by the user: kept, as Cura does
    s[key] = std::move(value);
  };
  auto text = [](double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.4g", v);
    return std::string(buf);
  };
  const double line_width = number("line_width", number("machine_nozzle_size", 0.4));
  if (s.count("infill_sparse_density")) {
    const double density = number("infill_sparse_density", 20);
    const std::string pattern = s.count("infill_pattern") ? s.at("infill_pattern") : "grid";
    double per = 1;  // lines, zigzag, concentric, gyroid, lightning
    if (pattern == "grid" || pattern == "tetrahedral" || pattern == "quarter_cubic") per = 2;
    if (pattern == "triangles" || pattern == "trihexagon" || pattern == "cubic" ||
        pattern == "cubicsubdiv")
      per = 3;
    const double infill_width = number("infill_line_width", line_width);
    derive("infill_line_distance",
           density <= 0 ? std::string("0") : text(infill_width * 100 / density * per));
  }
  if (s.count("wall_thickness")) {
    const double wall = number("wall_thickness", 0.8);
    derive("wall_line_count",
           text(std::max(1.0, std::round(wall / number("wall_line_width", line_width)))));
  }
  if (s.count("top_bottom_thickness")) {
    const double tb = number("top_bottom_thickness", 0.8), lh = number("layer_height", 0.1);
    derive("top_layers", text(std::ceil(tb / lh - 1e-6)));
    derive("bottom_layers", text(std::ceil(tb / lh - 1e-6)));
  }
  if (s.count("speed_print")) {
    const double v = number("speed_print", 50);
    derive("speed_infill", text(v));
    derive("speed_wall", text(v / 2));
    derive("speed_wall_0", text(number("speed_wall", v / 2)));
    derive("speed_wall_x", text(number("speed_wall", v / 2)));
    derive("speed_topbottom", text(v / 2));
  }
  if (s.count("retraction_speed")) {
    derive("retraction_retract_speed", s.at("retraction_speed"));
    derive("retraction_prime_speed", s.at("retraction_speed"));
  }
}

// Settings both vocabularies have: PrusaSlicer/Slic3r name, Cura name, whether PrusaSlicer
// writes the value as a percentage. A mixed comparison gives them in either vocabulary.
struct SharedSetting {
  std::string_view prusa, cura;
  bool percent;
};
constexpr std::array<SharedSetting, 15> kSharedSettings{{
    {"first_layer_height", "layer_height_0", false},
    {"perimeters", "wall_line_count", false},
    {"top_solid_layers", "top_layers", false},
    {"bottom_solid_layers", "bottom_layers", false},
    {"fill_density", "infill_sparse_density", true},
    {"perimeter_speed", "speed_wall_x", false},
    {"external_perimeter_speed", "speed_wall_0", false},
    {"infill_speed", "speed_infill", false},
    {"top_solid_infill_speed", "speed_topbottom", false},
    {"travel_speed", "speed_travel", false},
    {"first_layer_speed", "speed_layer_0", false},
    {"temperature", "material_print_temperature", false},
    {"bed_temperature", "material_bed_temperature", false},
    {"skirts", "skirt_line_count", false},
    {"retract_length", "retraction_amount", false},
}};

// `key`/`value` in the vocabulary of `slicer` (layer_height is the same in all three).
SettingKV in_vocabulary(std::string_view slicer, const SettingKV& kv) {
  const bool cura = slicer == "cura";
  for (const auto& s : kSharedSettings) {
    if (cura && kv.first == s.prusa) {
      std::string v = kv.second;
      if (s.percent && !v.empty() && v.back() == '%') v.pop_back();
      return {std::string(s.cura), v};
    }
    if (!cura && kv.first == s.cura) {
      std::string v = kv.second;
      if (s.percent && !v.empty() && v.back() != '%') v += '%';
      return {std::string(s.prusa), v};
    }
  }
  return kv;
}

}  // namespace

std::vector<SettingKV> slicer_settings(std::string_view slicer,
                                       const std::vector<SettingKV>& settings) {
  std::vector<SettingKV> out;
  out.reserve(settings.size());
  for (const auto& kv : settings) out.push_back(in_vocabulary(slicer, kv));
  return out;
}

std::string cura_definition_printer(const std::string& definition) {
  auto text = read_file(definition);
  if (!text) return {};
  const auto doc = nlohmann::json::parse(*text, nullptr, false);
  if (!doc.is_object() || !doc.contains("name") || !doc["name"].is_string()) return {};
  const LibraryPrinter* p = match_library_printer(doc["name"].get<std::string>());
  return p ? p->id : std::string();
}

bool is_known_slicer(std::string_view name) {
  return name == "printtwin" || info_of(name) != nullptr;
}

Status check_slicer_name(std::string_view name) {
  if (is_known_slicer(name)) return Ok{};
  return usage_error("--slicer must be printtwin, prusa-slicer, cura or slic3r, got '" +
                     std::string(name) + "'");
}

Result<SlicerProgram> find_slicer_program(std::string_view name, std::string_view path) {
  const SlicerInfo* info = info_of(name);
  if (info == nullptr) {
    if (auto st = check_slicer_name(name); !st) return st.error();
    return usage_error("printtwin's slicer is built in; it runs no program");
  }
  SlicerProgram p;
  p.name = std::string(name);
  if (!path.empty()) {
    fs::path given(path);
    if (given.parent_path().empty() && !fs::exists(given))
      p.program = on_path(path);
    else if (is_executable(given))
      p.program = fs::absolute(given).string();
    if (p.program.empty())
      return usage_error("--slicer-path " + std::string(path) + " is not an executable file");
  } else {
    for (auto prog : info->programs)
      if (!prog.empty() && (p.program = on_path(prog), !p.program.empty())) break;
    if (p.program.empty())
      return usage_error(std::string(name) + " is not installed (no " +
                         std::string(info->programs[0]) +
                         " on the PATH): install the Debian package " + std::string(info->package) +
                         ", or give the program with --slicer-path");
  }
  const ProcessRun v = run_process({p.program, std::string(info->version_flag)}, {}, 30);
  p.version = version_from_output(name, v.output);
  return p;
}

Result<std::vector<SettingKV>> parse_slicer_paths(const std::vector<std::string>& values,
                                                  const std::vector<std::string>& slicers) {
  std::vector<std::string> external;
  for (const auto& s : slicers)
    if (s != "printtwin") external.push_back(s);
  std::vector<SettingKV> out;
  for (const auto& v : values) {
    const auto eq = v.find('=');
    if (eq != std::string::npos && info_of(std::string_view(v).substr(0, eq)) != nullptr) {
      out.emplace_back(v.substr(0, eq), v.substr(eq + 1));
      continue;
    }
    if (external.size() != 1) return slicer_path_without_slicer(v, external.empty());
    out.emplace_back(external.front(), v);
  }
  return out;
}

std::vector<SettingKV> effective_settings(const std::vector<SettingKV>& settings) {
  std::map<std::string, std::string> last;
  for (const auto& [k, v] : settings) last[k] = v;
  return {last.begin(), last.end()};
}

Result<std::vector<std::string>> slicer_command(const SlicerProgram& program,
                                                const SlicerJob& job) {
  std::vector<std::string> argv{program.program};
  const auto translated = slicer_settings(program.name, job.settings);
  const auto settings = effective_settings(translated);
  if (program.name == "cura") {
    if (job.cura_definition.empty())
      return usage_error(
          "--slicer cura needs the printer's definition: --cura-definition "
          "/usr/share/cura/resources/definitions/creality_ender3.def.json (package cura)");
    argv.insert(argv.end(), {"slice", "-v", "-j", job.cura_definition});
    // CuraEngine takes the last -s of a key; the config file first, then the variant's.
    std::map<std::string, std::string> effective;
    std::set<std::string> from_file, from_command;
    if (!job.config_path.empty()) {
      auto file = read_cura_settings(job.config_path);
      if (!file) return file.error();
      for (const auto& [k, v] : *file) {
        effective[k] = v;
        from_file.insert(k);
      }
    }
    for (const auto& [k, v] : translated) {
      effective[k] = v;
      from_command.insert(k);
    }
    add_cura_children(effective, from_file, from_command);
    for (const auto& [k, v] : effective) argv.insert(argv.end(), {"-s", key_value(k, v)});
    argv.insert(argv.end(), {"-l", job.mesh_path, "-o", job.out_gcode});
    return argv;
  }
  // PrusaSlicer and Slic3r share the command line of Slic3r: --load, --key value.
  if (!job.config_path.empty()) argv.insert(argv.end(), {"--load", job.config_path});
  for (const auto& [k, v] : settings) {
    std::string flag = k;
    std::replace(flag.begin(), flag.end(), '_', '-');
    argv.insert(argv.end(), {"--" + flag, v});
  }
  if (program.name == "prusa-slicer") argv.emplace_back("--export-gcode");
  argv.insert(argv.end(), {"-o", job.out_gcode, job.mesh_path});
  return argv;
}

std::string shell_quote(const std::vector<std::string>& argv) {
  std::string out;
  for (const auto& a : argv) {
    if (!out.empty()) out += ' ';
    const bool plain = !a.empty() && std::all_of(a.begin(), a.end(), [](char c) {
      return std::isalnum(static_cast<unsigned char>(c)) || std::strchr("-_./=,:+%@", c) != nullptr;
    });
    if (plain) {
      out += a;
      continue;
    }
    out += '\'';
    for (char c : a) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
    out += '\'';
  }
  return out;
}

ProcessRun run_process(const std::vector<std::string>& argv, const std::vector<SettingKV>& env,
                       double timeout_s) {
  ProcessRun r;
  if (argv.empty()) return r;
  const auto t0 = std::chrono::steady_clock::now();
  // Output goes to an unlinked temporary file: no pipe to drain while waiting.
  char tmpl[] = "/tmp/printtwin-slicer-XXXXXX";
  const int out_fd = ::mkstemp(tmpl);
  if (out_fd < 0) return r;
  const std::string out_path = tmpl;
  std::vector<char*> args;
  args.reserve(argv.size() + 1);
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  // The child's environment is built here: between fork and exec a threaded process may
  // only make async-signal-safe calls (no setenv, no allocation).
  std::vector<std::string> env_text;
  for (char** e = environ; e != nullptr && *e != nullptr; ++e) {
    const std::string_view entry(*e);
    const bool replaced = std::any_of(env.begin(), env.end(), [&](const SettingKV& kv) {
      return entry.size() > kv.first.size() && entry.substr(0, kv.first.size()) == kv.first &&
             entry[kv.first.size()] == '=';
    });
    if (!replaced) env_text.emplace_back(entry);
  }
  for (const auto& [k, v] : env) env_text.push_back(key_value(k, v));
  std::vector<char*> envp;
  envp.reserve(env_text.size() + 1);
  for (auto& e : env_text) envp.push_back(e.data());
  envp.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(out_fd);
    ::unlink(out_path.c_str());
    return r;
  }
  if (pid == 0) {
    ::setpgid(0, 0);  // its own process group: a timeout stops its children too
    const int devnull = ::open("/dev/null", O_RDONLY);
    if (devnull >= 0) ::dup2(devnull, 0);
    ::dup2(out_fd, 1);
    ::dup2(out_fd, 2);
    ::execve(args[0], args.data(), envp.data());
    const char msg[] = "could not start the program\n";
    (void)!::write(2, msg, sizeof msg - 1);
    ::_exit(127);
  }
  ::setpgid(pid, pid);
  r.started = true;
  int status = 0;
  while (true) {
    const pid_t w = ::waitpid(pid, &status, WNOHANG);
    if (w == pid) break;
    if (w < 0 && errno != EINTR) break;
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (elapsed > timeout_s) {
      r.timed_out = true;
      ::kill(-pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(elapsed < 1 ? 5 : 25));
  }
  if (!r.timed_out && WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
  ::close(out_fd);
  r.output = read_tail(out_path, 128 * 1024);
  ::unlink(out_path.c_str());
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

std::vector<SettingKV> slicer_environment(const SlicerProgram& program, const SlicerJob& job) {
  std::vector<SettingKV> env;
  if (program.name == "cura") {
    // The definition inherits from fdmprinter and names extruders that live beside it.
    const char* given = std::getenv("CURA_ENGINE_SEARCH_PATH");
    const fs::path defs = fs::path(job.cura_definition).parent_path();
    env.emplace_back("CURA_ENGINE_SEARCH_PATH",
                     given ? std::string(given)
                           : defs.string() + ":" + (defs.parent_path() / "extruders").string());
  }
  return env;
}

Result<std::string> slicer_command_line(const SlicerProgram& program, const SlicerJob& job) {
  auto argv = slicer_command(program, job);
  if (!argv) return argv.error();
  std::string prefix;
  for (const auto& [k, v] : slicer_environment(program, job))
    prefix += shell_quote({key_value(k, v)});
  prefix += ' ';
  return prefix + shell_quote(*argv);
}

Result<std::string> slicer_config_file(std::string_view slicer, const std::string& config_path,
                                       const fs::path& extracted_ini) {
  if (config_path.empty()) return config_path;
  auto head = read_file_head(config_path, 4);
  if (!head) return head.error();
  if (*head != std::string_view("PK\x03\x04", 4)) return config_path;  // not a zip archive
  if (slicer == "cura")
    return bad_input(
        "a zip (3MF) archive: CuraEngine takes its settings as key=value lines, not a Cura "
        "project; give --cura-definition and the settings file",
        config_path);
  auto text = read_prusa_config(config_path);
  if (!text) return text.error();
  if (auto st = write_file_atomic(extracted_ini, *text); !st) return st.error();
  return extracted_ini.string();
}

Status run_external_slicer(const SlicerProgram& program, const SlicerJob& job, double timeout_s,
                           std::string* command_out) {
  auto argv = slicer_command(program, job);
  if (!argv) return argv.error();
  if (command_out) *command_out = slicer_command_line(program, job).value();
  const std::vector<SettingKV> env = slicer_environment(program, job);
  std::error_code ec;
  fs::create_directories(fs::path(job.out_gcode).parent_path(), ec);
  fs::remove(job.out_gcode, ec);
  const ProcessRun run = run_process(*argv, env, timeout_s);
  const std::string who = program.version.empty() ? program.name : program.version;
  if (!run.started) return bad_input(who + " could not be started", program.program);
  if (run.timed_out)
    return bad_input(who + " did not finish within --slicer-timeout " +
                         std::to_string(static_cast<int>(timeout_s)) + " s and was stopped",
                     job.mesh_path);
  const bool written =
      fs::is_regular_file(job.out_gcode, ec) && fs::file_size(job.out_gcode, ec) > 0;
  if (run.exit_code != 0 || !written) {
    std::string what = last_lines(run.output, 3);
    if (what.empty()) what = "no message";
    return bad_input(who + " failed on the part (exit " + std::to_string(run.exit_code) +
                         (written ? "" : ", no G-code written") + "): " + what,
                     job.mesh_path);
  }
  return Ok{};
}

}  // namespace printtwin
