// PBF layers streamed through the bounded pipeline and written layer by layer (issues 21, 23):
// the same vectors and the same file bytes as the whole run, any layer range computed on its own
// equal to that range of the whole, 1 and 2 threads alike, an error leaving no file.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <filesystem>
#include <string>
#include <vector>

#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/machine/cli.hpp"
#include "trellis/slice/pbf.hpp"

using namespace trellis;

namespace {

PbfDesign small_gyroid() {
  PbfDesign d;
  d.phi = tpms(TpmsKind::Gyroid, {2.5, 2.5, 2.5});
  d.c = {"0.15"};
  d.envelope = rectprism({2.5, 2.5, 1.2});
  return d;
}

PbfOptions small_options() {
  PbfOptions o;
  o.layer = 0.04;  // 30 layers
  return o;
}

void expect_same_vectors(const PbfLayer& a, const PbfLayer& b, std::size_t i) {
  ASSERT_EQ(a.contours.size(), b.contours.size()) << "layer " << i;
  for (std::size_t k = 0; k < a.contours.size(); ++k) {
    ASSERT_EQ(a.contours[k].size(), b.contours[k].size()) << "layer " << i;
    for (std::size_t m = 0; m < a.contours[k].size(); ++m) {
      EXPECT_EQ(a.contours[k][m].x, b.contours[k][m].x) << "layer " << i;
      EXPECT_EQ(a.contours[k][m].y, b.contours[k][m].y) << "layer " << i;
    }
  }
  ASSERT_EQ(a.hatches.size(), b.hatches.size()) << "layer " << i;
  for (std::size_t k = 0; k < a.hatches.size(); ++k) {
    EXPECT_EQ(a.hatches[k].a.x, b.hatches[k].a.x) << "layer " << i;
    EXPECT_EQ(a.hatches[k].b.y, b.hatches[k].b.y) << "layer " << i;
  }
  EXPECT_EQ(a.z, b.z);
  EXPECT_EQ(a.hatch_angle, b.hatch_angle);
  EXPECT_EQ(a.fr, b.fr);
  EXPECT_EQ(a.area, b.area);
}

TEST(PbfStream, SinkGetsEveryLayerInOrderWithTheWholeRunsVectors) {
  const PbfDesign d = small_gyroid();
  const PbfOptions o = small_options();
  const PbfResult whole = plan_pbf(d, o);
  ASSERT_EQ(whole.layers.size(), pbf_layer_count(d, o));
  ASSERT_GT(whole.layers.size(), 20u);
  for (const std::size_t threads : {1u, 2u}) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    std::vector<PbfLayer> got;
    std::vector<std::size_t> order;
    const PbfResult streamed = plan_pbf(d, o, [&](std::size_t i, const PbfLayer& L) {
      order.push_back(i);
      got.push_back(L);
    });
    ASSERT_EQ(got.size(), whole.layers.size()) << threads << " threads";
    for (std::size_t i = 0; i < got.size(); ++i) {
      EXPECT_EQ(order[i], i);
      expect_same_vectors(got[i], whole.layers[i], i);
    }
    // The result keeps the series, not the vectors; the totals are the whole run's.
    ASSERT_EQ(streamed.layers.size(), whole.layers.size());
    for (const auto& L : streamed.layers) {
      EXPECT_TRUE(L.contours.empty() && L.contours.capacity() == 0);
      EXPECT_TRUE(L.hatches.empty() && L.hatches.capacity() == 0);
    }
    EXPECT_EQ(streamed.layers[7].fr, whole.layers[7].fr);
    EXPECT_EQ(streamed.contour_vectors, whole.contour_vectors);
    EXPECT_EQ(streamed.hatch_vectors, whole.hatch_vectors);
    EXPECT_DOUBLE_EQ(streamed.hatch_length, whole.hatch_length);
    EXPECT_GT(whole.contour_vectors, 0u);
    EXPECT_GT(whole.hatch_vectors, 0u);
  }
}

TEST(PbfStream, ALayerRangeOnItsOwnIsThatRangeOfTheWholeRun) {
  const PbfDesign d = small_gyroid();
  const PbfOptions o = small_options();
  const PbfResult whole = plan_pbf(d, o);
  const std::size_t n = whole.layers.size();
  // Shards as a sharding run would cut them (uneven, touching), each started cold.
  const std::vector<std::pair<std::size_t, std::size_t>> shards{{0, 7}, {7, 8}, {8, 19}, {19, n}};
  std::size_t next = 0;
  for (const auto& [a, b] : shards) {
    const PbfResult part = plan_pbf(d, o,
                                    [&](std::size_t i, const PbfLayer& L) {
                                      ASSERT_EQ(i, next++);
                                      expect_same_vectors(L, whole.layers[i], i);
                                    },
                                    {a, b});
    EXPECT_EQ(part.layers.size(), b - a);
  }
  EXPECT_EQ(next, n);
  // Past the end: nothing; the end is clamped.
  EXPECT_TRUE(plan_pbf(d, o, [](std::size_t, const PbfLayer&) {}, {n + 3, n + 9}).layers.empty());
  EXPECT_EQ(plan_pbf(d, o, [](std::size_t, const PbfLayer&) {}, {n - 2}).layers.size(), 2u);
}

