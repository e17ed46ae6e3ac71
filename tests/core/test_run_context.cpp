// One run context (core/run_context.hpp) passed the same way to every entry point: a cancel set
// through it stops plan_pbf, run_slice, plan_gippo and a whole job (nothing written); warnings
// reach its diagnostics; its threads bound the work and do not change the result.
#include <gtest/gtest.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <random>
#include <set>
#include <thread>

#include "support/cancel.hpp"
#include "support/temp_dir.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/run_context.hpp"
#include "trellis/field/field.hpp"
#include "trellis/job/job.hpp"
#include "trellis/lattice/atlas.hpp"
#include "trellis/plan/gippo.hpp"
#include "trellis/slice/pbf.hpp"
#include "trellis/slice/pipeline.hpp"

namespace fs = std::filesystem;
using namespace trellis;
using test::CancelAt;

namespace {

std::string design(const std::string& name) {
  return std::string(TRELLIS_SOURCE_DIR) + "/examples/designs/" + name;
}

std::string fmt_c(double c) {
  return std::to_string(c);
}

// Small TPMS sheets of generated kinds, cells and thicknesses (seeded).
std::vector<PbfDesign> sheets(std::uint64_t seed, int n, double height = 0.6) {
  std::mt19937_64 rng(seed);
  const TpmsKind kinds[] = {TpmsKind::Gyroid, TpmsKind::SchwarzP, TpmsKind::SchwarzD};
  std::uniform_real_distribution<double> cell(1.5, 3.0), c(0.1, 0.3), size(1.5, 2.5);
  std::vector<PbfDesign> out;
  for (int i = 0; i < n; ++i) {
    PbfDesign d;
    const double a = cell(rng);
    d.phi = tpms(kinds[i % 3], {a, a, a});
    d.c = {fmt_c(c(rng))};
    const double s = size(rng);
    d.envelope = rectprism({s, s, height});
    out.push_back(d);
  }
  return out;
}

RunContext with_threads(int threads) {
  RunContext c;
  c.threads = threads;
  return c;
}

void expect_same_layers(const PbfResult& a, const PbfResult& b, const std::string& at) {
  ASSERT_EQ(a.layers.size(), b.layers.size()) << at;
  for (std::size_t i = 0; i < a.layers.size(); ++i) {
    const PbfLayer &x = a.layers[i], &y = b.layers[i];
    ASSERT_EQ(x.contours.size(), y.contours.size()) << at << " layer " << i;
    for (std::size_t k = 0; k < x.contours.size(); ++k) {
      ASSERT_EQ(x.contours[k].size(), y.contours[k].size()) << at << " layer " << i;
      for (std::size_t j = 0; j < x.contours[k].size(); ++j) {
        EXPECT_EQ(x.contours[k][j].x, y.contours[k][j].x) << at << " layer " << i;
        EXPECT_EQ(x.contours[k][j].y, y.contours[k][j].y) << at << " layer " << i;
      }
    }
    ASSERT_EQ(x.hatches.size(), y.hatches.size()) << at << " layer " << i;
    for (std::size_t k = 0; k < x.hatches.size(); ++k) {
      EXPECT_EQ(x.hatches[k].a.x, y.hatches[k].a.x) << at << " layer " << i;
      EXPECT_EQ(x.hatches[k].a.y, y.hatches[k].a.y) << at << " layer " << i;
      EXPECT_EQ(x.hatches[k].b.x, y.hatches[k].b.x) << at << " layer " << i;
      EXPECT_EQ(x.hatches[k].b.y, y.hatches[k].b.y) << at << " layer " << i;
    }
  }
}

void expect_same_toolpath(const Toolpath& a, const Toolpath& b, const std::string& at) {
  ASSERT_EQ(a.layers.size(), b.layers.size()) << at;
  for (std::size_t i = 0; i < a.layers.size(); ++i) {
    ASSERT_EQ(a.layers[i].paths.size(), b.layers[i].paths.size()) << at << " layer " << i;
    for (std::size_t k = 0; k < a.layers[i].paths.size(); ++k) {
      const Path &p = a.layers[i].paths[k], &q = b.layers[i].paths[k];
      ASSERT_EQ(p.points.size(), q.points.size()) << at << " layer " << i;
      EXPECT_EQ(p.role, q.role) << at << " layer " << i;
      for (std::size_t j = 0; j < p.points.size(); ++j) {
        EXPECT_EQ(p.points[j].x, q.points[j].x) << at << " layer " << i;
        EXPECT_EQ(p.points[j].y, q.points[j].y) << at << " layer " << i;
        EXPECT_EQ(p.points[j].z, q.points[j].z) << at << " layer " << i;
      }
    }
  }
}

}  // namespace

