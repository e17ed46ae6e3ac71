// Graded G-code written layer by layer (issue 23 item 2): the streamed writer plans the mixture
// changes from a pass over the layers (each printed path's printed length before it and its
// mixture command, not the paths) and locates a look-ahead change inside its path when that path
// is printed, so write_gcode_stream of a graded toolpath is byte for byte write_gcode of it:
// Strategy 1 with a prime tower and Strategy 2 with the 960 mm look-ahead on a mixing hotend,
// and both on a five-tool changer.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "trellis/core/diagnostics.hpp"
#include "trellis/core/file.hpp"
#include "trellis/job/job.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/machine/profile.hpp"
#include "trellis/settings/settings.hpp"

namespace fs = std::filesystem;
using namespace trellis;

namespace {

const std::string kRoot = TRELLIS_SOURCE_DIR;

fs::path work(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() /
                       ("trellis_graded_stream_" + std::to_string(::getpid()) + "_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// A cylinder graded across X and up Z (as tests/job/test_graded_shards.cpp): several colours
// in every layer and colours moving up the layers, so changes fall inside layers, across layer
// boundaries and, with the look-ahead, inside earlier paths.
// With `process`, inside process fields (fprocess: speed across X, flow across Y, fan up Z).
std::string graded_job(const fs::path& dir, int strategy, const std::string& profile,
                       const std::string& extra, bool process = false) {
  const std::string graded =
      "fgrade([\"(x+8)/32 + z/16.8\", \"1 - (x+8)/32 - z/16.8\"], [\"blue\", \"yellow\"]) {\n"
      "  cylinder(8, 8.4);\n}\n";
  std::ofstream(dir / "graded.vcad")
      << (process ? "fprocess([\"30 + 0.7*x\", \"1 + 0.02*y\", \"40 + 6*z\"], [\"speed\", "
                    "\"flow\", \"fan\"]) {\n" +
                        graded + "}\n"
                  : graded);
  const fs::path f = dir / "job.toml";
  std::ofstream(f) << "[job]\nroute = \"slice\"\nname = \"graded\"\ninput = \""
                   << (dir / "graded.vcad").string() << "\"\nmachine = \"" << kRoot << "/profiles/"
                   << profile << "\"\n\n[slice]\nstrategy = " << strategy << "\n"
                   << extra;
  return f.string();
}

struct Written {
  std::string whole, streamed;
  GcodeStats whole_stats, streamed_stats;
};

// The job's graded toolpath (kept whole), written whole and streamed layer by layer.
Written both(int strategy, const std::string& profile, const std::string& extra = {}) {
  const fs::path dir = work(profile + "_" + std::to_string(strategy));
  Job job = load_job(graded_job(dir, strategy, profile, extra), dir.string(), {"output.png=false"});
  job.keep_toolpath = true;
  Diagnostics diag;
  const JobResult r = run_job(job, diag);
  EXPECT_TRUE(r.toolpath);
  Written w;
  if (!r.toolpath) return w;
  const Toolpath& tp = *r.toolpath;
  const MachineProfile m = load_machine_profile(kRoot + "/profiles/" + profile);
  w.whole = write_gcode(tp, m, &w.whole_stats);
  Toolpath meta;
  meta.source = tp.source;
  meta.job = tp.job;
  meta.part_labels = tp.part_labels;
  const std::string path = (dir / "streamed.gcode").string();
  w.streamed_stats = write_gcode_stream(path, meta, tp.layers.size(), layers_of(tp), m);
  w.streamed = read_file(path);
  fs::remove_all(dir);
  return w;
}

void expect_same(const Written& w, const std::string& what) {
  ASSERT_FALSE(w.whole.empty()) << what;
  EXPECT_GT(w.whole_stats.gradient_changes, 10u) << what;
  EXPECT_EQ(w.streamed_stats.gradient_changes, w.whole_stats.gradient_changes) << what;
  EXPECT_EQ(w.streamed_stats.lookahead, w.whole_stats.lookahead) << what;
  EXPECT_EQ(w.streamed.size(), w.whole.size()) << what;
  EXPECT_TRUE(w.streamed == w.whole) << what << ": the streamed G-code differs from the whole";
}

}  // namespace

TEST(GradedStream, Strategy1TowerStreamedIsWhole) {
  const Written w = both(1, "geeetech_mizar_m_mixing.toml", "\n[fgm]\norder = \"faces\"\n");
  expect_same(w, "strategy 1 in face order, mixing hotend");
  EXPECT_EQ(w.whole_stats.lookahead, 0) << "a prime tower issues each change right before its path";
  EXPECT_NE(w.whole.find(";TYPE:Wipe tower"), std::string::npos);
}

// Strategy 1 in path order: changes inside beads, each written 960 mm of path early.
TEST(GradedStream, Strategy1PathOrderStreamedIsWhole) {
  const Written w = both(1, "geeetech_mizar_m_mixing.toml");
  expect_same(w, "strategy 1 in path order, mixing hotend");
  EXPECT_EQ(w.whole_stats.lookahead, 960);
  EXPECT_EQ(w.whole.find(";TYPE:Wipe tower"), std::string::npos);
}

TEST(GradedStream, Strategy2LookaheadStreamedIsWhole) {
  const Written w = both(2, "geeetech_mizar_m_mixing.toml");
  expect_same(w, "strategy 2, mixing hotend");
  EXPECT_EQ(w.whole_stats.lookahead, 960);
  EXPECT_NE(w.whole.find("M165 A"), std::string::npos);
}

TEST(GradedStream, ToolChangerStreamedIsWhole) {
  for (const int strategy : {1, 2}) {
    const Written w = both(strategy, "prusa_xl_5tools.toml", "\n[fgm]\ncolors = 5\n");
    expect_same(w, "tool changer, strategy " + std::to_string(strategy));
    EXPECT_NE(w.whole.find("\nT1\n"), std::string::npos) << "tools change";
  }
}

namespace {

// The job run with the whole toolpath kept and streamed (the command line writing G-code alone):
// {whole, streamed} G-code, report and summary.
struct Runs {
  std::string gcode[2], report[2], summary[2];
  bool held[2] = {false, false};
};

Runs whole_and_streamed(int strategy, const std::string& profile, const std::string& extra = {},
                        bool process = false) {
  const fs::path dir =
      work("job_" + profile + "_" + std::to_string(strategy) + (process ? "_process" : ""));
  const std::string f = graded_job(dir, strategy, profile, extra, process);
  Runs out;
  for (const int k : {0, 1}) {
    Job job = load_job(f, (dir / (k ? "stream" : "whole")).string(), {"output.png=false"});
    job.keep_toolpath = k == 0;
    Diagnostics diag;
    const JobResult r = run_job(job, diag);
    out.held[k] = static_cast<bool>(r.toolpath);
    out.gcode[k] = read_file(job.output);
    out.report[k] = job.report.empty() ? std::string() : read_file(job.report);
    out.summary[k] = r.summary;
  }
  fs::remove_all(dir);
  return out;
}

// The report without its timings (seconds differ run to run).
std::string without_timings(const std::string& report) {
  std::string s = report;
  for (const char* key : {"\"outline_seconds\"", "\"plan_seconds\"", "\"seconds\""}) {
    for (auto at = s.find(key); at != std::string::npos; at = s.find(key, at + 1)) {
      const auto end = s.find_first_of(",}\n", at);
      s.erase(at, end - at);
    }
  }
  return s;
}

void expect_same_runs(const Runs& r, const std::string& what) {
  EXPECT_TRUE(r.held[0]) << what;
  EXPECT_FALSE(r.held[1]) << what << ": a streamed run holds no toolpath";
  ASSERT_FALSE(r.gcode[0].empty()) << what;
  EXPECT_TRUE(r.gcode[1] == r.gcode[0]) << what << ": the streamed G-code differs from the whole";
  EXPECT_EQ(r.summary[1], r.summary[0]) << what;
  // The first line that differs (the reports are long).
  std::istringstream a(without_timings(r.report[0])), b(without_timings(r.report[1]));
  std::string la, lb;
  bool more_a = true, more_b = true;
  while ((more_a = static_cast<bool>(std::getline(a, la))) &
         (more_b = static_cast<bool>(std::getline(b, lb))))
    if (la != lb) break;
  EXPECT_TRUE(la == lb && more_a == more_b)
      << what << ": the reports differ: whole '" << la << "', streamed '" << lb << "'";
}

}  // namespace

// Strategy 2 on a mixing hotend slices layer by layer (stream_slice): the same G-code, summary
// and report (gradient error, colour changes, per-colour table) as the whole run.
TEST(GradedStream, Strategy2JobStreamsAsWhole) {
  const Runs r = whole_and_streamed(2, "geeetech_mizar_m_mixing.toml");
  expect_same_runs(r, "strategy 2 job");
  EXPECT_NE(r.summary[1].find("look-ahead 960 mm"), std::string::npos) << r.summary[1];
}

// With a prime tower (Strategy 1, tool changers) the layers are planned run by run, held in a
// temporary file while the tower observes them, and come back with the tower step: the same
// G-code, summary and report.
TEST(GradedStream, TowerJobsWrittenLayerByLayerAsWhole) {
  expect_same_runs(
      whole_and_streamed(1, "geeetech_mizar_m_mixing.toml", "\n[fgm]\norder = \"faces\"\n"),
      "strategy 1 job, face order");
  expect_same_runs(whole_and_streamed(1, "geeetech_mizar_m_mixing.toml"),
                   "strategy 1 job, path order");
  expect_same_runs(whole_and_streamed(2, "prusa_xl_5tools.toml", "\n[fgm]\ncolors = 5\n"),
                   "tool changer job");
}

// Process fields stream too, after the tower and the tools' mixtures (the tower's paths split as
// well), their changes counted across layers as the whole run counts them: the same G-code,
// summary and report on a mixing hotend (Strategy 1 and 2) and a five-tool changer.
TEST(GradedStream, ProcessFieldJobsStreamAsWhole) {
  struct Case {
    int strategy;
    const char* profile;
    const char* extra;
  };
  for (const Case c :
       {Case{1, "geeetech_mizar_m_mixing.toml", ""}, Case{2, "geeetech_mizar_m_mixing.toml", ""},
        Case{1, "prusa_xl_5tools.toml", "\n[fgm]\ncolors = 5\n"}}) {
    const std::string what =
        std::string(c.profile) + ", strategy " + std::to_string(c.strategy) + ", process";
    const Runs r = whole_and_streamed(c.strategy, c.profile, c.extra, true);
    expect_same_runs(r, what);
    EXPECT_NE(r.summary[0].find("process fields:"), std::string::npos)
        << what << ": " << r.summary[0];
    EXPECT_NE(r.report[0].find("\"process\""), std::string::npos) << what;
    EXPECT_NE(r.gcode[0].find("\nM106 S"), std::string::npos)
        << what << ": the fan field is written";
  }
}
