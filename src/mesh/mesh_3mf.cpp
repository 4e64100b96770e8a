#include "mesh/mesh_3mf.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <map>
#include <utility>
#include <vector>

#include "core/zip_reader.hpp"

namespace printtwin::detail {
namespace {

using Affine = Eigen::Affine3d;
using Triangle = std::array<std::uint32_t, 3>;

/// More triangles or placed objects than this after following every component is refused
/// (components that reference the same object many times over, level after level, multiply
/// quickly), and so are components nested deeper than kMaxDepth (the stack).
constexpr std::size_t kMaxTriangles = std::size_t{1} << 25;
constexpr std::size_t kMaxPlacements = std::size_t{1} << 20;
constexpr std::size_t kMaxDepth = 1000;

constexpr std::string_view kRootModelDefault = "3D/3dmodel.model";

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

std::string_view trimmed(std::string_view v) {
  while (!v.empty() && is_space(v.front())) v.remove_prefix(1);
  while (!v.empty() && is_space(v.back())) v.remove_suffix(1);
  return v;
}

/// The name after a namespace prefix ("p:path" -> "path").
std::string_view local_name(std::string_view qualified) {
  const std::size_t colon = qualified.rfind(':');
  return colon == std::string_view::npos ? qualified : qualified.substr(colon + 1);
}

// --- XML tags ----------------------------------------------------------------------------
// Only what 3MF model files need: element tags with their attributes (any order, ' or "
// quotes, namespace prefixes dropped), self-closing tags, comments, processing instructions,
// declarations and CDATA skipped, text ignored.

struct Attribute {
  std::string_view key;  ///< local name
  std::string_view value;
};

struct Tag {
  std::string_view name;  ///< local name
  bool closing = false;   ///< </name>
  bool self_closing = false;
  std::vector<Attribute> attributes;

  [[nodiscard]] std::optional<std::string_view> get(std::string_view key) const {
    for (const auto& a : attributes)
      if (a.key == key) return a.value;
    return std::nullopt;
  }
};

class TagScanner {
 public:
  explicit TagScanner(std::string_view text) : text_(text) {}

  /// The next element tag, or false at the end of the text or on an error (error() says).
  bool next(Tag& tag) {
    while (error_.empty()) {
      const std::size_t lt = text_.find('<', pos_);
      if (lt == std::string_view::npos) return false;
      start_ = lt;
      if (skip_markup("<!--", "-->", "a comment") || skip_markup("<![CDATA[", "]]>", "CDATA") ||
          skip_markup("<?", "?>", "a processing instruction") ||
          skip_markup("<!", ">", "a declaration"))
        continue;
      if (!error_.empty()) return false;
      return read_tag(tag);
    }
    return false;
  }

  [[nodiscard]] const std::string& error() const { return error_; }

  /// 1-based line of the last tag read (counted on demand, once over the text in all).
  long line() {
    const std::size_t upto = std::min(start_, text_.size());
    if (upto < counted_) {
      counted_ = 0;
      line_ = 1;
    }
    line_ += std::count(text_.begin() + static_cast<std::ptrdiff_t>(counted_),
                        text_.begin() + static_cast<std::ptrdiff_t>(upto), '\n');
    counted_ = upto;
    return line_;
  }

 private:
  /// Skips `open` ... `close` at the current '<' when it starts with `open`.
  bool skip_markup(std::string_view open, std::string_view close, const char* what) {
    if (text_.substr(start_, open.size()) != open) return false;
    const std::size_t end = text_.find(close, start_ + open.size());
    if (end == std::string_view::npos) {
      error_ = std::string(what) + " is not closed";
      return false;
    }
    pos_ = end + close.size();
    return true;
  }

  void skip_spaces(std::size_t& i) const {
    while (i < text_.size() && is_space(text_[i])) ++i;
  }

  bool fail(std::string why) {
    error_ = std::move(why);
    return false;
  }

  static bool ends_name(char c) { return is_space(c) || c == '/' || c == '>' || c == '='; }

