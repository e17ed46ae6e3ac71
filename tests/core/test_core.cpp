#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cmath>
#include <filesystem>
#include <set>

#include "support/temp_dir.hpp"
#include "trellis/core/budget.hpp"
#include "trellis/core/diagnostics.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/core/memory.hpp"
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

namespace {
std::set<std::string> names_in(const fs::path& dir) {
  std::set<std::string> out;
  for (auto& e : fs::recursive_directory_iterator(dir))
    out.insert(fs::relative(e.path(), dir).string());
  return out;
}
}  // namespace

TEST(File, BatchCommitsEveryOutputTogetherOrNone) {
  const trellis::test::TempDir tmp("trellis_test_batch");
  const fs::path dir = tmp.path();
  write_file_atomic((dir / "old.txt").string(), "old");
  const auto before = names_in(dir);
  {
    OutputBatch batch;
    write_file_atomic((dir / "a.txt").string(), "a");
    write_file_atomic((dir / "new" / "deep" / "b.txt").string(), "b");
    write_file_atomic((dir / "old.txt").string(), "replaced");
    // Staged: nothing visible under its name yet, the old file untouched.
    EXPECT_FALSE(fs::exists(dir / "a.txt"));
    EXPECT_EQ(read_file((dir / "old.txt").string()), "old");
    // No commit: the batch ends as a failed job would.
  }
  EXPECT_EQ(names_in(dir), before);
  EXPECT_EQ(read_file((dir / "old.txt").string()), "old");
  {
    OutputBatch batch;
    write_file_atomic((dir / "a.txt").string(), "a");
    {
      OutputBatch inner;  // nested (a job inside a command): only the outer one commits
      write_file_atomic((dir / "new" / "b.txt").string(), "b");
      inner.commit();
    }
    EXPECT_FALSE(fs::exists(dir / "new" / "b.txt"));
    batch.commit();
  }
  EXPECT_EQ(read_file((dir / "a.txt").string()), "a");
  EXPECT_EQ(read_file((dir / "new" / "b.txt").string()), "b");
  EXPECT_EQ(names_in(dir).size(), before.size() + 3);  // a.txt, new, new/b.txt; no temporaries
}

TEST(File, OutputsHonourTheUmask) {
  const trellis::test::TempDir tmp("trellis_test_umask");
  const mode_t old = ::umask(077);
  write_file_atomic(tmp.file("private.txt"), "x");
  ::umask(002);
  write_file_atomic(tmp.file("group.txt"), "x");
  ::umask(old);
  EXPECT_EQ(fs::status(tmp.path() / "private.txt").permissions() & fs::perms::all,
            fs::perms::owner_read | fs::perms::owner_write);
  EXPECT_EQ(fs::status(tmp.path() / "group.txt").permissions() & fs::perms::all,
            fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read |
                fs::perms::group_write | fs::perms::others_read);
}

TEST(Budget, RefusesBeyondEitherLimitWithTheEstimateAndForceGoesBeyond) {
  Budget b;
  b.memory = 1e9;
  b.seconds = 60;
  EXPECT_NO_THROW(check_budget({5e8, 30, "a small run", "--x"}, b));
  for (const Estimate& e :
       {Estimate{2e9, 1, "a big run", "--size"}, Estimate{1, 120, "a long run", "--size"},
        Estimate{std::nan(""), 1, "a NaN run", "--size"}}) {
    try {
      check_budget(e, b);
      ADD_FAILURE() << e.what;
    } catch (const ResourceError& err) {
      const std::string m = err.what();
      EXPECT_NE(m.find(e.what), std::string::npos) << m;
      EXPECT_NE(m.find("--size"), std::string::npos) << m;
      EXPECT_NE(m.find("run.force"), std::string::npos) << m;  // the key; the CLI adds --force
      EXPECT_NE(m.find("estimate"), std::string::npos) << m;
    }
  }
  b.force = true;
  EXPECT_NO_THROW(check_budget({2e12, 1e9, "a huge run", "--size"}, b));
}

