// MeatPack decoder: see meatpack.hpp for the encoding.
#include "gcode/meatpack.hpp"

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>

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

/// The MeatPack stream's state machine, 0xFF 0xFF <command>
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

bool meatpack_decode(std::string_view in, Bytes& buf, std::size_t& size, std::string& why,
                     bool fast) {
  // Each input byte gives at most two characters, each of which may get a space before it,
  // but G-code rarely comes near that: the buffer starts at twice the input and grows when
  // fewer than 2 kRoom bytes are left (a step of the loop below writes at most 4 bytes
  // after its runs, which stop kRoom bytes short of the end). Sizing it
  // for the worst case (4x) put a 64 KiB block's buffer above malloc's mmap threshold:
  // fresh pages, faulted in, for every file opened.
  constexpr std::size_t kRoom = 16;
  if (buf.size() < 2 * in.size() + 4 * kRoom) buf.resize(2 * in.size() + 4 * kRoom);
  char* begin = buf.data();
  char* o = begin;
  char* end = begin + buf.size();
  size = 0;
  auto room = [&] {  // at least 2 kRoom bytes free from o on
    if (static_cast<std::size_t>(end - o) >= 2 * kRoom) return;
    const auto used = static_cast<std::size_t>(o - begin);
    buf.resize(2 * buf.size());
    begin = buf.data();
    o = begin + used;
    end = begin + buf.size();
  };

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
  std::size_t i = 0;
  while (i < n) {
    room();
    // Fast paths, when no pair, character or command is pending (the machine's state is
    // then just the packing and "no spaces" modes): whole packed pairs and the whole-byte
    // characters they announce, with runs of digits and '.' (the bulk of G-code) apart;
    // in plain mode, the bytes of comment lines. Anything else (0xFF, a pair cut by the
    // end of the block) goes through the machine byte by byte.
    if (fast && m.full_pending == 0 && m.signals == 0 && !m.command_next) {
      if (m.packing) {
        const std::size_t run_end =
            std::min(n, i + (static_cast<std::size_t>(end - o) - kRoom) / 2);
        while (i < run_end && kPlainPair[bytes[i]]) {
          o[0] = kCodes[bytes[i] & 15];
          o[1] = prev = kCodes[bytes[i] >> 4];
          o += 2;
          ++i;
        }
        if (i == n) break;
        if (i == run_end) continue;  // out of room
        const std::uint8_t b = bytes[i];
        const std::uint8_t lo = b & 15, hi = b >> 4;
        if (b != kSignal) {
          if (lo != kNotPacked && hi != kNotPacked) {
            const char first = m.unpacked(lo);
            put(first);
            if (first != '\n') put(m.unpacked(hi));
            ++i;
            continue;
          }
          if (lo != kNotPacked && m.unpacked(lo) == '\n') {  // the high nibble is padding
            put('\n');
            ++i;
            continue;
          }
          const std::size_t whole = lo == kNotPacked && hi == kNotPacked ? 2 : 1;
          if (i + whole < n && bytes[i + 1] != kSignal && (whole == 1 || bytes[i + 2] != kSignal)) {
            if (whole == 2) {
              put(static_cast<char>(bytes[i + 1]));
              put(static_cast<char>(bytes[i + 2]));
            } else if (lo == kNotPacked) {
              put(static_cast<char>(bytes[i + 1]));
              put(m.unpacked(hi));
            } else {
              put(m.unpacked(lo));
              put(static_cast<char>(bytes[i + 1]));
            }
            i += whole + 1;
            continue;
          }
        }
      } else if (!g_line) {
        const std::size_t run_end = std::min(n, i + static_cast<std::size_t>(end - o) - kRoom);
        while (i < run_end && bytes[i] != kSignal && bytes[i] != '\n' && bytes[i] != 'G')
          *o++ = prev = static_cast<char>(bytes[i++]);
        if (i == n) break;
        if (i == run_end) continue;  // out of room
      }
    }
    if (!m.step(bytes, i, put, why)) return false;
    ++i;
  }
  size = static_cast<std::size_t>(o - begin);
  return m.finish(why);
}

}  // namespace printtwin::detail
