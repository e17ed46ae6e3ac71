// Field-driven process parameters: fprocess values along each printed path, quantised to their
// steps and written per piece (include/trellis/slice/fgm_process.hpp).
#include "trellis/slice/fgm_process.hpp"

#include <fmt/format.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <exception>

#include "trellis/core/error.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/slice/pipeline.hpp"

namespace trellis {

namespace {

// Samples along a segment of `length` mm at `sample` mm spacing, at least 1. A non-finite point
// or a count beyond an int (a runaway rather than a design) is an error naming the setting.
int samples_along(double length, double sample) {
  constexpr double kMaxSamples = 1e8;
  if (!std::isfinite(length))
    throw GeometryError("a path has a point that is not finite: cannot sample its process values",
                        {"", 0, "process.sample"});
  const double n = std::ceil(length / sample);
  if (!(n <= kMaxSamples))
    throw GeometryError(fmt::format("a {:g} mm segment at {:g} mm spacing needs {:g} samples (more "
                                    "than {:g}): raise process.sample",
                                    length, sample, n, kMaxSamples),
                        {"", 0, "process.sample"});
  return std::max(1, static_cast<int>(n));
}

// The rounded values a piece is written with; NaN where no fprocess sets the parameter.
struct Key {
  double q[kProcessParams];
  bool operator==(const Key& o) const {
    for (int k = 0; k < kProcessParams; ++k)
      if (!(q[k] == o.q[k] || (std::isnan(q[k]) && std::isnan(o.q[k])))) return false;
    return true;
  }
};

std::string fmt_num(double v) {
  return fmt::format("{:.6g}", v);
}

// Refuses a value the machine cannot print, naming the fprocess node.
void check_range(const ProcessValues& v, Vec3 at, const ProcessOptions& o) {
  for (int k = 0; k < kProcessParams; ++k) {
    const double x = v.value[k];
    if (std::isnan(x)) continue;
    double lo = 0, hi = 0;
    bool lo_open = true;
    std::string limit;
    switch (static_cast<ProcessParam>(k)) {
      case ProcessParam::Temperature:
        hi = o.max_temperature > 0 ? o.max_temperature : 1e9;
        limit = o.max_temperature > 0
                    ? fmt::format("above 0 and at most temperature.max_nozzle = {} °C",
                                  fmt_num(o.max_temperature))
                    : "above 0 °C";
        break;
      case ProcessParam::Speed:
        hi = o.max_speed > 0 ? o.max_speed : 1e9;
        limit = o.max_speed > 0
                    ? fmt::format("above 0 and at most speed.max = {} mm/s", fmt_num(o.max_speed))
                    : "above 0 mm/s";
        break;
      case ProcessParam::Flow:
        hi = 10;
        limit = "above 0 and at most 10 (an extrusion multiplier)";
        break;
      case ProcessParam::Fan:
        hi = 100;
        lo_open = false;
        limit = "0 to 100 %";
        break;
    }
    const bool ok = (lo_open ? x > lo : x >= lo) && x <= hi;
    if (!ok)
      throw GeometryError(
          fmt::format("{}: {} = {} at ({:.3f}, {:.3f}, {:.3f}) is out of the machine's range "
                      "(must be {})",
                      *v.node[k], to_string(static_cast<ProcessParam>(k)), fmt_num(x), at.x, at.y,
                      at.z, limit),
          {"", 0, ""});
  }
}

struct LayerResult {
  std::size_t paths = 0, pieces = 0, merged = 0, samples = 0, short_slowed = 0;
  std::vector<unsigned> masks;  // per path of the layer: bit k = parameter k set by a field
  std::array<double, kProcessParams> deviation{};
  std::exception_ptr error;
};

class PathSplitter {
 public:
  PathSplitter(Evaluator& ev, const ProcessOptions& o, LayerResult& r, double dz)
      : ev_(ev), o_(o), r_(r), dz_(dz) {}

  // The field at a toolpath point (its design coordinates).
  ProcessValues at(Vec3 p) { return ev_.process({p.x, p.y, p.z + dz_}); }

