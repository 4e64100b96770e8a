// The built-in printer library: printers/*.json compiled into the binary
// (cmake/embed_printers.cmake), parsed once on first use.
#include <algorithm>
#include <cctype>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <stdexcept>

#include "machine/printer_internal.hpp"
#include "printtwin/io.hpp"
#include "printtwin/printer.hpp"

namespace printtwin {

using nlohmann::json;

std::vector<std::string> name_words(std::string_view name) {
  std::vector<std::string> words;
  std::string w;
  for (const char c : name) {
    if (std::isalnum(static_cast<unsigned char>(c)) != 0) {
      w += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    } else if (!w.empty()) {
      words.push_back(std::move(w));
      w.clear();
    }
  }
  if (!w.empty()) words.push_back(std::move(w));
  return words;
}

namespace {

std::string lower(std::string_view s) {
  std::string out(s);
  for (auto& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

/// Parses every embedded file; a library profile may name another as its "base".
std::vector<LibraryPrinter> load_library() {
  std::map<std::string, std::pair<std::string, std::string_view>> texts;  // id -> (file, text)
  for (const auto& [file, text] : embedded_printer_files()) {
    std::string id(file.substr(0, file.rfind('.')));
    texts[lower(id)] = {std::string(file), text};
  }
  std::map<std::string, LibraryPrinter> done;
  std::set<std::string> in_progress;
  std::function<Result<PrinterProfile>(const std::string&)> load =
      [&](const std::string& id_in) -> Result<PrinterProfile> {
    const std::string id = lower(id_in);
    if (auto it = done.find(id); it != done.end()) return it->second.profile;
    auto t = texts.find(id);
    if (t == texts.end()) return builtin_printer(id_in);  // ender3, ender3-klipper, ...
    if (!in_progress.insert(id).second)
      return bad_input("\"base\" chain loops through " + id, t->second.first);
    const std::string source = "printers/" + t->second.first;
    auto profile = parse_printer_profile_with(t->second.second, source, load, "library");
    if (!profile) return profile.error();
    const json doc = json::parse(t->second.second);
    LibraryPrinter lp;
    lp.id = doc.value("id", id);
    if (lower(lp.id) != id)
      return bad_input("\"id\" must equal the file name (" + id + ")", source);
    lp.name = profile->name;
    for (const auto& a : doc.value("aliases", json::array()))
      lp.aliases.push_back(a.get<std::string>());
    for (const auto& s : doc.value("sources", json::array()))
      lp.sources.push_back(s.get<std::string>());
    if (lp.sources.empty()) return bad_input("a library printer must cite its \"sources\"", source);
    // Keys this file or a library base set name their profile; the rest are the generic default.
    PrinterOrigin origin;
    std::string base_id;
    if (auto b = doc.find("base"); b != doc.end()) base_id = lower(b->get<std::string>());
    const PrinterOrigin* base_origin =
        done.count(base_id) != 0 ? &done.at(base_id).origin : nullptr;
    for (const auto& key : printer_profile_keys()) {
      if (doc.contains(key))
        origin.set(key, "library", lp.id);
      else if (base_origin != nullptr && base_origin->find(key) != nullptr)
        origin.values.push_back(*base_origin->find(key));
      else
        origin.set(key, "default", "");
    }
    origin.library_id = lp.id;
    profile->origin = origin;
    lp.origin = origin;
    lp.profile = std::move(*profile);
    in_progress.erase(id);
    done[id] = lp;
    return lp.profile;
  };
  std::vector<LibraryPrinter> out;
  for (const auto& [id, t] : texts) {
    auto p = load(id);
    // The data is compiled in and checked by the tests: a bad file is a build defect.
    if (!p) throw std::logic_error("printer library: " + p.error().describe());
    out.push_back(done.at(id));
  }
  return out;
}

}  // namespace

const std::vector<LibraryPrinter>& printer_library() {
  static const std::vector<LibraryPrinter> library = load_library();
  return library;
}

const LibraryPrinter* find_library_printer(std::string_view id) {
  const std::string key = lower(id);
  for (const auto& p : printer_library())
    if (lower(p.id) == key) return &p;
  return nullptr;
}

namespace {

/// Words that may follow a printer's name in a settings id without naming another printer
/// ("Original Prusa MK4S 0.4 nozzle", "... Input Shaper", "... HF0.4").
bool is_variant_word(const std::string& w, const std::string& last_alias_word) {
  if (std::all_of(w.begin(), w.end(),
                  [](char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; }))
    return true;
  static const std::set<std::string> kVariant = {"nozzle", "mm",   "hf",    "is",   "input",
                                                 "shaper", "mmu",  "mmu2s", "mmu3", "high",
                                                 "flow",   "copy", "plate"};
  return kVariant.count(w) != 0 || w.rfind(last_alias_word, 0) == 0 || w.rfind("hf0", 0) == 0;
}

}  // namespace

const LibraryPrinter* match_library_printer(std::string_view name) {
  const auto words = name_words(name);
  if (words.empty()) return nullptr;
  const LibraryPrinter* best = nullptr;
  std::size_t best_words = 0, best_chars = 0;
  for (const auto& p : printer_library()) {
    for (const auto& alias : p.aliases) {
      const auto aw = name_words(alias);
      if (aw.empty() || aw.size() > words.size()) continue;
      std::size_t chars = 0;
      for (const auto& w : aw) chars += w.size();
      for (std::size_t at = 0; at + aw.size() <= words.size(); ++at) {
        if (!std::equal(aw.begin(), aw.end(), words.begin() + static_cast<std::ptrdiff_t>(at)))
          continue;
        const std::size_t next = at + aw.size();
        if (next < words.size() && !is_variant_word(words[next], aw.back())) continue;
        if (aw.size() > best_words || (aw.size() == best_words && chars > best_chars)) {
          best = &p;
          best_words = aw.size();
          best_chars = chars;
        }
      }
    }
  }
  return best;
}

std::string printer_library_table() {
  std::string s =
      "id                      printer                          bed (mm)             firmware\n";
  for (const auto& p : printer_library()) {
    const auto& q = p.profile;
    std::string bed = format_number(q.bed_max_x_mm - q.bed_min_x_mm) + " x " +
                      format_number(q.bed_max_y_mm - q.bed_min_y_mm) + " x " +
                      format_number(q.max_z_mm);
    auto pad = [](std::string t, std::size_t n) {
      if (t.size() < n) t.append(n - t.size(), ' ');
      return t;
    };
    s += pad(p.id, 24) + pad(p.name, 33) + pad(bed, 21) + q.firmware + "\n";
  }
  s += "built in: ender3 (default), ender3-marlin1, ender3-klipper\n";
  return s;
}

}  // namespace printtwin
