// The interactive viewer: one self-contained HTML file (WebGL, three.js bundled at build time from
// viewer/) showing toolpaths read from any input Trellis understands. The data goes into the page
// as compact binary arrays (base64, one chunk per layer), never as JSON text, so a 100 MB G-code
// file stays a few seconds to open. The statistics the page shows are computed by the page from
// those arrays and equal what `trellis analyze` / `trellis check` report for the same file.
#pragma once
#include <string>
#include <vector>

#include "trellis/core/diagnostics.hpp"
#include "trellis/core/vec.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {
struct Graph;
struct CollisionCheck;
struct MachineProfile;
}  // namespace trellis

namespace trellis {

// One file shown in the viewer.
struct ViewScene {
  std::string name;  // file name as shown
  std::string kind;  // gcode, nc, cli, toolpath, lattice, check
  Toolpath toolpath;
  std::vector<std::pair<Vec3, Vec3>> design;  // overlay lines (a lattice, the checked struts)
  std::vector<char> design_flag;              // per design line: 1 = flagged (a collision), 0 = not
  double print_time_s = -1;                   // time estimate (s), < 0 when unknown
  double filament_mm = -1;                    // filament (mm of E), < 0 when unknown
  std::vector<std::string> warnings;
  // Deviation from the design (set_design): per toolpath point in print order, the distance (mm)
  // to the nearest design strut; empty without a design.
  std::vector<float> deviation;
  // Collisions (set_collisions, or a `trellis check` report): the moving segment (path index in
  // print order and segment within it; path < 0 when only the report's point is known) and the
  // hit material's point, ringed in the view.
  struct Hit {
    long long path = -1, segment = -1;
    Vec3 point;
  };
  std::vector<Hit> hits;
  std::size_t collisions = 0;  // all collisions found (hits lists at most the checker's limit)
  bool checked = false;        // a collision check ran (or a report was read)
  // Build volume of a machine profile (set_build_volume): drawn as a box or a cylinder.
  struct Bed {
    std::string shape;  // "" = none, rectangle, circle
    double x = 0, y = 0, z = 0;
    bool center = false;  // (0,0) at the bed centre, else at a corner
    std::string machine;  // the profile's name
  } bed;
  std::vector<std::pair<std::string, std::string>> extra_stats;  // more statistics rows
  // Mixtures. A G-code file's paths carry the mixture deposited (machine/mixing_lag.hpp: the
  // commanded one shifted by the file's mixing look-ahead); `commanded` keeps the commanded one per
  // path in print order (empty: the same as the paths', e.g. a toolpath as planned).
  bool mixture_read_back = false;  // read from G-code commands (else as planned)
  double mixture_lookahead = 0;    // mm of printed path the commands ran ahead (0: none recorded)
  std::vector<std::vector<double>> commanded;
};

// How to read a pneumatic file: the front ends take the valve commands from the machine profile
// (--machine) unless --valve-on/--valve-off say otherwise; a file's own header wins over none.
struct ViewLoadOptions {
  std::string valve_on;   // pneumatic G-code: the command that opens the valve
  std::string valve_off;  // ... and closes it
};

// Reads FILE by its extension: .gcode/.g/.gco/.nc (G-code of any slicer), .cli (laser build
// file), toolpath JSON, lattice JSON/CSV/OBJ (drawn as struts), a `trellis check` report JSON.
// Throws ParseError naming the file when it is none of these.
ViewScene load_view_scene(const std::string& path, const ViewLoadOptions& options,
                          Diagnostics& diag);

// Sets the design overlay (every strut of `design`) and the deviation of every toolpath point from
// it (distance to the nearest strut, mm). The toolpath must be in design coordinates.
void set_design(ViewScene& scene, const Graph& design);

// Flags the struts a collision check found hit or hitting (red) and lists the collisions.
void set_collisions(ViewScene& scene, const CollisionCheck& check);

// The build volume of `machine` drawn around a G-code file (machine coordinates).
void set_build_volume(ViewScene& scene, const MachineProfile& machine, const std::string& name);

// What a scene's mixture colours show, for a picture's title: "(as deposited: ...)", "(as
// commanded ...)" or "(as planned)".
std::string mixture_label(const ViewScene& scene, bool commanded);

// A scene of an in-memory toolpath (the Python `_repr_html_`).
ViewScene view_scene(const Toolpath& toolpath, const std::string& name);

// The HTML page. `title` shows in the tab and the panel.
std::string viewer_html(const std::vector<ViewScene>& scenes, const std::string& title);

// The viewer in a notebook (Python's Toolpath._repr_html_), where a page holds many views: the
// viewer's script (about 0.6 MB) goes into the page once and each view carries only its data.
// viewer_notebook_script() is a <script> that defines window.trellisNotebook (the page template
// and a function that opens a view in a sandboxed iframe). viewer_notebook_view() is one view:
// its data (layers packed: positions in 1 µm steps, deflated; see docs/viewer.md) and a call to
// that function; a view whose page lacks the script waits for it and then says what to do.
std::string viewer_notebook_script();
std::string viewer_notebook_view(const std::vector<ViewScene>& scenes, const std::string& title);

// The bundled page template without data (for the size check; < 2 MB).
std::size_t viewer_template_size();

}  // namespace trellis