  bool read_tag(Tag& tag) {
    tag.attributes.clear();
    std::size_t i = start_ + 1;
    tag.closing = i < text_.size() && text_[i] == '/';
    if (tag.closing) ++i;
    const std::size_t name_begin = i;
    while (i < text_.size() && !ends_name(text_[i])) ++i;
    if (i == name_begin) return fail("a '<' starts no tag");
    tag.name = local_name(text_.substr(name_begin, i - name_begin));
    tag.self_closing = false;
    for (;;) {
      skip_spaces(i);
      if (i >= text_.size()) return fail("tag <" + std::string(tag.name) + "> is not closed");
      if (text_[i] == '>') break;
      if (text_[i] == '/' && i + 1 < text_.size() && text_[i + 1] == '>') {
        tag.self_closing = true;
        ++i;
        break;
      }
      const std::size_t key_begin = i;
      while (i < text_.size() && !ends_name(text_[i])) ++i;
      const std::string_view key = text_.substr(key_begin, i - key_begin);
      skip_spaces(i);
      if (key.empty() || i >= text_.size() || text_[i] != '=')
        return fail("tag <" + std::string(tag.name) + ">: expected attribute=\"value\"");
      ++i;
      skip_spaces(i);
      if (i >= text_.size() || (text_[i] != '"' && text_[i] != '\''))
        return fail("tag <" + std::string(tag.name) + ">: the value of '" + std::string(key) +
                    "' is not quoted");
      const std::size_t close = text_.find(text_[i], i + 1);
      if (close == std::string_view::npos)
        return fail("tag <" + std::string(tag.name) + ">: the value of '" + std::string(key) +
                    "' is not closed");
      tag.attributes.push_back({local_name(key), text_.substr(i + 1, close - i - 1)});
      i = close + 1;
    }
    pos_ = i + 1;
    return true;
  }

  std::string_view text_;
  std::size_t pos_ = 0;
  std::size_t start_ = 0;
  std::size_t counted_ = 0;
  long line_ = 1;
  std::string error_;
};

// --- numbers -----------------------------------------------------------------------------

bool parse_double(std::string_view v, double& out) {
  v = trimmed(v);
  if (!v.empty() && v.front() == '+') v.remove_prefix(1);
  const auto [ptr, ec] = std::from_chars(v.data(), v.data() + v.size(), out);
  return !v.empty() && ec == std::errc() && ptr == v.data() + v.size() && std::isfinite(out);
}

bool parse_index(std::string_view v, std::uint32_t& out) {
  v = trimmed(v);
  const auto [ptr, ec] = std::from_chars(v.data(), v.data() + v.size(), out);
  return !v.empty() && ec == std::errc() && ptr == v.data() + v.size();
}

/// A 3MF transform: 12 numbers m00 m01 m02 m10 m11 m12 m20 m21 m22 m30 m31 m32 that map a
/// point as a row vector: x' = x m00 + y m10 + z m20 + m30, and so on.
bool parse_transform(std::string_view v, Affine& out) {
  std::array<double, 12> m{};
  std::size_t n = 0;
  std::size_t i = 0;
  while (i < v.size()) {
    while (i < v.size() && is_space(v[i])) ++i;
    const std::size_t b = i;
    while (i < v.size() && !is_space(v[i])) ++i;
    if (i == b) break;
    if (n == m.size() || !parse_double(v.substr(b, i - b), m[n])) return false;
    ++n;
  }
  if (n != m.size()) return false;
  out = Affine::Identity();
  for (std::size_t r = 0; r < 3; ++r) {
    const auto row = static_cast<Eigen::Index>(r);
    for (std::size_t c = 0; c < 3; ++c)
      out.linear()(row, static_cast<Eigen::Index>(c)) = m[3 * c + r];
    out.translation()(row) = m[9 + r];
  }
  return true;
}

/// Millimetres per unit of a <model unit="..">; 0 when the unit is not one of 3MF's.
double millimetres_per_unit(std::string_view unit) {
  static constexpr std::array<std::pair<std::string_view, double>, 6> kUnits = {
      {{"micron", 0.001},
       {"millimeter", 1.0},
       {"centimeter", 10.0},
       {"inch", 25.4},
       {"foot", 304.8},
       {"meter", 1000.0}}};
  for (const auto& [n, mm] : kUnits)
    if (n == unit) return mm;
  return 0.0;
}

/// An archive entry name from a 3MF path ("/3D/Objects/object_1.model").
std::string entry_name(std::string_view path) {
  path = trimmed(path);
  while (!path.empty() && path.front() == '/') path.remove_prefix(1);
  return std::string(path);
}

// --- model files -------------------------------------------------------------------------

/// A reference to an object: a component of another object or a build item.
struct Reference {
  std::string entry;  ///< model file holding the object
  std::uint32_t id = 0;
  Affine transform = Affine::Identity();
  long line = 0;  ///< where the reference stands
  bool printable = true;
};

struct Object {
  bool part = true;  ///< false for type "support" and "other"
  std::vector<Vec3> vertices;
  std::vector<Triangle> triangles;
  std::vector<Reference> components;
  std::size_t beams = 0;  ///< <beam> elements (beam lattice extension: not triangles)
};

struct ModelFile {
  double mm_per_unit = 1.0;
  std::map<std::uint32_t, Object> objects;
  std::vector<Reference> items;
  bool references_other_files = false;
};

/// Reads one model file of the package. `entry` names it in errors.
class ModelParser {
 public:
  ModelParser(std::string_view xml, std::string entry, const std::string& name)
      : scan_(xml), entry_(std::move(entry)), name_(name) {}

