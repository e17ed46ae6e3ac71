// The readers (check, analyze, compare, view, render) run from a job file: `trellis run JOB.toml`
// with route = READER prints and writes what the command does, byte for byte, for every reader of
// the table and several generated prints; what a reader job cannot hold is refused naming it.
// Their reports and pages embed their job: `trellis rerun` of each writes it again byte for byte;
// a PNG carries none and its rerun is refused.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <tuple>

#include "support/cli_run.hpp"
#include "support/temp_dir.hpp"
#include "trellis/core/file.hpp"
#include "trellis/job/job.hpp"

namespace fs = std::filesystem;

namespace {

using CmdResult = trellis::test::CliRun;

const fs::path& work() {
  static const trellis::test::TempDir dir("trellis_reader_jobs");
  return dir.path();
}

std::string at(const std::string& name) {
  return (work() / name).string();
}

CmdResult run(const std::string& args) {
  return trellis::test::run_cli(args, work());
}

std::string quoted(const std::string& s) {
  return "\"" + s + "\"";
}

// One reader run both ways: the command's arguments, and the job's [job] keys and settings.
struct Case {
  std::string cli;                          // after the reader's name
  std::map<std::string, std::string> keys;  // [job] keys (TOML values)
  std::vector<std::string> settings;        // section.key=value, as --set and in the job
  std::vector<std::string> files;           // what both write (compared byte for byte)
};

std::string job_toml(const std::string& reader, const Case& c) {
  std::string t =
      "[job]\nroute = " + quoted(reader) + "\noutput_dir = " + quoted(work().string()) + "\n";
  for (const auto& [k, v] : c.keys) t += k + " = " + v + "\n";
  std::map<std::string, std::string> tables;  // [section] -> its lines
  for (const auto& s : c.settings) {
    const auto dot = s.find('.'), eq = s.find('=');
    tables[s.substr(0, dot)] += s.substr(dot + 1, eq - dot - 1) + " = " + s.substr(eq + 1) + "\n";
  }
  for (const auto& [section, lines] : tables) t += "[" + section + "]\n" + lines;
  return t;
}

// The prints of one generated design: a lattice, its plan and its G-code.
struct Prints {
  std::string lattice, toolpath, gcode, gcode2;
};

Prints make_prints(const std::string& pattern, double cell, int k) {
  const std::string p = "p" + std::to_string(k);
  Prints d{at(p + ".lattice.json"), at(p + ".toolpath.json"), at(p + ".gcode"), at(p + "b.gcode")};
  const std::string ender = std::string(TRELLIS_SOURCE_DIR) + "/profiles/ender3_s1_pro_tpu.toml";
  EXPECT_EQ(run("lattice2d --pattern " + pattern + " --cell " + std::to_string(cell) +
                " --size 6,6 -o " + d.lattice)
                .code,
            0);
  EXPECT_EQ(run("plan euler " + d.lattice + " -o " + d.toolpath).code, 0);
  EXPECT_EQ(run("gcode " + d.toolpath + " --machine " + ender + " --center -o " + d.gcode).code, 0);
  EXPECT_EQ(run("gcode " + d.toolpath + " --machine " + ender + " -o " + d.gcode2).code, 0);
  return d;
}

std::map<std::string, Case> cases(const Prints& d) {
  const std::string report = at("r.report.json");
  return {
      {"check",
       {d.lattice + " " + d.toolpath + " --report " + report,
        {{"design", quoted(d.lattice)},
         {"inputs", "[" + quoted(d.toolpath) + "]"},
         {"report", quoted("r.report.json")}},
        {"check.snap=0.01"},
        {report}}},
      {"analyze",
       {d.gcode + " --design " + d.lattice + " --report " + report,
        {{"design", quoted(d.lattice)},
         {"input", quoted(d.gcode)},
         {"report", quoted("r.report.json")}},
        {"analyze.bead_width=0.5", "analyze.align=true"},
        {report}}},
      {"compare",
       {d.lattice + " " + d.gcode + " " + d.gcode2 + " --report " + report,
        {{"design", quoted(d.lattice)},
         {"inputs", "[" + quoted(d.gcode) + ", " + quoted(d.gcode2) + "]"},
         {"report", quoted("r.report.json")}},
        {"analyze.layers=true"},
        {report}}},
      {"view",
       {d.toolpath + " --design " + d.lattice + " -o " + at("v.html"),
        {{"design", quoted(d.lattice)},
         {"inputs", "[" + quoted(d.toolpath) + "]"},
         {"output", quoted("v.html")}},
        {"view.title=\"a title\""},
        {at("v.html")}}},
      {"render",
       {d.gcode + " -o " + at("r.png"),
        {{"inputs", "[" + quoted(d.gcode) + "]"}, {"output", quoted("r.png")}},
        {"render.layer=0", "render.image_size=64"},
        {at("r.png")}}},
  };
}

}  // namespace

