// The output rules (core/run_files.hpp, core/file.hpp): no output over an input or another
// output, FIFOs written through, symbolic links refused unless asked, folders refused, stale
// temporaries of dead runs removed.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <future>
#include <iterator>
#include <string>

#include "support/temp_dir.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/core/run_files.hpp"

using namespace trellis;
namespace fs = std::filesystem;

namespace {

// The message of the IoError `f` throws ("" when it throws none).
template <typename F>
std::string refusal(F&& f) {
  try {
    f();
  } catch (const IoError& e) {
    return e.what();
  }
  return "";
}

bool has(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

}  // namespace

TEST(RunFiles, AnOutputThatIsAnInputIsRefusedByAnyName) {
  const test::TempDir tmp("trellis_test_runfiles");
  const std::string in = tmp.file("p.toml");
  write_file_atomic(in, "keep");
  fs::create_directory(tmp / "sub");
  fs::create_hard_link(in, tmp / "hard.toml");
  fs::create_symlink(in, tmp / "link.toml");
  for (const std::string& out : {in, tmp.file("sub/../p.toml"), tmp.file("hard.toml")}) {
    RunFiles files;
    files.input("the machine profile", in);
    files.output("the output", out);
    const std::string m = refusal([&] { files.check(); });
    EXPECT_TRUE(has(m, "the output would overwrite the machine profile")) << m;
    EXPECT_TRUE(has(m, out)) << m;
  }
  RunFiles through_link(true);  // followed, the link still leads to the input
  through_link.input("the input", in);
  through_link.output("the output", tmp.file("link.toml"));
  EXPECT_TRUE(has(refusal([&] { through_link.check(); }), "would overwrite the input"));
  RunFiles missing;  // neither exists yet: compared by absolute path
  missing.input("the input", tmp.file("new.json"));
  missing.output("the output", tmp.file("sub/../new.json"));
  EXPECT_TRUE(has(refusal([&] { missing.check(); }), "would overwrite the input"));
  EXPECT_EQ(read_file(in), "keep");
}

TEST(RunFiles, TwoOutputsOnOnePathAreRefusedButCharacterDevicesTakeAny) {
  const test::TempDir tmp("trellis_test_runfiles");
  RunFiles files;
  files.output("the report", tmp.file("x.json"));
  files.output("the toolpath", tmp.file("./x.json"));
  const std::string m = refusal([&] { files.check(); });
  EXPECT_TRUE(has(m, "the report and the toolpath are one file")) << m;
  RunFiles devices;
  devices.output("the report", "/dev/null");
  devices.output("the output", "/dev/null");
  EXPECT_EQ(refusal([&] { devices.check(); }), "");
}

TEST(RunFiles, FoldersSymbolicLinksAndNamesWithoutAFileAreRefused) {
  const test::TempDir tmp("trellis_test_runfiles");
  fs::create_directory(tmp / "dir");
  write_file_atomic(tmp.file("target.json"), "old");
  fs::create_symlink(tmp / "target.json", tmp / "link.json");
  for (const std::string& out : {tmp.file("dir"), tmp.file("dir/"), tmp.file("new/")}) {
    RunFiles files;
    files.output("the output", out);
    EXPECT_TRUE(has(refusal([&] { files.check(); }), "names a folder")) << out;
  }
  EXPECT_FALSE(fs::exists(tmp / "new"));
  RunFiles link;
  link.output("the output", tmp.file("link.json"));
  const std::string m = refusal([&] { link.check(); });
  EXPECT_TRUE(has(m, "is a symbolic link")) << m;
  EXPECT_TRUE(has(m, "run.follow_symlinks")) << m;  // the key; the CLI adds the flag
  RunFiles followed(true);
  followed.output("the output", tmp.file("link.json"));
  EXPECT_EQ(refusal([&] { followed.check(); }), "");
  write_file_atomic(tmp.file("link.json"), "new");  // the file it points to, the link kept
  EXPECT_TRUE(fs::is_symlink(tmp / "link.json"));
  EXPECT_EQ(read_file(tmp.file("target.json")), "new");
  RunFiles preview;  // a folder output is a folder
  preview.output_folder("the preview folder", tmp.file("dir"));
  EXPECT_EQ(refusal([&] { preview.check(); }), "");
}

TEST(RunFiles, TheOpenBatchRefusesWritesToAnInputOrTwiceToOneTarget) {
  const test::TempDir tmp("trellis_test_runfiles");
  const std::string in = tmp.file("in.json");
  write_file_atomic(in, "keep");
  fs::create_hard_link(in, tmp / "alias.json");
  {
    OutputBatch batch;
    RunFiles files;
    files.input("the input", in);
    files.check();
    // A derived name no role declared (a preview, a shard) that is the input after all.
    EXPECT_TRUE(has(refusal([&] { write_file_atomic(tmp.file("alias.json"), "x"); }),
                    "would overwrite the input"));
    write_file_atomic(tmp.file("out.json"), "a");
    EXPECT_TRUE(
        has(refusal([&] { write_file_atomic(tmp.file("./out.json"), "b"); }), "written twice"));
  }
  EXPECT_EQ(read_file(in), "keep");
  EXPECT_FALSE(fs::exists(tmp / "out.json"));
  OutputBatch after;  // the next run starts with nothing refused
  write_file_atomic(in, "replaced");
  after.commit();
  EXPECT_EQ(read_file(in), "replaced");
}

TEST(RunFiles, AFifoIsWrittenThroughNotReplaced) {
  const test::TempDir tmp("trellis_test_runfiles");
  const std::string fifo = tmp.file("out.gcode");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  auto reader = std::async(std::launch::async, [&] {
    std::ifstream in(fifo, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  });
  RunFiles files;
  files.output("the output", fifo);
  files.check();
  {
    OutputBatch batch;
    write_file_atomic(fifo, "G1 X1\n");
    batch.commit();
  }
  EXPECT_EQ(reader.get(), "G1 X1\n");
  struct stat st {};
  ASSERT_EQ(::lstat(fifo.c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode));
  std::size_t entries = 0;
  for ([[maybe_unused]] auto& e : fs::directory_iterator(tmp.path())) ++entries;
  EXPECT_EQ(entries, 1u);  // no temporary beside it
}

// An input that is a device or a pipe may never end (/dev/zero read as G-code grew without
// bound) or block forever (a FIFO nobody writes): refused before it is opened.
TEST(RunFiles, AnInputThatIsNotAFileIsRefusedBeforeItIsOpened) {
  const test::TempDir tmp("trellis_test_runfiles");
  const std::string fifo = tmp.file("in.gcode");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  for (const std::string& path : {std::string("/dev/zero"), fifo}) {
    RunFiles files;
    files.input("the G-code", path);
    files.output("the report", tmp.file("r.json"));
    const std::string why = refusal([&] { files.check(); });
    EXPECT_TRUE(has(why, path) && has(why, "the G-code is a") && has(why, "only a file is read"))
        << path << ": " << why;
  }
  // A file and a folder are inputs as before (a folder is named by its reader).
  write_file_atomic(tmp.file("in.json"), "{}");
  RunFiles files;
  files.input("the lattice", tmp.file("in.json"));
  files.input("the shards", tmp.path().string());
  EXPECT_EQ(refusal([&] { files.check(); }), "");
  EXPECT_FALSE(fs::exists(tmp / "r.json"));
}

TEST(File, StaleTemporariesOfDeadRunsAreRemovedByTheNextWrite) {
  const test::TempDir tmp("trellis_test_stale");
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  ASSERT_GT(child, 0);
  ::waitpid(child, nullptr, 0);  // a run that is gone
  const std::string dead = ".out.gcode.trellis-tmp." + std::to_string(child) + ".Ab12Cd";
  const std::string alive = ".out.gcode.trellis-tmp." + std::to_string(::getppid()) + ".Ab12Cd";
  const std::string other = ".other.gcode.trellis-tmp." + std::to_string(child) + ".Ab12Cd";
  const std::string like = ".notes.trellis-tmp.x.Ab12Cd";  // not one of ours: no PID
  for (const auto& n : {dead, alive, other, like}) std::ofstream(tmp / n) << "partial";
  // A killed run's preview folder holds only its temporaries; another folder holds a file too.
  fs::create_directory(tmp / "preview");
  std::ofstream(tmp / "preview" /
                (".layer_0001.png.trellis-tmp." + std::to_string(child) + ".Ab12Cd"))
      << "x";
  fs::create_directory(tmp / "kept");
  std::ofstream(tmp / "kept" / (".a.png.trellis-tmp." + std::to_string(child) + ".Ab12Cd")) << "x";
  std::ofstream(tmp / "kept" / "a.png") << "a user's file";
  fs::create_directory(tmp / "empty");
  write_file_atomic(tmp.file("out.gcode"), "whole");
  EXPECT_FALSE(fs::exists(tmp / dead));
  EXPECT_TRUE(fs::exists(tmp / alive));   // its process is alive: maybe writing it now
  EXPECT_FALSE(fs::exists(tmp / other));  // another output's, its run gone: never renamed now
  EXPECT_TRUE(fs::exists(tmp / like));
  EXPECT_FALSE(fs::exists(tmp / "preview"));
  EXPECT_TRUE(fs::exists(tmp / "kept" / "a.png"));
  EXPECT_EQ(std::distance(fs::directory_iterator(tmp / "kept"), fs::directory_iterator()), 1);
  EXPECT_TRUE(fs::exists(tmp / "empty"));  // a folder with no temporary in it is not ours
  EXPECT_EQ(read_file(tmp.file("out.gcode")), "whole");
}

TEST(File, TheWatchdogStopsARunPastTwiceItsTimeBudgetAndLeavesNothing) {
  const test::TempDir tmp("trellis_test_watchdog");
  int err[2];
  ASSERT_EQ(::pipe(err), 0);
  const pid_t child = ::fork();
  if (child == 0) {
    ::dup2(err[1], 2);
    install_signal_cleanup();
    set_interrupt_label("trellis test");
    OutputBatch batch;
    write_file_atomic(tmp.file("out.txt"), "staged, never committed");
    arm_watchdog(0.1);  // stopped after 0.2 s
    ::sleep(5);
    ::_exit(0);
  }
  ASSERT_GT(child, 0);
  ::close(err[1]);
  std::string said;
  char buf[512];
  for (ssize_t n; (n = ::read(err[0], buf, sizeof buf)) > 0;)
    said.append(buf, static_cast<std::size_t>(n));
  ::close(err[0]);
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 2);
  EXPECT_TRUE(has(said, "trellis test stopped")) << said;
  EXPECT_TRUE(has(said, "twice its time budget (run.max_time = 0.1 s)")) << said;
  EXPECT_TRUE(has(said, "nothing was written")) << said;
  EXPECT_EQ(std::distance(fs::directory_iterator(tmp.path()), fs::directory_iterator()), 0);
}

TEST(RunFiles, AFileReadAfterTheCheckIsAnInputButNotOneReadBefore) {
  const test::TempDir tmp("trellis_test_runfiles");
  const std::string before = tmp.file("header.gcode"), after = tmp.file("edges.csv");
  write_file_atomic(before, "old");
  write_file_atomic(after, "keep");
  OutputBatch batch;
  (void)read_file(before);  // `rerun FILE` reads the job in FILE, then writes FILE again
  RunFiles files;
  files.check();
  (void)read_file(after);  // a file the inputs name (the edges beside AERO vertices)
  EXPECT_TRUE(has(refusal([&] { write_file_atomic(after, "x"); }),
                  "would overwrite a file this run reads"));
  write_file_atomic(before, "new");
  batch.commit();
  EXPECT_EQ(read_file(before), "new");
  EXPECT_EQ(read_file(after), "keep");
}