  Result<ModelFile> parse() {
    Tag tag;
    while (scan_.next(tag)) {
      if (auto st = take(tag); !st) return st.error();
    }
    if (!scan_.error().empty()) return error(scan_.error());
    return std::move(model_);
  }

 private:
  Error error(const std::string& why) {
    return bad_input(entry_ + ", line " + std::to_string(scan_.line()) + ": " + why, name_);
  }

  Status take(const Tag& tag) {
    if (tag.closing) {
      if (tag.name == "object") object_ = nullptr;
      if (tag.name == "mesh") in_mesh_ = false;
      return Ok{};
    }
    if (tag.name == "model") return read_unit(tag);
    if (tag.name == "object") return open_object(tag);
    if (tag.name == "mesh") in_mesh_ = object_ != nullptr && !tag.self_closing;
    if (object_ != nullptr && in_mesh_ && tag.name == "vertex") return read_vertex(tag);
    if (object_ != nullptr && in_mesh_ && tag.name == "triangle") return read_triangle(tag);
    if (object_ != nullptr && in_mesh_ && tag.name == "beam") ++object_->beams;
    if (object_ != nullptr && tag.name == "component") {
      auto ref = read_reference(tag, "component");
      if (!ref) return ref.error();
      object_->components.push_back(std::move(*ref));
    }
    if (tag.name == "item") {
      auto ref = read_reference(tag, "item");
      if (!ref) return ref.error();
      const auto printable = tag.get("printable");
      ref->printable = !printable || trimmed(*printable) != "0";
      model_.items.push_back(std::move(*ref));
    }
    return Ok{};
  }

  Status read_unit(const Tag& tag) {
    const auto unit = tag.get("unit");
    if (!unit) return Ok{};
    model_.mm_per_unit = millimetres_per_unit(trimmed(*unit));
    if (model_.mm_per_unit == 0)
      return error("unknown unit '" + std::string(*unit) +
                   "', expected micron, millimeter, centimeter, inch, foot or meter");
    return Ok{};
  }

  Status open_object(const Tag& tag) {
    const auto id_text = tag.get("id");
    std::uint32_t id = 0;
    if (!id_text || !parse_index(*id_text, id))
      return error("<object> needs a numeric id, found '" + std::string(id_text.value_or("")) +
                   "'");
    if (model_.objects.count(id) != 0)
      return error("object " + std::to_string(id) + " is defined twice");
    object_ = &model_.objects[id];
    const auto type = tag.get("type");
    object_->part = !type || (trimmed(*type) != "support" && trimmed(*type) != "other");
    if (tag.self_closing) object_ = nullptr;
    return Ok{};
  }

  Status read_vertex(const Tag& tag) {
    Vec3 p;
    static constexpr std::array<std::string_view, 3> kAxes = {"x", "y", "z"};
    for (int k = 0; k < 3; ++k) {
      const auto v = tag.get(kAxes[static_cast<std::size_t>(k)]);
      if (!v || !parse_double(*v, p[k]))
        return error("vertex " + std::to_string(object_->vertices.size()) + ": " +
                     std::string(kAxes[static_cast<std::size_t>(k)]) + " is not a number ('" +
                     std::string(v.value_or("missing")) + "')");
    }
    object_->vertices.push_back(p);
    return Ok{};
  }

