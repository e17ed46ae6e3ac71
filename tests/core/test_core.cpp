#include <gtest/gtest.h>

#include <filesystem>
#include <set>

#include "support/temp_dir.hpp"
#include "trellis/core/diagnostics.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/core/rng.hpp"

using namespace trellis;
namespace fs = std::filesystem;

TEST(Rng, SameSeedSameStreamDifferentSeedsDiffer) {
  Rng a(42), b(42), c(43);
  for (int i = 0; i < 100; ++i) {
    const auto x = a.next();
    EXPECT_EQ(x, b.next());
    EXPECT_NE(x, c.next());
  }
  EXPECT_NE(Rng::stream(1, 0).next(), Rng::stream(1, 1).next());
}

TEST(Rng, UniformIndexStaysInRangeAndCoversIt) {
  Rng r(7);
  std::set<std::uint64_t> seen;
  for (int i = 0; i < 10000; ++i) {
    const auto v = r.uniform_index(13);
    ASSERT_LT(v, 13u);
    seen.insert(v);
  }
  EXPECT_EQ(seen.size(), 13u);
  for (int i = 0; i < 1000; ++i) {
    const double u = r.uniform01();
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
  }
}

TEST(Error, MessageNamesFileLineAndElement) {
  const ParseError e("bad number", {"lattice.csv", 12, "column 2"});
  EXPECT_STREQ(e.what(), "lattice.csv:12: column 2: bad number");
  EXPECT_EQ(Error("plain").what(), std::string("plain"));
}

TEST(Diagnostics, CountsEveryWarningKeepsFewMessages) {
  Diagnostics d;
  for (int i = 0; i < 20; ++i) d.warn("duplicate_edge", "dup " + std::to_string(i));
  d.warn("self_loop", "loop");
  EXPECT_EQ(d.count("duplicate_edge"), 20u);
  EXPECT_EQ(d.total(), 21u);
  EXPECT_EQ(d.messages().size(), Diagnostics::kMaxMessagesPerKind + 1);
}

TEST(File, AtomicWriteReplacesAndLeavesNoTempFiles) {
  const trellis::test::TempDir tmp("trellis_test_atomic");
  const fs::path dir = tmp.path();
  const std::string path = (dir / "sub" / "out.txt").string();
  write_file_atomic(path, "first");
  write_file_atomic(path, "second");
  EXPECT_EQ(read_file(path), "second");
  std::size_t files = 0;
  for (auto& e : fs::directory_iterator(dir / "sub")) files += e.is_regular_file();
  EXPECT_EQ(files, 1u);
}

TEST(File, MissingFileIsAnIoErrorNamingIt) {
  try {
    read_file("/nonexistent/lattice.json");
    FAIL();
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/lattice.json"), std::string::npos);
  }
}

TEST(File, LineOfOffset) {
  EXPECT_EQ(line_of_offset("a\nb\nc", 0), 1);
  EXPECT_EQ(line_of_offset("a\nb\nc", 2), 2);
  EXPECT_EQ(line_of_offset("a\nb\nc", 4), 3);
}
