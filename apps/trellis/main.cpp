// trellis: a thin command line over libtrellis.
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <iostream>

#include "commands.hpp"
#include "trellis/core/diagnostics.hpp"
#include "trellis/core/error.hpp"
#include "trellis/version.hpp"

namespace trellis::cli {

void progress_line(const std::string& stage, double fraction) {
  static const bool tty = ::isatty(2);
  if (!tty) return;
  std::fprintf(stderr, "\r%s: %3d%%%s", stage.c_str(), static_cast<int>(fraction * 100 + 0.5),
               fraction >= 1 ? "\n" : "");
}

void print_warnings(const Diagnostics& diag) {
  for (const auto& [kind, n] : diag.counts()) {
    std::cerr << "warning: " << kind << " (" << n << ")\n";
    for (const auto& m : diag.messages())
      if (m.kind == kind) std::cerr << "  " << m.text << "\n";
  }
}

std::vector<std::string> render_previews(const Toolpath& toolpath, const std::string& dir,
                                         std::size_t count, const RenderOptions& options) {
  std::vector<std::string> pngs;
  const std::size_t n = toolpath.layers.size();
  if (dir.empty() || count == 0 || n == 0) return pngs;
  std::filesystem::create_directories(dir);
  const std::size_t k = std::min(count, n);
  for (std::size_t t = 0; t < k; ++t) {
    const std::size_t layer = k == 1 ? n / 2 : t * (n - 1) / (k - 1);
    const std::string png = dir + "/layer_" + std::to_string(layer) + ".png";
    render_layer_png(toolpath, layer, png, options);
    pngs.push_back(png);
  }
  return pngs;
}

namespace {
int g_exit_code = 0;
}
void set_exit_code(int code) {
  g_exit_code = code;
}
int exit_code() {
  return g_exit_code;
}

void add_nozzle_options(CLI::App* cmd, NozzleModel& nozzle, const std::string& group) {
  cmd->add_option("--nozzle-radius", nozzle.radius, "nozzle radius R (mm)")
      ->capture_default_str()
      ->group(group);
  cmd->add_option("--tip-clearance", nozzle.tip_clearance,
                  "material less than this above the tip is not hit (mm)")
      ->capture_default_str()
      ->group(group);
  cmd->add_option("--node-clearance", nozzle.node_clearance,
                  "no collision within this of a node the two struts share (mm)")
      ->capture_default_str()
      ->group(group);
  cmd->add_option("--cone", nozzle.cone_half_angle_deg,
                  "struts within this angle of vertical print bottom-up (degrees)")
      ->capture_default_str()
      ->group(group);
}

std::string num(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

}  // namespace trellis::cli

int main(int argc, char** argv) {
  CLI::App app{
      "Trellis: toolpaths for architected materials.\n"
      "Design a lattice, plan continuous print paths (GIPPO, Euler, AERO for 3D lattices in a\n"
      "support bath), write G-code and check it for nozzle collisions; slice\n"
      "implicit designs (.vcad) and meshes; make laser powder-bed paths for TPMS lattices.\n"
      "Typical use:\n"
      "  trellis lattice2d --pattern honeycomb --cell 1 -o lattice.json\n"
      "  trellis plan gippo lattice.json -o toolpath.json --report report.json\n"
      "  trellis gcode toolpath.json --machine profiles/ender3_s1_pro_tpu.toml -o part.gcode\n"
      "  trellis run examples/honeycomb_tensile.toml\n"
      "  trellis slice examples/designs/csg_bracket.vcad --machine profiles/ender3_s1_pro_tpu.toml -o bracket.gcode\n"
      "  trellis pbf --cell-type gyroid --cell 2.5 --size 10,10,10 -o lattice.cli\n"
      "  trellis lattice3d --cell octet --size 7 --count 3 3 3 -o octet.json\n"
      "  trellis plan aero octet.json -o octet_path.json --report octet_report.json\n"
      "  trellis gcode octet_path.json --machine profiles/embedded_aero_410um.toml -o octet.nc\n"
      "  trellis check octet.json octet.nc --machine profiles/embedded_aero_410um.toml"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("trellis ") + trellis::version());
  trellis::cli::add_lattice2d(app);
  trellis::cli::add_lattice3d(app);
  trellis::cli::add_plan(app);
  trellis::cli::add_gcode(app);
  trellis::cli::add_render(app);
  trellis::cli::add_run(app);
  trellis::cli::add_analyze(app);
  trellis::cli::add_check(app);
  trellis::cli::add_compare(app);
  trellis::cli::add_walls(app);
  trellis::cli::add_slice(app);
  trellis::cli::add_pbf(app);
  trellis::cli::add_nonplanar(app);
  trellis::cli::add_surface(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return 2;
  } catch (const trellis::Error& e) {
    std::cerr << "trellis: error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "trellis: internal error: " << e.what() << "\n";
    return 3;
  }
  return trellis::cli::exit_code();
}
