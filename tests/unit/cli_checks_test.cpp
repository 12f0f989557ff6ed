// The range checks every program puts on its numeric options (app/cli_checks.h): NaN and
// infinities are refused where CLI::Range lets NaN through, integers out of range before an
// unsigned conversion wraps them, and the error names the option and the range.
#include "app/cli_checks.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace loam::cli {
namespace {

// Parses `args` (after the program name) into an app with --radius (0, 65536], --port
// 0..65535 and --point finite; returns the error message, empty when it parsed.
std::string parse(std::vector<std::string> args, double* radius = nullptr) {
  CLI::App app;
  double r = 4096;
  uint16_t port = 7878;
  std::vector<double> point;
  app.add_option("--radius", r)->check(FiniteRange(0, 65536, Bound::kOpen));
  app.add_option("--port", port)->check(IntRange(0, 65535));
  app.add_option("--point", point)->delimiter(',')->check(Finite());
  std::vector<const char*> argv = {"prog"};
  for (const std::string& a : args) argv.push_back(a.c_str());
  try {
    app.parse(int(argv.size()), argv.data());
  } catch (const CLI::ParseError& e) {
    return e.what();
  }
  if (radius) *radius = r;
  return {};
}

// The bug: CLI::Range(0.0, 65536.0) accepts "nan" (every comparison with NaN is false).
TEST(CliChecks, NanIsRefusedNamingTheOptionAndTheRange) {
  EXPECT_EQ(parse({"--radius", "nan"}), "--radius: must be a finite number in (0, 65536], got nan");
  EXPECT_NE(parse({"--radius", "inf"}), "");
  EXPECT_NE(parse({"--radius", "-inf"}), "");
  EXPECT_NE(parse({"--radius", "NAN"}), "");
}

TEST(CliChecks, FiniteRangeHonoursOpenAndClosedBounds) {
  EXPECT_NE(parse({"--radius", "0"}), "");
  EXPECT_NE(parse({"--radius", "-1"}), "");
  EXPECT_NE(parse({"--radius", "65536.5"}), "");
  EXPECT_NE(parse({"--radius", "12abc"}), "");
  double r = 0;
  EXPECT_EQ(parse({"--radius", "65536"}, &r), "");
  EXPECT_EQ(r, 65536.0);
  EXPECT_EQ(parse({"--radius", "1e-3"}, &r), "");
  EXPECT_EQ(r, 1e-3);
}

TEST(CliChecks, IntegersOutOfRangeAreRefusedBeforeAnUnsignedConversionWraps) {
  EXPECT_EQ(parse({"--port", "70000"}), "--port: must be an integer in 0..65535, got 70000");
  EXPECT_NE(parse({"--port", "-1"}), "");
  EXPECT_NE(parse({"--port", "1.5"}), "");
  EXPECT_NE(parse({"--port", "99999999999999999999999"}), "");
  EXPECT_EQ(parse({"--port", "65535"}), "");
}

TEST(CliChecks, FiniteChecksEveryElementOfAListOption) {
  EXPECT_EQ(parse({"--point", "1,2,3"}), "");
  const std::string e = parse({"--point", "1,nan,3"});
  EXPECT_NE(e.find("--point"), std::string::npos) << e;
  EXPECT_NE(e.find("finite"), std::string::npos) << e;
}

}  // namespace
}  // namespace loam::cli
