// Targets (issue 4): the Stanford bunny lattice (1,093 struts) planned in under 50 ms (the AERO
// program's Python needed 63 s here); a 100,000-strut lattice in under 10 s on 2 cores.
// Counters: trails, lower bound and violations of the plan, so speed and quality are read together.
#include <benchmark/benchmark.h>

#include "trellis/analysis/collisions.hpp"
#include "trellis/lattice/cells3d.hpp"
#include "trellis/lattice/io.hpp"
#include "trellis/plan/aero.hpp"

using namespace trellis;

namespace {

Graph example(const std::string& name) {
  Diagnostics d;
  return read_lattice(std::string(TRELLIS_SOURCE_DIR) + "/tests/data/aero/" + name + "_edges.csv",
                      {}, d);
}

void plan(benchmark::State& state, const Graph& g, AeroParams p) {
  AeroResult r;
  for (auto _ : state) {
    Diagnostics d;
    r = plan_aero(g, p, d);
    benchmark::DoNotOptimize(r.trails.trails.data());
  }
  state.counters["struts"] = static_cast<double>(g.edges.size());
  state.counters["trails"] = static_cast<double>(r.trails.trails.size());
  state.counters["lower_bound"] = static_cast<double>(r.lower_bound_trails);
  state.counters["violations"] = static_cast<double>(r.violations.size());
  state.counters["runs"] = static_cast<double>(r.runs);
}

}  // namespace

static void BM_AeroBunny(benchmark::State& state) {
  static const Graph g = example("stanford_bunny");
  plan(state, g, {});
}
BENCHMARK(BM_AeroBunny)->Unit(benchmark::kMillisecond)->UseRealTime();

static void BM_AeroOctet3x3x3(benchmark::State& state) {
  static const Graph g = example("octet_3x3x3");
  plan(state, g, {});
}
BENCHMARK(BM_AeroOctet3x3x3)->Unit(benchmark::kMillisecond)->UseRealTime();

static void BM_AeroPaperGroupsBunny(benchmark::State& state) {
  static const Graph g = example("stanford_bunny");
  AeroParams p;
  p.method = AeroMethod::Groups;
  plan(state, g, p);
}
BENCHMARK(BM_AeroPaperGroupsBunny)->Unit(benchmark::kMillisecond)->UseRealTime();

// 16x16x16 octet cells: 101,376 struts.
static void BM_Aero100k(benchmark::State& state) {
  static const Graph g = cell_lattice({UnitCell::Octet, 7, 16, 16, 16});
  plan(state, g, {});
}
BENCHMARK(BM_Aero100k)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);

static void BM_CollisionModel100k(benchmark::State& state) {
  static const Graph g = cell_lattice({UnitCell::Octet, 7, 16, 16, 16});
  std::size_t relations = 0;
  for (auto _ : state) relations = blocking_graph(g, NozzleModel{}).relations();
  state.counters["relations"] = static_cast<double>(relations);
}
BENCHMARK(BM_CollisionModel100k)->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1);

static void BM_CheckBunny(benchmark::State& state) {
  static const Graph g = example("stanford_bunny");
  Diagnostics d;
  static const Toolpath tp = aero_toolpath(g, plan_aero(g, {}, d), "bench");
  for (auto _ : state) benchmark::DoNotOptimize(check_collisions(g, tp, {}).collisions);
}
BENCHMARK(BM_CheckBunny)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_MAIN();