TEST(RunContext, DefaultDoesNothingAndWarnWithoutDiagnosticsIsANoOp) {
  const RunContext c;
  EXPECT_FALSE(c.cancelled());
  EXPECT_NO_THROW(c.check("nothing"));
  EXPECT_NO_THROW(c.report("stage", 0.5));
  EXPECT_NO_THROW(c.warn("kind", "dropped"));
  Diagnostics d;
  RunContext with;
  with.diagnostics = &d;
  with.warn("kind", "kept");
  EXPECT_EQ(d.count("kind"), 1u);
  std::atomic<bool> flag{true};
  with.progress.cancel = &flag;
  EXPECT_TRUE(with.cancelled());
  EXPECT_THROW(with.check("work"), Cancelled);
}

// The arena of `threads` workers: no more threads than that ever run the work inside it.
TEST(RunContext, ThreadsBoundTheWorkersOfTheCall) {
  for (const int threads : {1, 2, 3}) {
    std::mutex m;
    std::set<std::thread::id> seen;
    with_threads(threads).run([&] {
      tbb::parallel_for(0, 20000, [&](int) {
        std::lock_guard lock(m);
        seen.insert(std::this_thread::get_id());
      });
    });
    EXPECT_GE(seen.size(), 1u);
    EXPECT_LE(seen.size(), static_cast<std::size_t>(threads)) << threads;
  }
}

TEST(RunContext, CancelStopsPlanPbf) {
  for (const PbfDesign& d : sheets(7, 3, 2.5)) {
    PbfOptions o;
    o.layer = 0.02;  // 125 layers, reported every 32
    CancelAt c("layers");
    RunContext context;
    context.progress = c.progress;
    EXPECT_THROW(plan_pbf(d, o, context), Cancelled);
    for (const auto& [stage, f] : c.reports()) EXPECT_LT(f, 1.0) << stage;
    EXPECT_FALSE(plan_pbf(d, o).layers.empty());  // the same call without cancel finishes
  }
}

TEST(RunContext, CancelStopsRunSlice) {
  for (const double h : {0.1, 0.2}) {
    SliceJob job;
    job.input = design("csg_bracket.vcad");
    job.planar.layer_height = h;
    CancelAt c("outlines");
    RunContext context;
    context.progress = c.progress;
    EXPECT_THROW(run_slice(job, context), Cancelled);
    for (const auto& [stage, f] : c.reports()) EXPECT_NE(stage, "walls and infill");
  }
}

TEST(RunContext, CancelStopsPlanGippo) {
  for (const double width : {8.0, 12.0}) {
    AtlasParams a;
    a.region.width = a.region.height = width;
    const Graph g = make_lattice2d(a);
    GippoParams p;
    p.iterations = 3000;
    CancelAt c("gippo");
    RunContext context;
    context.progress = c.progress;
    context.threads = 2;
    EXPECT_THROW(plan_gippo(g, p, context), Cancelled);
    for (const auto& [stage, f] : c.reports()) EXPECT_LT(f, 0.5);
  }
}