  Key key(Vec3 p) {
    const ProcessValues v = at(p);
    ++r_.samples;
    check_range(v, {p.x, p.y, p.z + dz_}, o_);
    Key k;
    for (int i = 0; i < kProcessParams; ++i) {
      const double s = o_.step(static_cast<ProcessParam>(i));
      k.q[i] = std::isnan(v.value[i]) ? v.value[i] : std::round(v.value[i] / s) * s;
      // Every sample lies in a piece written with its own rounded value (unless merged).
      if (!std::isnan(v.value[i]))
        r_.deviation[i] = std::max(r_.deviation[i], std::abs(v.value[i] - k.q[i]));
    }
    return k;
  }

  // The path cut where its key changes, pieces under min_length merged into a neighbour.
  std::vector<Path> split(const Path& path) {
    std::vector<Path> pieces;
    std::vector<Key> keys;
    Key cur = key(path.points.front());
    Path proto = path;  // the attributes; its points released (pieces must not keep their capacity)
    proto.points = std::vector<Vec3>();
    auto start = [&](Vec3 at, const Key& k) {
      Path p = proto;
      p.points.assign(1, at);
      pieces.push_back(std::move(p));
      keys.push_back(k);
    };
    start(path.points.front(), cur);
    for (std::size_t i = 1; i < path.points.size(); ++i) {
      const Vec3 a = path.points[i - 1], b = path.points[i];
      const double len = distance(a, b);
      const int n = samples_along(len, o_.sample);
      double lo = 0;
      for (int j = 1; j <= n; ++j) {
        const double t = static_cast<double>(j) / n;
        Key k = key(a + (b - a) * t);
        // The key may change more than once between two samples: one bisection per change.
        for (int guard = 0; !(k == cur) && guard < 64; ++guard) {
          double l = lo, h = t;
          Key kh = k;
          for (int it = 0; it < 40 && (h - l) * len > 1e-4; ++it) {  // 0.1 µm
            const double m = 0.5 * (l + h);
            Key km = key(a + (b - a) * m);
            if (km == cur) {
              l = m;
            } else {
              h = m;
              kh = km;
            }
          }
          const Vec3 cut = a + (b - a) * h;
          if (distance(cut, pieces.back().points.back()) > 1e-9)
            pieces.back().points.push_back(cut);
          if (pieces.back().points.size() < 2) {  // a cut at the piece's start: re-key it
            keys.back() = kh;
          } else {
            start(cut, kh);
          }
          cur = kh;
          lo = h;
        }
        lo = t;
      }
      if (distance(b, pieces.back().points.back()) > 1e-12) pieces.back().points.push_back(b);
    }
    if (pieces.back().points.size() < 2) {  // cut at the very end
      pieces.pop_back();
      keys.pop_back();
    }
    std::vector<char> grown;
    merge_short(pieces, keys, grown);
    const bool field_speed = std::any_of(keys.begin(), keys.end(), [](const Key& k) {
      return !std::isnan(k.q[static_cast<int>(ProcessParam::Speed)]);
    });
    if (field_speed && o_.short_path_factor != 1 &&
        path.segments() < static_cast<std::size_t>(std::max(0, o_.short_path_segments)))
      ++r_.short_slowed;
    for (std::size_t k = 0; k < pieces.size(); ++k) {
      write(pieces[k], keys[k], k > 0 || path.joined);
      unsigned mask = 0;
      for (int i = 0; i < kProcessParams; ++i)
        if (!std::isnan(keys[k].q[i])) mask |= 1u << i;
      r_.masks.push_back(mask);
    }
    // Pieces that took others in: measured; the rest are within the samples' rounding (key()).
    for (std::size_t k = 0; k < pieces.size(); ++k)
      if (grown[k]) measure(pieces[k]);
    return pieces;
  }

