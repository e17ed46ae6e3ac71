// The slicers' reports: the planar and graded slice route (slice_report_json), the non-planar
// route (nonplanar_report_json) and the process pass's object in them (process_json).
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>

#include "process_json.hpp"
#include "trellis/geom/polygon.hpp"
#include "trellis/job/reports.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

std::string slice_report_json(const SliceJob& job, const SliceResult& r, const GcodeStats* g) {
  nlohmann::ordered_json j;
  j["format"] = "trellis.slice_report";
  j["version"] = 1;
  j["input"] = job.input;
  j["route"] = to_string(r.route);
  j["extent_mm"] = {{"min", {r.extent.min.x, r.extent.min.y, r.extent.min.z}},
                    {"max", {r.extent.max.x, r.extent.max.y, r.extent.max.z}}};
  j["settings"] = {{"layer_height_mm", job.planar.layer_height},
                   {"bead_width_mm", job.planar.bead_width},
                   {"walls", job.planar.walls},
                   {"top_layers", job.planar.top_layers},
                   {"bottom_layers", job.planar.bottom_layers},
                   {"infill_density", job.planar.infill_density},
                   {"infill_angle_deg", job.planar.infill_angle},
                   {"resolution_mm", job.field.resolution},
                   {"mesh_voxel_mm", job.mesh_voxel}};
  double outline_area = r.outline_area;
  std::size_t empty_layers = r.empty_layers;
  for (const auto& l : r.outlines) {
    outline_area += area(l.regions);
    empty_layers += l.regions.empty() ? 1 : 0;
  }
  const TravelStats travel = r.streamed ? r.travel : travel_stats(r.toolpath);
  j["layers"] = r.streamed ? r.layers : r.outlines.size();
  j["empty_layers"] = empty_layers;
  j["paths"] = r.planar.paths;
  j["wall_loops"] = r.planar.walls;
  j["skin_paths"] = r.planar.skin_lines;
  j["infill_lines"] = r.planar.infill_lines;
  j["extruded_length_mm"] = r.planar.extruded_length;
  j["travel_moves"] = travel.moves;
  j["travel_length_mm"] = travel.length;
  j["outline_area_mm2_total"] = outline_area;
  if (job.strategy == 0) {
    // The linking stage (slice/link.hpp): starts beside their lower bound, per layer and in all.
    const PlanarOptions& po = job.planar;
    const LinkStats& l = r.planar.link;
    nlohmann::json per = {{"starts", nlohmann::json::array()},
                          {"lower_bound", nlohmann::json::array()},
                          {"travel_mm", nlohmann::json::array()},
                          {"travels_leaving_part", nlohmann::json::array()}};
    for (const LinkStats& s : r.planar.layer_link) {
      per["starts"].push_back(s.starts);
      per["lower_bound"].push_back(s.lower_bound);
      per["travel_mm"].push_back(std::round(s.travel_length * 1000) / 1000);
      per["travels_leaving_part"].push_back(s.travels - s.inside_travels);
    }
    j["linking"] = {{"seam", to_string(po.link.seam)},
                    {"connect", po.link.connect},
                    {"connect_max_spacings", po.link.connect_max},
                    {"comb", po.link.comb},
                    {"comb_detour", po.link.comb_detour},
                    {"infill_pattern", to_string(po.infill_pattern)},
                    {"starts", l.starts},
                    {"starts_lower_bound", l.lower_bound},
                    {"travels_in_layers", l.travels},
                    {"travels_inside_part", l.inside_travels},
                    {"travel_in_layers_mm", l.travel_length},
                    {"fill_lines", l.fill_lines},
                    {"fill_chains", l.fill_chains},
                    {"connector_length_mm", l.connector_length},
                    {"layer_plan_seconds", r.planar.layer_seconds},
                    {"link_seconds", r.planar.link_seconds},
                    {"per_layer", std::move(per)}};
    if (po.infill_pattern == InfillPattern::Lattice)
      j["linking"]["lattice"] = {{"pattern", po.infill_lattice},
                                 {"trails", r.planar.lattice_trails},
                                 {"trails_lower_bound", r.planar.lattice_trail_bound}};
  }
  if (r.route == SliceRoute::Field)
    j["field"] = {{"samples", r.field_stats.samples},
                  {"blocks", r.field_stats.blocks},
                  {"blocks_skipped_by_bounds", r.field_stats.skipped_blocks}};
  if (r.mesh_triangles) j["mesh_triangles"] = r.mesh_triangles;
  if (r.repaired)
    j["mesh_repair"] = {{"degenerate_faces", r.repair.degenerate_faces},
                        {"duplicate_faces", r.repair.duplicate_faces},
                        {"nonmanifold_edges", r.repair.nonmanifold_edges},
                        {"flipped_faces", r.repair.flipped_faces},
                        {"stitched_edges", r.repair.stitched_edges},
                        {"snapped_vertices", r.repair.snapped_vertices},
                        {"holes_filled", r.repair.holes_filled},
                        {"hole_faces", r.repair.hole_faces},
                        {"nonmanifold_vertices", r.repair.nonmanifold_vertices},
                        {"inverted_faces", r.repair.inverted_faces},
                        {"summary", r.repair.summary()}};
  if (job.strategy == 1 || job.strategy == 2)
    j["fgm"] = {{"strategy", job.strategy},
                {"purges", r.fgm.purges},
                {"purge_volume_mm3", r.fgm.purge_volume},
                {"purge_mass_g", r.fgm.purge_volume * 1.24e-3},
                {"colors", r.fgm.quantized_from ? job.tools : job.fgm.palette.colors},
                {"colors_asked", job.fgm.palette.colors},
                {"colors_used", r.fgm.colours_used},
                {"materials", r.fgm.materials},
                {"zipper_percent", 100 * job.fgm.zipper},
                {"material_resolution_mm", job.fgm.material_resolution},
                {"gradient_error",
                 {{"mean", r.fgm.error_mean},
                  {"max", r.fgm.error_max},
                  {"bound", r.fgm.error_bound},
                  {"samples", r.fgm.error_samples},
                  {"length_mm", r.fgm.error_length},
                  {"mean_weighted_by", "length"},
                  {"mixtures", r.fgm.error_lookahead > 0 ? "deposited" : "planned"},
                  {"lookahead_mm", r.fgm.error_lookahead}}},
                {"band_percent", 100.0 * r.fgm.band},
                {"faces", r.fgm.faces},
                {"order", to_string(job.fgm.order)},
                {"paths", r.fgm.paths},
                {"joined_pieces", r.fgm.joined},
                {"colour_changes", r.fgm.colour_changes},
                {"abrupt_changes", r.fgm.abrupt_changes},
                {"shortest_segment_mm", r.fgm.shortest_path},
                {"min_segment",
                 {{"min_mm", r.fgm.min_segment},
                  {"merged", r.fgm.short_merged},
                  {"kept", r.fgm.short_kept},
                  {"refused_by_gradient_bound", r.fgm.short_kept_bound},
                  {"whole_beads", r.fgm.short_beads},
                  {"kept_reason", r.fgm.short_kept == 0
                                      ? ""
                                      : "merging would exceed the gradient bound α/2 (or no "
                                        "piece of another colour touches it end to end); use "
                                        "more colours or a smaller fgm.min_segment"}}},
                {"gradient_changes", g ? g->gradient_changes : 0},
                {"lookahead_mm", g ? g->lookahead : 0.0},
                {"fill", job.fgm.concentric ? "concentric" : "rectilinear"}};
  if ((job.strategy == 1 || job.strategy == 2) &&
      (r.streamed ? !r.colour_use.empty() : !r.toolpath.layers.empty())) {
    // §4.1: material and time per colour of the part itself (the tower's share follows). Volume
    // with the rectangular bead (bead width × layer height) the fills balance against and the
    // writer's E deposits; densities per material from the profile, as the tower's.
    std::map<std::vector<double>, std::pair<double, double>> by_mixture =
        r.colour_use;  // length, time
    if (!r.streamed)
      for (const auto& l : r.toolpath.layers) add_colour_use(job, l, by_mixture);
    const double h = job.planar.layer_height, w = job.planar.bead_width;
    const double bead_area = w * h;
    nlohmann::ordered_json colours = nlohmann::json::array();
    double mass_total = 0, time_total = 0;
    for (const auto& [mixture, lt] : by_mixture) {
      double density = 0;
      for (std::size_t m = 0; m < mixture.size(); ++m)
        density += mixture[m] * (m < job.purge.density.size() ? job.purge.density[m] : 1.0);
      const double volume = lt.first * bead_area, mass = volume * 1e-3 * density;
      mass_total += mass;
      time_total += lt.second;
      colours.push_back({{"mixture", mixture},
                         {"length_mm", lt.first},
                         {"volume_mm3", volume},
                         {"mass_g", mass},
                         {"time_s", lt.second}});
    }
    j["fgm"]["part_colours"] = colours;
    j["fgm"]["part_mass_g"] = mass_total;
    j["fgm"]["part_time_s"] = time_total;
  }
  if (r.fgm.tower.built) {
    // §4.1 reports material and time per colour.
    nlohmann::ordered_json colours = nlohmann::json::array();
    for (const auto& c : r.fgm.tower.colours)
      colours.push_back({{"color", c.color},
                         {"mixture", c.mixture},
                         {"purges", c.purges},
                         {"length_mm", c.length},
                         {"volume_mm3", c.volume},
                         {"mass_g", c.mass},
                         {"time_s", c.time}});
    j["fgm"]["tower"] = {{"centre_mm", {r.fgm.tower.x, r.fgm.tower.y}},
                         {"side_mm", r.fgm.tower.side},
                         {"size_mm", {r.fgm.tower.size_x, r.fgm.tower.size_y}},
                         {"layers", r.fgm.tower.layers},
                         {"purge_length_mm", r.fgm.tower.purge_path},
                         {"length_mm", r.fgm.tower.length},
                         {"volume_mm3", r.fgm.tower.volume},
                         {"mass_g", r.fgm.tower.mass},
                         {"time_s", r.fgm.tower.time},
                         {"colours", colours}};
  }
  if (g) {
    j["gcode"] = {{"bytes", g->bytes},
                  {"filament_mm", g->filament},
                  {"retractions", g->retractions},
                  {"print_time_s", g->print_time_s}};
  }
  if (r.process.active) j["process"] = process_json(r.process, job.process, g);  // fprocess fields
  return j.dump(2) + "\n";
}

