// Measuring a printed toolpath (ours or any slicer's, read from G-code) against the design
// lattice: how much was extruded compared with the struts, what was deposited twice, which struts
// were never printed, what landed off the design, and the GIPPO numbers of the printed paths.
#pragma once
#include <string>
#include <vector>

#include "trellis/core/diagnostics.hpp"
#include "trellis/geom/polygon.hpp"
#include "trellis/lattice/graph.hpp"
#include "trellis/machine/gcode_reader.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

// Streaming counts over G-code moves (constant memory).
struct GcodeCounts {
  std::size_t extrusion_moves = 0, extrusion_starts = 0, travel_moves = 0, retractions = 0;
  // Layers as the toolpath IR has them (gcode_reader.hpp): by layer comment, else by the z of
  // the extrusion; a layer without extrusion is not counted.
  std::size_t layers = 0;
  // Paths of the toolpath IR: runs of connected extrusion, split also where the tool, feature
  // type, mixture or temperature changes (the paths `trellis view` shows).
  std::size_t toolpath_paths = 0;
  // Our graded G-code's "; mixture lookahead" (mm; 0: none). With one, analyze_gcode_file counts
  // toolpath_paths on the IR read as deposited (GcodeReadOptions::commanded_mixtures).
  double mixture_lookahead = 0;
  double extruded_length = 0, travel_length = 0, filament = 0;
  // The print-time estimate (machine/print_time.hpp): moves with acceleration and jerk, dwells
  // and heater waits; heating_s is the heater waits' part of it (other slicers leave it out).
  double print_time_s = 0, heating_s = 0;
  // Prime lines drawn before the print (not paths; their filament is not in `filament`).
  double prime_length = 0, prime_filament = 0;
  // Per-path sums for Eq. 1-3 (a path = a run of connected extrusion moves; its edges = moves).
  std::size_t paths = 0;
  double weighted = 0;                        // Σ length_i · edges_i
  double long_length = 0, long_weighted = 0;  // the same over long paths (≥ long_nodes nodes)
  // Build plates: per labelled part (M486 / Klipper EXCLUDE_OBJECT), in order of first use, the
  // extrusion and the time of the moves made while it is open (travels into it included).
  struct Part {
    std::string label;
    double extruded_length = 0, filament = 0, print_time_s = 0;
  };
  std::vector<Part> parts;
  // Per layer (the IR's layers, in order): extrusion starts, retractions, travel moves and their
  // XY length. A travel belongs to the layer of the extrusion it leads to, a retraction to the
  // layer being printed (those before the first extrusion to the first layer).
  struct Layer {
    double z = 0;
    std::size_t starts = 0, retractions = 0, travel_moves = 0;
    double travel_length = 0;
  };
  std::vector<Layer> per_layer;
};

class CountingSink : public GcodeSink {
 public:
  // `acceleration` (mm/s²): the time estimate's when the file sets none (limits() without one).
  explicit CountingSink(std::size_t long_nodes = 5, double acceleration = 0)
      : long_nodes_(long_nodes), acceleration_(acceleration) {
    limits(MotionLimits{});
  }
  void layer_change(double) override { commented_ = layer_pending_ = true; }
  void extrude(Vec3 a, Vec3 b, double e, double feed) override;
  void travel(Vec3 a, Vec3 b, double feed) override;
  void retract() override;
  void tool_change(int) override { attribute_changed_ = true; }
  void role(PathRole) override { attribute_changed_ = true; }
  void mixture(const std::vector<double>&) override { attribute_changed_ = true; }
  void mixture_lookahead(double mm) override { counts.mixture_lookahead = mm; }
  void temperature(double) override { attribute_changed_ = true; }
  void object(std::string_view label) override;
  void dwell(double seconds) override { time_.dwell(seconds); }
  void motion(Vec3 a, Vec3 b, double de, double feed) override { time_.move(a, b, de, feed); }
  void limits(const MotionLimits& l) override {
    MotionLimits with = l;
    if (with.acceleration == 0) with.acceleration = acceleration_;
    time_.set_limits(with);
  }
  void heater(int heater, double celsius, bool wait) override {
    time_sink_heater(heater, celsius, wait);
  }
  void home() override { time_.flush(); }
  void prime(Vec3 a, Vec3 b, double e, double feed) override;
  // Closes the last path and completes the time estimate; call once after the last line.
  void finish();
  GcodeCounts counts;

