#include "slice/project_settings.hpp"

#include <algorithm>
#include <array>
#include <map>
#include <optional>

namespace printtwin::detail {
namespace {

using Settings = std::vector<std::pair<std::string, std::string>>;

/// One XML tag: its name ("object", "/object", "metadata", ...) and its attributes.
struct Tag {
  std::string name;
  std::map<std::string, std::string, std::less<>> attributes;
};

std::string unescape_xml(std::string_view v) {
  static constexpr std::array<std::pair<std::string_view, char>, 5> kEntities = {
      {{"&quot;", '"'}, {"&apos;", '\''}, {"&lt;", '<'}, {"&gt;", '>'}, {"&amp;", '&'}}};
  std::string out;
  out.reserve(v.size());
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (v[i] != '&') {
      out += v[i];
      continue;
    }
    bool matched = false;
    for (const auto& [entity, ch] : kEntities) {
      if (v.substr(i, entity.size()) == entity) {
        out += ch;
        i += entity.size() - 1;
        matched = true;
        break;
      }
    }
    if (!matched && v.substr(i, 2) == "&#") {  // numeric character reference (newlines)
      const std::size_t end = v.find(';', i);
      if (end != std::string_view::npos && end - i <= 10) {
        const bool hex = v.size() > i + 2 && (v[i + 2] == 'x' || v[i + 2] == 'X');
        const std::string digits(v.substr(i + (hex ? 3 : 2), end - i - (hex ? 3 : 2)));
        const long code = std::strtol(digits.c_str(), nullptr, hex ? 16 : 10);
        out += code > 0 && code < 128 ? static_cast<char>(code) : '?';
        i = end;
        matched = true;
      }
    }
    if (!matched) out += '&';
  }
  return out;
}

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

/// Parses the tag between '<' and '>' (exclusive). Comments and declarations give an empty
/// name.
Tag parse_tag(std::string_view body) {
  Tag tag;
  if (body.empty() || body.front() == '?' || body.front() == '!') return tag;
  std::size_t i = 0;
  while (i < body.size() && !is_space(body[i]) && body[i] != '/') ++i;
  if (i == 0 && body.front() == '/') {  // closing tag
    tag.name = std::string(body);
    return tag;
  }
  tag.name = std::string(body.substr(0, i));
  while (i < body.size()) {
    while (i < body.size() && (is_space(body[i]) || body[i] == '/')) ++i;
    const std::size_t eq = body.find('=', i);
    if (eq == std::string_view::npos) break;
    std::string key(body.substr(i, eq - i));
    while (!key.empty() && is_space(key.back())) key.pop_back();
    std::size_t q = eq + 1;
    while (q < body.size() && is_space(body[q])) ++q;
    if (q >= body.size() || (body[q] != '"' && body[q] != '\'')) break;
    const std::size_t close = body.find(body[q], q + 1);
    if (close == std::string_view::npos) break;
    tag.attributes[key] = unescape_xml(body.substr(q + 1, close - q - 1));
    i = close + 1;
  }
  return tag;
}

/// Volume rows that describe the part itself, not print settings.
bool is_volume_property(std::string_view key) {
  static constexpr std::array<std::string_view, 13> kProperties = {"name",
                                                                   "modifier",
                                                                   "volume_type",
                                                                   "matrix",
                                                                   "source_file",
                                                                   "source_object_id",
                                                                   "source_volume_id",
                                                                   "source_offset_x",
                                                                   "source_offset_y",
                                                                   "source_offset_z",
                                                                   "source_in_inches",
                                                                   "source_in_meters",
                                                                   "source_is_builtin_volume"};
  return std::find(kProperties.begin(), kProperties.end(), key) != kProperties.end();
}

struct Volume {
  std::string name;
  std::string type = "ModelPart";
  Settings settings;
};

struct Object {
  std::string name;
  Settings settings;
  std::vector<Volume> volumes;
};

Result<std::vector<Object>> read_objects(std::string_view xml, const std::string& source) {
  std::vector<Object> objects;
  Object* object = nullptr;
  Volume* volume = nullptr;
  std::size_t pos = 0;
  while ((pos = xml.find('<', pos)) != std::string_view::npos) {
    const std::size_t end = xml.find('>', pos);
    if (end == std::string_view::npos)
      return bad_input(
          std::string(kProjectModelConfigEntry) + ": a tag is not closed (the project is damaged)",
          source);
    Tag tag = parse_tag(xml.substr(pos + 1, end - pos - 1));
    pos = end + 1;
    if (tag.name == "object") {
      object = &objects.emplace_back();
      volume = nullptr;
    } else if (tag.name == "/object") {
      object = nullptr;
      volume = nullptr;
    } else if (tag.name == "volume" && object != nullptr) {
      volume = &object->volumes.emplace_back();
    } else if (tag.name == "/volume") {
      volume = nullptr;
    } else if (tag.name == "metadata" && object != nullptr) {
      const std::string type = tag.attributes["type"];
      const std::string key = tag.attributes["key"];
      std::string value = tag.attributes["value"];
      if (key.empty()) continue;
      if (type == "object" && volume == nullptr) {
        if (key == "name")
          object->name = std::move(value);
        else
          object->settings.emplace_back(key, std::move(value));
      } else if (type == "volume" && volume != nullptr) {
        if (key == "name") {
          volume->name = std::move(value);
        } else if (key == "volume_type") {
          volume->type = std::move(value);
        } else if (key == "modifier") {
          if (value == "1" && volume->type == "ModelPart") volume->type = "ParameterModifier";
        } else if (!is_volume_property(key)) {
          volume->settings.emplace_back(key, std::move(value));
        }
      }
    }
  }
  return objects;
}

std::string describe_settings(const Settings& s) {
  std::string out;
  for (const auto& [k, v] : s) {
    if (!out.empty()) out += ", ";
    out.append(k).append(" = ").append(v);
  }
  return out.empty() ? "none" : out;
}

std::string quoted_name(const std::string& name, std::size_t index) {
  return name.empty() ? "object " + std::to_string(index + 1) : "object '" + name + "'";
}

/// The settings that hold for the whole of one object, or why there are none.
Result<Settings> whole_part_settings(const Object& o, std::size_t index, const std::string& src) {
  Settings settings = o.settings;
  const Volume* printed = nullptr;
  for (const Volume& v : o.volumes) {
    if (v.type != "ModelPart") {
      return bad_input(
          quoted_name(o.name, index) + " has a " + v.type + " volume" +
              (v.name.empty() ? "" : " '" + v.name + "'") +
              ": printtwin slices the part as one body and cannot apply it. Save the project "
              "without it, or give the print settings as an .ini",
          src);
    }
    if (v.settings.empty()) continue;
    if (printed != nullptr && printed->settings != v.settings) {
      return bad_input(quoted_name(o.name, index) +
                           " has parts with different settings: printtwin slices the part as "
                           "one body. Give the settings of one part as an .ini",
                       src);
    }
    printed = &v;
  }
  if (printed != nullptr)
    settings.insert(settings.end(), printed->settings.begin(), printed->settings.end());
  return settings;
}

}  // namespace

Result<Settings> project_object_settings(std::string_view model_config,
                                         std::string_view layer_ranges, const std::string& source) {
  if (layer_ranges.find("<range") != std::string_view::npos) {
    return bad_input(std::string(kProjectLayerRangesEntry) +
                         ": the project sets settings for height ranges, which printtwin "
                         "cannot apply (it slices with one set of settings). Save the "
                         "project without them, or give the print settings as an .ini",
                     source);
  }
  auto objects = read_objects(model_config, source);
  if (!objects) return objects.error();
  std::optional<Settings> common;
  std::string first_name;
  for (std::size_t i = 0; i < objects->size(); ++i) {
    auto settings = whole_part_settings((*objects)[i], i, source);
    if (!settings) return settings.error();
    if (!common) {
      common = std::move(*settings);
      first_name = quoted_name((*objects)[i].name, i);
    } else if (*common != *settings) {
      return bad_input("the project's objects have different settings (" + first_name + ": " +
                           describe_settings(*common) + "; " + quoted_name((*objects)[i].name, i) +
                           ": " + describe_settings(*settings) +
                           "). printtwin checks one part: save a project with that part only",
                       source);
    }
  }
  return common.value_or(Settings{});
}

}  // namespace printtwin::detail
