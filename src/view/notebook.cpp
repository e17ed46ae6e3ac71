// The viewer in a notebook: the page template sent once (viewer_notebook_script), then each view
// as data only (viewer_notebook_view). The loader is viewer/src/notebook.js, minified by
// viewer/build.mjs into viewer_notebook.inc.
#include <string>

#include "page.hpp"
#include "trellis/core/error.hpp"
#include "trellis/view/view.hpp"

namespace trellis {

namespace {

const char kLoaderText[] =
#include "viewer_notebook.inc"
    ;
constexpr std::string_view kPagePlaceholder = "TRELLIS_PAGE";

// Text as a JavaScript string literal that cannot end the <script> it sits in:
// JSON's escaping, then `<!--` and `</` broken up (`\x3C`, `<\/` read back as the same text).
std::string script_string(std::string_view text) {
  const std::string json = nlohmann::json(std::string(text))
                               .dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  std::string out;
  out.reserve(json.size() + json.size() / 50);
  for (std::size_t i = 0; i < json.size(); ++i) {
    if (json.compare(i, 4, "<!--") == 0) {
      out += "\\x3C";
    } else if (json.compare(i, 2, "</") == 0) {
      out += "<\\";
    } else {
      out += json[i];
    }
  }
  return out;
}

// Shown until the viewer opens: what to do when it never does (scripts off, an untrusted
// notebook, or the output with the viewer script cleared).
constexpr std::string_view kWaiting =
    "Trellis viewer: this view needs JavaScript and the viewer script that the first view of a "
    "notebook carries; it opens here when the notebook is trusted and its outputs are shown.";
constexpr std::string_view kMissing =
    "Trellis viewer: the viewer script is not on this page (the output that carried it, the first "
    "view shown in this kernel session or trellis.notebook_viewer(), was cleared or not saved). "
    "Run trellis.notebook_viewer() in a cell above this one and then this cell again, or save a "
    "standalone page with toolpath.save_view(path).";

}  // namespace

std::string viewer_notebook_script() {
  const std::string_view loader(kLoaderText, sizeof kLoaderText - 1);
  const auto at = loader.find(kPagePlaceholder);
  if (at == std::string_view::npos) throw Error("viewer notebook loader has no page placeholder");
  const std::string_view page = view_page::page_template();
  const auto data = page.find(view_page::kDataMarker);
  if (data == std::string_view::npos) throw Error("viewer template has no data marker");
  std::string out = "<script>";
  out += loader.substr(0, at);
  out += '[';
  out += script_string(page.substr(0, data));
  out += ',';
  out += script_string(page.substr(data + view_page::kDataMarker.size()));
  out += ']';
  out += loader.substr(at + kPagePlaceholder.size());
  out += "</script>";
  return out;
}

std::string viewer_notebook_view(const std::vector<ViewScene>& scenes, const std::string& title) {
  using namespace view_page;
  std::size_t points = 0;
  for (const auto& s : scenes)
    for (const auto& l : s.toolpath.layers)
      for (const auto& p : l.paths) points += p.points.size();
  // data-points: what the view holds, for a reader of the notebook file (and its size test).
  std::string out =
      "<div class=\"trellis-nb-view\" data-points=\"" + std::to_string(points) + "\"><template>";
  out += data_blocks(scenes, title, LayerData::Packed);
  out +=
      "</template><div class=\"tv-nb-msg\" style=\"padding:6px 8px;border:1px solid #ccc;"
      "font:13px system-ui,sans-serif;color:#555\">";
  out += html_escape(std::string(kWaiting));
  // The call: show now when the script is on the page, else wait for it (notebook.js shows
  // every waiting view when it runs) and say after 3 s that it is missing.
  out +=
      "</div><script>(function(h){if(window.trellisNotebook)return window.trellisNotebook.show(h);"
      "h.setAttribute('data-tv-waiting','');setTimeout(function(){var m=h.querySelector("
      "'.tv-nb-msg');if(m)m.textContent=" +
      script_string(kMissing) + "},3000)})(document.currentScript.parentNode)</script></div>";
  return out;
}

}  // namespace trellis
