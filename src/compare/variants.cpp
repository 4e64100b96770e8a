// Variant expansion and sharding: the command line's --vary / --config / --gcode / --label
// become an ordered, deterministic list of VariantSpec; shares pick from it round robin.
#include <algorithm>
#include <filesystem>
#include <optional>
#include <set>

#include "printtwin/compare.hpp"

namespace printtwin {

namespace {

constexpr std::size_t kMaxVariants = 10000;

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

// Setting keys are compared the way the slicer reads them: '-' and '_' are the same.
std::string normalized_key(std::string_view key) {
  std::string k(key);
  std::replace(k.begin(), k.end(), '-', '_');
  return k;
}

std::string stem_of(const std::string& path) { return std::filesystem::path(path).stem().string(); }

// Gives repeated names a " (2)", " (3)" suffix in list order.
void make_unique(std::vector<std::string>& names) {
  std::set<std::string> seen;
  for (auto& n : names) {
    if (seen.insert(n).second) continue;
    for (int k = 2;; ++k) {
      std::string candidate = n + " (" + std::to_string(k) + ")";
      if (seen.insert(candidate).second) {
        n = candidate;
        break;
      }
    }
  }
}

}  // namespace

std::string_view to_string(VariantKind kind) {
  return kind == VariantKind::gcode ? "gcode" : "slicer";
}

Result<SettingKV> parse_setting_kv(std::string_view text) {
  const auto eq = text.find('=');
  if (eq == std::string_view::npos)
    return usage_error("expected key=value, got '" + std::string(text) + "'");
  const std::string_view key = trim(text.substr(0, eq));
  if (key.empty())
    return usage_error("expected key=value with a key, got '" + std::string(text) + "'");
  return SettingKV{normalized_key(key), std::string(trim(text.substr(eq + 1)))};
}

Result<SweepAxis> parse_sweep_axis(std::string_view text) {
  auto kv = parse_setting_kv(text);
  if (!kv) return usage_error("--vary " + kv.error().message + " (e.g. layer_height=0.1,0.2)");
  SweepAxis axis;
  axis.key = kv->first;
  std::string_view rest = kv->second;
  std::set<std::string> seen;
  while (true) {
    const auto comma = rest.find(',');
    const std::string value(trim(rest.substr(0, comma)));
    if (value.empty())
      return usage_error("--vary " + axis.key + ": empty value in '" + std::string(text) +
                         "' (expected values separated by commas)");
    if (!seen.insert(value).second)
      return usage_error("--vary " + axis.key + ": value '" + value + "' is listed twice");
    axis.values.push_back(value);
    if (comma == std::string_view::npos) break;
    rest.remove_prefix(comma + 1);
  }
  return axis;
}

namespace {

// The number of setting combinations the --vary axes make (kMaxVariants + 1 at most).
Result<std::size_t> count_combinations(const std::vector<SweepAxis>& axes) {
  std::set<std::string> keys;
  std::size_t combos = 1;
  for (const auto& axis : axes) {
    if (axis.values.empty()) return usage_error("--vary " + axis.key + ": no values");
    if (!keys.insert(normalized_key(axis.key)).second)
      return usage_error("--vary " + axis.key +
                         " is given twice; list all its values in one --vary");
    combos *= axis.values.size();
    if (combos > kMaxVariants) break;
  }
  return combos;
}

// The --config files: `--config cura=ender3.cfg` is a config for one slicer only; a bare
// path is for every one.
struct SweepConfigs {
  std::vector<std::string> slicer;  ///< empty: every slicer
  std::vector<std::string> path;
  std::vector<std::string> name;  ///< the file's stem, unique

