// A job: everything from design to G-code in one TOML file (`trellis run job.toml`).
//
//   [job]     name, output_dir, machine (profile path, relative to the job file)
//   [lattice] file (a lattice file, relative to the job file) or an atlas pattern:
//             pattern, cell_size, strand_distance, rotation_deg, voronoi_density, seed,
//             region ("rectangle" | "circle"), width, height, diameter,
//             center = [x, y] (default: the lattice's lower-left corner at 0,0),
//             contour, handles, handle_length, handle_width, handle_spacing,
//             reentrant_angle_deg, arrowhead_outer_deg, arrowhead_inner_deg
//   [layers]  count, rotation_deg (added per layer), layer_height
//   [plan]    planner, mode, iterations, seed, order, threads, long_path_nodes
//   [solid]   file: a closed mesh; each layer's pattern is cropped to its cross-section there
//             (GIPPO's per-layer infill; [layers] count defaults to the mesh height / layer height)
//   [surface] kind ("sphere-cap" | "mesh" | "function"), radius, diameter, file, height_fn,
//             domain = [x0, y0, x1, y1], offset ("normal" | "vertical"), chord_tolerance: the
//             planned layers are laid on the surface (GIPPO non-planar; the lattice is centred
//             on the surface unless [lattice] center is given)
//   [output]  gcode, png, png_size
//   [machine_overrides] "section.key" = value, applied over the profile
// Unknown keys are errors naming the file and line.
#pragma once
#include <string>
#include <vector>

#include "trellis/core/progress.hpp"
#include "trellis/lattice/atlas.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/plan/plan.hpp"
#include "trellis/slice/nonplanar.hpp"

namespace trellis {

struct Job {
  std::string name = "job";
  std::string output_dir = "out";
  std::string machine;                 // resolved path to a profile; empty = defaults
  std::vector<std::string> overrides;  // "section.key=value"
  std::string lattice_file;            // resolved path; empty = atlas
  AtlasParams atlas;
  int layer_count = 1;
  double layer_rotation_deg = 0;
  PlanParams plan;
  std::string solid_file;  // resolved path; empty = no solid
  struct Surface {
    std::string kind;  // empty = planar
    std::string file, height_fn;
    double radius = 10, diameter = 12;
    std::vector<double> domain;
    ProjectParams project;
  } surface;
  bool gcode = true;
  bool png = true;
  int png_size = 1000;
};

Job load_job(const std::string& path);

struct JobOutputs {
  std::string lattice, toolpath, report, gcode;
  std::vector<std::string> pngs;
  PlanResult result;
  GcodeStats gcode_stats;
};

// Builds the lattice (file, or atlas layers rotated per layer), plans it, writes lattice JSON,
// toolpath JSON, report JSON, G-code and PNGs into job.output_dir.
JobOutputs run_job(const Job& job, Diagnostics& diag, const Progress& progress = {});

// The multi-layer atlas lattice of a job: layer i at z = i·layer_height, rotated by i·rotation,
// cropped to the solid's cross-section at the middle of the layer when there is a solid.
Graph job_lattice(const Job& job);

// The job's surface (throws if it has none).
HeightField job_surface(const Job& job);

}  // namespace trellis