  Status read_triangle(const Tag& tag) {
    Triangle t{};
    static constexpr std::array<std::string_view, 3> kCorners = {"v1", "v2", "v3"};
    const std::size_t nv = object_->vertices.size();
    for (std::size_t k = 0; k < 3; ++k) {
      const auto v = tag.get(kCorners[k]);
      if (!v || !parse_index(*v, t[k]) || t[k] >= nv)
        return error("triangle " + std::to_string(object_->triangles.size()) + ": " +
                     std::string(kCorners[k]) + " '" + std::string(v.value_or("missing")) +
                     "' is not one of the object's " + std::to_string(nv) + " vertices");
    }
    object_->triangles.push_back(t);
    return Ok{};
  }

  Result<Reference> read_reference(const Tag& tag, const char* what) {
    Reference ref;
    ref.line = scan_.line();
    const auto id = tag.get("objectid");
    if (!id || !parse_index(*id, ref.id))
      return error(std::string("<") + what + "> needs a numeric objectid, found '" +
                   std::string(id.value_or("")) + "'");
    if (const auto t = tag.get("transform"); t && !parse_transform(*t, ref.transform))
      return error(std::string("<") + what + ">: transform '" + std::string(*t) +
                   "' is not 12 numbers");
    ref.entry = entry_;
    if (const auto path = tag.get("path")) {
      ref.entry = entry_name(*path);
      model_.references_other_files = model_.references_other_files || ref.entry != entry_;
    }
    return ref;
  }

  TagScanner scan_;
  std::string entry_;
  const std::string& name_;
  ModelFile model_;
  Object* object_ = nullptr;
  bool in_mesh_ = false;
};

// --- the slicers' parts ------------------------------------------------------------------
// PrusaSlicer keeps an object's volumes (its parts, modifiers, negative volumes, support
// blockers and enforcers) as ranges of the object's triangles, typed in
// Metadata/Slic3r_PE_model.config: <object id="1"><volume firstid="0" lastid="11">
// <metadata type="volume" key="volume_type" value="ParameterModifier"/> (before 2.4:
// key="modifier" value="1"). Bambu Studio and OrcaSlicer make each part a component of the
// object and type it in Metadata/model_settings.config: <object id="2"><part id="1"
// subtype="modifier_part"> (id: the component's objectid). Only the printed parts are solid.

constexpr std::string_view kPrusaVolumesEntry = "Metadata/Slic3r_PE_model.config";
constexpr std::string_view kBambuPartsEntry = "Metadata/model_settings.config";

struct SlicerParts {
  /// Triangle ranges [first, last] of a root model object that are not printed parts.
  std::map<std::uint32_t, std::vector<std::pair<std::size_t, std::size_t>>> dropped_ranges;
  /// (object, component objectid) pairs that are not printed parts.
  std::vector<std::pair<std::uint32_t, std::uint32_t>> dropped_components;

