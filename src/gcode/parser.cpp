// G-code lines and words: the streaming line reader and the allocation-free line parser.
// Syntax follows Marlin's GCodeParser (gcode/parser.cpp): optional N line number, a command
// letter with an integer code and optional .subcode, parameters as letter + number, `;`
// and `( )` comments, `*` checksum (XOR of the bytes before it). Numbers are read with
// std::from_chars (locale-independent, no allocation).
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>

#include "printtwin/gcode.hpp"

namespace printtwin {

namespace {
constexpr std::size_t kReadChunk = 256 * 1024;  // > kMaxGcodeLineLength
constexpr double kMaxParameterMagnitude = 1e9;

bool is_upper(char c) { return c >= 'A' && c <= 'Z'; }
bool is_lower(char c) { return c >= 'a' && c <= 'z'; }
bool is_digit(char c) { return c >= '0' && c <= '9'; }
char upper(char c) { return is_lower(c) ? static_cast<char>(c - 'a' + 'A') : c; }
bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r'; }

/// The line as it appears in messages: at most 80 bytes, non-printable bytes as '?'.
std::string excerpt(std::string_view text) {
  std::string s;
  const std::size_t n = std::min<std::size_t>(text.size(), 80);
  s.reserve(n + 3);
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    s.push_back(c >= 32 && c < 127 ? static_cast<char>(c) : '?');
  }
  if (text.size() > n) s += "...";
  return s;
}

Status parse_error(std::string_view text, long line, const std::string& what) {
  return bad_input(what + " in \"" + excerpt(text) + "\"", {}, line);
}

Status not_gcode(std::string_view text, long line, const char* at) {
  const auto c = static_cast<unsigned char>(*at);
  return parse_error(text, line,
                     "byte 0x" + std::string(1, "0123456789abcdef"[c >> 4]) +
                         std::string(1, "0123456789abcdef"[c & 15]) + " at column " +
                         std::to_string(at - text.data() + 1) + " is not G-code");
}

/// Reads a number at `p` (optional sign, digits, '.', exponent). Returns the end or nullptr.
const char* read_number(const char* p, const char* end, double& out) {
  const char* start = p;
  bool negative = false;
  if (p < end && (*p == '+' || *p == '-')) {
    negative = *p == '-';
    ++p;
  }
  // from_chars would accept "inf"/"nan": only digits and '.' may start a number here.
  if (p >= end || !(is_digit(*p) || *p == '.')) return nullptr;
  // Fast path (Clinger): a plain decimal of <= 15 digits without exponent is an exact
  // integer divided by an exact power of ten: one correctly rounded division.
  {
    static constexpr double kPow10[] = {1e0, 1e1, 1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                        1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15};
    const char* q = p;
    std::uint64_t mantissa = 0;  // may wrap for > 19 digits: then the slow path is taken
    while (q < end) {
      const auto d = static_cast<unsigned>(*q) - '0';
      if (d > 9) break;
      mantissa = mantissa * 10 + d;
      ++q;
    }
    long digits = q - p;
    long frac = 0;
    if (q < end && *q == '.') {
      const char* f = ++q;
      while (q < end) {
        const auto d = static_cast<unsigned>(*q) - '0';
        if (d > 9) break;
        mantissa = mantissa * 10 + d;
        ++q;
      }
      frac = q - f;
      digits += frac;
    }
    if (digits > 0 && digits <= 15 && !(q < end && (*q == 'e' || *q == 'E'))) {
      const double v = static_cast<double>(mantissa) / kPow10[frac];
      out = negative ? -v : v;
      return q;
    }
  }
  double v = 0;
  const auto r = std::from_chars(p, end, v, std::chars_format::general);
  if (r.ec == std::errc::result_out_of_range) {
    out = std::numeric_limits<double>::infinity();
    return r.ptr;
  }
  if (r.ec != std::errc()) return nullptr;
  (void)start;
  out = negative ? -v : v;
  return r.ptr;
}
}  // namespace

GcodeLineReader::GcodeLineReader(std::istream& in) : in_(in), buf_(kReadChunk) {}

bool GcodeLineReader::fill() {
  if (eof_) return false;
  if (end_ == buf_.size()) return false;
  in_.read(buf_.data() + end_, static_cast<std::streamsize>(buf_.size() - end_));
  const auto got = static_cast<std::size_t>(in_.gcount());
  end_ += got;
  if (got == 0 || !in_) eof_ = true;
  return got > 0;
}