TEST(ReaderJobs, RunOfAReaderJobIsItsCommandByteForByte) {
  int k = 0;
  for (const auto& [pattern, cell] :
       std::vector<std::pair<std::string, double>>{{"honeycomb", 1.5}, {"square", 1.2}}) {
    const Prints d = make_prints(pattern, cell, k++);
    const auto all = cases(d);
    // Every reader of the table has its case.
    for (const trellis::RouteSpec& reader : trellis::route_specs())
      if (reader.reads) ASSERT_TRUE(all.count(reader.name)) << reader.name;
    for (const auto& [reader, c] : all) {
      std::string sets;
      for (const auto& s : c.settings) {  // --set takes text as it is, TOML in quotes
        const auto eq = s.find('=');
        std::string value = s.substr(eq + 1);
        if (value.size() >= 2 && value.front() == '"') value = value.substr(1, value.size() - 2);
        sets += " --set '" + s.substr(0, eq + 1) + value + "'";
      }
      for (const auto& f : c.files) fs::remove(f);
      const CmdResult cli = run(reader + " " + c.cli + sets);
      ASSERT_EQ(cli.code, 0) << reader << ": " << cli.err;
      std::map<std::string, std::string> wrote;
      for (const auto& f : c.files) {
        ASSERT_TRUE(fs::exists(f)) << reader << " " << f;
        wrote[f] = trellis::read_file(f);
        fs::remove(f);
      }
      const std::string job = at(reader + ".toml");
      std::ofstream(job) << job_toml(reader, c);
      const CmdResult ran = run("run " + job);
      ASSERT_EQ(ran.code, cli.code) << reader << ": " << ran.err;
      EXPECT_EQ(ran.out, cli.out) << reader;
      EXPECT_EQ(ran.err, cli.err) << reader;
      for (const auto& f : c.files) {
        ASSERT_TRUE(fs::exists(f)) << reader << " " << f;
        EXPECT_TRUE(trellis::read_file(f) == wrote[f]) << reader << " " << f;
      }
    }
  }
}