  [[nodiscard]] bool drops_component(std::uint32_t object, std::uint32_t component) const {
    return std::find(dropped_components.begin(), dropped_components.end(),
                     std::make_pair(object, component)) != dropped_components.end();
  }
};

/// Reads the volume and part types of both slicers' configs (the entries that are present).
Result<SlicerParts> read_slicer_parts(std::string_view archive, const std::string& name) {
  SlicerParts parts;
  for (const std::string_view entry : {kPrusaVolumesEntry, kBambuPartsEntry}) {
    auto bytes = zip_entry(archive, std::string(entry), name);
    if (!bytes) return bytes.error();
    if (!*bytes) continue;
    TagScanner scan(**bytes);
    Tag tag;
    std::uint32_t object = 0;
    std::optional<std::pair<std::size_t, std::size_t>> volume;
    std::string volume_type;
    const auto end_volume = [&] {
      if (volume && volume_type != "ModelPart") parts.dropped_ranges[object].push_back(*volume);
      volume.reset();
    };
    while (scan.next(tag)) {
      if (tag.closing) {
        if (tag.name == "volume") end_volume();
        continue;
      }
      if (tag.name == "object") {
        if (!parse_index(tag.get("id").value_or(""), object)) object = 0;
      } else if (tag.name == "volume") {
        std::uint32_t first = 0;
        std::uint32_t last = 0;
        if (parse_index(tag.get("firstid").value_or(""), first) &&
            parse_index(tag.get("lastid").value_or(""), last))
          volume = std::make_pair(std::size_t{first}, std::size_t{last});
        volume_type = "ModelPart";
        if (tag.self_closing) end_volume();
      } else if (tag.name == "metadata" && volume) {
        const std::string_view key = trimmed(tag.get("key").value_or(""));
        const std::string_view value = trimmed(tag.get("value").value_or(""));
        if (key == "volume_type") volume_type = std::string(value);
        if (key == "modifier" && value == "1" && volume_type == "ModelPart")
          volume_type = "ParameterModifier";
      } else if (tag.name == "part") {
        std::uint32_t id = 0;
        const auto subtype = tag.get("subtype");
        if (subtype && trimmed(*subtype) != "normal_part" &&
            parse_index(tag.get("id").value_or(""), id))
          parts.dropped_components.emplace_back(object, id);
      }
    }
    if (!scan.error().empty())
      return bad_input(
          std::string(entry) + ", line " + std::to_string(scan.line()) + ": " + scan.error(), name);
  }
  return parts;
}

/// The root model's entry, from the package relationships (the default path without them).
Result<std::string> root_model_entry(std::string_view archive, const std::string& name) {
  auto rels = zip_entry(archive, "_rels/.rels", name);
  if (!rels) return rels.error();
  if (!*rels) return std::string(kRootModelDefault);
  TagScanner scan(**rels);
  Tag tag;
  while (scan.next(tag)) {
    const auto type = tag.get("Type");
    const auto target = tag.get("Target");
    if (tag.name == "Relationship" && type && target && type->size() >= 8 &&
        type->substr(type->size() - 8) == "/3dmodel")
      return entry_name(*target);
  }
  return std::string(kRootModelDefault);
}

/// The package's model files, read when first referenced, and the placed triangles.
class Package {
 public:
  Package(std::string_view archive, const std::string& name, SlicerParts parts)
      : archive_(archive), name_(name), parts_(std::move(parts)) {}

  /// Reads model file `entry` from `bytes` (once).
  Result<const ModelFile*> add(const std::string& entry, std::string_view bytes) {
    auto model = ModelParser(bytes, entry, name_).parse();
    if (!model) return model.error();
    return &files_.emplace(entry, std::move(*model)).first->second;
  }

  /// Model file `entry`, read when first referenced (from line `line` of `referrer`).
  Result<const ModelFile*> file(const std::string& entry, const std::string& referrer, long line) {
    if (auto it = files_.find(entry); it != files_.end()) return &it->second;
    auto bytes = zip_entry(archive_, entry, name_);
    if (!bytes) return bytes.error();
    if (!*bytes)
      return bad_input(referrer + ", line " + std::to_string(line) + ": the model file '/" + entry +
                           "' is not in the archive",
                       name_);
    return add(entry, **bytes);
  }

  /// Appends object `ref` (and its components) placed by `placement` to `out`.
  Status place(const Reference& ref, const std::string& referrer, const Affine& placement,
               Mesh& out) {
    auto model = file(ref.entry, referrer, ref.line);
    if (!model) return model.error();
    const auto it = (*model)->objects.find(ref.id);
    if (it == (*model)->objects.end())
      return bad_input(referrer + ", line " + std::to_string(ref.line) + ": object " +
                           std::to_string(ref.id) + " is not defined in '/" + ref.entry + "'",
                       name_);
    const std::pair<std::string, std::uint32_t> key{ref.entry, ref.id};
    if (std::find(path_.begin(), path_.end(), key) != path_.end()) {
      std::string chain;
      for (const auto& [e, id] : path_) chain += "/" + e + " object " + std::to_string(id) + " -> ";
      return bad_input(referrer + ", line " + std::to_string(ref.line) +
                           ": the components form a cycle: " + chain + "/" + ref.entry +
                           " object " + std::to_string(ref.id),
                       name_);
    }
    if (path_.size() > kMaxDepth)
      return bad_input(referrer + ", line " + std::to_string(ref.line) +
                           ": components nest deeper than " + std::to_string(kMaxDepth) + " levels",
                       name_);
    const Object& object = it->second;
    if (!object.part) return Ok{};
    const Affine world = placement * ref.transform;
    // The slicers type the parts of the objects that build items place.
    const bool item = path_.empty();
    static const std::vector<std::pair<std::size_t, std::size_t>> kNone;
    const auto dropped = item ? parts_.dropped_ranges.find(ref.id) : parts_.dropped_ranges.end();
    append(object, world, dropped == parts_.dropped_ranges.end() ? kNone : dropped->second, out);
    if (out.triangles.size() > kMaxTriangles || ++placements_ > kMaxPlacements)
      return bad_input("the components expand to more than " + std::to_string(kMaxTriangles) +
                           " triangles or " + std::to_string(kMaxPlacements) + " placed objects",
                       name_);
    path_.push_back(key);
    for (const auto& c : object.components) {
      if (item && parts_.drops_component(ref.id, c.id)) continue;
      if (auto st = place(c, ref.entry, world, out); !st) return st.error();
    }
    path_.pop_back();
    return Ok{};
  }

