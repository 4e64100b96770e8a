// MeatPack decoder: see meatpack.hpp for the encoding.
#include "gcode/meatpack.hpp"

#include <array>
#include <cstdint>

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

constexpr std::array<char, 15> kCodes = {'0', '1', '2', '3', '4', '5', '6', '7', '8', '9', '.', ' ', '\n', 'G', 'X'};

/// The letters before which a G line gets its space back.
constexpr bool is_g_parameter(char c) {
  switch (c) {
    case 'X': case 'Y': case 'Z': case 'E': case 'F': case 'I': case 'J': case 'R':
    case 'G': case 'P': case 'W': case 'H': case 'C': case 'A':
      return true;
    default:
      return false;
  }
}

/// Writes characters as PrusaSlicer's reader does (spaces back in G lines, no empty lines).
class TextWriter {
 public:
  TextWriter(std::string& out) : out_(out), start_(out.size()) {}
  void put(char c) {
    const bool at_start = out_.size() == start_;
    const char prev = at_start ? '\0' : out_.back();
    bool line_start_g = false;
    if (c == 'G' && (at_start || prev == '\n')) {
      in_g_line_ = true;
      line_start_g = true;
    } else if (c == '\n') {
      in_g_line_ = false;
    }
    if (!line_start_g && in_g_line_ && (at_start || prev != ' ') && is_g_parameter(c)) out_.push_back(' ');
    if (c != '\n' || at_start || prev != '\n') out_.push_back(c);
  }

 private:
  std::string& out_;
  std::size_t start_;
  bool in_g_line_ = false;
};

}  // namespace

bool meatpack_decode(std::string_view in, std::string& out, std::string& why) {
  out.reserve(out.size() + 2 * in.size());
  TextWriter text(out);
  bool packing = false, no_spaces = false;
  int signals = 0;           // 0xFF bytes seen in a row (0 or 1) before a possible command
  bool command_next = false;  // two 0xFF seen: the next byte is a command
  int full_pending = 0;       // whole-byte characters still to come for the current pair
  char held = '\0';           // a packed second character waiting behind a whole-byte first one

  auto unpacked = [&](std::uint8_t code) { return code == 11 && no_spaces ? 'E' : kCodes[code]; };
  auto receive = [&](std::uint8_t b) {
    if (!packing) {
      text.put(static_cast<char>(b));
      return;
    }
    if (full_pending > 0) {
      text.put(static_cast<char>(b));
      if (held != '\0') {
        text.put(held);
        held = '\0';
      }
      --full_pending;
      return;
    }
    const std::uint8_t lo = b & 0x0F, hi = b >> 4;
    if (lo == kNotPacked) {
      ++full_pending;
      if (hi == kNotPacked) ++full_pending;
      else held = unpacked(hi);
      return;
    }
    const char first = unpacked(lo);
    text.put(first);
    if (first == '\n') return;
    if (hi == kNotPacked) ++full_pending;
    else text.put(unpacked(hi));
  };

  for (std::size_t i = 0; i < in.size(); ++i) {
    const auto b = static_cast<std::uint8_t>(in[i]);
    if (b == kSignal) {
      if (signals > 0) {
        command_next = true;
        signals = 0;
      } else {
        ++signals;
      }
      continue;
    }
    if (command_next) {
      command_next = false;
      switch (b) {
        case kEnablePacking: packing = true; break;
        case kDisablePacking: packing = false; break;
        case kResetAll: packing = false; break;
        case kQueryConfig: break;
        case kEnableNoSpaces: no_spaces = true; break;
        case kDisableNoSpaces: no_spaces = false; break;
        default:
          why = "unknown MeatPack command 0x" + std::string(1, "0123456789ABCDEF"[b >> 4]) +
                std::string(1, "0123456789ABCDEF"[b & 15]) + " at byte " + std::to_string(i) +
                " of the block's data";
          return false;
      }
      continue;
    }
    if (signals > 0) {
      receive(kSignal);
      signals = 0;
    }
    receive(b);
  }
  if (signals > 0 || command_next) {
    why = "MeatPack data ends inside a command (0xFF 0xFF <command>)";
    return false;
  }
  if (full_pending > 0) {
    why = "MeatPack data ends before the " + std::to_string(full_pending) + " unpacked character(s) it announces";
    return false;
  }
  return true;
}

}  // namespace printtwin::detail