TEST(ReaderJobs, WhatAReaderJobCannotHoldIsRefusedNamingIt) {
  const Prints d = make_prints("triangle", 1.5, 9);
  const auto job = [&](const std::string& text) {
    std::ofstream(at("bad.toml")) << text;
    return run("run " + at("bad.toml"));
  };
  const std::string head = "[job]\nroute = \"analyze\"\ninput = " + quoted(d.gcode) + "\n";
  // A setting of a section the reader does not read, or one its route= condition withholds.
  CmdResult r = job(head + "[slice]\nwalls = 2\n");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("[slice]"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("slice.walls"), std::string::npos) << r.err;
  r = job("[job]\nroute = \"render\"\ninput = " + quoted(d.gcode) + "\n[read]\nstrict = true\n");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("read.strict"), std::string::npos) << r.err;
  std::ofstream(at("ok.toml")) << head;
  r = run("run " + at("ok.toml") + " --set slice.walls=2");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--set slice.walls"), std::string::npos) << r.err;
  // Outputs it does not write, files missing, a design it does not read, plates, shards.
  r = job(head + "toolpath = \"t.json\"\n");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("job.toolpath"), std::string::npos) << r.err;
  r = job("[job]\nroute = \"check\"\ndesign = " + quoted(d.lattice) + "\n");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("job.inputs"), std::string::npos) << r.err;
  r = job("[job]\nroute = \"render\"\ninput = " + quoted(d.gcode) +
          "\ndesign = " + quoted(d.lattice) + "\n");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("job.design"), std::string::npos) << r.err;
  r = job(head + "[[part]]\nx = 1\n");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("part"), std::string::npos) << r.err;
  r = run("run " + at("ok.toml") + " --shard 1/2");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("does not shard"), std::string::npos) << r.err;
  // A route's job does not take a reader's keys.
  r = job("[job]\nroute = \"gcode\"\ninputs = [" + quoted(d.toolpath) + "]\n");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("job.inputs"), std::string::npos) << r.err;
  // A reader's report embeds its job: rerun writes it again.
  ASSERT_EQ(run("run " + at("ok.toml")).code, 0);
  const std::string report = (work() / "out" / "ok" / "ok.report.json").string();
  ASSERT_TRUE(fs::exists(report));
  const std::string before = trellis::read_file(report);
  r = run("rerun " + report);
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(trellis::read_file(report), before);
}

