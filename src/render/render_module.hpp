// The cairo module's table (src/core/module.hpp): every PNG the library draws.
#pragma once
#include "../core/module.hpp"
#include "trellis/render/render.hpp"

namespace trellis {

struct RenderModule {
  detail::ModuleHeader header;
  void (*render_layer_png)(const Toolpath&, std::size_t, const std::string&, const RenderOptions&);
  void (*render_3d_png)(const Toolpath&, const std::string&, const View3dOptions&);
  void (*render_overlay_png)(const std::vector<Segment2>&, const Layer&,
                             const std::vector<Segment2>&, const std::vector<Segment2>&, double,
                             const std::string&, int);
  void (*render_scores_png)(const std::vector<double>&, std::size_t, const std::string&,
                            const std::string&);
  void (*render_series_png)(const std::vector<double>&, const std::vector<PlotSeries>&,
                            const std::string&, const std::string&, const std::string&);
};

}  // namespace trellis
