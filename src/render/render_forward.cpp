// Drawing runs in the cairo module, loaded on first use (G-code thumbnails do not: thumbnail.cpp).
#include <fmt/format.h>

#include "render_module.hpp"

namespace trellis {
namespace {
const RenderModule& cairo() {
  return detail::module_table<RenderModule>("cairo");
}
}  // namespace

// Measured (one thread, CPU time, 1000 px): 50 PBF layers of 100 paths 1.95 s, 122 sliced
// layers of 600 points each 4.5 s: about 4e-8 s a pixel (fill, bands, PNG encoding) and 1e-6 s
// a path point; an RGB surface of 4 bytes a pixel and the PNG's rows, one image at a time.
Estimate layer_images_estimate(double images, int size_px, double points) {
  const double px = double(size_px) * double(size_px);
  Estimate e;
  e.bytes = px * 4 * 2;
  e.seconds = images * px * 4e-8 + points * 1e-6;
  e.what = fmt::format("{:.0f} image(s) of {} x {} px", images, size_px, size_px);
  e.change = "the image size or the number of images";
  return e;
}

void render_layer_png(const Toolpath& toolpath, std::size_t layer, const std::string& path,
                      const RenderOptions& options) {
  cairo().render_layer_png(toolpath, layer, path, options);
}

void render_3d_png(const Toolpath& toolpath, const std::string& path,
                   const View3dOptions& options) {
  cairo().render_3d_png(toolpath, path, options);
}

void render_overlay_png(const std::vector<Segment2>& design, const Layer& printed,
                        const std::vector<Segment2>& red, const std::vector<Segment2>& blue,
                        double bead_width, const std::string& path, int size_px) {
  cairo().render_overlay_png(design, printed, red, blue, bead_width, path, size_px);
}

void render_scores_png(const std::vector<double>& scores, std::size_t best_iteration,
                       const std::string& title, const std::string& path) {
  cairo().render_scores_png(scores, best_iteration, title, path);
}

void render_series_png(const std::vector<double>& x, const std::vector<PlotSeries>& series,
                       const std::string& title, const std::string& x_label,
                       const std::string& path) {
  cairo().render_series_png(x, series, title, x_label, path);
}

}  // namespace trellis