bool GcodeLineReader::next(std::string_view& line) {
  if (!next_line(line)) return false;
  // A UTF-8 byte order mark (editors on Windows write one) is not part of the first line.
  constexpr std::string_view kBom = "\xEF\xBB\xBF";
  if (line_ == 1 && line.substr(0, kBom.size()) == kBom) line.remove_prefix(kBom.size());
  return true;
}

bool GcodeLineReader::next_line(std::string_view& line) {
  truncated_ = false;
  for (;;) {
    const char* base = buf_.data();
    if (begin_ < end_) {
      const void* nl = std::memchr(base + begin_, '\n', end_ - begin_);
      if (nl != nullptr) {
        const auto pos = static_cast<std::size_t>(static_cast<const char*>(nl) - base);
        std::size_t len = pos - begin_;
        if (len > 0 && base[begin_ + len - 1] == '\r') --len;
        line = std::string_view(base + begin_, len);
        begin_ = pos + 1;
        ++line_;
        if (len > kMaxGcodeLineLength) {
          line = line.substr(0, kMaxGcodeLineLength);
          truncated_ = true;
        }
        return true;
      }
    }
    // No newline in the buffer: move the partial line to the front and read more.
    if (begin_ > 0) {
      std::memmove(buf_.data(), buf_.data() + begin_, end_ - begin_);
      end_ -= begin_;
      begin_ = 0;
    }
    if (end_ >= kMaxGcodeLineLength) {
      // An over-long line: keep its first kMaxGcodeLineLength bytes at the front and
      // discard the rest up to the newline, reading through the space behind them.
      ++line_;
      truncated_ = true;
      std::size_t scan = kMaxGcodeLineLength;
      for (;;) {
        const void* nl = scan < end_ ? std::memchr(buf_.data() + scan, '\n', end_ - scan) : nullptr;
        if (nl != nullptr) {
          begin_ = static_cast<std::size_t>(static_cast<const char*>(nl) - buf_.data()) + 1;
          break;
        }
        end_ = kMaxGcodeLineLength;
        scan = kMaxGcodeLineLength;
        if (!fill()) {
          begin_ = end_;
          ended_mid_line_ = true;
          break;
        }
      }
      line = std::string_view(buf_.data(), kMaxGcodeLineLength);
      return true;
    }
    if (!fill()) {
      if (begin_ < end_) {  // last line without a newline
        std::size_t len = end_ - begin_;
        if (len > 0 && buf_[begin_ + len - 1] == '\r') --len;
        line = std::string_view(buf_.data() + begin_, len);
        begin_ = end_;
        ++line_;
        ended_mid_line_ = true;
        return true;
      }
      return false;
    }
  }
}

