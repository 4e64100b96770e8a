// Binary G-code (bgcode.hpp): files encoded here by a small encoder written for the tests
// (every compression and encoding), decoded to the expected text; bad input named by block;
// and PrusaSlicer's own .bgcode against its text twin when the shared real-world folder exists.
#include <gtest/gtest.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "gcode/meatpack.hpp"
#include "printtwin/bgcode.hpp"
#include "printtwin/io.hpp"
#include "printtwin/mesh.hpp"
#include "printtwin/printer.hpp"
#include "printtwin/simulate.hpp"
#include "printtwin/verify.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

// ---- a small encoder, written for the tests from the format's description ----

void put16(std::string& s, std::uint16_t v) {
  s.push_back(static_cast<char>(v & 0xFF));
  s.push_back(static_cast<char>(v >> 8));
}
void put32(std::string& s, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) s.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
}

/// MSB-first bit writer.
struct BitWriter {
  std::string out;
  std::uint32_t acc = 0;
  int bits = 0;
  void put(std::uint32_t v, int n) {
    for (int i = n - 1; i >= 0; --i) {
      acc = (acc << 1) | ((v >> i) & 1u);
      if (++bits == 8) {
        out.push_back(static_cast<char>(acc));
        acc = 0;
        bits = 0;
      }
    }
  }
  std::string finish() {
    if (bits > 0) put(0, 8 - bits);
    return out;
  }
};

/// Heatshrink: literals only (always valid), or back-references found through the last
/// position of each byte pair (2..16 bytes, within the window).
std::string heatshrink_encode(std::string_view in, int window_bits, bool backrefs) {
  BitWriter w;
  const std::size_t window = std::size_t{1} << window_bits;
  std::vector<std::size_t> last(65536, SIZE_MAX);
  auto pair = [&](std::size_t i) {
    return static_cast<std::uint8_t>(in[i]) | (static_cast<std::uint8_t>(in[i + 1]) << 8);
  };
  for (std::size_t i = 0; i < in.size();) {
    std::size_t len = 0, off = 0;
    if (backrefs && i + 1 < in.size()) {
      const std::size_t prev = last[pair(i)];
      if (prev != SIZE_MAX && i - prev <= window) {
        off = i - prev;
        while (len < 16 && i + len < in.size() && in[i + len - off] == in[i + len]) ++len;
      }
    }
    const std::size_t step = len >= 2 ? len : 1;
    if (len >= 2) {
      w.put(0, 1);
      w.put(static_cast<std::uint32_t>(off - 1), window_bits);
      w.put(static_cast<std::uint32_t>(len - 1), 4);
    } else {
      w.put(1, 1);
      w.put(static_cast<std::uint8_t>(in[i]), 8);
    }
    for (std::size_t k = i; k < i + step && k + 1 < in.size(); ++k) last[pair(k)] = k;
    i += step;
  }
  return w.finish();
}

/// MeatPack as PrusaSlicer's writer does it: G lines lose their spaces and comments, other
/// lines their comments; comment lines are kept (packing off) when `keep_comments`.
std::string meatpack_encode(std::string_view text, bool keep_comments, bool no_spaces) {
  auto packable = [&](char c) {
    return (c >= '0' && c <= '9') || c == '.' || c == '\n' || c == 'G' || c == 'X' ||
           (no_spaces ? c == 'E' : c == ' ');
  };
  auto code = [&](char c) -> std::uint8_t {
    if (c >= '0' && c <= '9') return static_cast<std::uint8_t>(c - '0');
    switch (c) {
      case '.':
        return 10;
      case '\n':
        return 12;
      case 'G':
        return 13;
      case 'X':
        return 14;
      default:
        return 11;  // ' ' or, without spaces, 'E'
    }
  };
  std::string out = "\xFF\xFF\xFB";
  if (no_spaces) out += "\xFF\xFF\xF7";
  bool packing = true;
  std::istringstream lines{std::string(text)};
  std::string line;
  while (std::getline(lines, line)) {
    if (!line.empty() && line[0] == ';') {
      if (!keep_comments) continue;
      if (packing) out += "\xFF\xFF\xFA", packing = false;
      out += line + "\n";
      continue;
    }
    line = line.substr(0, line.find(';'));
    while (!line.empty() && line.back() == ' ') line.pop_back();
    if (line.empty()) continue;
    if (line[0] == 'G') line.erase(std::remove(line.begin(), line.end(), ' '), line.end());
    line += '\n';
    if (!packing) out += "\xFF\xFF\xFB", packing = true;
    for (std::size_t i = 0; i < line.size(); i += 2) {
      const char a = line[i], b = i + 1 < line.size() ? line[i + 1] : '\n';
      const bool pa = packable(a), pb = packable(b);
      if (pa && pb) {
        out.push_back(static_cast<char>(code(a) | (code(b) << 4)));
      } else if (pa) {
        out.push_back(static_cast<char>(code(a) | 0xF0));
        out.push_back(b);
      } else if (pb) {
        out.push_back(static_cast<char>(0x0F | (code(b) << 4)));
        out.push_back(a);
      } else {
        out.push_back(static_cast<char>(0xFF));
        out.push_back(a);
        out.push_back(b);
      }
    }
  }
  return out;
}