 private:
  // Pieces under min_length joined to the previous piece (a short start: to the next), in one
  // pass; `grown` marks the pieces that took others in (their deviation must be measured).
  void merge_short(std::vector<Path>& pieces, std::vector<Key>& keys, std::vector<char>& grown) {
    std::vector<Path> out;
    std::vector<Key> out_keys;
    grown.clear();
    for (std::size_t i = 0; i < pieces.size(); ++i) {
      Path& p = pieces[i];
      if (!out.empty() && p.length() < o_.min_length) {
        auto& prev = out.back().points;
        prev.insert(prev.end(), p.points.begin() + 1, p.points.end());
        grown.back() = 1;
        ++r_.merged;
        continue;
      }
      if (out.size() == 1 && out[0].length() < o_.min_length) {
        p.points.insert(p.points.begin(), out[0].points.begin(), out[0].points.end() - 1);
        out[0] = std::move(p);
        out_keys[0] = keys[i];
        grown[0] = 1;
        ++r_.merged;
        continue;
      }
      out.push_back(std::move(p));
      out_keys.push_back(keys[i]);
      grown.push_back(0);
    }
    pieces = std::move(out);
    keys = std::move(out_keys);
  }

  static void write(Path& p, const Key& k, bool joined) {
    const double* q = k.q;
    if (!std::isnan(q[0])) p.temperature = q[0];
    if (!std::isnan(q[1])) p.speed = q[1];
    if (!std::isnan(q[2])) p.flow = q[2];
    if (!std::isnan(q[3])) p.fan = q[3];
    p.joined = joined;
    if (joined) p.via.clear();  // no travel into a piece that continues the bead
  }

  // Max |field − written| along a piece, at the sample spacing and both ends.
  void measure(const Path& p) {
    for (std::size_t i = 1; i < p.points.size(); ++i) {
      const Vec3 a = p.points[i - 1], b = p.points[i];
      const int n = samples_along(distance(a, b), o_.sample);
      for (int j = i == 1 ? 0 : 1; j <= n; ++j) {
        const ProcessValues v = at(a + (b - a) * (static_cast<double>(j) / n));
        for (int k = 0; k < kProcessParams; ++k) {
          if (std::isnan(v.value[k])) continue;
          const double w = written_process_value(p, static_cast<ProcessParam>(k));
          if (!std::isnan(w)) r_.deviation[k] = std::max(r_.deviation[k], std::abs(v.value[k] - w));
        }
      }
    }
  }