// A job cancelled through the context of run_job: Cancelled, and none of its outputs written.
TEST(RunContext, CancelledJobWritesNothing) {
  const test::TempDir tmp("trellis_run_context");
  const fs::path job_file = tmp / "g.toml";
  std::ofstream(job_file)
      << "[job]\nroute = \"pbf\"\nname = \"g\"\n[pbf]\nsize = [2.5, 2.5, 2.5]\n";  // 125 layers
  for (const std::string& stage : {std::string("layers"), std::string()}) {
    const fs::path out = tmp / ("out" + stage);
    Job job = load_job(job_file.string(), out.string(), {"output.png=false"});
    Diagnostics diag;
    CancelAt c(stage);
    RunContext context;
    context.progress = c.progress;
    context.diagnostics = &diag;
    EXPECT_THROW(run_job(job, context), Cancelled) << stage;
    EXPECT_FALSE(c.reports().empty());
    std::size_t files = 0;
    if (fs::exists(out))
      for (const auto& e : fs::recursive_directory_iterator(out)) files += e.is_regular_file();
    EXPECT_EQ(files, 0u) << stage;
  }
}

// Warnings of a call go to the context's diagnostics (and stay in the result's).
TEST(RunContext, WarningsReachTheContextsDiagnostics) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> outside(0.45, 0.8);  // SL beyond the paper's 400 µm
  for (const PbfDesign& d : sheets(11, 3)) {
    PbfOptions o;
    o.layer = 0.1;
    o.segment_length = outside(rng);
    Diagnostics diag;
    RunContext context;
    context.diagnostics = &diag;
    const PbfResult r = plan_pbf(d, o, context);
    EXPECT_EQ(diag.count("pbf.sl_untested"), 1u);
    EXPECT_EQ(diag.total(), r.diagnostics.total());
    o.segment_length = 0.1;  // inside: nothing said
    Diagnostics quiet;
    context.diagnostics = &quiet;
    plan_pbf(d, o, context);
    EXPECT_EQ(quiet.count("pbf.sl_untested"), 0u);
  }
  // Through run_job: the job's warnings (a setting outside the paper's range) in the context's.
  const test::TempDir tmp("trellis_run_context_warn");
  const fs::path job_file = tmp / "w.toml";
  std::ofstream(job_file)
      << "[job]\nroute = \"pbf\"\nname = \"w\"\n[pbf]\nsize = [2.5, 2.5, 0.3]\n";
  Job job = load_job(job_file.string(), (tmp / "out").string(),
                     {"output.png=false", "scan.segment_length=0.6"});
  Diagnostics diag;
  RunContext context;
  context.diagnostics = &diag;
  run_job(job, context);
  EXPECT_GE(diag.count("pbf.sl_untested"), 1u);
}

TEST(RunContext, OneOrTwoThreadsMakeTheSamePbfPaths) {
  for (const PbfDesign& d : sheets(5, 3)) {
    PbfOptions o;
    o.layer = 0.05;
    const PbfResult one = plan_pbf(d, o, with_threads(1));
    const PbfResult two = plan_pbf(d, o, with_threads(2));
    EXPECT_FALSE(one.layers.empty());
    expect_same_layers(one, two, d.c.text);
  }
}

TEST(RunContext, OneOrTwoThreadsMakeTheSameSlice) {
  for (const std::string& name : {std::string("csg_bracket.vcad"), std::string("bracket_20mm.stl")})
    for (const double h : {0.2, 0.3}) {
      SliceJob job;
      job.input = design(name);
      job.planar.layer_height = h;
      const SliceResult one = run_slice(job, with_threads(1));
      const SliceResult two = run_slice(job, with_threads(2));
      EXPECT_FALSE(one.toolpath.layers.empty());
      expect_same_toolpath(one.toolpath, two.toolpath, name);
    }
}

// The context's budget is what run_slice checks its estimates against: a time budget far below
// the estimate refuses the run before any layer; forced, it runs.
TEST(RunContext, BudgetIsTheContexts) {
  SliceJob job;
  job.input = design("csg_bracket.vcad");
  job.planar.layer_height = 0.2;
  RunContext context;
  context.budget.seconds = 1e-9;
  std::size_t seen = 0;
  context.progress.estimate = [&](const Estimate&) { ++seen; };
  EXPECT_THROW(run_slice(job, context), ResourceError);
  EXPECT_GE(seen, 1u);
  context.budget.force = true;
  EXPECT_FALSE(run_slice(job, context).toolpath.layers.empty());
}