struct TestBlock {
  std::uint16_t type = 1;
  std::uint16_t compression = 0;
  std::string params;  ///< encoded parameters
  std::string data;    ///< data before compression
  bool backrefs = true;
};

std::string encoding_param(std::uint16_t v) {
  std::string s;
  put16(s, v);
  return s;
}

std::string compress(const TestBlock& b) {
  switch (b.compression) {
    case 1: {
      uLongf n = compressBound(static_cast<uLong>(b.data.size()));
      std::string out(n, '\0');
      EXPECT_EQ(compress2(reinterpret_cast<Bytef*>(out.data()), &n,
                          reinterpret_cast<const Bytef*>(b.data.data()),
                          static_cast<uLong>(b.data.size()), 9),
                Z_OK);
      out.resize(n);
      return out;
    }
    case 2:
      return heatshrink_encode(b.data, 11, b.backrefs);
    case 3:
      return heatshrink_encode(b.data, 12, b.backrefs);
    default:
      return b.data;
  }
}

std::string encode_block(const TestBlock& b, bool crc) {
  std::string s;
  put16(s, b.type);
  put16(s, b.compression);
  put32(s, static_cast<std::uint32_t>(b.data.size()));
  const std::string stored = compress(b);
  if (b.compression != 0) put32(s, static_cast<std::uint32_t>(stored.size()));
  s += b.params + stored;
  if (crc)
    put32(s, static_cast<std::uint32_t>(::crc32(0, reinterpret_cast<const Bytef*>(s.data()),
                                                static_cast<uInt>(s.size()))));
  return s;
}

/// A G-code block with the sizes given (not those of the data), CRC32 correct.
std::string raw_block(std::uint16_t type, std::uint16_t compression, std::uint32_t uncompressed,
                      const std::string& stored) {
  std::string s;
  put16(s, type);
  put16(s, compression);
  put32(s, uncompressed);
  if (compression != 0) put32(s, static_cast<std::uint32_t>(stored.size()));
  s += encoding_param(0) + stored;
  put32(s, static_cast<std::uint32_t>(
               ::crc32(0, reinterpret_cast<const Bytef*>(s.data()), static_cast<uInt>(s.size()))));
  return s;
}

std::string encode_file(const std::vector<TestBlock>& blocks, bool crc = true,
                        std::uint32_t version = 1) {
  std::string s = "GCDE";
  put32(s, version);
  put16(s, crc ? 1 : 0);
  for (const auto& b : blocks) s += encode_block(b, crc);
  return s;
}

TestBlock metadata_block(std::uint16_t type, std::string ini, std::uint16_t compression = 0) {
  return {type, compression, encoding_param(0), std::move(ini)};
}
TestBlock thumbnail_block(std::uint16_t format, std::uint16_t w, std::uint16_t h,
                          std::string bytes) {
  std::string p;
  put16(p, format);
  put16(p, w);
  put16(p, h);
  return {5, 0, p, std::move(bytes)};
}
TestBlock gcode_block(std::string text, std::uint16_t compression, std::uint16_t encoding) {
  return {1, compression, encoding_param(encoding), std::move(text)};
}

/// The blocks PrusaSlicer writes, in order, around the given G-code blocks.
std::vector<TestBlock> file_with(std::vector<TestBlock> gcode) {
  std::vector<TestBlock> blocks = {
      metadata_block(0, "Producer=PrusaSlicer 2.8.1\nProduced on=2024-10-21 at 06:38:01 UTC\n"),
      metadata_block(3, "printer_model=MK4S\nnozzle_diameter=0.4\n"),
      thumbnail_block(0, 16, 12, std::string("\x89PNG\r\n\x1a\nfake", 12)),
      metadata_block(4, "estimated printing time (normal mode)=1m 2s\nfilament used [mm]=3.5\n", 1),
      metadata_block(2, "machine_max_acceleration_x=4000\nlayer_height = 0.2\n", 3),
  };
  for (auto& g : gcode) blocks.push_back(std::move(g));
  return blocks;
}

const std::string kHeader =
    "; generated by PrusaSlicer 2.8.1 on 2024-10-21 at 06:38:01 UTC\n"
    "; printer_model = MK4S\n; nozzle_diameter = 0.4\n"
    "; estimated printing time (normal mode) = 1m 2s\n; filament used [mm] = 3.5\n";
const std::string kTrailer =
    "; prusaslicer_config = begin\n; machine_max_acceleration_x = 4000\n; layer_height = 0.2\n"
    "; prusaslicer_config = end\n";

const std::string kGcode =
    ";LAYER_CHANGE\n;Z:0.2\nM104 S215 ; hotend\nG1 X10.5 Y20 Z.2 E.3 F1200\nG1 X110.25 Y-2.5 "
    "E12.75\n"
    ";TYPE:External perimeter\nG2 X20 Y20 I5 J5 E1.2\nG28 W\nM204 P4000 R1200 T4000\nG92 E0\n";
/// kGcode as MeatPack gives it back: no inline comments, spaces put back in G lines.
const std::string kGcodeMeatpacked =
    ";LAYER_CHANGE\n;Z:0.2\nM104 S215\nG1 X10.5 Y20 Z.2 E.3 F1200\nG1 X110.25 Y-2.5 E12.75\n"
    ";TYPE:External perimeter\nG2 X20 Y20 I5 J5 E1.2\nG28 W\nM204 P4000 R1200 T4000\nG92 E0\n";

