// Pictures with cairo: a PNG per layer (paths coloured by feature type, print order or mixture in
// the colours of the viewer, render/palette.hpp; travel dashed grey, start points as green dots,
// end points as small dark dots) with a title band (file, layer, Z, what colour means) and a legend
// band (legend or colour bar, scale bar in mm), and the GIPPO score over iterations (paper Fig. 2
// i).
#pragma once
#include <string>
#include <utility>
#include <vector>

#include "trellis/core/budget.hpp"
#include "trellis/geom/polygon.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

struct RenderOptions {
  int size_px = 1000;  // longer side of the image
  double margin_mm = 1.0;
  bool travel = true;
  bool starts = true;
  double bead_width = 0;        // line width in mm; 0 = from paths or 0.2
  bool colour_by_role = false;  // feature type (the viewer's palette); else print order
  // Graded paths by their first material's fraction (the palette's mixture map, as the viewer);
  // three materials as the blend of their colours.
  bool colour_by_mixture = false;
  // Paths by Path::tool (a swatch per tool; before role and mixture): the lasers of a multi-laser
  // build file, labelled "laser N" from 1 (as the .cli and the reports) with tools_are_lasers,
  // else "tool N" from 0.
  bool colour_by_tool = false;
  bool tools_are_lasers = false;
  // Paths by laser parameter set (before all the others): the toolpath's named sets
  // (Toolpath::parameter_sets), then each further role, power and speed, a swatch per set.
  bool colour_by_set = false;
  // What the mixture shown is, in the title after "colour: mixture" (a G-code file read back shows
  // it as deposited, its mixing look-ahead undone; view/view.hpp).
  std::string mixture_label = "(as planned)";
  std::string title;  // first line of the title band; default: the toolpath's source
};

// Height (px) of the title band above and the legend band below a layer PNG of `size_px`.
inline int layer_band_px(int size_px) {
  return size_px / 12 > 36 ? size_px / 12 : 36;
}

// Writes one PNG of `layer` (index into toolpath.layers), atomically.
// Before rendering: `images` PNGs of at most size_px × size_px drawing `points` path points in
// all (0 when not known yet), for check_budget.
Estimate layer_images_estimate(double images, int size_px, double points);

void render_layer_png(const Toolpath& toolpath, std::size_t layer, const std::string& path,
                      const RenderOptions& options = {});

// An oblique 3D view (a dimetric projection) of a whole toolpath (all layers), paths coloured by
// print order (the palette's continuous map), start points green, travel dashed grey; `upto` > 0
// draws only the first `upto` paths (a frame of the print order) over the rest in light grey.
// Optional `marks` (3D points) are drawn as red rings, e.g. collisions.
struct View3dOptions {
  int size_px = 1000;
  double azimuth_deg = -60;   // view direction around Z (from +X towards +Y)
  double elevation_deg = 20;  // above the horizon
  bool travel = true;
  std::size_t upto = 0;
  std::vector<Vec3> marks;
  std::string title;
  // What colour means: print order (a first..last bar), height (a z colour bar in mm, so curved
  // non-planar layers read as curved), or tool (a swatch per tool: the material groups of a
  // multi-material print).
  enum class Colour { Order, Height, Tool } colour = Colour::Order;
};
void render_3d_png(const Toolpath& toolpath, const std::string& path,
                   const View3dOptions& options = {});

// Analysis picture (paper Fig. 4 ii-iii): design struts light grey, the printed layer as thin
// dark lines, `red` pieces (deposited twice) and `blue` segments (missing struts) on top.
void render_overlay_png(const std::vector<Segment2>& design, const Layer& printed,
                        const std::vector<Segment2>& red, const std::vector<Segment2>& blue,
                        double bead_width, const std::string& path, int size_px = 1000);

// A thumbnail for G-code headers (PNG bytes, width x height): the whole print seen from the front
// and above, fitted on a transparent background, the nearest bead in each pixel shaded by height
// and depth (paths rasterised straight into the pixel grid, not stroked with cairo).
std::string render_thumbnail_png(const Toolpath& toolpath, int width, int height);
// The same over streamed layers (visited twice: the extent, then the drawing).
std::string render_thumbnail_png(const LayerSource& layers, int width, int height);
// Thumbnails of several sizes from the same two visits of the layers.
std::vector<std::string> render_thumbnails_png(const LayerSource& layers,
                                               const std::vector<std::pair<int, int>>& sizes);

// Scatter of scores per iteration with the best (red) and the worst (green, the lowest score)
// marked, as GIPPO's Fig. 2 (i).
void render_scores_png(const std::vector<double>& scores, std::size_t best_iteration,
                       const std::string& title, const std::string& path);

// A line plot of one or more series over x (e.g. FR_a over layers, PBF paper Fig. 3(b)), with a
// legend; non-finite values break the line.
struct PlotSeries {
  std::string label;
  std::vector<double> values;
  double r = 0.1, g = 0.3, b = 0.8;
};
void render_series_png(const std::vector<double>& x, const std::vector<PlotSeries>& series,
                       const std::string& title, const std::string& x_label,
                       const std::string& path);

}  // namespace trellis
