// Inputs that once crashed a fuzz target: each must now parse or fail with a trellis::Error.
#include <gtest/gtest.h>

#include <filesystem>

#include "trellis/analysis/metrics.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/lattice/io.hpp"
#include "trellis/machine/cli.hpp"
#include "trellis/toolpath/json.hpp"

using namespace trellis;

TEST(FuzzRegressions, EveryParserSurvivesEveryCrashInput) {
  std::size_t n = 0;
  for (const auto& f :
       std::filesystem::directory_iterator(std::string(TRELLIS_TEST_DATA) + "/fuzz_regressions")) {
    const std::string text = read_file(f.path().string());
    ++n;
    auto survive = [&](auto parse) {
      try {
        parse();
      } catch (const Error&) {
      }
    };
    survive([&] {
      Diagnostics d;
      clean_graph(parse_lattice_json(text, "f").graph, {}, d);
    });
    survive([&] {
      Diagnostics d;
      clean_graph(parse_segments_csv(text, "f").graph, {}, d);
    });
    survive([&] {
      Diagnostics d;
      clean_graph(parse_obj_lines(text, "f").graph, {}, d);
    });
    survive([&] { toolpath_from_json(text, "f"); });
    survive([&] { read_cli(text, "f"); });
    survive([&] {
      Diagnostics d;
      Graph design;
      design.nodes = {{0, 0, 0}, {10, 0, 0}};
      design.edges = {{0, 1}};
      analyze(read_gcode(text, {}, d, "f"), {}, &design, {});
    });
  }
  EXPECT_GE(n, 4u);
}

TEST(FuzzRegressions, HugeNumbersAreParseErrors) {
  EXPECT_THROW(parse_lattice_json(R"({"nodes":[[330e685,0,0]],"edges":[]})", "f"), ParseError);
  EXPECT_THROW(parse_segments_csv("0,0,0,1e300,0,0\n", "f"), ParseError);
  EXPECT_THROW(parse_obj_lines("v 1e20 0 0\nv 0 0 0\nl 1 2\n", "f"), ParseError);
}