// Every reader's report (check, analyze, compare) and page (view) carries its job; `trellis rerun`
// of it writes the same bytes, for generated prints, with and without a machine profile, made by
// the command or by a job file. Besides the job the report is what Python's read_run returns as its
// report. A print gone since is refused naming it, the report left as it was; a PNG (render,
// previews) carries no job and its rerun is refused, nothing written.
TEST(ReaderJobs, RerunOfEveryReadersReportOrPageWritesItAgainByteForByte) {
  const std::string ender = std::string(TRELLIS_SOURCE_DIR) + "/profiles/ender3_s1_pro_tpu.toml";
  int k = 20;
  for (const auto& [pattern, cell] :
       std::vector<std::pair<std::string, double>>{{"triangle", 1.4}, {"square", 1.1}}) {
    const Prints d = make_prints(pattern, cell, k++);
    const std::string rep = at("again.report.json"), page = at("again.html");
    // reader -> (its arguments, the file that carries the job)
    const std::vector<std::tuple<std::string, std::string, std::string>> runs = {
        {"check", d.lattice + " " + d.toolpath + " --report " + rep, rep},
        {"check", d.lattice + " " + d.gcode + " --machine " + ender + " --report " + rep, rep},
        {"analyze", d.gcode + " --design " + d.lattice + " --align --report " + rep, rep},
        {"analyze", d.toolpath + " --layers --report " + rep, rep},
        {"compare", d.lattice + " " + d.gcode + " " + d.gcode2 + " --report " + rep, rep},
        {"view", d.toolpath + " --design " + d.lattice + " -o " + page, page},
        {"view", d.gcode + " --machine " + ender + " -o " + page, page},
    };
    std::set<std::string> covered;
    for (const auto& [reader, args, file] : runs) {
      fs::remove(file);
      const CmdResult cli = run(reader + " " + args);
      ASSERT_LE(cli.code, 1) << reader << " " << args << ": " << cli.err;
      const std::string first = trellis::read_file(file);
      // The job is in the file, for its route.
      EXPECT_EQ(trellis::job_from_output(file).route, reader) << args;
      // Rerun over the file itself, and to another name in its folder.
      const std::string other = at(std::string("rerun") + fs::path(file).extension().string());
      fs::remove(other);
      CmdResult again = run("rerun " + file + " -o " + other);
      EXPECT_EQ(again.code, cli.code) << reader << " " << args << ": " << again.err;
      ASSERT_TRUE(fs::exists(other)) << reader << " " << args;
      EXPECT_TRUE(trellis::read_file(other) == first) << reader << " " << args;
      again = run("rerun " + file);
      EXPECT_EQ(again.code, cli.code) << reader << " " << args << ": " << again.err;
      EXPECT_TRUE(trellis::read_file(file) == first) << reader << " " << args;
      covered.insert(reader);
      if (reader == "view") continue;
      // A report is the reader's report with the job added, nothing else.
      auto j = nlohmann::ordered_json::parse(first);
      if (j.is_array()) {
        // compare: every analysis carries the same job, and the array holds analyses only.
        ASSERT_FALSE(j.empty()) << args;
        ASSERT_TRUE(j.front().contains("job")) << args;
        const auto job_text = j.front()["job"];
        for (auto& a : j) {
          ASSERT_TRUE(a.contains("job")) << args;
          EXPECT_EQ(a["job"], job_text) << args;
          ASSERT_TRUE(a.contains("extrusion_ratio")) << args;
          a.erase("job");
        }
      } else {
        ASSERT_TRUE(j.contains("job")) << args;
        j.erase("job");
      }
      // The reader run again in the library, writing nothing, makes the rest.
      trellis::Job job = trellis::job_from_output(file);
      job.report.clear();
      trellis::Diagnostics diag;
      EXPECT_EQ(nlohmann::ordered_json::parse(trellis::run_job(job, diag).report_json), j) << args;
    }
    // Every reader whose output can carry a job is covered.
    for (const trellis::RouteSpec& r : trellis::route_specs())
      if (r.reads && (r.main_output == &trellis::Job::report || r.name == "view"))
        EXPECT_TRUE(covered.count(r.name)) << r.name;
    // The job file's run embeds the same job as the command's.
    std::ofstream(at("jobrun.toml"))
        << "[job]\nroute = \"compare\"\ndesign = " + quoted(d.lattice) + "\ninputs = [" +
               quoted(d.gcode) + ", " + quoted(d.gcode2) +
               "]\nreport = \"again.report.json\"\noutput_dir = " + quoted(work().string()) + "\n";
    fs::remove(rep);
    ASSERT_EQ(
        run("compare " + d.lattice + " " + d.gcode + " " + d.gcode2 + " --report " + rep).code, 0);
    const std::string by_command = trellis::read_file(rep);
    fs::remove(rep);
    ASSERT_EQ(run("run " + at("jobrun.toml")).code, 0);
    EXPECT_TRUE(trellis::read_file(rep) == by_command);
    // A print gone since: refused naming it, the report as it was.
    ASSERT_EQ(run("analyze " + d.gcode2 + " --report " + rep).code, 0);
    const std::string kept = trellis::read_file(rep);
    fs::rename(d.gcode2, d.gcode2 + ".moved");
    CmdResult gone = run("rerun " + rep);
    EXPECT_EQ(gone.code, 2);
    EXPECT_NE(gone.err.find(fs::path(d.gcode2).filename().string()), std::string::npos) << gone.err;
    EXPECT_TRUE(trellis::read_file(rep) == kept);
    fs::rename(d.gcode2 + ".moved", d.gcode2);
    // render's PNG carries no job: refused, nothing written.
    const std::string png = at("again.png"), png2 = at("again2.png");
    ASSERT_EQ(run("render " + d.gcode + " --layer 0 --image-size 64 -o " + png).code, 0);
    const std::string pixels = trellis::read_file(png);
    fs::remove(png2);
    gone = run("rerun " + png + " -o " + png2);
    EXPECT_EQ(gone.code, 2);
    EXPECT_NE(gone.err.find("PNG carries no Trellis job"), std::string::npos) << gone.err;
    EXPECT_FALSE(fs::exists(png2));
    EXPECT_TRUE(trellis::read_file(png) == pixels);
  }
}