/// Bytes as \xNN escapes (failure messages).
std::string printable_for_test(std::string_view bytes) {
  std::string s;
  for (unsigned char c : bytes) {
    static constexpr char kHex[] = "0123456789ABCDEF";
    s += "\\x";
    s += kHex[c >> 4];
    s += kHex[c & 15];
  }
  return s;
}

std::string decoded(const std::string& bytes) {
  auto text = decode_bgcode(bytes, "test.bgcode");
  EXPECT_TRUE(text.ok()) << (text.ok() ? "" : text.error().describe());
  return text.ok() ? *text : std::string();
}

// ---- decoding ----

TEST(Bgcode, EveryCompressionDecodesToTheText) {
  for (std::uint16_t compression : {0, 1, 2, 3}) {
    for (bool backrefs : {false, true}) {
      TestBlock g = gcode_block(kGcode, compression, 0);
      g.backrefs = backrefs;
      EXPECT_EQ(decoded(encode_file(file_with({g}))), kHeader + kGcode + kTrailer)
          << "compression " << compression;
    }
  }
}

TEST(Bgcode, HeatshrinkBackReferencesOverlapAndCrossTheWindow) {
  // Long runs (overlapping copies) and text repeated more than 2 KiB apart (the 11-bit
  // window cannot reach it, the 12-bit one can).
  std::string text = "G1 X1 Y1\n" + std::string(300, ';') + "\n";
  for (int i = 0; i < 200; ++i)
    text += "G1 X" + std::to_string(i % 17) + ".25 Y" + std::to_string(i * 7 % 31) + " E.5\n";
  for (std::uint16_t compression : {2, 3}) {
    const std::string bytes =
        encode_file({metadata_block(3, "a=b\n"), gcode_block(text, compression, 0)});
    EXPECT_EQ(decoded(bytes), "; a = b\n" + text);
    EXPECT_LT(bytes.size(), text.size() / 2);  // the back-references were used
  }
}

TEST(Bgcode, MeatPackDecodesWithAndWithoutComments) {
  for (bool no_spaces : {false, true}) {
    const std::string with = meatpack_encode(kGcode, true, no_spaces);
    EXPECT_EQ(decoded(encode_file(file_with({gcode_block(with, 3, 2)}))),
              kHeader + kGcodeMeatpacked + kTrailer);
    std::string without_comments;
    std::istringstream lines(kGcodeMeatpacked);
    for (std::string line; std::getline(lines, line);)
      if (line[0] != ';') without_comments += line + "\n";
    const std::string stripped = meatpack_encode(kGcode, false, no_spaces);
    EXPECT_EQ(decoded(encode_file(file_with({gcode_block(stripped, 1, 1)}))),
              kHeader + without_comments + kTrailer);
  }
}

TEST(Bgcode, DecoderCornerCases) {
  auto gcode_only = [](const std::string& data, std::uint16_t encoding,
                       std::uint16_t compression = 0) {
    return decoded(encode_file({gcode_block(data, compression, encoding)}));
  };
  // MeatPack: both characters whole bytes (first one first); a whole first byte with a
  // packed second; a '\n' in the low nibble ends the pair; a lone 0xFF in plain mode is a
  // byte; "no spaces" turns code 11 into 'E'; the G line gets its spaces back.
  EXPECT_EQ(gcode_only("\xFF\xFF\xFB"
                       "\xFFMY"
                       "\x1F"
                       "A"
                       "\x5C",
                       1),
            "MYA1\n");
  EXPECT_EQ(gcode_only("\xFF\xFF\xF7\xFF\xFF\xFB"
                       "\x1D"
                       "\x1B"
                       "\xCE",
                       1),
            "G1 E1 X\n");
  EXPECT_EQ(gcode_only(";a\xFF;\n\n\n;b\n", 2), ";a\xFF;\n;b\n");
  // Heatshrink: a back-reference reaching before the start reads the zeroed window, and
  // overlapping copies repeat the last bytes.
  BitWriter w;
  w.put(0, 1), w.put(2, 12), w.put(1, 4);  // offset 3, count 2: two zero bytes
  w.put(1, 1), w.put('A', 8);              // literal 'A'
  w.put(0, 1), w.put(0, 12), w.put(4, 4);  // offset 1, count 5: "AAAAA"
  const std::string stored = w.finish();
  std::string file = "GCDE";
  put32(file, 1);
  put16(file, 0);
  put16(file, 1), put16(file, 3), put32(file, 8),
      put32(file, static_cast<std::uint32_t>(stored.size()));
  file += encoding_param(0) + stored;
  EXPECT_EQ(decoded(file), std::string("\0\0AAAAAA", 8));
}