  Evaluator& ev_;
  const ProcessOptions& o_;
  LayerResult& r_;
  double dz_ = 0;
};

}  // namespace

double ProcessOptions::step(ProcessParam p) const {
  switch (p) {
    case ProcessParam::Temperature:
      return temperature_step;
    case ProcessParam::Speed:
      return speed_step;
    case ProcessParam::Flow:
      return flow_step;
    case ProcessParam::Fan:
      return fan_step;
  }
  return 1;
}

double written_process_value(const Path& path, ProcessParam p) {
  const double nan = std::nan("");
  switch (p) {
    case ProcessParam::Temperature:
      return path.temperature > 0 ? path.temperature : nan;
    case ProcessParam::Speed:
      return path.speed > 0 ? path.speed : nan;
    case ProcessParam::Flow:
      return path.flow > 0 ? path.flow : nan;
    case ProcessParam::Fan:
      return path.fan >= 0 ? path.fan : nan;
  }
  return nan;
}

namespace {

void check_options(const ProcessOptions& o) {
  for (int k = 0; k < kProcessParams; ++k)
    if (!(o.step(static_cast<ProcessParam>(k)) > 0))
      throw SettingError("process steps must be > 0", {"", 0, "process"});
  if (!(o.sample > 0)) throw SettingError("process.sample must be > 0", {"", 0, "process.sample"});
}

// One layer's paths split where a rounded value changes (the layer-local step).
void split_layer(Evaluator& ev, const ProcessOptions& o, Layer& layer, double dz, LayerResult& r) {
  PathSplitter splitter(ev, o, r, dz);
  std::vector<Path> out;
  for (const Path& p : layer.paths) {
    if (p.points.size() < 2) {
      out.push_back(p);
      r.masks.push_back(0);
      continue;
    }
    ++r.paths;
    for (Path& q : splitter.split(p)) {
      out.push_back(std::move(q));
      ++r.pieces;
    }
  }
  layer.paths = std::move(out);
}

}  // namespace

// The written values and their changes in print order (the whole-print step): a layer at a
// time, after split_layer, for the whole and the streamed run alike.
struct ProcessPass::Tally {
  std::array<double, kProcessParams> last;
  std::array<std::string, kProcessParams> nodes;
  Tally() { last.fill(std::nan("")); }
  void add(Evaluator& ev, const Layer& layer, const LayerResult& r, ProcessStats& st) {
    st.paths += r.paths;
    st.pieces += r.pieces;
    st.merged += r.merged;
    st.samples += r.samples;
    st.short_slowed += r.short_slowed;
    for (int k = 0; k < kProcessParams; ++k)
      st.param[k].max_deviation = std::max(st.param[k].max_deviation, r.deviation[k]);
    const auto& paths = layer.paths;
    for (std::size_t pi = 0; pi < paths.size(); ++pi) {
      if (paths[pi].points.size() >= 2) {
        // The node that sets a parameter: named from the first path that meets it.
        const ProcessValues v = ev.process(paths[pi].points.front());
        for (int k = 0; k < kProcessParams; ++k)
          if (v.node[k] && nodes[k].empty()) nodes[k] = *v.node[k];
      }
      const unsigned mask = r.masks[pi];
      for (int k = 0; k < kProcessParams; ++k) {
        if (!(mask & (1u << k))) continue;
        ProcessParamStats& s = st.param[k];
        const double w = written_process_value(paths[pi], static_cast<ProcessParam>(k));
        if (!s.set) {
          s.set = true;
          s.min = s.max = w;
          s.node = nodes[k];
        }
        s.min = std::min(s.min, w);
        s.max = std::max(s.max, w);
        if (!std::isnan(last[k]) && w != last[k]) ++s.changes;
        last[k] = w;
      }
    }
  }
};

struct ProcessPass::Evaluators {
  explicit Evaluators(const Field& design) : per_thread([&design] { return Evaluator(design); }) {}
  tbb::enumerable_thread_specific<Evaluator> per_thread;
};

ProcessPass::ProcessPass(const Field& design, const ProcessOptions& options)
    : options_(options),
      ev_(std::make_unique<Evaluator>(design)),
      evaluators_(std::make_unique<Evaluators>(design)),
      tally_(std::make_unique<Tally>()) {
  check_options(options_);
  stats_.active = true;
}
ProcessPass::~ProcessPass() = default;

void ProcessPass::layers(const std::vector<Layer*>& layers, const std::vector<double>& dz) {
  // Split in parallel, then counted in order; the lowest layer's error, so the message does not
  // depend on the threads.
  std::vector<LayerResult> results(layers.size());
  tbb::parallel_for(std::size_t{0}, layers.size(), [&](std::size_t i) {
    try {
      split_layer(evaluators_->per_thread.local(), options_, *layers[i], dz[i], results[i]);
    } catch (...) {
      results[i].error = std::current_exception();
    }
  });
  for (const auto& r : results)
    if (r.error) std::rethrow_exception(r.error);
  for (std::size_t i = 0; i < layers.size(); ++i) tally_->add(*ev_, *layers[i], results[i], stats_);
}

void apply_process_fields(const Field& design, Toolpath& toolpath, const ProcessOptions& o,
                          ProcessStats* stats, const std::vector<double>& design_dz) {
  if (!design.has_process()) {
    if (stats) *stats = ProcessStats{};
    return;
  }
  // The streamed pass over every layer at once.
  ProcessPass pass(design, o);
  std::vector<Layer*> layers;
  std::vector<double> dz;
  for (std::size_t li = 0; li < toolpath.layers.size(); ++li) {
    layers.push_back(&toolpath.layers[li]);
    dz.push_back(design_dz.empty() ? 0.0 : design_dz[std::min(li, design_dz.size() - 1)]);
  }
  pass.layers(layers, dz);
  if (stats) *stats = pass.stats();
}

std::vector<double> process_design_dz(const SliceJob& job, const SliceResult& r) {
  // A layer's outline is the one at its nozzle height (part layer g at (g + 1) h; a graded
  // toolpath leaves out layers without paths, so the indices need not match).
  std::vector<double> dz;
  const double h = job.planar.layer_height;
  for (const Layer& l : r.toolpath.layers) {
    const long g = std::lround(l.z / h) - 1 - static_cast<long>(r.outline_first);
    dz.push_back(g >= 0 && static_cast<std::size_t>(g) < r.outlines.size()
                     ? r.outlines[static_cast<std::size_t>(g)].z - l.z
                     : (dz.empty() ? 0.0 : dz.back()));
  }
  return dz;
}

void apply_slice_process(const SliceJob& job, const Field& design, SliceResult& r) {
  if (!design.has_process()) return;
  try {
    apply_process_fields(design, r.toolpath, job.process, &r.process, process_design_dz(job, r));
  } catch (const GeometryError& e) {
    if (!e.where().file.empty()) throw;
    throw GeometryError(e.message(), {job.input, 0, e.where().element});
  }
  check_process_temperature(job, r.process);
}

void check_process_temperature(const SliceJob& job, const ProcessStats& stats) {
  const ProcessParamStats& t = stats.param[static_cast<int>(ProcessParam::Temperature)];
  if (t.set && job.strategy != 0 && job.process.temperature_from_mixture)
    throw SettingError(t.node +
                           " sets the nozzle temperature, but the machine makes the "
                           "gradient's mixtures with it (gradient.mode = temperature): drop the "
                           "temperature field or print the gradient on a mixing or tool-changer "
                           "profile",
                       {job.input, 0, "gradient.mode"});
}

namespace {
constexpr const char* kUnits[kProcessParams] = {" °C", " mm/s", "", " %"};
}

std::string process_summary(const ProcessStats& st, const GcodeStats& g) {
  if (!st.active) return {};
  std::string s = "; process fields:";
  bool first = true;
  for (int k = 0; k < kProcessParams; ++k) {
    const ProcessParamStats& p = st.param[k];
    if (!p.set) continue;
    s += fmt::format("{} {} {}..{}{} ({} changes", first ? "" : ",",
                     to_string(static_cast<ProcessParam>(k)), fmt_num(p.min), fmt_num(p.max),
                     kUnits[k], p.changes);
    if (k == static_cast<int>(ProcessParam::Temperature))
      s += fmt::format(", +{} s settle", fmt_num(g.settle_time_s));
    s += fmt::format(", max deviation {})", fmt_num(p.max_deviation));
    first = false;
  }
  if (first) s += " none reached a printed path";
  return s;
}

std::vector<std::pair<std::string, std::string>> process_warnings(const ProcessStats& st,
                                                                  const ProcessOptions& o) {
  std::vector<std::pair<std::string, std::string>> out;
  for (int k = 0; k < kProcessParams; ++k) {
    const ProcessParamStats& p = st.param[k];
    const double half = o.step(static_cast<ProcessParam>(k)) / 2;
    if (p.set && p.max_deviation > half * (1 + 1e-6) + 1e-9)
      out.emplace_back(
          "process_quantisation",
          fmt::format("{}: the written {} strays up to {}{} from the field, more than half its "
                      "step ({}{}): "
                      "{} pieces shorter than process.min_length = {} mm were merged into a "
                      "neighbour; use a "
                      "smaller process.min_length or a larger step",
                      p.node, to_string(static_cast<ProcessParam>(k)), fmt_num(p.max_deviation),
                      kUnits[k], fmt_num(half), kUnits[k], st.merged, fmt_num(o.min_length)));
  }
  if (st.short_slowed > 0)
    out.emplace_back(
        "process_short_paths",
        fmt::format(
            "{}: {} paths of fewer than speed.short_path_segments = {} segments print at "
            "speed.short_path_factor = {} x the speed field (as every short path does; set the "
            "factor to 1 to print the field's speed there)",
            st.param[static_cast<int>(ProcessParam::Speed)].node, st.short_slowed,
            o.short_path_segments, fmt_num(o.short_path_factor)));
  return out;
}

}  // namespace trellis