// The same for a part taller than a period of its TPMS (25 layers of 0.1 mm in 2.5 mm cells),
// tiled across the plane and along z: layers a period apart take tiles made from their class of
// layers alone (PbfTestSwitches::z_tiles_budget), so a shard started cold makes the same ones as
// the whole run, which kept them from a layer the shard does not have.
TEST(PbfStream, ALayerRangeOfATallTiledPartIsThatRangeOfTheWholeRun) {
  PbfDesign d = small_gyroid();
  d.envelope = rectprism({5, 5, 6});
  PbfOptions o;
  o.layer = 0.1;  // 60 layers
  const PbfResult whole = plan_pbf(d, o);
  EXPECT_GT(whole.tiled_blocks, 0u);
  const std::size_t n = whole.layers.size();
  ASSERT_GT(n, 50u);
  std::size_t next = 27;
  const PbfResult part = plan_pbf(d, o,
                                  [&](std::size_t i, const PbfLayer& L) {
                                    ASSERT_EQ(i, next++);
                                    expect_same_vectors(L, whole.layers[i], i);
                                  },
                                  {27, n});
  EXPECT_EQ(next, n);
}

std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("trellis_pbf_stream_" + name)).string();
}

TEST(PbfStream, CliWrittenLayerByLayerIsByteForByteTheWholeFile) {
  const PbfDesign d = small_gyroid();
  const PbfOptions o = small_options();
  const LaserProfile prof;
  const PbfResult whole = plan_pbf(d, o);
  Toolpath tp = pbf_toolpath(whole, prof.contour_power, prof.contour_speed, prof.hatch_power,
                             prof.hatch_speed);
  tp.job = "[job]\nroute = 'pbf'";
  for (const bool binary : {false, true}) {
    const CliWriteOptions wo{binary, true};
    const std::string path = temp_path(binary ? "b.cli" : "a.cli");
    {
      CliStreamWriter w(path, prof, wo, tp.source, tp.job);
      plan_pbf(d, o, [&](std::size_t i, const PbfLayer& L) {
        w.add(pbf_layer_toolpath(L, i, o.layer, prof.contour_power, prof.contour_speed,
                                 prof.hatch_power, prof.hatch_speed));
      });
      EXPECT_FALSE(std::filesystem::exists(path));  // nothing before finish()
      w.finish();
    }
    const std::string want = write_cli(tp, prof, wo);
    EXPECT_EQ(read_file(path), want) << (binary ? "binary" : "ascii");
    EXPECT_GT(want.size(), 10000u);
    std::filesystem::remove(path);
  }
}

TEST(PbfStream, ALayerTheLaserCannotScanLeavesNoFile) {
  LaserProfile prof;
  const std::string path = temp_path("refused.cli");
  std::filesystem::remove(path);
  Layer ok, hot;
  ok.z = 0.02;
  hot.z = 0.04;
  Path p;
  p.role = PathRole::Contour;
  p.power = prof.contour_power;
  p.speed = prof.contour_speed;
  p.points = {{0, 0, 0.02}, {1, 0, 0.02}};
  ok.paths.push_back(p);
  p.power = prof.max_power * 2;
  hot.paths.push_back(p);
  try {
    CliStreamWriter w(path, prof, {}, "test", "");
    w.add(ok);
    w.add(hot);
    w.finish();
    FAIL() << "a path above the laser's power was written";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("layer 1 path 0"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(path));
  // The whole part beyond the plate (each layer alone within it) is refused at finish().
  prof.build_x = 5;
  Layer a, b;
  Path q = ok.paths[0];
  q.points = {{0, 0, 0.02}, {3, 0, 0.02}};
  a.paths.push_back(q);
  q.points = {{-3, 0, 0.04}, {0, 0, 0.04}};
  b.paths.push_back(q);
  EXPECT_THROW(
      {
        CliStreamWriter w(path, prof, {}, "test", "");
        w.add(a);
        w.add(b);
        w.finish();
      },
      Error);
  EXPECT_FALSE(std::filesystem::exists(path));
}

}  // namespace