TEST(Bgcode, MeatPackFastPathsMatchTheStateMachine) {
  // The fast loop against the byte-at-a-time machine (its reference): encoded G-code in
  // every mode, and random bytes rich in 0xFF, commands and whole-byte codes, cut anywhere.
  std::vector<std::string> inputs;
  for (bool comments : {false, true})
    for (bool no_spaces : {false, true})
      inputs.push_back(meatpack_encode(kGcode + kGcode, comments, no_spaces));
  // The worst case, four characters per byte ("G X X X ..."): the buffer grows.
  inputs.push_back("\xFF\xFF\xFB\xED" + std::string(3000, '\xEE'));
  {
    detail::Bytes buf;
    std::size_t size = 0;
    std::string why;
    ASSERT_TRUE(detail::meatpack_decode(inputs.back(), buf, size, why));
    std::string expected = "G X";
    for (int k = 0; k < 6000; ++k) expected += " X";
    EXPECT_EQ(std::string_view(buf.data(), size), expected);
  }
  // Three 0xFF in a row: the third is a signal again, and the byte after it the command.
  inputs.push_back("\xFF\xFF\xFF\xFB\x1D\x2C");
  inputs.push_back("\xFF\xFF\xFB\x1D\xFF\xFF\xFF\x60");
  std::uint32_t seed = 20;
  auto next = [&seed] { return seed = seed * 1664525u + 1013904223u, seed >> 8; };
  for (int k = 0; k < 4000; ++k) {
    std::string s = k % 4 == 0 ? "" : "\xFF\xFF\xFB";  // packing on, mostly
    const auto len = next() % 48;
    for (std::uint32_t j = 0; j < len; ++j) {
      const auto r = next() % 16;
      s.push_back(static_cast<char>(r == 0   ? 0xFF
                                    : r == 1 ? 0xF6 + next() % 6
                                    : r == 2 ? 0xF0 | (next() & 15)
                                    : r == 3 ? (next() & 0xF0) | 0x0F
                                             : next() & 0xFF));
    }
    inputs.push_back(s);
  }
  std::size_t decoded_ok = 0;
  for (const std::string& in : inputs) {
    detail::Bytes fast_buf, slow_buf;
    std::size_t fast_size = 0, slow_size = 0;
    std::string fast_why, slow_why;
    const bool fast = detail::meatpack_decode(in, fast_buf, fast_size, fast_why, true);
    const bool slow = detail::meatpack_decode(in, slow_buf, slow_size, slow_why, false);
    ASSERT_EQ(fast, slow) << printable_for_test(in);
    ASSERT_EQ(fast_why, slow_why) << printable_for_test(in);
    if (!fast) continue;
    ++decoded_ok;
    ASSERT_EQ(std::string_view(fast_buf.data(), fast_size),
              std::string_view(slow_buf.data(), slow_size))
        << printable_for_test(in);
  }
  EXPECT_GT(decoded_ok, inputs.size() / 2);
}

TEST(Bgcode, MetadataAndThumbnailsAreExposed) {
  const std::string bytes = encode_file(file_with({gcode_block(kGcode, 0, 0)}));
  auto meta = read_bgcode_metadata(bytes, "test.bgcode");
  ASSERT_TRUE(meta.ok()) << meta.error().describe();
  EXPECT_EQ(meta->version, 1u);
  EXPECT_TRUE(meta->crc32);
  EXPECT_EQ(bgcode_find(meta->file, "Producer").value_or(""), "PrusaSlicer 2.8.1");
  EXPECT_EQ(bgcode_find(meta->printer, "printer_model").value_or(""), "MK4S");
  EXPECT_EQ(bgcode_find(meta->print, "filament used [mm]").value_or(""), "3.5");
  ASSERT_EQ(meta->slicer.size(), 2u);  // order kept, spaces around '=' trimmed
  EXPECT_EQ(meta->slicer[1], (std::pair<std::string, std::string>{"layer_height", "0.2"}));
  ASSERT_EQ(meta->thumbnails.size(), 1u);
  EXPECT_EQ(meta->thumbnails[0].format, BgcodeImageFormat::png);
  EXPECT_EQ(meta->thumbnails[0].width, 16);
  EXPECT_EQ(meta->thumbnails[0].height, 12);
  EXPECT_EQ(meta->thumbnails[0].bytes.substr(1, 3), "PNG");
  ASSERT_EQ(meta->blocks.size(), 5u);
  EXPECT_EQ(meta->blocks[4].type, BgcodeBlockType::slicer_metadata);
  EXPECT_EQ(meta->blocks[4].compression, BgcodeCompression::heatshrink_12_4);
  EXPECT_EQ(meta->first_gcode_block_offset,
            bytes.size() - encode_block(gcode_block(kGcode, 0, 0), true).size());

  // The same from a file; without checksums too.
  const auto dir = test::temp_dir("bgcode_meta");
  ASSERT_TRUE(write_file_atomic(dir / "x.bgcode",
                                encode_file(file_with({gcode_block(kGcode, 1, 0)}), false))
                  .ok());
  auto from_file = read_bgcode_metadata(dir / "x.bgcode");
  ASSERT_TRUE(from_file.ok()) << from_file.error().describe();
  EXPECT_FALSE(from_file->crc32);
  EXPECT_EQ(from_file->printer, meta->printer);
}

