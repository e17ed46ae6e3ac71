// A print checked against its design, one way for `trellis check`, `trellis view --design` and
// Python's check_json: the settings' [nozzle] validated, the design cleaned as their [lattice]
// section says, each print read back into design coordinates (read_print) and replayed against
// the nozzle model (check_collisions).
#pragma once
#include <string>

#include "trellis/analysis/collisions.hpp"
#include "trellis/core/budget.hpp"
#include "trellis/lattice/graph.hpp"
#include "trellis/settings/settings.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

class PrintCheck {
 public:
  // `machine`: the settings hold the machine profile the G-code was written for (its valve
  // commands, tool offsets and node overlap); without one, each G-code is read with the job it
  // embeds. `snap` as CheckOptions::snap (kNodeSnap becomes the profile's node overlap +
  // kNodeSnap). `budget`: the reading and the replay are estimated against it first.
  PrintCheck(const Settings& settings, bool machine, double snap = kNodeSnap, Budget budget = {});

  // The design: read from a lattice file, or a graph given in memory; cleaned either way.
  void read_design(const std::string& path, Diagnostics& diag);
  void set_design(const Graph& graph, Diagnostics& diag);
  const Graph& design() const { return design_; }

  // Reads a print (toolpath JSON, G-code, .bgcode or 3MF toolpath) in design coordinates; the
  // options of its check (the snap as that print's machine sets it) become options().
  Toolpath read(const std::string& print, Diagnostics& diag, bool commanded_mixtures = false);
  CollisionCheck check(const Toolpath& print) const;
  // read + check in one, a text G-code streamed from its file (print_layers: memory for the
  // layers a later tip can reach, whatever the file's length); other prints are read whole.
  CollisionCheck check_file(const std::string& print, Diagnostics& diag,
                            bool commanded_mixtures = false);
  const CheckOptions& options() const { return options_; }

 private:
  const Settings& settings_;
  bool machine_;
  double snap_;
  CheckOptions options_;
  CleanOptions clean_;
  Graph design_;
};

// Reading a print to replay it, from its size alone (the whole text and the toolpath with every
// segment are held: about 7 bytes a byte of G-code, 4 of a toolpath JSON).
Estimate print_read_estimate(const std::string& path);
// Streaming it instead: read twice (the replay's own estimate follows the first reading).
Estimate print_stream_estimate(const std::string& path);

}  // namespace trellis
