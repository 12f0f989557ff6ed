// The stamp kinds table (protocol/stamps/stamp_kinds.h) is the one place a kind's traits live:
// validation follows it, and the shaders compare KIND only against the constants the GPU
// stamper generates from it, never against bare numbers.
#include "protocol/stamps/stamp_kinds.h"

#include <gtest/gtest.h>

#include <cctype>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "protocol/stamps/stamp_at_mip.h"
#include "protocol/stamps/stamp_validate.h"

namespace loam {
namespace {

TEST(StampKinds, EveryKindHasItsRowAndNamesComeFromIt) {
  for (int i = 0; i < kStampKindCount; ++i) {
    const StampKindRow& r = stamp_kind(StampKind(i));
    EXPECT_EQ(int(r.kind), i);
    EXPECT_EQ(std::string(to_string(StampKind(i))), std::string(r.name));
    EXPECT_EQ(is_per_sample(StampKind(i)), r.per_sample);
    EXPECT_FALSE(r.constant.empty());
  }
}

// What check_quantized refuses follows the rows: a field a row does not use must be 0.
TEST(StampKinds, CheckQuantizedRefusesTheFieldsARowDoesNotUse) {
  WorldParams w;
  w.tiles_x = w.tiles_y = 2;
  for (const StampKindRow& r : kStampKinds) {
    SCOPED_TRACE(std::string(r.name));
    QuantizedStamp q;
    q.kind = r.kind;
    q.center_x = q.center_y = 100 * 256;
    q.radius = 8 * 256;
    q.shape = 100;
    Status st = check_quantized(q, w);
    EXPECT_EQ(!st.ok() && st.error().field == "stamp.shape", !r.uses_shape);
    q.shape = 0;
    q.damping = 100;
    st = check_quantized(q, w);
    EXPECT_EQ(!st.ok() && st.error().field == "stamp.damping", !r.uses_wave);
  }
}

std::string read(const std::filesystem::path& p) {
  std::ifstream f(p);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// The right-hand sides of every `KIND ==`, `KIND !=`, `KIND <`... in a shader's text (the
// token KIND exactly, not KIND_<NAME>).
std::vector<std::string> kind_comparisons(const std::string& text) {
  std::vector<std::string> out;
  auto word = [&](size_t i) { return i < text.size() && (std::isalnum(uint8_t(text[i])) || text[i] == '_'); };
  for (size_t at = text.find("KIND"); at != std::string::npos; at = text.find("KIND", at + 4)) {
    if ((at > 0 && word(at - 1)) || word(at + 4)) continue;
    size_t i = at + 4;
    while (i < text.size() && text[i] == ' ') ++i;
    if (i >= text.size() || std::string("=!<>").find(text[i]) == std::string::npos) continue;
    while (i < text.size() && std::string("=!<> ").find(text[i]) != std::string::npos) ++i;
    size_t j = i;
    while (word(j)) ++j;
    out.push_back(text.substr(i, j - i));
  }
  return out;
}

TEST(StampKinds, ShadersCompareKindOnlyAgainstTheGeneratedConstants) {
  std::set<std::string> generated;
  for (const StampKindRow& r : kStampKinds) generated.insert("KIND_" + std::string(r.constant));
  EXPECT_EQ(kind_comparisons("#if KIND == 3 || KIND==KIND_CRATER\n#elif KIND_NEEDS_CONTACT"),
            (std::vector<std::string>{"3", "KIND_CRATER"}));
  size_t checked = 0;
  for (const auto& e :
       std::filesystem::directory_iterator(std::filesystem::path(LOAM_SOURCE_DIR) / "shaders")) {
    if (e.path().extension() != ".glsl") continue;
    for (const std::string& rhs : kind_comparisons(read(e.path()))) {
      EXPECT_TRUE(generated.count(rhs)) << e.path().filename() << ": KIND compared with " << rhs;
      ++checked;
    }
  }
  EXPECT_GT(checked, 0u) << "the stamp shaders branch on KIND";
}

}  // namespace
}  // namespace loam