  /// The indices of the configs that apply to `s`.
  [[nodiscard]] std::vector<std::size_t> of(const std::string& s) const {
    std::vector<std::size_t> out;
    for (std::size_t c = 0; c < path.size(); ++c)
      if (slicer[c].empty() || slicer[c] == s) out.push_back(c);
    return out;
  }
};

Error config_for_other_slicer(const std::string& config, const std::string& slicer) {
  return usage_error("--config " + config + " is for " + slicer +
                     ", which is not a --slicer of this comparison");
}

Result<SweepConfigs> parse_configs(const std::vector<std::string>& configs,
                                   const std::vector<std::string>& slicers) {
  SweepConfigs out;
  for (const auto& c : configs) {
    const auto eq = c.find('=');
    const std::string prefix = eq == std::string::npos ? std::string() : c.substr(0, eq);
    const bool named = !prefix.empty() && is_known_slicer(prefix);
    if (named && std::find(slicers.begin(), slicers.end(), prefix) == slicers.end())
      return config_for_other_slicer(c, prefix);
    out.slicer.push_back(named ? prefix : std::string());
    out.path.push_back(named ? c.substr(eq + 1) : c);
    out.name.push_back(stem_of(out.path.back()));
  }
  make_unique(out.name);
  return out;
}

Status check_slicers(const std::vector<std::string>& slicers) {
  std::set<std::string> seen;
  for (const auto& s : slicers) {
    if (auto st = check_slicer_name(s); !st) return st.error();
    if (!seen.insert(s).second) return usage_error("--slicer " + s + " is given twice");
  }
  return Ok{};
}

// The variants of one slicer with one config (none: no config): every combination of the axes,
// odometer order, last axis fastest.
void append_slicer_variants(const SweepSpec& spec, const SweepConfigs& configs,
                            const std::string& slicer, bool several_slicers,
                            std::optional<std::size_t> c, std::size_t combos,
                            std::vector<VariantSpec>& out) {
  std::vector<std::size_t> at(spec.axes.size(), 0);
  for (std::size_t n = 0; n < combos; ++n) {
    VariantSpec v;
    v.kind = VariantKind::slicer;
    v.slicer = slicer;
    // Several slicers: each label starts with its slicer's name.
    std::string label = several_slicers ? slicer : std::string();
    if (c) {
      if (!label.empty()) label += ' ';
      v.config_path = configs.path[*c];
      label += configs.name[*c];
    }
    v.settings = spec.common_settings;
    for (std::size_t a = 0; a < spec.axes.size(); ++a) {
      const auto& axis = spec.axes[a];
      v.settings.emplace_back(normalized_key(axis.key), axis.values[at[a]]);
      if (!label.empty()) label += ' ';
      label += normalized_key(axis.key) + "=" + axis.values[at[a]];
    }
    if (label.empty()) label = slicer == "printtwin" ? std::string("printtwin defaults") : slicer;
    v.label = label;
    out.push_back(std::move(v));
    for (std::size_t a = spec.axes.size(); a-- > 0;) {
      if (++at[a] < spec.axes[a].values.size()) break;
      at[a] = 0;
    }
  }
}

void append_gcode_variants(const std::vector<std::string>& gcodes, std::vector<VariantSpec>& out) {
  std::vector<std::string> names;
  names.reserve(gcodes.size());
  for (const auto& g : gcodes) names.push_back(stem_of(g));
  make_unique(names);
  for (std::size_t g = 0; g < gcodes.size(); ++g) {
    VariantSpec v;
    v.kind = VariantKind::gcode;
    v.gcode_path = gcodes[g];
    v.label = names[g];
    out.push_back(std::move(v));
  }
}

// --label in variant order, or else the generated labels made unique.
Status apply_labels(const std::vector<std::string>& labels, std::vector<VariantSpec>& out) {
  if (!labels.empty()) {
    std::set<std::string> seen;
    for (std::size_t i = 0; i < out.size(); ++i) {
      const std::string label(trim(labels[i]));
      if (label.empty())
        return usage_error("--label number " + std::to_string(i + 1) + " is empty");
      if (!seen.insert(label).second)
        return usage_error("--label '" + label + "' is given to two variants; labels must differ");
      out[i].label = label;
    }
    return Ok{};
  }
  // Generated labels can collide (a config named like another's stem plus a sweep value
  // is impossible, but a G-code file named "printtwin defaults" is not).
  std::vector<std::string> names;
  names.reserve(out.size());
  for (const auto& v : out) names.push_back(v.label);
  make_unique(names);
  for (std::size_t i = 0; i < out.size(); ++i) out[i].label = names[i];
  return Ok{};
}

}  // namespace

Result<std::vector<VariantSpec>> expand_variants(const SweepSpec& spec) {
  const auto combos = count_combinations(spec.axes);
  if (!combos) return combos.error();
  std::vector<std::string> slicers = spec.slicers;
  if (slicers.empty()) slicers.emplace_back("printtwin");
  const auto configs = parse_configs(spec.configs, slicers);
  if (!configs) return configs.error();
  std::size_t config_sets = 0;
  for (const auto& s : slicers) config_sets += std::max<std::size_t>(configs->of(s).size(), 1);
  if (auto st = check_slicers(slicers); !st) return st.error();

  const bool slicer_variants =
      !spec.axes.empty() || !spec.configs.empty() || !spec.slicers.empty() || spec.gcodes.empty();
  const std::size_t total = (slicer_variants ? config_sets * *combos : 0) + spec.gcodes.size();
  if (*combos > kMaxVariants || total > kMaxVariants)
    return usage_error("the sweep has more than " + std::to_string(kMaxVariants) +
                       " variants; split it into several comparisons");
  if (!spec.labels.empty() && spec.labels.size() != total)
    return usage_error("--label was given " + std::to_string(spec.labels.size()) + " times for " +
                       std::to_string(total) +
                       " variants; give one label per variant, in variant order, or none");

  std::vector<VariantSpec> out;
  out.reserve(total);
  if (slicer_variants) {
    for (const auto& slicer : slicers) {
      const std::vector<std::size_t> of = configs->of(slicer);
      if (of.empty())
        append_slicer_variants(spec, *configs, slicer, slicers.size() > 1, std::nullopt, *combos,
                               out);
      for (std::size_t c : of)
        append_slicer_variants(spec, *configs, slicer, slicers.size() > 1, c, *combos, out);
    }
  }
  append_gcode_variants(spec.gcodes, out);
  if (auto st = apply_labels(spec.labels, out); !st) return st.error();
  for (std::size_t i = 0; i < out.size(); ++i) out[i].index = static_cast<int>(i);
  return out;
}

Result<std::vector<int>> shard_indices(int variant_count, int k, int n) {
  if (n < 1) return usage_error("--of must be at least 1, got " + std::to_string(n));
  if (k < 0 || k >= n)
    return usage_error("--variant must be in 0.." + std::to_string(n - 1) + " for --of " +
                       std::to_string(n) + " (shares are numbered from 0), got " +
                       std::to_string(k));
  std::vector<int> out;
  for (int i = k; i < variant_count; i += n) out.push_back(i);
  return out;
}

}  // namespace printtwin