 private:
  /// The object's own triangles but those in `dropped` ranges, mapped by `world`; a
  /// mirroring transform reverses their corner order so that the faces still point out of
  /// the solid.
  static void append(const Object& object, const Affine& world,
                     const std::vector<std::pair<std::size_t, std::size_t>>& dropped, Mesh& out) {
    const auto base = static_cast<std::uint32_t>(out.vertices_mm.size());
    for (const auto& p : object.vertices) out.vertices_mm.push_back(world * p);
    const bool mirrored = world.linear().determinant() < 0;
    for (std::size_t i = 0; i < object.triangles.size(); ++i) {
      if (std::any_of(dropped.begin(), dropped.end(),
                      [i](const auto& r) { return i >= r.first && i <= r.second; }))
        continue;
      const Triangle& t = object.triangles[i];
      if (mirrored)
        out.triangles.push_back({base + t[0], base + t[2], base + t[1]});
      else
        out.triangles.push_back({base + t[0], base + t[1], base + t[2]});
    }
  }

  std::string_view archive_;
  const std::string& name_;
  std::map<std::string, ModelFile> files_;
  SlicerParts parts_;
  std::vector<std::pair<std::string, std::uint32_t>> path_;
  std::size_t placements_ = 0;
};

}  // namespace

/// Beams of the objects in `model`, for the message of a package without triangles.
std::size_t beam_count(const ModelFile& model) {
  std::size_t n = 0;
  for (const auto& [id, object] : model.objects) n += object.beams;
  return n;
}

Result<Mesh> read_3mf(std::string_view archive, double scale, const std::string& name) {
  auto root_entry = root_model_entry(archive, name);
  if (!root_entry) return root_entry.error();
  auto root_bytes = zip_entry(archive, *root_entry, name);
  if (!root_bytes) return root_bytes.error();
  if (!*root_bytes)
    return bad_input("the root model '/" + *root_entry +
                         "' (named by _rels/.rels, or 3MF's default) is not in the archive",
                     name);
  auto parts = read_slicer_parts(archive, name);
  if (!parts) return parts.error();
  Package package(archive, name, std::move(*parts));
  auto root = package.add(*root_entry, **root_bytes);
  if (!root) return root.error();

  Mesh mesh;
  std::size_t left_out = 0;
  for (const auto& item : (*root)->items) {
    if (!item.printable) {
      ++left_out;
      continue;
    }
    if (auto st = package.place(item, *root_entry, Affine::Identity(), mesh); !st)
      return st.error();
  }
  if (mesh.triangles.empty() && left_out > 0)
    return bad_input(*root_entry + ": every build item is marked printable=\"0\" (" +
                         std::to_string(left_out) + " left out), nothing to print",
                     name);
  if (mesh.triangles.empty()) {
    const std::size_t beams = beam_count(**root);
    return bad_input(
        "the file holds no triangles, expected a mesh (" + *root_entry + ": " +
            std::to_string((*root)->items.size()) + " build items" +
            (beams > 0 ? "; " + std::to_string(beams) +
                             " beams of the beam lattice extension, which printtwin does not "
                             "read"
                       : "") +
            ")",
        name);
  }
  const double mm = (*root)->mm_per_unit * scale;
  for (auto& p : mesh.vertices_mm) p *= mm;
  return mesh;
}

}  // namespace printtwin::detail
