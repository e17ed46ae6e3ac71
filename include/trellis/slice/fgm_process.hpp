// Field-driven process parameters (FGM issue item 5): the temperature, speed, flow and fan a
// design sets with fprocess nodes, evaluated along every printed path of a sliced toolpath and
// written per piece: each path is split where the value rounded to its step changes (the split
// found by bisection between samples), the pieces after the first marked `joined` (one bead,
// no travel). Values outside the machine's range are refused naming the fprocess node; what is
// written is measured against the field along every piece (max deviation per parameter).
#pragma once
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "trellis/field/field.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

struct ProcessOptions {
  // Quantum per parameter: the written value is the field rounded to a multiple of it, so it
  // stays within half a step of the field; a path is split where the rounded value changes.
  double temperature_step = 1;  // °C
  double speed_step = 1;        // mm/s
  double flow_step = 0.01;      // multiplier
  double fan_step = 1;          // %
  double sample = 0.2;          // mm between samples along a path
  double min_length = 0.5;      // mm: shorter pieces are merged into the previous one
  // The machine's limits (from the profile): beyond them is an error naming the node.
  double max_temperature = 0;  // °C, 0 = unchecked
  double max_speed = 0;        // mm/s, 0 = unchecked
  // The profile makes mixtures with the nozzle temperature (gradient.mode = temperature): a
  // temperature field on a graded print would fight it.
  bool temperature_from_mixture = false;
  // The writer slows paths of fewer segments than this by the factor (speed.short_path_*),
  // field speeds too: counted and warned about.
  int short_path_segments = 0;
  double short_path_factor = 1;
  double step(ProcessParam p) const;
};

struct ProcessParamStats {
  bool set = false;          // some fprocess node sets it
  double min = 0, max = 0;   // of the written values
  std::size_t changes = 0;   // written value changes, in print order
  double max_deviation = 0;  // |field − written| over the samples of every piece
  std::string node;          // the fprocess node that sets it (first seen)
};

struct ProcessStats {
  bool active = false;
  std::array<ProcessParamStats, kProcessParams> param;
  std::size_t paths = 0;   // printed paths the field applies to
  std::size_t pieces = 0;  // after splitting
  std::size_t merged = 0;  // pieces under min_length merged into their neighbour
  std::size_t samples = 0;
  std::size_t short_slowed = 0;  // paths with a field speed the writer slows as short paths
};

// Applies the design's process fields to every printed path of `toolpath` (in place). Throws
// GeometryError naming the fprocess node when a value is out of range; no-op without fprocess.
// `design_dz[i]` is added to the Z of layer i's points to get design coordinates (the planar
// slicer puts the first layer on Z = 0; a point is evaluated at its layer's slicing plane);
// layers beyond it take its last entry, none = 0.
void apply_process_fields(const Field& design, Toolpath& toolpath, const ProcessOptions& options,
                          ProcessStats* stats = nullptr, const std::vector<double>& design_dz = {});

// The same pass a few layers at a time, in print order (streamed slicing): layers() splits the
// layers' paths in parallel (`dz[i]` added to layer i's points' Z gives design coordinates) and
// counts what is written in order; stats() is apply_process_fields's for the layers so far.
// Errors as apply_process_fields's, at the lowest layer that has one.
class ProcessPass {
 public:
  ProcessPass(const Field& design, const ProcessOptions& options);
  ~ProcessPass();
  ProcessPass(const ProcessPass&) = delete;
  ProcessPass& operator=(const ProcessPass&) = delete;
  void layers(const std::vector<Layer*>& layers, const std::vector<double>& dz);
  const ProcessStats& stats() const { return stats_; }

 private:
  struct Tally;
  struct Evaluators;
  ProcessOptions options_;
  std::unique_ptr<Evaluator> ev_;
  std::unique_ptr<Evaluators> evaluators_;
  std::unique_ptr<Tally> tally_;
  ProcessStats stats_;
};

// The value a path is written with (NaN when the path does not set it).
double written_process_value(const Path& path, ProcessParam p);

// The slice route's step (slice/pipeline.hpp): applies the design's fprocess fields to the
// planned toolpath into result.process; errors name the design file and the node.
struct SliceJob;
struct SliceResult;
void apply_slice_process(const SliceJob& job, const Field& design, SliceResult& result);
// A temperature field on a graded print whose machine makes its mixtures by temperature:
// SettingError naming the node.
void check_process_temperature(const SliceJob& job, const ProcessStats& stats);
// Per toolpath layer of `result`, what to add to its points' Z for design coordinates.
std::vector<double> process_design_dz(const SliceJob& job, const SliceResult& result);

// The summary's part for a print with process fields ("" without): per parameter the range
// written, its changes, and the settle time the temperature changes add (from the writer).
struct GcodeStats;
std::string process_summary(const ProcessStats& stats, const GcodeStats& gcode);
// Warnings as (kind, message), naming the node: "process_quantisation" for a parameter whose
// written values stray beyond half a step from the field (pieces merged under min_length),
// "process_short_paths" when the writer slows short paths below the speed field.
std::vector<std::pair<std::string, std::string>> process_warnings(const ProcessStats& stats,
                                                                  const ProcessOptions& options);

}  // namespace trellis