TEST(Bgcode, TheStreamSpansBlocksAndSeeks) {
  // Lines cut across blocks of every compression; seeking to the end and back re-decodes.
  const std::string text = kGcode + kGcode + kGcode;
  const std::vector<std::size_t> cuts = {0, 17, 100, 101, 250, text.size()};
  std::vector<TestBlock> gcode;
  for (std::size_t i = 0; i + 1 < cuts.size(); ++i)
    gcode.push_back(gcode_block(text.substr(cuts[i], cuts[i + 1] - cuts[i]),
                                static_cast<std::uint16_t>(i % 4), 0));
  const std::string bytes = encode_file(file_with(gcode));
  const std::string whole = kHeader + text + kTrailer;
  EXPECT_EQ(decoded(bytes), whole);

  auto stream = BgcodeGcodeStream::from_memory(bytes, "test.bgcode");
  ASSERT_TRUE(stream.ok()) << stream.error().describe();
  auto& in = **stream;
  in.seekg(0, std::ios::end);
  EXPECT_EQ(static_cast<std::size_t>(in.tellg()), whole.size());
  for (std::size_t at :
       {std::size_t{5}, whole.size() - 40, std::size_t{200}, kHeader.size() + 99}) {
    in.clear();
    in.seekg(static_cast<std::streamoff>(at));
    std::string got(30, '\0');
    in.read(got.data(), 30);
    got.resize(static_cast<std::size_t>(in.gcount()));
    EXPECT_EQ(got, whole.substr(at, 30)) << "at " << at;
  }
  EXPECT_FALSE(in.error().has_value());
  EXPECT_EQ(in.metadata().thumbnails.size(), 1u);
}

TEST(Bgcode, DetectedByMagicNotByName) {
  EXPECT_TRUE(looks_like_bgcode("GCDE\x01"));
  EXPECT_FALSE(looks_like_bgcode("G1 X1"));
  EXPECT_TRUE(is_bgcode_input("GCDE", "part.gcode"));
  EXPECT_TRUE(is_bgcode_input("G1 X", "part.BGCODE"));  // then read (and rejected) as binary
  EXPECT_FALSE(is_bgcode_input("G1 X", "part.gcode"));
}

// ---- the text twin: same moves and figures ----

/// Moves without their line numbers (the binary text has other comment lines).
std::vector<Move> without_lines(std::vector<Move> moves) {
  for (auto& m : moves) m.line = 0;
  return moves;
}

bool same_moves(const std::vector<Move>& a, const std::vector<Move>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const Move &x = a[i], &y = b[i];
    if (x.start_mm != y.start_mm || x.end_mm != y.end_mm || x.e_mm != y.e_mm ||
        x.feedrate_mm_s != y.feedrate_mm_s || x.layer != y.layer || x.feature != y.feature ||
        x.kind != y.kind || x.object_id != y.object_id || x.width_hint_mm != y.width_hint_mm ||
        x.height_hint_mm != y.height_hint_mm)
      return false;
  }
  return true;
}

void expect_same_print(const std::filesystem::path& text, const std::filesystem::path& binary,
                       bool limits_from_gcode) {
  SimulateOptions o;
  o.limits_from_gcode = limits_from_gcode;
  auto text_moves = interpret_gcode_file(text, ender3_marlin2(), o);
  auto binary_moves = interpret_gcode_file(binary, ender3_marlin2(), o);
  ASSERT_TRUE(text_moves.ok()) << text_moves.error().describe();
  ASSERT_TRUE(binary_moves.ok()) << binary_moves.error().describe();
  ASSERT_GT(text_moves->size(), 100u);
  EXPECT_TRUE(same_moves(without_lines(*text_moves), without_lines(*binary_moves)))
      << text_moves->size() << " vs " << binary_moves->size() << " moves";

  auto a = simulate_gcode_file(text, ender3_marlin2(), o);
  auto b = simulate_gcode_file(binary, ender3_marlin2(), o);
  ASSERT_TRUE(a.ok()) << a.error().describe();
  ASSERT_TRUE(b.ok()) << b.error().describe();
  EXPECT_EQ(a->moves, b->moves);
  EXPECT_EQ(a->segments, b->segments);
  EXPECT_DOUBLE_EQ(a->print_time_s, b->print_time_s);
  EXPECT_DOUBLE_EQ(a->motion_time_s, b->motion_time_s);
  EXPECT_DOUBLE_EQ(a->filament_mm, b->filament_mm);
  EXPECT_EQ(a->layers.size(), b->layers.size());
  EXPECT_EQ(a->slicer, b->slicer);
  EXPECT_EQ(a->slicer_estimate_s.has_value(), b->slicer_estimate_s.has_value());
  if (a->slicer_estimate_s && b->slicer_estimate_s) {
    EXPECT_DOUBLE_EQ(*a->slicer_estimate_s, *b->slicer_estimate_s);
  }
}

/// A PrusaSlicer text file encoded as PrusaSlicer does (heatshrink 12/4, MeatPack with
/// comments, 64 KiB blocks), its config block moved into the slicer metadata. No file
/// metadata: the text's own "; generated by" line names the slicer.
std::string encode_like_prusaslicer(const std::string& text) {
  const auto config = text.find("; prusaslicer_config = begin");
  EXPECT_NE(config, std::string::npos);
  std::string ini;
  std::istringstream cfg(text.substr(config));
  for (std::string line; std::getline(cfg, line);)
    if (line.rfind("; ", 0) == 0 && line.find(" = ") != std::string::npos &&
        line.find("prusaslicer_config") == std::string::npos)
      ini += line.substr(2) + "\n";
  std::vector<TestBlock> blocks = {metadata_block(3, "printer_model=\n"),
                                   metadata_block(2, ini, 1)};
  const std::string body = text.substr(0, config);
  for (std::size_t at = 0; at < body.size();) {
    std::size_t end = std::min(body.size(), at + 65535);
    if (end < body.size()) end = body.rfind('\n', end) + 1;
    blocks.push_back(gcode_block(meatpack_encode(body.substr(at, end - at), true, false), 3, 2));
    at = end;
  }
  return encode_file(blocks);
}