TEST(Budget, TheDefaultMemoryBudgetIsHalfTheMemoryAvailable) {
  const double available = available_memory_bytes();
  if (available <= 0) GTEST_SKIP() << "no /proc/meminfo: no default memory budget to test";
  EXPECT_DOUBLE_EQ(default_memory_budget(), 0.5 * available);
  Budget b;  // memory 0: the default share
  b.seconds = 1e9;
  // Three quarters of what is available fits the machine but not the share: refused, naming it.
  try {
    check_budget({0.75 * available, 1, "a run of three quarters of the memory", "--size"}, b);
    ADD_FAILURE() << "three quarters of the memory available was accepted";
  } catch (const ResourceError& err) {
    EXPECT_NE(std::string(err.what()).find("half the memory available"), std::string::npos)
        << err.what();
  }
  EXPECT_NO_THROW(check_budget({0.25 * available, 1, "a run of a quarter", "--size"}, b));
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

namespace {
// Sets TMPDIR for one scope and restores it after.
struct TmpdirScope {
  explicit TmpdirScope(const std::string& value) {
    if (const char* v = std::getenv("TMPDIR")) old = v, had = true;
    ::setenv("TMPDIR", value.c_str(), 1);
  }
  ~TmpdirScope() { had ? ::setenv("TMPDIR", old.c_str(), 1) : ::unsetenv("TMPDIR"); }
  std::string old;
  bool had = false;
};
}  // namespace

TEST(File, TemporaryFilesAreAnonymousAndInTmpdir) {
  const trellis::test::TempDir tmp("trellis_test_tmpdir");
  {
    const TmpdirScope scope(tmp.path().string());
    std::FILE* f = temporary_file();
    ASSERT_NE(f, nullptr);
    ASSERT_GE(std::fputs("spilled", f), 0);
    ASSERT_EQ(std::fflush(f), 0);
    // The open file lives in TMPDIR but has no name there.
    const auto target = fs::read_symlink("/proc/self/fd/" + std::to_string(::fileno(f))).string();
    EXPECT_EQ(target.rfind(fs::canonical(tmp.path()).string() + "/", 0), 0u) << target;
    EXPECT_TRUE(names_in(tmp.path()).empty());
    std::rewind(f);
    char buf[16] = {};
    EXPECT_EQ(std::fread(buf, 1, 7, f), 7u);
    EXPECT_STREQ(buf, "spilled");
    std::fclose(f);
  }
  {
    // A TMPDIR that is not there is an error naming it, not a silent fallback elsewhere.
    const std::string missing = (tmp.path() / "missing").string();
    const TmpdirScope scope(missing);
    try {
      std::fclose(temporary_file());
      ADD_FAILURE() << "no error for a missing TMPDIR";
    } catch (const IoError& e) {
      EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
    }
  }
  {
    const TmpdirScope scope("");  // empty: /tmp
    std::FILE* f = temporary_file();
    const auto target = fs::read_symlink("/proc/self/fd/" + std::to_string(::fileno(f))).string();
    EXPECT_EQ(target.rfind("/tmp/", 0), 0u) << target;
    std::fclose(f);
  }
}

// Buffers advised for huge pages are the buffers they would be: resize_filled keeps what a
// vector or string held and value-fills the rest, at sizes across several 2 MB pages; a file of
// random bytes larger than a huge page reads back whole (read_file uses it).
TEST(Memory, ResizeFilledIsResize) {
  Rng rng(40);
  for (const std::size_t n : {0u, 1u, 4096u, (5u << 20) + 3u}) {
    std::vector<std::uint32_t> v = {1, 2, 3};
    resize_filled(v, n);
    ASSERT_EQ(v.size(), n);
    for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(v[i], i < 3 ? i + 1 : 0u) << n << " " << i;
    std::string s = "ab";
    resize_filled(s, n);
    ASSERT_EQ(s.size(), n);
    for (std::size_t i = 2; i < n; ++i) ASSERT_EQ(s[i], '\0');
  }
  test::TempDir dir;
  std::string bytes((6u << 20) + 11u, '\0');
  for (auto& c : bytes) c = static_cast<char>(rng.next() & 255);
  const std::string path = dir.file("big.bin");
  write_file_atomic(path, bytes);
  EXPECT_TRUE(read_file(path) == bytes);
}
