// The Progress contract per slicing route: a cancel flag set from the progress callback stops
// the call with Cancelled before it finishes; without it the same call finishes.
#include <gtest/gtest.h>

#include <atomic>
#include <mutex>

#include "support/cancel.hpp"
#include "trellis/core/error.hpp"
#include "trellis/field/field.hpp"
#include "trellis/slice/nonplanar.hpp"
#include "trellis/slice/pbf.hpp"
#include "trellis/slice/pipeline.hpp"

using namespace trellis;
using test::CancelAt;

namespace {

std::string design(const std::string& name) {
  return std::string(TRELLIS_SOURCE_DIR) + "/examples/designs/" + name;
}

// Cancelled at the first "outlines" report (every 16 layers), so "walls and infill" never starts.
void expect_cancelled_while_outlining(const SliceJob& job) {
  CancelAt c("outlines");
  EXPECT_THROW(run_slice(job, RunContext{c.progress}), Cancelled);
  const auto reports = c.reports();
  ASSERT_FALSE(reports.empty());
  for (const auto& [stage, f] : reports) {
    EXPECT_EQ(stage, "outlines");
    EXPECT_LT(f, 1.0);
  }
}

}  // namespace

TEST(Cancel, PlanarSlicingStopsWhileOutlining) {
  SliceJob job;
  job.input = design("csg_bracket.vcad");
  job.planar.layer_height = 0.1;
  expect_cancelled_while_outlining(job);
  EXPECT_FALSE(run_slice(job).toolpath.layers.empty());
}

TEST(Cancel, GradedSlicingStopsWhileOutlining) {
  for (int strategy : {1, 2}) {
    SliceJob job;
    job.input = design("fgm_column1_cylinder.vcad");
    job.strategy = strategy;
    job.planar.layer_height = 0.5;
    expect_cancelled_while_outlining(job);
  }
}

TEST(Cancel, SlicingStopsBeforeWallsWhenCancelledAtTheLastOutline) {
  SliceJob job;
  job.input = design("csg_bracket.vcad");
  Progress p;
  std::atomic<bool> flag{false};
  std::atomic<bool> walls{false};
  p.cancel = &flag;
  p.report = [&](const std::string& stage, double f) {
    if (stage == "outlines" && f >= 1) flag = true;
    if (stage == "walls and infill") walls = true;
  };
  EXPECT_THROW(run_slice(job, RunContext{p}), Cancelled);
  EXPECT_FALSE(walls);
}

TEST(Cancel, PbfStopsPerLayer) {
  PbfDesign d;
  d.phi = tpms(TpmsKind::Gyroid, {2.5, 2.5, 2.5});
  d.c = {"0.15"};
  d.envelope = rectprism({2.5, 2.5, 2.5});
  PbfOptions o;  // 0.02 mm layers: 125 layers, reported every 32
  CancelAt c("layers");
  EXPECT_THROW(plan_pbf(d, o, RunContext{c.progress}), Cancelled);
  for (const auto& [stage, f] : c.reports()) EXPECT_LT(f, 0.75);
}

TEST(Cancel, NonplanarStopsPerLayer) {
  NonplanarParams prm;
  prm.layers = 6;
  CancelAt c("layers");  // the first layer's report
  EXPECT_THROW(slice_nonplanar(corrugation({}), prm, RunContext{c.progress}), Cancelled);
  std::size_t joined = 0;
  for (const auto& [stage, f] : c.reports()) joined += stage == "layers";
  EXPECT_EQ(joined, 1u);
  EXPECT_EQ(slice_nonplanar(corrugation({}), prm).toolpath.layers.size(), 6u);
}

// Normal offsets (the slow part: a search per point) report as their lines finish, from the
// worker threads, so a run of a few layers shows progress inside each layer and stops there.
TEST(Cancel, NonplanarNormalOffsetsReportPerLine) {
  NonplanarParams prm;
  prm.layers = 2;
  prm.width = 0.8;
  prm.offset = OffsetMode::Normal;
  std::vector<double> seen;
  std::mutex m;
  Progress p;
  p.report = [&](const std::string& stage, double f) {
    std::lock_guard lock(m);
    if (stage == "normal offsets") seen.push_back(f);
  };
  slice_nonplanar(corrugation({}), prm, RunContext{p});
  std::size_t inside = 0;  // reports strictly between the layers' ends
  for (double f : seen) inside += f > 0 && f < 1 && std::abs(f - 0.5) > 1e-9;
  EXPECT_GT(inside, 10u);
  ASSERT_FALSE(seen.empty());
  EXPECT_DOUBLE_EQ(seen.back(), 1.0);
  for (double f : seen) EXPECT_LE(f, 1.0 + 1e-9);

  CancelAt c("normal offsets");
  EXPECT_THROW(slice_nonplanar(corrugation({}), prm, RunContext{c.progress}), Cancelled);
}
