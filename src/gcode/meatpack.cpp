// MeatPack decoder: see meatpack.hpp for the encoding.
#include "gcode/meatpack.hpp"

#include <array>
#include <cstdint>
#include <cstring>

#include "core/plain_path.hpp"

namespace printtwin::detail {

namespace {

constexpr std::uint8_t kSignal = 0xFF;
constexpr std::uint8_t kEnablePacking = 0xFB;
constexpr std::uint8_t kDisablePacking = 0xFA;
constexpr std::uint8_t kResetAll = 0xF9;
constexpr std::uint8_t kQueryConfig = 0xF8;
constexpr std::uint8_t kEnableNoSpaces = 0xF7;
constexpr std::uint8_t kDisableNoSpaces = 0xF6;
constexpr std::uint8_t kNotPacked = 0x0F;

constexpr std::array<char, 15> kCodes = {'0', '1', '2', '3', '4',  '5', '6', '7',
                                         '8', '9', '.', ' ', '\n', 'G', 'X'};

/// The letters before which a G line gets its space back.
constexpr std::array<bool, 256> kGParameter = [] {
  std::array<bool, 256> t{};
  for (unsigned char c : std::string_view("XYZEFIJRGPWHCA")) t[c] = true;
  return t;
}();

/// Packed bytes whose two characters are both digits or '.' (the bulk of G-code): none of
/// the writer's rules apply to them, whatever the "no spaces" mode.
constexpr std::array<bool, 256> kPlainPair = [] {
  std::array<bool, 256> t{};
  for (int b = 0; b < 256; ++b) t[static_cast<std::size_t>(b)] = (b & 15) <= 10 && (b >> 4) <= 10;
  return t;
}();

/// Applies the command byte `b` that follows 0xFF 0xFF at byte `i` of the block's data.
/// False, with `why` set, on an unknown command.
bool apply_command(std::uint8_t b, std::size_t i, bool& packing, char& code11, std::string& why) {
  switch (b) {
    case kEnablePacking:
      packing = true;
      return true;
    case kDisablePacking:
    case kResetAll:
      packing = false;
      return true;
    case kQueryConfig:
      return true;
    case kEnableNoSpaces:
      code11 = 'E';
      return true;
    case kDisableNoSpaces:
      code11 = ' ';
      return true;
    default:
      why = "unknown MeatPack command 0x" + std::string(1, "0123456789ABCDEF"[b >> 4]) +
            std::string(1, "0123456789ABCDEF"[b & 15]) + " at byte " + std::to_string(i) +
            " of the block's data";
      return false;
  }
}

/// False, with `why` set, when the block ends inside a command or before the whole-byte
/// characters it announced.
bool ends_cleanly(bool in_command, int full_pending, std::string& why) {
  if (in_command) {
    why = "MeatPack data ends inside a command (0xFF 0xFF <command>)";
    return false;
  }
  if (full_pending > 0) {
    why = "MeatPack data ends before the " + std::to_string(full_pending) +
          " unpacked character(s) it announces";
    return false;
  }
  return true;
}

/// The MeatPack stream's state machine, shared by both decoders: 0xFF 0xFF <command>
/// switches modes; in packing mode each byte gives up to two characters, a "not packed"
/// code announcing a whole byte. Characters go to `put` in text order.
struct Unpacker {
  bool packing = false;
  char code11 = ' ';          ///< ' ', or 'E' once "no spaces" is on
  int signals = 0;            ///< 0xFF bytes seen in a row (0 or 1) before a possible command
  bool command_next = false;  ///< two 0xFF seen: the next byte is a command
  int full_pending = 0;       ///< whole-byte characters still to come for the current pair
  char held = '\0';           ///< a packed second character waiting behind a whole-byte first one

  [[nodiscard]] char unpacked(std::uint8_t code) const {
    return code == 11 ? code11 : kCodes[code];
  }

  template <class Put>
  void receive(std::uint8_t b, Put&& put) {
    if (!packing) {
      put(static_cast<char>(b));
      return;
    }
    if (full_pending > 0) {
      put(static_cast<char>(b));
      if (held != '\0') {
        put(held);
        held = '\0';
      }
      --full_pending;
      return;
    }
    const std::uint8_t lo = b & 0x0F, hi = b >> 4;
    if (lo == kNotPacked) {
      ++full_pending;
      if (hi == kNotPacked)
        ++full_pending;
      else
        held = unpacked(hi);
      return;
    }
    const char first = unpacked(lo);
    put(first);
    if (first == '\n') return;
    if (hi == kNotPacked)
      ++full_pending;
    else
      put(unpacked(hi));
  }

