#include "trellis/job/print_check.hpp"

#include <fmt/format.h>

#include <filesystem>

#include "trellis/job/job.hpp"
#include "trellis/lattice/io.hpp"

namespace trellis {

PrintCheck::PrintCheck(const Settings& settings, bool machine, double snap, Budget budget)
    : settings_(settings), machine_(machine), snap_(snap) {
  const Config cfg = settings.config();
  cfg.aero.nozzle.validate();
  options_.nozzle = cfg.aero.nozzle;
  options_.snap = snap;
  options_.budget = std::move(budget);
  clean_ = cfg.clean_options();
}

void PrintCheck::read_design(const std::string& path, Diagnostics& diag) {
  design_ = read_lattice(path, clean_, diag);
}

void PrintCheck::set_design(const Graph& graph, Diagnostics& diag) {
  design_ = clean_graph(graph, clean_, diag);
}

Toolpath PrintCheck::read(const std::string& print, Diagnostics& diag, bool commanded_mixtures) {
  check_budget(print_read_estimate(print), options_.budget);
  options_.snap = snap_;  // each print's machine sets its own
  return read_print(print, machine_ ? &settings_ : nullptr, &options_.snap, diag,
                    commanded_mixtures);
}

CollisionCheck PrintCheck::check(const Toolpath& print) const {
  return check_collisions(design_, print, options_);
}

CollisionCheck PrintCheck::check_file(const std::string& print, Diagnostics& diag,
                                      bool commanded_mixtures) {
  options_.snap = snap_;
  const LayerSource layers = print_layers(print, machine_ ? &settings_ : nullptr, &options_.snap,
                                          diag, commanded_mixtures);
  if (!layers) return check(read(print, diag, commanded_mixtures));
  check_budget(print_stream_estimate(print), options_.budget);
  return check_collisions(design_, layers, options_);
}

// Measured on a 28 MB G-code of 10^6 moves: 183 MB at peak, about 7 bytes a byte of G-code; a
// toolpath JSON is held at about 4 bytes a byte (estimate_gcode_of). Reading at about 50 MB/s.
Estimate print_read_estimate(const std::string& path) {
  std::error_code ec;
  const double size = static_cast<double>(std::filesystem::file_size(path, ec));
  Estimate e;
  if (ec) return e;  // the reader says what is wrong with the file
  const bool json = std::filesystem::path(path).extension() == ".json";
  e.bytes = size * (json ? 4 : 7);
  e.seconds = size * 2e-8;
  e.what = fmt::format("reading a {:.3g} MB print to replay", size / 1e6);
  e.change = "the print (check it in parts)";
  return e;
}

Estimate print_stream_estimate(const std::string& path) {
  Estimate e = print_read_estimate(path);
  e.bytes = 0;  // a chunk and a layer
  e.seconds *= 2;
  e.what += " (read twice: streamed)";
  return e;
}

}  // namespace trellis
