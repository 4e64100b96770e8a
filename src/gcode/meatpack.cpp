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

/// The writer's state between two characters, for the table-driven loop (the reference
/// writer in meatpack_decode() keeps `prev` and `g_line` instead).
enum Writer : std::uint8_t {
  kBlockStart,  ///< nothing written yet: a '\n' is written, a 'G' starts a G line
  kLineStart,   ///< after a '\n': another '\n' is dropped, a 'G' starts a G line
  kGLine,       ///< inside a G line, after anything but a space: parameters get a space
  kGLineSpace,  ///< inside a G line, after a space
  kOtherLine,   ///< inside any other line
  kWriterStates
};

/// One character through the writer: what it writes (up to two bytes: a space and the
/// character) and the state after it.
struct CharStep {
  std::array<char, 2> out{};
  std::uint8_t len = 0;
  std::uint8_t next = kOtherLine;
};

constexpr CharStep char_step(int state, char c) {
  CharStep s;
  if (c == '\n') {
    s.next = kLineStart;
    if (state != kLineStart) s.out[s.len++] = c;
    return s;
  }
  const bool line_start = state == kBlockStart || state == kLineStart;
  if (c == 'G' && line_start) {
    s.out[s.len++] = c;
    s.next = kGLine;
    return s;
  }
  if (state == kGLine || state == kGLineSpace) {
    if (state == kGLine && kGParameter[static_cast<unsigned char>(c)]) s.out[s.len++] = ' ';
    s.out[s.len++] = c;
    s.next = c == ' ' ? kGLineSpace : kGLine;
    return s;
  }
  s.out[s.len++] = c;
  s.next = kOtherLine;
  return s;
}

using CharTable = std::array<std::array<CharStep, 256>, kWriterStates>;
constexpr CharTable kCharSteps = [] {
  CharTable t{};
  for (int state = 0; state < kWriterStates; ++state)
    for (int c = 0; c < 256; ++c)
      t[static_cast<std::size_t>(state)][static_cast<std::size_t>(c)] =
          char_step(state, static_cast<char>(c));
  return t;
}();

/// What one byte of packed data does, from a state with nothing pending.
enum PairKind : std::uint8_t {
  kPair,      ///< both characters packed (or a '\n' first): `out` is all it writes
  kHighFull,  ///< packed first character (in `out`), then the next byte whole
  kLowFull,   ///< the next byte whole first, then the packed character `second`
  kBothFull,  ///< the next two bytes whole
  kSignal1,   ///< 0xFF: a command may follow; the state machine takes it
};

/// One packed byte through the unpacker and the writer.
struct PairStep {
  std::array<char, 4> out{};
  std::uint8_t len = 0;
  std::uint8_t next = kOtherLine;
  std::uint8_t kind = kPair;
  char second = '\0';
};

using PairTable = std::array<std::array<PairStep, 256>, kWriterStates>;

/// The table for one "no spaces" mode (`code11` = ' ' or 'E').
constexpr PairTable pair_table(char code11) {
  PairTable t{};
  auto code = [code11](int nibble) {
    return nibble == 11 ? code11 : kCodes[static_cast<std::size_t>(nibble)];
  };
  for (int state = 0; state < kWriterStates; ++state) {
    for (int b = 0; b < 256; ++b) {
      PairStep& p = t[static_cast<std::size_t>(state)][static_cast<std::size_t>(b)];
      p.next = static_cast<std::uint8_t>(state);
      const int lo = b & 15, hi = b >> 4;
      auto write = [&p](char c) {
        const CharStep& s = kCharSteps[p.next][static_cast<unsigned char>(c)];
        for (int k = 0; k < s.len; ++k) p.out[p.len++] = s.out[static_cast<std::size_t>(k)];
        p.next = s.next;
      };
      if (b == kSignal) {
        p.kind = kSignal1;
      } else if (lo == kNotPacked) {
        p.kind = hi == kNotPacked ? kBothFull : kLowFull;
        if (hi != kNotPacked) p.second = code(hi);
      } else {
        write(code(lo));
        if (code(lo) == '\n') continue;  // the high nibble is padding
        if (hi == kNotPacked)
          p.kind = kHighFull;
        else
          write(code(hi));
      }
    }
  }
  return t;
}

constexpr PairTable kPairSpaces = pair_table(' ');
constexpr PairTable kPairNoSpaces = pair_table('E');

/// Writes what one step gives at `o` (a whole word: the buffer has slack) and moves `o`.
void emit(char*& o, const PairStep& p) {
  std::memcpy(o, p.out.data(), 4);
  o += p.len;
}
void emit(char*& o, const CharStep& c) {
  std::memcpy(o, c.out.data(), 2);
  o += c.len;
}

/// A byte that is a whole pair and leaves the writer in `state`.
constexpr bool stays(const PairStep& p, std::uint8_t state) {
  return (p.kind | (p.next ^ state)) == 0;
}

