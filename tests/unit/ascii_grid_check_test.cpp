// The ESRI ASCII grid text check (dem/ascii_grid_check.h): what GDAL would read as 0 is refused
// with the cell's row and column, in one piece or fed in chunks split anywhere.
#include "dem/ascii_grid_check.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace loam {
namespace {

const char* const kHeader =
    "ncols 4\nnrows 3\nxllcorner 100\nyllcorner 200\ncellsize 30\nNODATA_value -9999\n";

Status check_text(const std::string& text) {
  return check_ascii_grid(
      std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(text.data()), text.size()), "grid.asc");
}

std::string message(const Status& st) { return st.ok() ? std::string("ok") : st.error().describe(); }

TEST(AsciiGridCheck, NumbersInEveryWrittenFormPass) {
  const std::string text = std::string(kHeader) + "1 -2 +3.5 .5\n5. 1e3 -1.25E-2 -9999\nnan NaN 0 7\n";
  const Status st = check_text(text);
  EXPECT_TRUE(st.ok()) << message(st);
}

TEST(AsciiGridCheck, ACellThatIsNotANumberIsRefusedNamingItsRowColumnAndLine) {
  const std::string text = std::string(kHeader) + "1 2 3 4\n5 banana 7 8\n9 10 11 12\n";
  const Status st = check_text(text);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::kCorrupt);
  EXPECT_EQ(st.error().field, "grid.asc");
  EXPECT_EQ(st.error().message, "row 2, column 2 (line 8): 'banana' is not a number");
}

TEST(AsciiGridCheck, RowsAreCountedInCellsNotLines) {
  // Writers wrap long rows: the row and column come from the cell's index, the line from the file.
  const std::string text = std::string(kHeader) + "1 2\n3 4\n5 6\n7 x\n";
  const Status st = check_text(text);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().message, "row 2, column 4 (line 10): 'x' is not a number");
}

TEST(AsciiGridCheck, MalformedNumbersAndHeadersAreRefused) {
  for (const char* cell : {"1.2.3", "1e", "e5", "-", ".", "0x10", "inf", "1,5", "12abc", "--1"}) {
    const Status st = check_text(std::string(kHeader) + cell + " 2 3 4\n");
    EXPECT_FALSE(st.ok()) << cell;
    EXPECT_NE(message(st).find("row 1, column 1"), std::string::npos) << message(st);
  }
  const struct {
    const char* text;
    const char* says;
  } headers[] = {
      {"ncols four\nnrows 3\n1 2 3 4\n", "ncols 'four' is not a whole number"},
      {"ncols 4\nnrows 0\n1\n", "nrows '0' is not a whole number"},
      {"ncols 4\nnrows 3\ncellsize ten\n1\n", "cellsize 'ten' is not a number"},
      {"ncols 4\n1 2 3 4\n", "before the header named ncols and nrows"},
      {"ncols 4\nnrows 3\nrotation 3\n", "row 1, column 1 (line 3): 'rotation' is not a number"},
      {"nrows 3\nncols", "the header ends at 'ncols' without its value"},
      {"", "no ncols and nrows header"},
  };
  for (const auto& h : headers) {
    const Status st = check_text(h.text);
    ASSERT_FALSE(st.ok()) << h.text;
    EXPECT_NE(st.error().message.find(h.says), std::string::npos) << message(st);
  }
}

TEST(AsciiGridCheck, BinaryAndOverlongTokensAreRefusedWithinBoundedMemory) {
  std::string with_nul = std::string(kHeader) + "1 2";
  with_nul.push_back('\0');
  Status st = check_text(with_nul + " 3 4\n");
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("NUL byte"), std::string::npos) << message(st);
  st = check_text(std::string(kHeader) + std::string(100000, '7'));
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("longer than 64 bytes"), std::string::npos) << message(st);
}

TEST(AsciiGridCheck, FeedingInChunksSplitAtEveryByteGivesTheSameVerdict) {
  const std::vector<std::string> texts = {
      std::string(kHeader) + "1 2 3 4\n5 6 7 8\n9 10 11 12\n",
      std::string(kHeader) + "1 2 3 4\n5 6 7 8\n9 10 11 1x2\n",
      "ncols 4\r\nnrows 3\r\ncellsize 1\r\n1 2 3 4\r\n5 6 7 8\r\n9 10 11 12",
      "ncols 4\nnrows",
  };
  for (const std::string& text : texts) {
    const std::string whole = message(check_text(text));
    for (size_t cut = 0; cut <= text.size(); ++cut) {
      AsciiGridChecker c("grid.asc");
      Status st = c.feed(std::span<const char>(text.data(), cut));
      if (st.ok()) st = c.feed(std::span<const char>(text.data() + cut, text.size() - cut));
      if (st.ok()) st = c.finish();
      ASSERT_EQ(message(st), whole) << "split at byte " << cut << " of " << text;
    }
  }
}

}  // namespace
}  // namespace loam