TEST(Bgcode, SelfEncodedPrusaSlicerFileGivesTheMovesOfItsText) {
  const auto path = test::source_path("samples/gcode/prusa_cube10.gcode");
  auto text = read_file(path);
  ASSERT_TRUE(text.ok());
  const auto dir = test::temp_dir("bgcode_twin");
  ASSERT_TRUE(write_file_atomic(dir / "cube.bin", encode_like_prusaslicer(*text))
                  .ok());  // detected by its magic
  expect_same_print(path, dir / "cube.bin", true);
}

TEST(Bgcode, VerifyReadsBinaryGcode) {
  // verify() (and compare, through the same print_gcode) of the 10 mm cube against the
  // binary form of PrusaSlicer's G-code: the same report as from the text; a corrupt
  // binary is an error naming the block.
  const auto dir = test::temp_dir("bgcode_verify");
  const auto text_path = test::source_path("samples/gcode/prusa_cube10.gcode");
  auto text = read_file(text_path);
  ASSERT_TRUE(text.ok());
  const std::string binary = encode_like_prusaslicer(*text);
  ASSERT_TRUE(write_file_atomic(dir / "cube10.bgcode", binary).ok());
  test::expect_same_cube10_verify(text_path, dir / "cube10.bgcode", dir);
  VerifyOptions options;
  options.mesh_path = dir / "cube10.stl";
  options.settings.voxel_mm = 0.2;

  std::string corrupt = binary;
  corrupt[corrupt.size() - 100] = static_cast<char>(corrupt[corrupt.size() - 100] ^ 4);
  ASSERT_TRUE(write_file_atomic(dir / "corrupt.bgcode", corrupt).ok());
  options.gcode_path = dir / "corrupt.bgcode";
  auto c = verify(options);
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.error().describe().find("CRC32 mismatch"), std::string::npos) << c.error().describe();
  EXPECT_NE(c.error().describe().find("corrupt.bgcode"), std::string::npos) << c.error().describe();
}

TEST(Bgcode, RealPrusaSlicerBinaryGivesTheMovesOfItsTextTwin) {
  const auto dir = test::realworld_dir();
  if (!dir) GTEST_SKIP() << "no shared real-world folder";
  const auto text = *dir / "gcode/prusaslicer-2.8.1_MK4S_mini_cube_arcs.gcode";
  const auto binary = *dir / "gcode/prusaslicer-2.8.1_MK4S_mini_cube_arcs_BINARY.bgcode";
  if (!std::filesystem::exists(text) || !std::filesystem::exists(binary))
    GTEST_SKIP() << "pair not in " << *dir;
  expect_same_print(text, binary, false);
  expect_same_print(text, binary, true);  // the machine limits come from the slicer metadata

  auto meta = read_bgcode_metadata(binary);
  ASSERT_TRUE(meta.ok()) << meta.error().describe();
  EXPECT_EQ(bgcode_find(meta->printer, "printer_model").value_or(""), "MK4S");
  EXPECT_EQ(bgcode_find(meta->print, "estimated printing time (normal mode)").value_or(""),
            "3m 41s");
  EXPECT_EQ(bgcode_find(meta->print, "filament used [mm]").value_or(""), "252.22");
  EXPECT_TRUE(bgcode_find(meta->slicer, "machine_max_acceleration_x").has_value());
  ASSERT_EQ(meta->thumbnails.size(), 2u);
  EXPECT_EQ(meta->thumbnails[1].format, BgcodeImageFormat::qoi);
  EXPECT_EQ(meta->thumbnails[1].width, 313);
  EXPECT_EQ(meta->thumbnails[1].height, 173);
  EXPECT_EQ(meta->thumbnails[1].bytes.substr(0, 4), "qoif");
}