namespace {
/// Every byte of free text must be printable ASCII (binary garbage is rejected, not
/// interpreted). The parameter scan rejects any other byte itself.
Status check_free_text(std::string_view text, long line, const char* from, const char* end) {
  for (const char* q = from; q < end; ++q) {
    const auto c = static_cast<unsigned char>(*q);
    if ((c < 32 && c != '\t') || c >= 127) return not_gcode(text, line, q);
  }
  return Ok{};
}

/// Cuts the `;` comment off [p, end) into `out.comment` and trims spaces at both ends.
void strip_comment(std::string_view text, GcodeCommand& out, const char*& p, const char*& end) {
  if (const void* semi = std::memchr(p, ';', text.size()); semi != nullptr) {
    const char* c = static_cast<const char*>(semi);
    const char* cs = c + 1;
    while (cs < end && is_space(*cs)) ++cs;
    const char* ce = end;
    while (ce > cs && is_space(ce[-1])) --ce;
    out.comment = std::string_view(cs, static_cast<std::size_t>(ce - cs));
    end = c;
  }
  while (p < end && is_space(*p)) ++p;
  while (end > p && is_space(end[-1])) --end;
}

/// Checks and cuts a `*checksum` (XOR of the bytes before it) off the end of [p, end).
Status strip_checksum(std::string_view text, long line, const char* p, const char*& end) {
  if (const void* star = std::memchr(p, '*', static_cast<std::size_t>(end - p)); star != nullptr) {
    const char* s = static_cast<const char*>(star);
    double expected = 0;
    const char* after = read_number(s + 1, end, expected);
    if (after == nullptr || after != end || expected < 0 || expected > 255)
      return parse_error(text, line, "malformed checksum (expected *0..255 at the end)");
    unsigned char sum = 0;
    for (const char* q = text.data(); q < s; ++q) sum ^= static_cast<unsigned char>(*q);
    if (sum != static_cast<unsigned char>(expected))
      return parse_error(text, line,
                         "checksum mismatch (computed " + std::to_string(sum) + ", line says " +
                             std::to_string(static_cast<int>(expected)) + ")");
    end = s;
    while (end > p && is_space(end[-1])) --end;
  }
  return Ok{};
}

/// Reads the command word: letter + number (G1, M104, T0, G29.1) or an extended (Klipper
/// style) command, whose arguments are kept as text; `done` then says nothing follows.
Status read_command_word(std::string_view text, long line, GcodeCommand& out, const char*& p,
                         const char* end, bool& done) {
  const char c0 = upper(*p);
  if (is_upper(c0) && (p + 1 == end || !(is_upper(upper(p[1])) || p[1] == '_'))) {
    // Letter + number: G1, M104, T0, G29.1
    ++p;
    while (p < end && is_space(*p)) ++p;
    if (p == end || !is_digit(*p)) {
      if (c0 == 'G' || c0 == 'M' || c0 == 'T')
        return parse_error(text, line, std::string("command letter ") + c0 + " without a number");
      return parse_error(text, line, std::string("expected a command (G, M, T) but found ") + c0);
    }
    if (c0 != 'G' && c0 != 'M' && c0 != 'T')
      return parse_error(text, line, std::string("expected a command (G, M, T) but found ") + c0);
    long code = 0;
    while (p < end && is_digit(*p)) {
      code = code * 10 + (*p - '0');
      if (code > 100000) return parse_error(text, line, "command number too large");
      ++p;
    }
    out.letter = c0;
    out.code = static_cast<int>(code);
    if (p < end && *p == '.') {
      ++p;
      int sub = 0;
      while (p < end && is_digit(*p)) {
        sub = std::min(sub * 10 + (*p - '0'), 1000);
        ++p;
      }
      out.subcode = sub;
    }
  } else if (is_upper(c0) || (c0 == '_' && p + 1 < end && is_upper(upper(p[1])))) {
    // Extended command (Klipper style): EXCLUDE_OBJECT_START NAME=part, _PRINT_START
    const char* w = p;
    while (p < end && (is_upper(upper(*p)) || is_digit(*p) || *p == '_')) ++p;
    out.word = std::string_view(w, static_cast<std::size_t>(p - w));
    while (p < end && is_space(*p)) ++p;
    out.args = std::string_view(p, static_cast<std::size_t>(end - p));
    done = true;
    return check_free_text(text, line, p, end);
  } else {
    if (*p == '[' || *p == '{') return parse_error(text, line, "unexpanded slicer placeholder");
    const auto uc = static_cast<unsigned char>(*p);
    if ((uc < 32 && uc != '\t') || uc >= 127) return not_gcode(text, line, p);
    return parse_error(text, line,
                       std::string("expected a command (G, M, T) but found '") + *p + "'");
  }
  return Ok{};
}

/// Reads the parameters after the command word: letter + number, bare flags, a quoted
/// string (kept in `args`), M486's object name; `(...)` comments are skipped.
Status read_parameters(std::string_view text, long line, GcodeCommand& out, const char* p,
                       const char* end) {
  // Parameters.
  while (p < end) {
    const char c = *p;
    if (is_space(c)) {
      ++p;
      continue;
    }
    if (c == '(') {  // inline comment
      const void* close = std::memchr(p, ')', static_cast<std::size_t>(end - p));
      if (close == nullptr) return parse_error(text, line, "'(' comment without ')'");
      p = static_cast<const char*>(close) + 1;
      continue;
    }
    if (c == '[' || c == '{') return parse_error(text, line, "unexpanded slicer placeholder");
    const char letter = upper(c);
    if (!is_upper(letter)) {
      const auto uc = static_cast<unsigned char>(c);
      if ((uc < 32 && uc != '\t') || uc >= 127) return not_gcode(text, line, p);
      return parse_error(text, line, std::string("unexpected character '") + c + "'");
    }
    // M486 A<name>: the object name is text.
    if (out.letter == 'M' && out.code == 486 && letter == 'A') {
      out.present |= 1U << ('A' - 'A');
      out.value[0] = 0;
      out.args = std::string_view(p + 1, static_cast<std::size_t>(end - p - 1));
      return check_free_text(text, line, p + 1, end);
    }
    ++p;
    while (p < end && is_space(*p)) ++p;
    double v = 0;
    if (p < end && *p == '"') {
      // A quoted string argument (Prusa `M862.3 P "MK4S"`, RepRapFirmware `M98 P"x.g"`):
      // the parameter is present with value 0; the first string is kept in `args`.
      const void* close =
          p + 1 < end ? std::memchr(p + 1, '"', static_cast<std::size_t>(end - p - 1)) : nullptr;
      if (close == nullptr) return parse_error(text, line, "quoted string without a closing '\"'");
      const char* q = static_cast<const char*>(close);
      if (auto st = check_free_text(text, line, p + 1, end); !st) return st;
      if (out.args.empty()) out.args = std::string_view(p + 1, static_cast<std::size_t>(q - p - 1));
      p = q + 1;
    } else if (p < end && (is_digit(*p) || *p == '.' || *p == '-' || *p == '+')) {
      const char* q = read_number(p, end, v);
      if (q == nullptr)
        return parse_error(text, line, std::string("malformed number after ") + letter);
      if (!std::isfinite(v) || std::fabs(v) > kMaxParameterMagnitude)
        return parse_error(text, line,
                           std::string("value of ") + letter + " out of range (|v| <= 1e9)");
      p = q;
      out.valued |= 1U << static_cast<unsigned>(letter - 'A');
    } else if (p < end && (*p == '[' || *p == '{')) {
      return parse_error(text, line, "unexpanded slicer placeholder");
    } else if (p < end && !is_space(*p) && is_upper(upper(*p)) && letter != 'N') {
      // "X nan", "Xinf": letters right after a parameter letter.
      if (upper(*p) == 'N' || upper(*p) == 'I')
        return parse_error(text, line, std::string("value of ") + letter + " is not a number");
      // "G1 Yabc": a move's axis needs a number, not more letters (a bare flag such as
      // "G28 X Y" stands apart).
      if (out.letter == 'G' && out.code <= 3)
        return parse_error(
            text, line, std::string("expected a number after ") + letter + ", found '" + *p + "'");
    }
    const unsigned bit = static_cast<unsigned>(letter - 'A');
    out.present |= 1U << bit;
    out.value[bit] = v;
  }
  return Ok{};
}
}  // namespace

