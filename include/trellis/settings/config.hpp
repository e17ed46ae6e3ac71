// The typed settings of every route in one value: the params structs the library's one-call
// functions take, plus the few route choices that are not a params field. `Settings::config()`
// fills it from the schema (settings.hpp); a default-constructed Config holds every default.
#pragma once
#include <array>
#include <string>
#include <vector>

#include "trellis/analysis/collisions.hpp"
#include "trellis/analysis/metrics.hpp"
#include "trellis/field/field.hpp"
#include "trellis/lattice/atlas.hpp"
#include "trellis/lattice/cells3d.hpp"
#include "trellis/machine/gcode_reader.hpp"
#include "trellis/machine/laser.hpp"
#include "trellis/machine/profile.hpp"
#include "trellis/plan/aero.hpp"
#include "trellis/plan/plan.hpp"
#include "trellis/render/render.hpp"
#include "trellis/slice/nonplanar.hpp"
#include "trellis/slice/pbf.hpp"
#include "trellis/slice/pbf_lasers.hpp"
#include "trellis/slice/pbf_skin.hpp"
#include "trellis/slice/pipeline.hpp"
#include "trellis/slice/scan_strategy.hpp"

namespace trellis {

// The route choices that are not a params field, parsed once by the schema into these enums; each
// one's names (to_string) are the setting's choices, in the enum's order.
// plan.planner: the graph planners of plan/plan.hpp, or AERO (plan/aero.hpp).
enum class LatticePlanner { Gippo, Euler, Aero };
// pbf.route: slice the field directly, or its marching-cubes mesh (for comparison).
enum class PbfRoute { Direct, Stl };
// pbf.strategy: TPMS sheets (hybrid, r67) or solid parts (the others, slice/scan_strategy.hpp).
enum class PbfStrategy { Hybrid, R67, Rectilinear, Meander, Stripe, Island };
// plate.sequence: FDM plates printed layer by layer or part by part.
enum class PlateSequence { Layers, Parts };
// lattice3d.kind: unit cells tessellated, a Voronoi foam, or cells clipped to a mesh.
enum class Lattice3dKind { Cells, Foam, Conformal };
// pbf.grade_axis: the sigmoid blending pbf.grade_to in runs along z (axial) or r (radial).
enum class GradeAxis { Z, R };
// onto.kind: planned layers left flat, or laid on a sphere cap, a mesh or a height function.
enum class OntoKind { Flat, SphereCap, Mesh, Function };
// surface.kind: the non-planar paper's generated test surfaces, and the angle test.
enum class SurfaceKind { Corrugation, Miura, MCurve, SphereCap, AngleTest };
// render.colour: what a layer PNG's colours mean; auto: tool for a laser file of several lasers,
// else feature.
enum class RenderColour { Auto, Feature, Order, Mixture, Commanded, Tool, Set };
std::string to_string(LatticePlanner planner);
std::string to_string(PbfRoute route);
std::string to_string(PbfStrategy strategy);
std::string to_string(PlateSequence sequence);
std::string to_string(Lattice3dKind kind);
std::string to_string(SurfaceKind kind);
std::string to_string(OntoKind kind);  // "" for flat
std::string to_string(GradeAxis axis);
std::string to_string(RenderColour colour);
// Whether the strategy scans solid parts (not TPMS sheets).
inline bool solid_strategy(PbfStrategy s) {
  return s != PbfStrategy::Hybrid && s != PbfStrategy::R67;
}

// lattice3d.*: unit cells tessellated, or a Voronoi foam.
struct Lattice3dConfig {
  Lattice3dKind kind = Lattice3dKind::Cells;
  CellLatticeParams cells;
  FoamParams foam;
  ConformalParams conformal;  // skin, skin density (mesh, cell, seed from the others)
  double radius = 0.25;       // mm, strut radius written to 3MF beam lattices
  MaterialRule materials = MaterialRule::None;
};

// layers.*: GIPPO multi-layer parts (a 2D pattern repeated per layer, optionally cropped to a
// solid and laid on a surface).
struct LayersConfig {
  int count = 1;            // 0 with a solid = from its height
  double rotation_deg = 0;  // added per layer
  std::string solid;        // closed mesh each layer is cropped to (path)
};

// onto.*: planned layers laid on a surface (GIPPO non-planar).
struct OntoConfig {
  OntoKind kind = OntoKind::Flat;
  double radius = 10, diameter = 12;
  std::string file, height_fn;
  std::vector<double> domain;  // x0, y0, x1, y1
  ProjectParams project;
};

// pbf.*: the TPMS sheet design and the route; scan parameters live in the laser profile.
struct PbfConfig {
  TpmsKind cell_type = TpmsKind::Gyroid;
  double cell = 2.5;         // mm
  std::string c = "0.15";    // Φ = φ² − c²; a number or an expression of x, y, z, rho, r
  double thickness = 0;      // mm; > 0: c = t·|∇φ|/2 (uniform walls)
  std::vector<double> size;  // box X, Y, Z (mm); empty = 4 cells
  std::vector<double> plate_position;  // X, Y of the design's origin on the plate; empty = centre
  std::string envelope;                // .vcad solid the lattice fills (path)
  std::string solids;                  // .vcad solid parts, hatched (path)
  std::string grade_to;                // TYPE:CELL blended in by a sigmoid
  GradeAxis grade_axis = GradeAxis::Z;
  double grade_center = 0, grade_width = 1;
  std::string hierarchical;      // TYPE:CELL:WEIGHT superposed
  double wall_thickness = 0;     // mm; > 0: a plane thin wall (PBF paper Fig. 3) instead of a TPMS
  double wall_inclination = 90;  // deg from horizontal
  double wall_azimuth = 0;       // deg from X
  bool binary = false;           // binary CLI geometry
  double laser_overlap = 1;      // mm: neighbouring lasers' stripes overlap (laser.lasers > 1)
  LaserAxis laser_split_axis = LaserAxis::X;  // the lasers' stripes follow one another along
  PbfRoute route = PbfRoute::Direct;
  // hybrid | r67 (TPMS sheets; a mesh part is scanned as meander) | rectilinear | meander |
  // stripe | island (solid parts: a mesh, or a .vcad scanned as a solid)
  PbfStrategy strategy = PbfStrategy::Hybrid;
  int contours = 1;             // solid parts: contour offsets per region
  double contour_distance = 0;  // mm between contours (0 = the hatch distance)
  SkinOptions skin;             // solid parts: skin/core, up-skin, down-skin thicknesses (mm)
  // Per HatchKind (core, up-skin, down-skin; skin's are the pattern's): hatch distance (mm, 0 =
  // the hatch distance) and rotation per layer (deg, one number; empty = pbf.hatch_rotation).
  std::array<double, kHatchKinds> kind_hatch_distance{};
  std::array<std::vector<double>, kHatchKinds> kind_rotation;
  ScanPattern pattern;  // stripe and island sizes (hatch from the laser profile)
  PbfOptions options;   // resolution, thin_multiple, min_inclination (scan from laser)
};

// surface.*: the non-planar paper's generated test surfaces.
struct SurfaceConfig {
  SurfaceKind kind = SurfaceKind::Corrugation;
  CorrugationParams corrugation;
  MiuraParams miura;
  MCurveParams m_curve;
  double radius = 10, diameter = 12;  // sphere-cap
  double resolution = 0.1;            // grid of generated meshes (mm)
};

// nonplanar.* beyond its params: where the surface comes from.
struct NonplanarConfig {
  NonplanarParams params;
  std::string height_fn;
  std::vector<double> domain;
  std::string layer_tools;      // "3:0,3:1,3:0" or "0,1"
  bool planar_control = false;  // slice the layers' solid flat instead (slice_planar_control)
};

struct OutputConfig {
  int preview_layers = 4;  // PNGs spread over the layers
  int image_size = 1000;   // px
  bool gcode = true;       // plan/run: also write G-code when a machine is given
  bool png = true;         // job: write previews
  int frames = 0;          // aero: step pictures of the first N trails
};

// run.max_memory, run.max_time, run.force: the budget every route checks its estimate against
// before it starts (core/budget.hpp).
struct BudgetConfig {
  double max_memory_mb = 0;  // MB; unset (derived) = the memory available when the run starts
  double max_time = 600;     // s: ten minutes, generous for any route at sane settings
  bool force = false;
};

// read.*, check.*, analyze.*, render.*, view.*: the reader routes, which read prints back
// (job/job.hpp RouteSpec::reads).
struct ReadConfig {
  GcodeReadOptions gcode;   // read.valve_on, read.valve_off, read.commanded_mixtures, read.strict
  double snap = kNodeSnap;  // check.snap (mm): at this default, plus the profile's node overlap
  AnalysisParams analysis;  // analyze.bead_width, layer_height, acceleration, align
  bool per_layer = false;   // analyze.layers: a line per layer
  double filament_diameter = MachineProfile{}.filament_diameter;  // analyze.filament_diameter
  RenderColour colour = RenderColour::Auto;                       // render.colour
  int layer = -1;        // render.layer: unset (-1) = every layer
  RenderOptions render;  // render.image_size, render.bead_width, render.travel
  std::string title;     // view.title: empty = the file names
};

// Build plates (job/plate.hpp).
struct PlateConfig {
  double clearance = 2;  // plate.clearance (mm): least gap between the parts' footprints
  // plate.sequence: FDM plates printed layer by layer (every part's layer i, then layer i + 1)
  // or part by part (each part whole before the next; the machine's extruder clearance allowing)
  PlateSequence sequence = PlateSequence::Layers;
};

struct Config {
  MachineProfile machine;
  LaserProfile laser;
  AtlasParams lattice2d;
  Lattice3dConfig lattice3d;
  LayersConfig layers;
  OntoConfig onto;
  LatticePlanner planner = LatticePlanner::Gippo;           // plan.planner
  PlanParams plan;                                          // plan.* and gippo.*
  double merge_tolerance = CleanOptions{}.merge_tolerance;  // lattice.merge_tolerance (mm)
  bool keep_graph = false;  // lattice.keep_graph: no node merging, no T-junction splitting
  // How a lattice is read under lattice.keep_graph and lattice.merge_tolerance.
  CleanOptions clean_options() const {
    return keep_graph ? keep_graph_options() : CleanOptions{merge_tolerance, true};
  }
  double line_width = 0.4;     // lattice2d.line_width (mm): for the pore area
  double target_porosity = 0;  // lattice2d.target_porosity (%): tune the cell size; 0 = off
  int gippo_seeds = 0;         // gippo.seeds: robustness run over this many seeds
  AeroParams aero;
  SliceJob slice;  // slice.* and fgm.* (input set by the route)
  PbfConfig pbf;
  NonplanarConfig nonplanar;
  SurfaceConfig surface;
  OutputConfig output;
  PlateConfig plate;
  int threads = 0;               // run.threads: 0 = all cores
  bool follow_symlinks = false;  // run.follow_symlinks: write through symbolic links (RunFiles)
  // run.progress: progress on stderr (the command line reads it): not given = on a terminal only.
  bool progress = false;
  BudgetConfig budget;  // run.max_memory, run.max_time, run.force
  ReadConfig read;      // the reader routes' own sections
};

}  // namespace trellis