TEST(Bgcode, EveryRealBinaryFileMeetsTheRealFileBar) {
  // Every .bgcode of the shared real-world folder, twin or not, held to what a real text
  // file must show (issue 20): slicer, printer and firmware found from its metadata; the
  // slicer's layers; filament within 0.5 % and, on the limits the file states, motion time
  // within 2 % of the slicer's figures; no error finding. Skipped without the folder.
  const auto dir = test::realworld_dir();
  if (!dir) GTEST_SKIP() << "no shared real-world folder";
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(*dir / "gcode")) {
    if (!is_bgcode_file(entry.path()) || entry.path().extension() == ".gcode") continue;
    ++files;
    const std::string name = entry.path().filename().string();
    auto printer = resolve_printer("auto", entry.path());
    ASSERT_TRUE(printer.ok()) << name << ": " << printer.error().describe();
    EXPECT_FALSE(printer->settings.slicer.empty()) << name;
    EXPECT_FALSE(printer->profile.origin.library_id.empty())
        << name << ": " << printer_provenance_summary(printer->profile);
    EXPECT_FALSE(printer->profile.firmware.empty()) << name;
    SimulateOptions o;
    o.limits_from_gcode = true;
    apply_printer_to_options(*printer, o.interpreter);
    auto r = simulate_gcode_file(entry.path(), printer->profile, o);
    ASSERT_TRUE(r.ok()) << name << ": " << r.error().describe();
    for (const auto& f : r->findings)
      EXPECT_NE(f.severity, Severity::error) << name << ": " << f.code << " " << f.message;
    // The slicer's layers: its layer-change markers in the decoded text.
    auto bytes = read_file(entry.path());
    ASSERT_TRUE(bytes.ok());
    auto text = decode_bgcode(*bytes, name);
    ASSERT_TRUE(text.ok()) << text.error().describe();
    long markers = 0;
    for (std::size_t at = 0; (at = text->find("\n;LAYER_CHANGE\n", at)) != std::string::npos; ++at)
      ++markers;
    EXPECT_EQ(r->layers_from, "markers") << name;
    EXPECT_EQ(static_cast<long>(r->layers.size()), markers) << name;
    ASSERT_TRUE(r->slicer_filament_mm.has_value()) << name;
    const double s = *r->slicer_filament_mm;
    EXPECT_LT(std::min(std::fabs(r->filament_part_mm - s), std::fabs(r->filament_mm - s)) / s,
              0.005)
        << name << ": part " << r->filament_part_mm << ", total " << r->filament_mm << ", slicer "
        << s;
    ASSERT_TRUE(r->slicer_estimate_s.has_value()) << name;
    EXPECT_NEAR(r->motion_time_s, *r->slicer_estimate_s, 0.02 * *r->slicer_estimate_s) << name;
    std::printf(
        "%s: %s, %s, firmware %s, %zu layers, filament %.2f mm (slicer %.2f), motion "
        "%.1f s (slicer %.1f s)\n",
        name.c_str(), printer->settings.slicer.c_str(), printer->profile.origin.library_id.c_str(),
        printer->profile.firmware.c_str(), r->layers.size(), r->filament_part_mm, s,
        r->motion_time_s, *r->slicer_estimate_s);
  }
  if (files == 0) GTEST_SKIP() << "no .bgcode in " << dir->string();
}

// ---- bad input: a clear error naming the block, exit 3 ----

struct BadCase {
  std::string name;
  std::string bytes;
  std::vector<std::string> words;  ///< each must appear in the message
};

std::string q(const std::filesystem::path& p) { return "'" + p.string() + "'"; }

void expect_rejected(const BadCase& c) {
  SCOPED_TRACE(c.name);
  auto text = decode_bgcode(c.bytes, "bad.bgcode");
  ASSERT_FALSE(text.ok()) << "decoded " << text->size() << " bytes";
  const std::string msg = text.error().describe();
  for (const auto& w : c.words)
    EXPECT_NE(msg.find(w), std::string::npos) << msg << "\n  lacks: " << w;
  EXPECT_EQ(text.error().code, ErrorCode::bad_input);
}

std::vector<BadCase> bad_cases() {
  std::vector<BadCase> cases;
  const std::vector<TestBlock> blocks =
      file_with({gcode_block(kGcode, 3, 0), gcode_block(kGcode, 1, 0)});
  const std::string good = encode_file(blocks);
  // Truncated inside each block: header, parameters, data and checksum of each type.
  std::size_t at = 10;
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    const std::size_t size = encode_block(blocks[i], true).size();
    const std::string type(bgcode_block_type_name(static_cast<BgcodeBlockType>(blocks[i].type)));
    const std::string where = "block " + std::to_string(i + 1);
    for (std::size_t cut : {std::size_t{5}, size / 2, size - 1}) {
      std::vector<std::string> words = {"bad.bgcode", where, "at byte " + std::to_string(at),
                                        "truncated"};
      if (cut > 8) words.push_back(type);
      cases.push_back(
          {"truncated " + type + " at +" + std::to_string(cut), good.substr(0, at + cut), words});
    }
    // A flipped byte in the data: the CRC catches it.
    std::string flipped = good;
    flipped[at + size - 6] = static_cast<char>(flipped[at + size - 6] ^ 0x10);
    cases.push_back({"flipped byte in " + type,
                     flipped,
                     {where, type, "at byte " + std::to_string(at), "CRC32 mismatch"}});
    at += size;
  }
  std::string flipped_crc = good;
  flipped_crc[good.size() - 1] = static_cast<char>(flipped_crc[good.size() - 1] ^ 1);
  cases.push_back(
      {"flipped CRC byte", flipped_crc, {"block 7 (G-code, deflate)", "CRC32 mismatch"}});

  auto with = [&](std::size_t index, auto change) {
    std::vector<TestBlock> b = blocks;
    change(b[index]);
    return encode_file(b);
  };
  cases.push_back({"unknown compression",
                   with(5, [](TestBlock& b) { b.compression = 7; }),
                   {"block 6 (G-code)", "unknown compression 7"}});
  cases.push_back({"unknown block type",
                   with(1, [](TestBlock& b) { b.type = 9; }),
                   {"block 2 at byte 90", "unknown block type 9"}});
  cases.push_back({"unknown G-code encoding",
                   with(6, [](TestBlock& b) { b.params = encoding_param(4); }),
                   {"block 7", "unknown G-code encoding 4"}});
  cases.push_back({"unknown metadata encoding",
                   with(1, [](TestBlock& b) { b.params = encoding_param(1); }),
                   {"block 2 (printer metadata)", "unknown metadata encoding 1"}});
  cases.push_back({"unknown image format",
                   with(2, [](TestBlock& b) { b.params[0] = 5; }),
                   {"block 3 (thumbnail)", "unknown thumbnail image format 5"}});
  cases.push_back({"metadata line without =",
                   with(1, [](TestBlock& b) { b.data += "no equals sign\n"; }),
                   {"block 2 (printer metadata)", "line 3 has no '='"}});
  cases.push_back(
      {"wrong uncompressed size",
       encode_file(file_with({})) + raw_block(1, 3, 11, heatshrink_encode("G1 X1\n", 12, false)),
       {"block 6 (G-code, heatshrink 12/4)", "decodes to 6 bytes, the block header states 11"}});
  cases.push_back(
      {"deflate longer than stated",
       encode_file(file_with({})) + raw_block(1, 1, 3, compress(gcode_block("G1 X1\n", 1, 0))),
       {"block 6 (G-code, deflate)", "more than the 3 bytes"}});
  cases.push_back({"deflate garbage",
                   encode_file(file_with({})) + raw_block(1, 1, 6, "garbage"),
                   {"block 6 (G-code, deflate)", "corrupt"}});
  cases.push_back({"bad MeatPack command",
                   encode_file(file_with({gcode_block("\xFF\xFF\xFB\xFF\xFF\x01", 0, 1)})),
                   {"block 6", "unknown MeatPack command 0x01"}});
  cases.push_back(
      {"bad magic", "GCDX" + good.substr(4), {"not a binary G-code file", "GCDX", "GCDE"}});
  cases.push_back({"version 2",
                   [&] {
                     std::string s = good;
                     s[4] = 2;
                     return s;
                   }(),
                   {"version 2", "version 1"}});
  cases.push_back({"checksum type 3",
                   [&] {
                     std::string s = good;
                     s[8] = 3;
                     return s;
                   }(),
                   {"unknown checksum type 3"}});
  cases.push_back(
      {"no G-code block", encode_file(file_with({})), {"no G-code block", "after block 5"}});
  cases.push_back({"empty file", std::string(), {"not a binary G-code file"}});
  cases.push_back({"huge stated size",
                   encode_file(file_with({})) + raw_block(1, 1, 0xFFFFFFF0u, "abcd"),
                   {"block 6", "more than the"}});
  return cases;
}

