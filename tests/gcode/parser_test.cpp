// Parser and line reader: syntax, numbers, comments, checksums and every kind of bad line.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <sstream>
#include <string>

#include "printtwin/gcode.hpp"

namespace printtwin {
namespace {

GcodeCommand parse_ok(std::string_view text) {
  GcodeCommand c;
  auto st = parse_gcode_line(text, 7, c);
  EXPECT_TRUE(st.ok()) << text << ": " << (st.ok() ? "" : st.error().describe());
  return c;
}

std::string parse_fail(std::string_view text) {
  GcodeCommand c;
  auto st = parse_gcode_line(text, 42, c);
  EXPECT_FALSE(st.ok()) << text;
  if (st.ok()) return {};
  EXPECT_EQ(st.error().line, 42);
  return st.error().message;
}

TEST(GcodeParser, CommandAndParameters) {
  const auto c = parse_ok("G1 X10.5 Y-3 Z.2 E0.0123 F1800 ; move");
  EXPECT_TRUE(c.is('G', 1));
  EXPECT_DOUBLE_EQ(c.get('X'), 10.5);
  EXPECT_DOUBLE_EQ(c.get('Y'), -3.0);
  EXPECT_DOUBLE_EQ(c.get('Z'), 0.2);
  EXPECT_DOUBLE_EQ(c.get('E'), 0.0123);
  EXPECT_DOUBLE_EQ(c.get('F'), 1800.0);
  EXPECT_FALSE(c.has('I'));
  EXPECT_EQ(c.comment, "move");
  EXPECT_EQ(c.line, 7);
}

TEST(GcodeParser, LowerCaseSpacesSubcodeAndBareLetters) {
  const auto a = parse_ok("g1 x 5 y+2.5e1");
  EXPECT_TRUE(a.is('G', 1));
  EXPECT_DOUBLE_EQ(a.get('X'), 5.0);
  EXPECT_DOUBLE_EQ(a.get('Y'), 25.0);
  const auto b = parse_ok("G29.1");
  EXPECT_EQ(b.code, 29);
  EXPECT_EQ(b.subcode, 1);
  const auto h = parse_ok("G28 X Y");
  EXPECT_TRUE(h.has('X'));
  EXPECT_TRUE(h.has('Y'));
  EXPECT_FALSE(h.has('Z'));
}

TEST(GcodeParser, CommentsOnlyAndInlineParentheses) {
  const auto c = parse_ok(";TYPE:External perimeter");
  EXPECT_EQ(c.letter, 0);
  EXPECT_EQ(c.comment, "TYPE:External perimeter");
  const auto d = parse_ok("G1 (inline) X3");
  EXPECT_DOUBLE_EQ(d.get('X'), 3.0);
  const auto e = parse_ok("   ");
  EXPECT_EQ(e.letter, 0);
}

TEST(GcodeParser, LineNumbersAndChecksums) {
  // Checksum: XOR of every byte before '*'.
  std::string body = "N12 G1 X1";
  unsigned char cs = 0;
  for (char ch : body) cs ^= static_cast<unsigned char>(ch);
  const auto c = parse_ok(body + "*" + std::to_string(cs));
  EXPECT_TRUE(c.is('G', 1));
  EXPECT_DOUBLE_EQ(c.get('X'), 1.0);
  const auto msg = parse_fail(body + "*" + std::to_string((cs + 1) % 256));
  EXPECT_NE(msg.find("checksum mismatch"), std::string::npos);
}

TEST(GcodeParser, ExtendedAndTextCommands) {
  const auto c = parse_ok("EXCLUDE_OBJECT_START NAME=part_1");
  EXPECT_EQ(c.word, "EXCLUDE_OBJECT_START");
  EXPECT_EQ(c.args, "NAME=part_1");
  const auto m = parse_ok("M117 Printing X=1 [ok]");
  EXPECT_TRUE(m.is('M', 117));
  EXPECT_EQ(m.args, "Printing X=1 [ok]");
}

TEST(GcodeParser, RejectsPlaceholdersNonFiniteAndGarbage) {
  EXPECT_NE(parse_fail("G1 Z[next_layer_z] F600").find("placeholder"), std::string::npos);
  EXPECT_NE(parse_fail("G1 X0 Y{machine_depth}").find("placeholder"), std::string::npos);
  EXPECT_NE(parse_fail("G1 Xnan").find("not a number"), std::string::npos);
  EXPECT_NE(parse_fail("G1 Xinf").find("not a number"), std::string::npos);
  EXPECT_NE(parse_fail("G1 X20 Yabc E1").find("expected a number after Y, found 'a'"),
            std::string::npos);
  EXPECT_NE(parse_fail("G0 XY").find("expected a number after X"), std::string::npos);
  EXPECT_NE(parse_fail("G1 X1e308").find("out of range"), std::string::npos);
  EXPECT_NE(parse_fail("G1 X1e400").find("out of range"), std::string::npos);
  EXPECT_NE(parse_fail("G1 X-").find("malformed number"), std::string::npos);
  EXPECT_NE(parse_fail(std::string("G1 X1\x01\xff", 7)).find("is not G-code"), std::string::npos);
  EXPECT_NE(parse_fail("Q5").find("expected a command"), std::string::npos);
  EXPECT_NE(parse_fail("G X1").find("without a number"), std::string::npos);
  // The message quotes the line so that a user can find it.
  EXPECT_NE(parse_fail("G1 Z[next_layer_z] F600").find("G1 Z[next_layer_z] F600"),
            std::string::npos);
}

TEST(GcodeParser, RandomBytesNeverCrashAndAlwaysAnswer) {
  std::mt19937 rng(12345);  // seed printed by gtest on failure through the message below
  GcodeCommand c;
  int errors = 0;
  for (int i = 0; i < 20000; ++i) {
    std::string s(rng() % 40, '\0');
    for (auto& ch : s) ch = static_cast<char>("G1XYZEF-.0123456789 ;*N[{M\x80"[rng() % 28]);
    auto st = parse_gcode_line(s, i + 1, c);
    if (!st.ok()) {
      ++errors;
      ASSERT_EQ(st.error().line, i + 1) << "seed 12345, input: " << s;
      ASSERT_FALSE(st.error().message.empty());
    } else {
      for (int k = 0; k < 26; ++k) {
        if (c.has(static_cast<char>('A' + k))) {
          ASSERT_TRUE(std::isfinite(c.value[static_cast<std::size_t>(k)]));
        }
      }
    }
  }
  EXPECT_GT(errors, 1000);  // the generator makes many bad lines
}

TEST(GcodeLineReader, CrLfLastLineAndOverlongLine) {
  std::string text = "G1 X1\r\nG1 X2\n";
  text += "; " + std::string(1 << 20, 'A') + "\n";  // a 1 MB line
  text += "G1 X3";                                  // no final newline
  std::istringstream in(text);
  GcodeLineReader reader(in);
  std::string_view line;
  ASSERT_TRUE(reader.next(line));
  EXPECT_EQ(line, "G1 X1");
  ASSERT_TRUE(reader.next(line));
  EXPECT_EQ(line, "G1 X2");
  ASSERT_TRUE(reader.next(line));
  EXPECT_TRUE(reader.truncated());
  EXPECT_EQ(line.size(), kMaxGcodeLineLength);
  EXPECT_EQ(reader.line_number(), 3);
  ASSERT_TRUE(reader.next(line));
  EXPECT_FALSE(reader.truncated());
  EXPECT_EQ(line, "G1 X3");
  EXPECT_EQ(reader.line_number(), 4);
  EXPECT_TRUE(reader.ended_mid_line());
  EXPECT_FALSE(reader.next(line));
}

TEST(GcodeLineReader, ByteOrderMarkBeforeTheFirstLineIsDropped) {
  // Saved by a Windows editor: a UTF-8 byte order mark, CRLF endings. Only the first line's
  // mark is dropped; the same bytes later are the line's own (and not G-code).
  std::istringstream in("\xEF\xBB\xBF; generated by PrusaSlicer\r\nG1 X1\r\n\xEF\xBB\xBFG1 X2\n");
  GcodeLineReader reader(in);
  std::string_view line;
  ASSERT_TRUE(reader.next(line));
  EXPECT_EQ(line, "; generated by PrusaSlicer");
  GcodeCommand cmd;
  EXPECT_TRUE(parse_gcode_line(line, 1, cmd).ok());
  ASSERT_TRUE(reader.next(line));
  EXPECT_EQ(line, "G1 X1");
  ASSERT_TRUE(reader.next(line));
  EXPECT_EQ(line, "\xEF\xBB\xBFG1 X2");
  EXPECT_FALSE(parse_gcode_line(line, 3, cmd).ok());
  EXPECT_FALSE(reader.next(line));
}

TEST(GcodeLineReader, ManyLinesAcrossBufferBoundaries) {
  std::string text;
  for (int i = 0; i < 100000; ++i) text += "G1 X" + std::to_string(i) + " Y1\n";
  std::istringstream in(text);
  GcodeLineReader reader(in);
  std::string_view line;
  long n = 0;
  GcodeCommand c;
  double sum = 0;
  while (reader.next(line)) {
    ASSERT_TRUE(parse_gcode_line(line, reader.line_number(), c).ok()) << line;
    sum += c.get('X');
    ++n;
  }
  EXPECT_EQ(n, 100000);
  EXPECT_DOUBLE_EQ(sum, 99999.0 * 100000.0 / 2.0);
  EXPECT_FALSE(reader.ended_mid_line());
}

}  // namespace
}  // namespace printtwin
