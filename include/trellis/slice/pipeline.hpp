// From a design file (.vcad, .stl, .obj, .3mf) to a planar toolpath: the library side of
// `trellis slice`.
#pragma once
#include <functional>
#include <map>
#include <string>

#include "trellis/core/budget.hpp"
#include "trellis/core/run_context.hpp"
#include "trellis/geom/mesh_repair.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/slice/fgm.hpp"
#include "trellis/slice/fgm_process.hpp"
#include "trellis/slice/slice.hpp"

namespace trellis {

enum class SliceRoute { Auto, Field, Mesh };
SliceRoute slice_route_from_string(const std::string& name);  // auto|field|mesh
const char* to_string(SliceRoute route);

struct SliceJob {
  std::string input;
  SliceRoute route = SliceRoute::Auto;  // .vcad → field, meshes → mesh
  FieldSliceOptions field;              // XY resolution of direct contours
  double mesh_voxel = 0.25;             // mm, mesh → distance field (field route of a mesh)
  PlanarOptions planar;
  int strategy = 0;  // 0: one material; 1 / 2: the FGM paper's strategies (slice/fgm.hpp)
  // Whether `strategy` was chosen: a graded design (two or more materials) with strategy 0 not
  // chosen is an error, so that a gradient is never dropped silently.
  bool strategy_chosen = false;
  FgmOptions fgm;      // palette and fill (bead width, layer, grid from above)
  PurgeOptions purge;  // Strategy 1
  // Meshes that are not closed and manifold: repaired (geom/mesh_repair.hpp) and sliced, or,
  // with repair off, refused.
  bool repair = true;
  MeshRepairOptions repair_options;
  // A tool changer (gradient.mode = tools): its tool count; 0 = mixing or temperature. More
  // colours than tools is an error unless `quantize` (then the palette is the tools').
  int tools = 0;
  bool quantize = false;
  // Sharding (job/plate.hpp): only the part's printed layers [layer_begin, layer_end) (counted
  // from its first printed layer) are sliced and planned, with the outlines the skins need
  // around them; the toolpath holds those layers. Graded slicing (strategy 1 or 2): the
  // layer-local step only (no tower, mixtures as planned; finish_graded does the rest) and no
  // gradient error; layers without paths are left out as in the whole run.
  std::size_t layer_begin = 0, layer_end = static_cast<std::size_t>(-1);
  // Or the range from the design's extent and its printed layers (found before any layer is
  // sliced), so a shard of one part opens the design once.
  std::function<std::pair<std::size_t, std::size_t>(const BBox3& extent, std::size_t layers)>
      range_of;
  // Process parameters a .vcad design sets with fprocess (slice/fgm_process.hpp).
  ProcessOptions process;
  // The writer issues each mixture change this many mm of printed path early (gradient.lookahead
  // of a mixing machine whose G-code is written; 0: none): the gradient error is then measured
  // on the mixtures as deposited (deposit_start_mixtures), not as planned.
  double lookahead = 0;
};

struct SliceResult {
  Toolpath toolpath;
  std::vector<LayerOutline> outlines;
  SliceRoute route = SliceRoute::Field;
  BBox3 extent;            // of the design (mm)
  SliceStats field_stats;  // field route only
  PlanarStats planar;
  FgmStats fgm;
  std::size_t mesh_triangles = 0;
  bool repaired = false;          // the mesh needed repair; `repair` says what changed
  double design_min_feature = 0;  // mm: the design's minfeaturesize (3MF level sets); 0 = none
  MeshRepairReport repair;
  double outline_seconds = 0, plan_seconds = 0;
  // The part's printed layers (all of them, also when only a range was asked for) and the index
  // of the toolpath's first layer among them.
  std::size_t part_layers = 0, first_layer = 0;
  // The design's z that the part's first printed layer starts at: the bed (z = 0 in the
  // toolpath, whose layer i lies at (i + 1) × the layer height). The extent's bottom, unless
  // the extent is a loose bound with empty planes above it.
  double bottom = 0;
  // A range: the part's layer of outlines[0] (the range less the layers its skins read), and
  // whether the design has process fields (a graded shard leaves their pass to the merge).
  std::size_t outline_first = 0;
  bool process_fields = false;
  // Streamed (stream_slice): no outlines or toolpath are kept; what the report needs of them is
  // summed as the layers pass.
  bool streamed = false;
  std::size_t layers = 0, empty_layers = 0;
  double outline_area = 0;  // mm², all layers
  TravelStats travel;
  ProcessStats process;  // fprocess designs
  // Streamed graded slicing: printed length and time (mm, s) of the part's paths per mixture,
  // summed in print order (the report's per-colour table).
  std::map<std::vector<double>, std::pair<double, double>> colour_use;
};

// Planar and graded slicing in one call. `context` (core/run_context.hpp): stages "outlines"
// (from worker threads, under a lock) and "walls and infill"; cancel checked per layer while
// outlining and between stages; the work estimated from the extent, the layers and the grids is
// checked against its budget before any layer is sliced; oneTBB work on its threads.
SliceResult run_slice(const SliceJob& job, const RunContext& context = {});

// Planar slicing (strategy 0) of the whole part streamed in bounded memory: layers are outlined
// and planned by a oneTBB pipeline (a few runs of `chunk_layers` in flight, each planned with the
// outlines its skins read around it) and handed to `sink` in order as each is done, never all
// held. The layers are run_slice's, byte for byte; the result carries the statistics (no
// outlines, no toolpath). Graded slicing streams the same way, the gradient error and the
// statistics summed in layer order (Strategy 2 plans each layer from its own outline, Strategy 1
// cuts the planar layers by colour). With a prime tower (Strategy 1, tool changers), which is
// placed and sized from every layer, the planned layers go to a temporary file first and come
// back in order with the tower and the tools' mixtures added, before `sink`. Process fields
// (fprocess) split each layer as it passes, after the tower, and are counted in print order.
using LayerSink = std::function<void(std::size_t index, Layer&& layer)>;
struct SliceStreamOptions {
  std::size_t chunk_layers = 16;  // planes outlined together (a mesh is bucketed once per run)
  std::size_t tokens = 0;         // runs in flight; 0 = twice the threads
  // Layers planned together, at least (but the last run). Planar slicing intersects the windows
  // of layers its skins read once, as the outlines come (SkinWindows), whatever the run length;
  // graded slicing plans each run with the bottom_layers + top_layers outlines around it.
  std::size_t plan_layers = 32;
};
SliceResult stream_slice(const SliceJob& job, const LayerSink& sink,
                         const SliceStreamOptions& options = {}, const RunContext& context = {});

// Graded slicing (strategy 1 or 2) in two steps, so that a sharded run (job/plate.hpp) and the
// whole run build the same G-code: the layer-local step (each layer's colour faces, pieces or
// fill, mixtures, short pieces merged) runs per shard, the whole-print step on all layers in
// order (docs/plates.md, "Graded slicing").
// The graded options of a job for a design of `materials` materials: the palette (a tool
// changer's palette is its tools', quantised if asked: *quantized_from = the colours asked for),
// bead, layer. SettingError / GeometryError naming job.input.
FgmOptions graded_options(const SliceJob& job, int materials, int* quantized_from = nullptr);
// The whole-print step on the planned layers (in order, no empty layer): the prime tower
// (Strategy 1, and Strategy 2 on a tool changer: its place and size from every layer, a purge
// where a layer's mixture differs from the one before, walls up to the last purge), then a
// tool changer's mixtures made the tools' (what each tool prints). Fills stats.purges,
// purge_length, purge_volume and tower; GeometryError naming job.input if no tower fits.
void finish_graded(const SliceJob& job, const FgmOptions& options, Toolpath& toolpath,
                   FgmStats& stats);
// Whether a graded job prints a prime tower: Strategy 1 in face order (fgm.order = faces), and
// any tool changer; not Strategy 1 in path order or Strategy 2 on a mixing hotend or by
// temperature (their changes run ahead of the nozzle by gradient.lookahead).
bool graded_tower(const SliceJob& job);
// The palette colours some part path (not the tower) of a graded toolpath prints.
int graded_colours_used(const Toolpath& toolpath);
// Adds a layer's part paths to the per-mixture printed length and time (the report's table).
void add_colour_use(const SliceJob& job, const Layer& layer,
                    std::map<std::vector<double>, std::pair<double, double>>& use);

}  // namespace trellis
