#pragma once
// A strict little XML reader for the tests: elements, attributes, text, the five predefined
// entities and numeric character references, comments and the prolog. Rejects mismatched
// tags, duplicate attributes, raw '<' or stray '&' in text and attributes, and anything after
// the root element. Enough to prove junit.xml is well-formed and read its structure.
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "printtwin/result.hpp"

namespace printtwin::test {

struct XmlElement {
  std::string name;
  std::vector<std::pair<std::string, std::string>> attrs;
  std::vector<XmlElement> children;
  std::string text;
  [[nodiscard]] std::string attr(const std::string& key) const {
    for (const auto& [k, v] : attrs)
      if (k == key) return v;
    return {};
  }
};

namespace detail_xml {

struct Reader {
  std::string_view s;
  std::size_t i = 0;
  std::string error;

  bool fail(const std::string& what) {
    if (error.empty()) error = what + " at offset " + std::to_string(i);
    return false;
  }
  void skip_ws() {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\n' || s[i] == '\r' || s[i] == '\t')) ++i;
  }
  bool starts(std::string_view p) const { return s.substr(i, p.size()) == p; }
  static bool name_char(char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-' || c == '.' || c == ':';
  }
  bool read_name(std::string& out) {
    const std::size_t b = i;
    while (i < s.size() && name_char(s[i])) ++i;
    if (i == b) return fail("expected a name");
    out = std::string(s.substr(b, i - b));
    return true;
  }
  // Decodes text up to `stop`, resolving entities.
  bool read_text(char stop, std::string& out) {
    while (i < s.size() && s[i] != stop) {
      if (s[i] == '<') return fail("raw '<' in text or attribute");
      if (s[i] != '&') {
        out += s[i++];
        continue;
      }
      const std::size_t semi = s.find(';', i);
      if (semi == std::string_view::npos || semi - i > 10) return fail("unterminated entity");
      const std::string_view ent = s.substr(i + 1, semi - i - 1);
      if (ent == "amp")
        out += '&';
      else if (ent == "lt")
        out += '<';
      else if (ent == "gt")
        out += '>';
      else if (ent == "quot")
        out += '"';
      else if (ent == "apos")
        out += '\'';
      else if (!ent.empty() && ent[0] == '#') {
        const bool hex = ent.size() > 1 && ent[1] == 'x';
        const unsigned long cp =
            std::stoul(std::string(ent.substr(hex ? 2 : 1)), nullptr, hex ? 16 : 10);
        if (cp > 127) return fail("non-ASCII character reference (not needed here)");
        out += static_cast<char>(cp);
      } else {
        return fail("unknown entity &" + std::string(ent) + ";");
      }
      i = semi + 1;
    }
    return true;
  }
  bool skip_misc() {
    for (;;) {
      skip_ws();
      if (starts("<?")) {
        const std::size_t e = s.find("?>", i);
        if (e == std::string_view::npos) return fail("unterminated processing instruction");
        i = e + 2;
      } else if (starts("<!--")) {
        const std::size_t e = s.find("-->", i);
        if (e == std::string_view::npos) return fail("unterminated comment");
        i = e + 3;
      } else {
        return true;
      }
    }
  }
  bool element(XmlElement& el, int depth) {
    if (depth > 64) return fail("nesting too deep");
    if (!starts("<")) return fail("expected '<'");
    ++i;
    if (!read_name(el.name)) return false;
    for (;;) {
      skip_ws();
      if (starts("/>")) {
        i += 2;
        return true;
      }
      if (starts(">")) {
        ++i;
        break;
      }
      std::string key, value;
      if (!read_name(key)) return false;
      skip_ws();
      if (!starts("=")) return fail("expected '=' after attribute " + key);
      ++i;
      skip_ws();
      if (i >= s.size() || (s[i] != '"' && s[i] != '\'')) return fail("expected a quoted value");
      const char q = s[i++];
      if (!read_text(q, value)) return false;
      if (i >= s.size()) return fail("unterminated attribute value");
      ++i;
      for (const auto& a : el.attrs)
        if (a.first == key) return fail("duplicate attribute " + key);
      el.attrs.emplace_back(key, value);
    }
    for (;;) {
      if (starts("<!--")) {
        const std::size_t e = s.find("-->", i);
        if (e == std::string_view::npos) return fail("unterminated comment");
        i = e + 3;
      } else if (starts("</")) {
        i += 2;
        std::string close;
        if (!read_name(close)) return false;
        if (close != el.name) return fail("</" + close + "> closes <" + el.name + ">");
        skip_ws();
        if (!starts(">")) return fail("expected '>'");
        ++i;
        return true;
      } else if (starts("<")) {
        XmlElement child;
        if (!element(child, depth + 1)) return false;
        el.children.push_back(std::move(child));
      } else if (i >= s.size()) {
        return fail("unterminated element <" + el.name + ">");
      } else {
        if (!read_text('<', el.text)) return false;
      }
    }
  }
};

}  // namespace detail_xml

/// Parses a whole XML document; returns its root element.
inline Result<XmlElement> parse_xml(std::string_view text) {
  detail_xml::Reader r{text};
  XmlElement root;
  if (!r.skip_misc() || !r.element(root, 0) || !r.skip_misc()) return bad_input("XML: " + r.error);
  if (r.i != text.size()) return bad_input("XML: content after the root element");
  return root;
}

}  // namespace printtwin::test