Status parse_gcode_line(std::string_view text, long line, GcodeCommand& out) {
  out.letter = 0;
  out.code = -1;
  out.subcode = -1;
  out.present = 0;
  out.valued = 0;
  out.word = {};
  out.args = {};
  out.comment = {};
  out.line = line;

  const char* p = text.data();
  const char* end = p + text.size();
  strip_comment(text, out, p, end);
  if (p == end) return Ok{};
  if (auto st = strip_checksum(text, line, p, end); !st) return st;

  // Optional line number N<int>.
  if ((*p == 'N' || *p == 'n') && p + 1 < end && is_digit(p[1])) {
    ++p;
    while (p < end && is_digit(*p)) ++p;
    while (p < end && is_space(*p)) ++p;
    if (p == end) return Ok{};
  }

  bool done = false;
  if (auto st = read_command_word(text, line, out, p, end, done); !st || done) return st;

  // Commands whose argument is free text: messages and file names; M115 U<version>
  // (Prusa's firmware-version check, "U6.1.3+7898"); Bambu's M1002 (status actions such
  // as "gcode_claim_action : 2") and M624 (the objects a block belongs to, in base64:
  // "M624 AQAAAAAAAAA=").
  if (out.letter == 'M' && (out.code == 117 || out.code == 118 || out.code == 23 ||
                            out.code == 28 || out.code == 30 || out.code == 32 || out.code == 928 ||
                            out.code == 115 || out.code == 1002 || out.code == 624)) {
    while (p < end && is_space(*p)) ++p;
    out.args = std::string_view(p, static_cast<std::size_t>(end - p));
    return check_free_text(text, line, p, end);
  }
  return read_parameters(text, line, out, p, end);
}

}  // namespace printtwin