std::string nonplanar_report_json(const NonplanarResult& r, const NonplanarParams& prm,
                                  const HeightField& surface, const SurfaceDeviation& dev,
                                  const GcodeStats* g) {
  nlohmann::ordered_json j;
  j["surface"] = surface.name();
  j["kind"] = surface.is_mesh() ? "mesh" : "function";
  j["footprint_mm"] = {surface.domain().width(), surface.domain().height()};
  j["path_width_mm"] = prm.width;
  j["layer_height_mm"] = prm.layer_height;
  j["offset"] = to_string(prm.offset);
  j["chord_tolerance_mm"] = prm.chord_tolerance;
  j["layers"] = r.layers.size();
  double length = 0, conn = 0;
  std::size_t travel = 0, changes = 0, jumps = 0;
  for (std::size_t k = 0; k < r.layers.size(); ++k) {
    length += r.layers[k].length, conn += r.layers[k].connector_length;
    jumps += r.layers[k].jumps;
    travel += r.layers[k].travel_moves;
    if (k > 0 && r.layers[k].tool != r.layers[k - 1].tool) ++changes;
  }
  j["path_length_mm"] = length;
  j["connector_length_mm"] = conn;
  j["travel_moves_within_layers"] = travel;
  j["tool_changes"] = changes;
  j["surface_jumps"] = jumps;
  j["max_descent_deg"] = r.max_descent_deg;
  j["max_deviation_mm"] = dev.max_point;
  j["max_chord_deviation_mm"] = dev.max_chord;
  auto layers = nlohmann::ordered_json::array();
  for (const auto& l : r.layers)
    layers.push_back({{"offset_mm", l.offset},
                      {"angle_deg", l.angle},
                      {"tool", l.tool},
                      {"lines", l.lines},
                      {"paths", l.paths},
                      {"travel_moves", l.travel_moves},
                      {"length_mm", l.length},
                      {"connector_length_mm", l.connector_length},
                      {"jumps", l.jumps},
                      {"hole_joins", l.hole_joins}});
  j["per_layer"] = layers;
  if (g)
    j["gcode"] = {{"tool_changes", g->tool_changes},
                  {"travel_moves", g->travel_moves},
                  {"travel_length_mm", g->travel_length},
                  {"print_time_s", g->print_time_s},
                  {"bytes", g->bytes}};
  return j.dump(2) + "\n";
}

nlohmann::ordered_json process_json(const ProcessStats& stats, const ProcessOptions& options,
                                    const GcodeStats* gcode) {
  nlohmann::ordered_json jp;
  jp["paths"] = stats.paths;
  jp["pieces"] = stats.pieces;
  jp["merged_under_min_length"] = stats.merged;
  jp["short_paths_slowed"] = stats.short_slowed;
  for (int k = 0; k < kProcessParams; ++k) {
    const ProcessParamStats& s = stats.param[k];
    if (!s.set) continue;
    jp[to_string(static_cast<ProcessParam>(k))] = {
        {"node", s.node},       {"step", options.step(static_cast<ProcessParam>(k))},
        {"min", s.min},         {"max", s.max},
        {"changes", s.changes}, {"max_deviation", s.max_deviation}};
  }
  if (gcode) {
    jp["temperature_commands"] = gcode->temperature_changes;
    jp["settle_time_s"] = gcode->settle_time_s;
    jp["fan_commands"] = gcode->fan_changes;
  }
  return jp;
}

}  // namespace trellis
