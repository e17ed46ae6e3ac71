#include <gtest/gtest.h>

#include <cmath>

#include "trellis/core/error.hpp"
#include "trellis/job/reports.hpp"
#include "trellis/lattice/atlas.hpp"
#include "trellis/plan/gippo.hpp"

using namespace trellis;

TEST(GippoRobustness, PerSeedBestScoresAndTheirSpread) {
  AtlasParams a;
  a.pattern = Pattern::Honeycomb;
  a.cell_size = 2;
  a.region.width = a.region.height = 16;
  a.region.center = corner_at_origin(a);
  const Graph g = make_lattice2d(a);
  GippoParams p;
  p.iterations = 40;
  p.seed = 7;
  const GippoRobustness r = gippo_robustness(g, p, 6);
  ASSERT_EQ(r.best_scores.size(), 6u);
  double sum = 0;
  for (int k = 0; k < 6; ++k) {
    // Each seed's best is what a single run with that seed finds.
    GippoParams one = p;
    one.seed = 7 + k;
    const GippoResult x = plan_gippo(g, one);
    EXPECT_EQ(r.seeds[k], 7u + k);
    EXPECT_DOUBLE_EQ(r.best_scores[k], x.scores[x.best_iteration]);
    EXPECT_LE(r.worst_scores[k], r.best_scores[k]);
    // Fig. 2 (vi): each seed's LTS is Eq. 2 of that seed's best (and worst) solution.
    EXPECT_DOUBLE_EQ(r.best_lts[k], path_metrics(g, x.best).lts);
    EXPECT_DOUBLE_EQ(r.worst_lts[k], path_metrics(g, x.worst).lts);
    EXPECT_GE(r.best_lts[k], 0);
    EXPECT_LE(r.best_lts[k], 100);
    sum += r.best_scores[k];
  }
  const double mean = sum / 6;
  double ss = 0;
  for (double v : r.best_scores) ss += (v - mean) * (v - mean);
  EXPECT_NEAR(r.mean, mean, 1e-12);
  EXPECT_NEAR(r.sd, std::sqrt(ss / 5), 1e-12);
  EXPECT_GT(r.sd, 0);  // 40 iterations do not always find the same best
  EXPECT_LE(r.min, r.mean);
  EXPECT_GE(r.max, r.mean);
  EXPECT_THROW(gippo_robustness(g, p, 0), SettingError);
  EXPECT_NE(gippo_robustness_json(r, p).find("\"cv_percent\""), std::string::npos);
  EXPECT_NE(gippo_robustness_json(r, p).find("\"best_lts_per_seed\""), std::string::npos);
  // A stricter threshold for "long" can only lower each seed's LTS.
  const GippoRobustness strict = gippo_robustness(g, p, 6, 9);
  for (int k = 0; k < 6; ++k) EXPECT_LE(strict.best_lts[k], r.best_lts[k]);
}