/// The table-driven loop over packed bytes, from a state with nothing pending: each byte's
/// characters, the spaces before the parameters of a G line and the dropped empty lines
/// come from one lookup by writer state and byte (kPairSpaces, kPairNoSpaces); a byte
/// announcing whole-byte characters takes them through kCharSteps. Writes from `o` on,
/// never past `limit` (at most 4 bytes per byte read, and 4 more of slack). `prev` and
/// `g_line` are the reference writer's state, read on entry and left as it would leave
/// them. True when it stopped for room (or at the end); false when byte `i` needs the
/// state machine (0xFF, or a pair whose whole bytes are cut off or are 0xFF).
bool packed_run(const std::uint8_t* bytes, std::size_t n, std::size_t& i, char code11,
                const char* begin, char*& o, const char* limit, char& prev, bool& g_line) {
  const PairTable& table = code11 == 'E' ? kPairNoSpaces : kPairSpaces;
  std::uint8_t w = o == begin     ? kBlockStart
                   : prev == '\n' ? kLineStart
                   : !g_line      ? kOtherLine
                   : prev == ' '  ? kGLineSpace
                                  : kGLine;
  const std::size_t run_end = std::min(n, i + static_cast<std::size_t>(limit - o) / 4);
  bool room_or_end = true;
  const std::array<PairStep, 256>& g_row = table[kGLine];
  const std::array<PairStep, 256>& start_row = table[kLineStart];
  const std::array<CharStep, 256>& g_chars = kCharSteps[kGLine];
  while (i < run_end) {
    // Inside a G line, most bytes leave the state as it is, and a G line follows the '\n':
    // the rows of those two states are fixed, so no lookup waits for the state the one
    // before it gives, and the branches are predicted.
    while (w == kGLine && i < run_end) {
      if (i + 1 < run_end) {  // two bytes that both stay in the line: one branch for both
        const PairStep& a = g_row[bytes[i]];
        const PairStep& b = g_row[bytes[i + 1]];
        if ((a.kind | (a.next ^ kGLine) | b.kind | (b.next ^ kGLine)) == 0) {
          emit(o, a);
          emit(o, b);
          i += 2;
          continue;
        }
      }
      const PairStep& p = g_row[bytes[i]];
      if (stays(p, kGLine)) {
        emit(o, p);
        ++i;
        continue;
      }
      if (stays(p, kLineStart)) {  // the line ends
        emit(o, p);
        ++i;
        w = kLineStart;
        if (i == run_end) break;
        const PairStep& q = start_row[bytes[i]];
        if (!stays(q, kGLine)) break;
        emit(o, q);
        ++i;
        w = kGLine;
        continue;
      }
      // A parameter letter stored whole (Y, Z, F...) beside a packed character.
      if ((p.kind != kHighFull && p.kind != kLowFull) || i + 1 == n) break;
      const std::uint8_t c = bytes[i + 1];
      const CharStep& whole = g_chars[c];
      if (c == kSignal || whole.next != kGLine || p.next != kGLine) break;
      if (p.kind == kHighFull) {
        emit(o, p);
        emit(o, whole);
      } else {
        emit(o, whole);
        const CharStep& second = g_chars[static_cast<std::uint8_t>(p.second)];
        emit(o, second);
        w = second.next;
      }
      i += 2;
    }
    if (i >= run_end) break;
    // Any state, any byte: one lookup, the whole bytes through kCharSteps.
    const PairStep& p = table[w][bytes[i]];
    if (p.kind == kPair) {
      emit(o, p);
      w = p.next;
      ++i;
      continue;
    }
    const std::size_t whole = p.kind == kBothFull ? 2 : 1;
    if (p.kind == kSignal1 || i + whole >= n || bytes[i + 1] == kSignal ||
        bytes[i + whole] == kSignal) {
      room_or_end = false;
      break;
    }
    emit(o, p);  // kHighFull's packed first character, else nothing
    w = p.next;
    auto write = [&](std::uint8_t c) {
      const CharStep& step = kCharSteps[w][c];
      emit(o, step);
      w = step.next;
    };
    write(bytes[i + 1]);
    if (p.kind == kLowFull) write(static_cast<std::uint8_t>(p.second));
    if (p.kind == kBothFull) write(bytes[i + 2]);
    i += whole + 1;
  }
  if (o != begin) prev = o[-1];
  g_line = w == kGLine || w == kGLineSpace;
  return room_or_end;
}

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
    // then just the packing and "no spaces" modes): a whole command; in packing mode, the
    // table loop; in plain mode, the bytes of comment lines. Anything else (a lone 0xFF, a
    // pair cut by the end of the block or by 0xFF) goes through the machine byte by byte.
    if (fast && m.full_pending == 0 && m.signals == 0 && !m.command_next) {
      if (bytes[i] == kSignal && i + 2 < n && bytes[i + 1] == kSignal &&
          bytes[i + 2] != kSignal) {  // (a third 0xFF is a signal again, not the command)
        if (!apply_command(bytes[i + 2], i + 2, m.packing, m.code11, why)) return false;
        i += 3;
        continue;
      }
      if (m.packing) {
        if (packed_run(bytes, n, i, m.code11, begin, o, end - kRoom, prev, g_line)) continue;
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