  /// Byte `i` of `bytes` through the machine. False, with `why` set, on an unknown command.
  template <class Put>
  bool step(const std::uint8_t* bytes, std::size_t i, Put&& put, std::string& why) {
    const std::uint8_t b = bytes[i];
    if (b == kSignal) {
      if (signals > 0) {
        command_next = true;
        signals = 0;
      } else {
        ++signals;
      }
      return true;
    }
    if (command_next) {
      command_next = false;
      return apply_command(b, i, packing, code11, why);
    }
    if (signals > 0) {
      receive(kSignal, put);
      signals = 0;
    }
    receive(b, put);
    return true;
  }

  /// False, with `why` set, when the block ends inside a command or a pair.
  bool finish(std::string& why) const {
    return ends_cleanly(signals > 0 || command_next, full_pending, why);
  }
};

}  // namespace

bool meatpack_decode_plain(std::string_view in, Bytes& buf, std::size_t& size, std::string& why) {
  // Each input byte gives at most two characters, each of which may get a space before it.
  if (buf.size() < 4 * in.size() + 8) buf.resize(4 * in.size() + 8);
  char* const begin = buf.data();
  char* o = begin;
  size = 0;

  // The text writer (PrusaSlicer's reader): spaces back before the parameters of a line
  // that starts with 'G', no empty lines. `prev` is the last character written, '\0' at
  // the start of the block.
  char prev = '\0';
  bool g_line = false;
  auto put = [&](char c) {
    if (c == '\n') {
      g_line = false;
      if (prev != '\n') *o++ = prev = c;
      return;
    }
    if (c == 'G' && (prev == '\n' || o == begin)) {
      g_line = true;
    } else if (g_line && prev != ' ' && kGParameter[static_cast<unsigned char>(c)]) {
      *o++ = ' ';
    }
    *o++ = prev = c;
  };

  Unpacker m;

  const auto* bytes = reinterpret_cast<const std::uint8_t*>(in.data());
  const std::size_t n = in.size();
  for (std::size_t i = 0; i < n; ++i) {
    // Fast paths, when no pair, character or command is pending: runs of packed digits and
    // '.' (the bulk of G-code), and the plain bytes of comment lines.
    if (m.full_pending == 0 && m.signals == 0 && !m.command_next) {
      if (m.packing) {
        while (i < n && kPlainPair[bytes[i]]) {
          o[0] = kCodes[bytes[i] & 15];
          o[1] = prev = kCodes[bytes[i] >> 4];
          o += 2;
          ++i;
        }
      } else if (!g_line) {
        while (i < n && bytes[i] != kSignal && bytes[i] != '\n' && bytes[i] != 'G')
          *o++ = prev = static_cast<char>(bytes[i++]);
      }
      if (i == n) break;
    }
    if (!m.step(bytes, i, put, why)) return false;
  }
  size = static_cast<std::size_t>(o - begin);
  return m.finish(why);
}

namespace {

/// What one packed byte (not 0xFF) gives: the characters it puts in the text, and whether
/// the next byte is a whole character (a "not packed" code), with the packed character
/// that then follows it (`held`, for a byte whose low code is the unpacked one).
struct PackedPair {
  char c0 = '\0', c1 = '\0';
  std::uint8_t count = 0;  ///< characters written now: 0, 1 or 2
  std::uint8_t take = 0;   ///< 1: the next byte is a whole character
  char held = '\0';        ///< written after that whole character ('\0': none)
};

/// One table per meaning of code 11 (' ', or 'E' once "no spaces" is on).
constexpr std::array<PackedPair, 256> packed_pairs(char code11) {
  auto code = [&](int c) { return c == 11 ? code11 : kCodes[static_cast<std::size_t>(c)]; };
  std::array<PackedPair, 256> t{};
  for (int b = 0; b < 255; ++b) {
    const int lo = b & 15, hi = b >> 4;
    PackedPair& e = t[static_cast<std::size_t>(b)];
    if (lo != kNotPacked) {
      e.c0 = code(lo);
      e.count = 1;
      if (e.c0 == '\n') continue;  // the high nibble is padding
      if (hi == kNotPacked) {
        e.take = 1;
      } else {
        e.c1 = code(hi);
        e.count = 2;
      }
    } else {
      e.take = 1;
      e.held = code(hi);
    }
  }
  return t;
}
constexpr std::array<PackedPair, 256> kPairsWithSpaces = packed_pairs(' ');
constexpr std::array<PackedPair, 256> kPairsNoSpaces = packed_pairs('E');

/// Step 1: the MeatPack stream to the characters it carries, before the text writer's rules
/// (same state machine as meatpack_decode_plain, with a table for packed bytes and memchr
/// for plain runs). Writes at most 2 characters per input byte plus one of slack.
bool unpack(std::string_view in, char* const begin, std::size_t& size, std::string& why) {
  char* o = begin;
  Unpacker m;
  auto put = [&](char c) { *o++ = c; };

  const auto* bytes = reinterpret_cast<const std::uint8_t*>(in.data());
  const std::size_t n = in.size();
  for (std::size_t i = 0; i < n; ++i) {
    if (m.full_pending <= 1 && m.signals == 0 && !m.command_next) {
      if (m.packing) {
        // Packed bytes and the whole bytes they announce, up to the next 0xFF (which may
        // start a command): one lookup and two stores per byte.
        const PackedPair* table = m.code11 == 'E' ? kPairsNoSpaces.data() : kPairsWithSpaces.data();
        int full_pending = m.full_pending;
        char held = m.held;
        while (i < n && bytes[i] != kSignal) {
          const std::uint8_t b = bytes[i++];
          const PackedPair& e = table[b];
          const bool whole = full_pending != 0;
          o[0] = whole ? static_cast<char>(b) : e.c0;
          o[1] = whole ? held : e.c1;
          o += whole ? 1 + static_cast<int>(held != '\0') : e.count;
          full_pending = whole ? 0 : e.take;
          held = whole ? '\0' : e.held;
        }
        m.full_pending = full_pending;
        m.held = held;
      } else {  // plain bytes up to the next 0xFF
        const void* ff = std::memchr(bytes + i, kSignal, n - i);
        const std::size_t end =
            ff == nullptr ? n
                          : static_cast<std::size_t>(static_cast<const std::uint8_t*>(ff) - bytes);
        std::memcpy(o, bytes + i, end - i);
        o += end - i;
        i = end;
      }
      if (i == n) break;
    }
    if (!m.step(bytes, i, put, why)) return false;
  }
  size = static_cast<std::size_t>(o - begin);
  return m.finish(why);
}

/// Step 2, the text writer's rules line by line: a line starting with 'G' gets a space
/// before each parameter letter not already behind one; an empty line is dropped unless
/// it is the first thing written. `in[n]` must be writable (a sentinel goes there). Writes
/// at most twice the input plus one.
std::size_t write_text(char* in, std::size_t n, char* const begin) {
  in[n] = '\n';  // ends the last G line without a bound check per character
  char* o = begin;
  std::size_t i = 0;
  while (i < n) {
    if (in[i] == '\n') {  // an empty line
      if (o == begin) *o++ = '\n';
      ++i;
      continue;
    }
    if (in[i] == 'G') {
      *o++ = 'G';
      for (++i; in[i] != '\n'; ++i) {
        const char c = in[i];
        *o = ' ';  // kept only when the letter needs it (no branch)
        o += static_cast<std::size_t>(kGParameter[static_cast<unsigned char>(c)] &&
                                      in[i - 1] != ' ');
        *o++ = c;
      }
    } else {
      const void* nl = std::memchr(in + i, '\n', n - i);
      const std::size_t end =
          nl == nullptr ? n : static_cast<std::size_t>(static_cast<const char*>(nl) - in);
      std::memcpy(o, in + i, end - i);
      o += end - i;
      i = end;
    }
    if (i < n) {
      *o++ = '\n';
      ++i;
    }
  }
  return static_cast<std::size_t>(o - begin);
}

}  // namespace

bool meatpack_decode(std::string_view in, Bytes& buf, Bytes& raw, std::size_t& size,
                     std::string& why) {
  if (plain_path("meatpack_table")) return meatpack_decode_plain(in, buf, size, why);
  size = 0;
  if (raw.size() < 2 * in.size() + 8) raw.resize(2 * in.size() + 8);
  std::size_t raw_size = 0;
  if (!unpack(in, raw.data(), raw_size, why)) return false;
  if (buf.size() < 2 * raw_size + 8) buf.resize(2 * raw_size + 8);
  size = write_text(raw.data(), raw_size, buf.data());
  return true;
}

}  // namespace printtwin::detail
