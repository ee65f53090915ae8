// TextTokenizer: tokens, lines and binary blocks across buffer refills, positions in messages, number parsing.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <limits>

#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/io/text_tokenizer.h"

namespace ugvr {
namespace {

std::string write_file(const test::ScratchDir& dir, const std::string& name, const std::string& bytes) {
  const std::string path = dir.file(name);
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

using test::error_of;

TEST(TextTokenizer, TokensLinesAndPeek) {
  test::ScratchDir dir;
  const InputFile file(write_file(dir, "t.txt", "  alpha\tbeta\r\n\n gamma 42\n-7 +3.5e2 nan"));
  TextTokenizer t(file);
  EXPECT_EQ(t.next_token(), "alpha");
  EXPECT_EQ(t.token_line(), 1u);
  EXPECT_EQ(t.token_offset(), 2u);
  EXPECT_EQ(t.peek_token(), "beta");
  EXPECT_EQ(t.next_token(), "beta");
  EXPECT_EQ(t.next_token(), "gamma");
  EXPECT_EQ(t.token_line(), 3u);
  EXPECT_EQ(t.next_number<uint32_t>("a count"), 42u);
  EXPECT_EQ(t.next_number<int64_t>("a value"), -7);
  EXPECT_DOUBLE_EQ(t.next_number<double>("a value"), 350.0);
  EXPECT_TRUE(std::isnan(t.next_number<float>("a value")));
  EXPECT_EQ(t.token_line(), 4u);
  EXPECT_EQ(t.next_token(), "");
  EXPECT_TRUE(t.at_end());
}

TEST(TextTokenizer, LinesAndBinaryBlocks) {
  test::ScratchDir dir;
  std::string bytes = "HEAD 3   \r\n";
  bytes += std::string("\x01\n\x02", 3);  // binary, with a newline byte inside
  bytes += "\nnext line\r\nlast";
  const InputFile file(write_file(dir, "b.bin", bytes));
  TextTokenizer t(file);
  EXPECT_EQ(t.next_token(), "HEAD");
  EXPECT_EQ(t.next_token(), "3");
  EXPECT_TRUE(t.at_line_end());
  t.skip_line();
  EXPECT_EQ(t.line(), 2u);
  char raw[3];
  t.read_bytes(raw, 3);
  EXPECT_EQ(raw[1], '\n');
  EXPECT_EQ(t.line(), 2u) << "binary bytes do not count as lines";
  t.skip_line();  // the newline after the block
  EXPECT_EQ(t.read_line(), std::optional<std::string_view>("next line"));
  EXPECT_EQ(t.read_line(), std::optional<std::string_view>("last"));
  EXPECT_EQ(t.read_line(), std::nullopt);
  EXPECT_NE(error_of([&] { t.read_bytes(raw, 1); }).find("byte " + std::to_string(bytes.size())), std::string::npos);
}

TEST(TextTokenizer, TokensAcrossRefillsAndMarks) {
  // Far more than one buffer, so tokens straddle refills; every token is checked with its line.
  test::ScratchDir dir;
  std::string text;
  const int kLines = 40000;
  for (int i = 0; i < kLines; ++i) text += "v" + std::to_string(i) + " " + std::to_string(i * 3) + "\n";
  const InputFile file(write_file(dir, "many.txt", text));
  TextTokenizer t(file, TextTokenizer::Mark{0, 1}, 1);  // the smallest buffer allowed
  TextTokenizer::Mark middle;
  for (int i = 0; i < kLines; ++i) {
    if (i == kLines / 2) middle = t.mark();
    ASSERT_EQ(t.next_token(), "v" + std::to_string(i));
    ASSERT_EQ(t.next_number<int64_t>("value"), int64_t(i) * 3);
    ASSERT_EQ(t.token_line(), uint64_t(i) + 1);
  }
  EXPECT_EQ(t.next_token(), "");
  // A second tokenizer resumes at a remembered position, with its line number.
  TextTokenizer again(file, middle);
  EXPECT_EQ(again.next_token(), "v" + std::to_string(kLines / 2));
  EXPECT_EQ(again.token_line(), uint64_t(kLines / 2) + 1);
}

TEST(TextTokenizer, LargeBinaryReadsBypassTheBuffer) {
  test::ScratchDir dir;
  std::string bytes = "X\n";
  for (int i = 0; i < 3'000'000; ++i) bytes += char(i * 7);
  bytes += "\nEND";
  const InputFile file(write_file(dir, "big.bin", bytes));
  TextTokenizer t(file);
  EXPECT_EQ(t.next_token(), "X");
  t.skip_line();
  std::vector<char> block(3'000'000);
  t.read_bytes(block.data(), block.size());
  EXPECT_EQ(block[2'999'999], char(2'999'999 * 7));
  EXPECT_EQ(t.next_token(), "END");
  TextTokenizer skipper(file);
  skipper.skip_line();
  skipper.skip_bytes(3'000'000);
  EXPECT_EQ(skipper.next_token(), "END");
  EXPECT_NE(error_of([&] { skipper.skip_bytes(10); }).find("unexpected end of file"), std::string::npos);
}

TEST(TextTokenizer, ErrorsNameFileAndLine) {
  test::ScratchDir dir;
  const std::string path = write_file(dir, "bad.txt", "1 2\n3 x4\n" + std::string(70000, 'a'));
  const InputFile file(path);
  TextTokenizer t(file);
  t.next_number<int>("v");
  t.next_number<int>("v");
  t.next_number<int>("v");
  const std::string message = error_of([&] { t.next_number<int>("the fourth value"); });
  EXPECT_NE(message.find("bad.txt:2:"), std::string::npos) << message;
  EXPECT_NE(message.find("the fourth value"), std::string::npos) << message;
  EXPECT_NE(message.find("'x4'"), std::string::npos) << message;
  const std::string long_token = error_of([&] { t.next_token(); });
  EXPECT_NE(long_token.find("bad.txt:3: a token longer than"), std::string::npos) << long_token;
}

TEST(ParseNumber, RangesAndSpecialValues) {
  int8_t i8 = 0;
  EXPECT_TRUE(parse_number("-128", i8));
  EXPECT_EQ(i8, -128);
  EXPECT_FALSE(parse_number("128", i8));
  uint32_t u = 0;
  EXPECT_FALSE(parse_number("-1", u));
  EXPECT_TRUE(parse_number("+17", u));
  EXPECT_EQ(u, 17u);
  EXPECT_FALSE(parse_number("1.5", u));
  EXPECT_FALSE(parse_number("", u));
  EXPECT_FALSE(parse_number("+", u));
  float f = 0;
  EXPECT_TRUE(parse_number("1e60", f));
  EXPECT_TRUE(std::isinf(f)) << "overflow saturates as strtof does";
  EXPECT_TRUE(parse_number("1e-60", f));
  EXPECT_EQ(f, 0.0f);
  EXPECT_TRUE(parse_number("-inf", f));
  EXPECT_EQ(f, -std::numeric_limits<float>::infinity());
  double d = 0;
  EXPECT_TRUE(parse_number("2.5E+3", d));
  EXPECT_EQ(d, 2500.0);
  EXPECT_FALSE(parse_number("2.5e", d));
  EXPECT_FALSE(parse_number("0x10", d));
  EXPECT_TRUE(equals_ignore_case("Point_Data", "POINT_DATA"));
  EXPECT_FALSE(equals_ignore_case("POINT_DAT", "POINT_DATA"));
}

}  // namespace
}  // namespace ugvr