 private:
  enum class State { Idle, Extruding, Travelling };
  State state_ = State::Idle;
  bool extruded_ = false;
  bool commented_ = false, layer_pending_ = false, attribute_changed_ = false;
  double layer_z_ = 0;
  double pending_ = 0;                 // travel length since the last extrusion
  std::size_t early_retractions_ = 0;  // before the first extrusion
  Vec3 last_;
  std::size_t long_nodes_;
  double acceleration_;
  PrintTimeEstimator time_;  // the one estimate (the writer's too), tagged by part
  void time_sink_heater(int heater, double celsius, bool wait);
  std::ptrdiff_t part_ = -1;  // index into counts.parts of the labelled part open, -1 = none
  double path_length_ = 0;
  std::size_t path_edges_ = 0;
  void close_path();
};

struct AnalysisParams {
  double width = 0.2;           // bead width: deposits closer than width/2 to a strut cover it (mm)
  double layer_height = 0.148;  // nozzle z = design z + layer height
  double parallel_cos = 0.9;    // a pass covers a strut when it runs within ~25° of it
  double min_covered = 0.5;     // a strut is missing if less than this fraction is covered
  std::size_t long_nodes = 5;
  bool align_centers = false;  // move the print's XY centre onto the design's before measuring
  // Without align_centers: align anyway when less than half of the extruded length lies in the
  // design's XY box (a part placed on the bed); Analysis::auto_aligned says so.
  bool auto_align = true;
  bool keep_printed = false;  // build the IR (Analysis::printed) even without a design
  double acceleration = 0;    // mm/s² for the print-time estimate (0 = feed rates only)
};

struct StrutCoverage {
  EdgeId edge;
  double covered = 0;  // fraction of the strut (outside node zones) covered
  int passes = 0;      // most passes over one point of it
};

struct LayerAnalysis {
  double z = 0;               // printed layer height
  double nominal_length = 0;  // design struts matched to this layer
  double extruded_length = 0;
  double double_length = 0;  // strut length covered by more than one pass (counted per extra pass)
  double off_design_length = 0;  // deposits farther than width/2 from every strut
  std::size_t design_edges = 0, missing_edges = 0;
  // The fewest paths that print the layer's struts each once: Σ max(1, odd nodes / 2) over its
  // connected components (lattice/graph.hpp).
  std::size_t lower_bound = 0;
  std::vector<Segment2> doubles;  // pieces deposited twice (for pictures)
  std::vector<EdgeId> missing;    // missing struts
};

struct Analysis {
  std::string name;
  GcodeCounts counts;
  std::size_t paths = 0, edges_real = 0, edges_nominal = 0;
  double extruded_length = 0, nominal_length = 0, extrusion_ratio = 0;
  double double_length = 0, off_design_length = 0;
  std::size_t design_edges = 0, missing_edges = 0;
  double score = 0, score_corrected = 0, lts = 0, oe = 0;
  bool has_design = false;
  bool auto_aligned = false;  // the print was moved onto the design by auto_align
  Vec2 shift;                 // XY added to the print to align it (0 if not aligned)
  std::vector<LayerAnalysis> layers;
  Toolpath printed;  // the print as measured (after alignment), for pictures
};

// `printed` is the IR read from G-code; `counts` its streaming counts; `design` may be null.
Analysis analyze(const Toolpath& printed, const GcodeCounts& counts, const Graph* design,
                 const AnalysisParams& params);

// The counts of a planned toolpath, as its G-code would give them to a CountingSink: every
// segment an extrusion move, the moves between paths (through their via points) travel (none
// where a path starts at the end of the last: one run, as the writer prints it), feeds
// from the paths' speeds (0: no time). Filament and retractions are the machine's, so 0.
GcodeCounts toolpath_counts(const Toolpath& toolpath);

// Whether `p` continues the run `prev` (the path printed before it; null for the first) ends: it
// starts where `prev` ends with no travel between (joined, or no travel corners), so the writer
// prints both as one run of extrusion. A path of `trellis analyze` (GcodeCounts::paths) and of
// the viewer is a run: this path is a piece of the one before. A laser path (power > 0) never is.
bool continues_run(const Path* prev, const Path& p);
// The runs of extrusion between travels in a toolpath (toolpath_counts(t).paths, cheaper).
std::size_t run_count(const Toolpath& toolpath);

// Reads a G-code file and analyses it (the IR is kept in memory for the design comparison).
Analysis analyze_gcode_file(const std::string& path, const Graph* design,
                            const AnalysisParams& params, const GcodeReadOptions& read,
                            Diagnostics& diag);

std::string comparison_table(const std::vector<Analysis>& runs);

}  // namespace trellis
