// The PBF route's shared per-layer work on a real section (issue 21): the compensated R67 hatch
// of a gyroid sheet's cross-section (`hatch_inset`, the section's outline as the direct route
// densifies it: ~50 µm edges), the hybrid path's trim of the thin walls (`trim_hatch` with
// remove_inside), and the contour chords along the mid-curve φ = 0 (`chord_vectors`, SL 100 µm,
// LHD 20 µm). Single thread, default settings (hatch 40 µm, beam compensation 30 µm); one layer
// of a 4-cell cube of 2.5 mm cells, c = 0.15.
#include <benchmark/benchmark.h>

#include <cmath>

#include "../src/slice/pbf_chords.hpp"
#include "trellis/field/field.hpp"
#include "trellis/geom/contour.hpp"
#include "trellis/geom/regions.hpp"
#include "trellis/slice/pbf.hpp"

using namespace trellis;

namespace {

class Cut : public PlaneFunction {
 public:
  Cut(const Field& f, double z) : e_(f), z_(z) {}
  void sample(const Vec2* p, double* out, std::size_t n) override {
    pts_.resize(n);
    for (std::size_t i = 0; i < n; ++i) pts_[i] = {p[i].x, p[i].y, z_};
    e_.values(pts_.data(), out, n);
  }

 private:
  Evaluator e_;
  double z_;
  std::vector<Vec3> pts_;
};

// The sheet's section at z and, standing in for its thin walls, the section of a narrower sheet
// on the same mid-surface (c = 0.06).
struct Layer {
  Regions section, thin;
};

Layer layer(double z) {
  PbfDesign d;
  d.phi = tpms(TpmsKind::Gyroid, {2.5, 2.5, 2.5});
  d.c = {"0.15"};
  d.envelope = rectprism({10, 10, 10});
  PbfDesign narrow = d;
  narrow.c = {"0.06"};
  MarchOptions mo;
  mo.resolution = 0.05;  // the section's outline after densification on the 0.1 mm grid
  mo.refine_fraction = 5e-3;
  Layer L;
  Cut s(d.part(), z), t(narrow.part(), z);
  L.section = nest_oriented_rings(march_squares(s, {-5.2, -5.2}, {5.2, 5.2}, 0, mo).lines.loops);
  L.thin = nest_oriented_rings(march_squares(t, {-5.2, -5.2}, {5.2, 5.2}, 0, mo).lines.loops);
  return L;
}

void BM_HatchInsetSection(benchmark::State& state) {
  const Layer L = layer(0.31);
  std::size_t n = 0;
  for (auto _ : state) {
    const auto h = hatch_inset(L.section, {}, 67, 0.04, 0.03);
    n = h.size();
    benchmark::DoNotOptimize(h.data());
  }
  state.counters["vectors"] = static_cast<double>(n);
}

void BM_TrimHatchThinWalls(benchmark::State& state) {
  const Layer L = layer(0.31);
  const auto h = hatch_inset(L.section, {}, 67, 0.04, 0.03);
  std::size_t n = 0;
  for (auto _ : state) {
    const auto t = trim_hatch(h, L.thin, 67, 0.04, 0.03, true);
    n = t.size();
    benchmark::DoNotOptimize(t.data());
  }
  state.counters["vectors"] = static_cast<double>(n);
}

// Every mid-curve line of the layer cut into chords (the whole curve, as if all of it were thin).
void BM_ChordVectorsMidCurve(benchmark::State& state) {
  const double z = 0.31;
  const Field phi = tpms(TpmsKind::Gyroid, {2.5, 2.5, 2.5});
  Cut cut(phi, z);
  MarchOptions mo;
  mo.resolution = 0.05;
  mo.refine_fraction = 0.01;
  const auto lines = march_squares(cut, {-5, -5}, {5, 5}, 0, mo).lines;
  Evaluator e(phi);
  const pbf_detail::Curve curve{[&](Vec2 q, Vec2* g) {
                                  Vec3 g3;
                                  const double f = e.value_gradient({q.x, q.y, z}, &g3);
                                  *g = {g3.x, g3.y};
                                  return f;
                                },
                                0.1};
  std::size_t n = 0;
  for (auto _ : state) {
    std::vector<std::vector<Vec2>> out;
    for (const auto& l : lines.open)
      pbf_detail::chord_vectors(l, false, 0.1, 0.02, 0.03, curve, out);
    for (auto l : lines.loops) {
      l.push_back(l.front());
      pbf_detail::chord_vectors(l, true, 0.1, 0.02, 0.03, curve, out);
    }
    n = out.size();
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["chords"] = static_cast<double>(n);
}

}  // namespace

BENCHMARK(BM_HatchInsetSection)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_TrimHatchThinWalls)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ChordVectorsMidCurve)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