TEST(Bgcode, BadInputNamesTheBlock) {
  const auto cases = bad_cases();
  EXPECT_GT(cases.size(), 30u);
  for (const auto& c : cases) expect_rejected(c);
}

TEST(Bgcode, ZlibTwinOfLibdeflateReadsAndRejectsTheSame) {
  // zlib (PRINTTWIN_PLAIN=bgcode_libdeflate) inflates and checks CRCs as libdeflate does:
  // the same text from every compression, the same words for every bad file.
  const std::string good = encode_file(file_with({gcode_block(kGcode, 1, 0)}));
  ASSERT_EQ(::setenv("PRINTTWIN_PLAIN", "bgcode_libdeflate", 1), 0);
  EXPECT_EQ(decoded(good), kHeader + kGcode + kTrailer);
  for (const auto& c : bad_cases()) expect_rejected(c);
  ::unsetenv("PRINTTWIN_PLAIN");
}

TEST(Bgcode, SimulateExitsThreeOnBadInput) {
  // Through the CLI: exit 3, the block named, no crash; a decode error in the middle of the
  // G-code is not a short print. One case of each kind (the CLI is slow to start).
  const auto dir = test::temp_dir("bgcode_cli");
  const std::vector<TestBlock> blocks =
      file_with({gcode_block(kGcode, 3, 0), gcode_block(kGcode, 1, 0)});
  const std::string good = encode_file(blocks);
  struct CliCase {
    std::string name, bytes, words;
  };
  std::string flipped = good;
  flipped[good.size() - 10] = static_cast<char>(flipped[good.size() - 10] ^ 0x40);
  std::string unknown = good;
  unknown[10 + 2] = 5;  // compression of block 1
  const std::vector<CliCase> cases = {
      {"flipped.bgcode", flipped, "block 7 (G-code, deflate) at byte"},
      {"truncated.bgcode", good.substr(0, good.size() - 30), "truncated"},
      {"unknown.gcode", unknown, "block 1 (file metadata) at byte 10: unknown compression 5"},
      {"magic.bgcode", "GCDF" + good.substr(4), "not a binary G-code file"},
  };
  for (const auto& c : cases) {
    ASSERT_TRUE(write_file_atomic(dir / c.name, c.bytes).ok());
    const auto run = test::run_cli("simulate " + q(dir / c.name));
    EXPECT_EQ(run.exit_code, 3) << c.name << ": " << run.err;
    EXPECT_NE(run.err.find(c.words), std::string::npos) << c.name << ": " << run.err;
  }
  ASSERT_TRUE(write_file_atomic(dir / "good.bgcode", good).ok());
  const auto run = test::run_cli("simulate " + q(dir / "good.bgcode"));
  EXPECT_NE(run.exit_code, 3) << run.err;
  EXPECT_EQ(run.err.find("error"), std::string::npos) << run.err;
}

}  // namespace
}  // namespace printtwin
