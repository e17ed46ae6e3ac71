#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "../../src/view/page.hpp"
#include "support/temp_dir.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/lattice/graph.hpp"
#include "trellis/view/view.hpp"

using namespace trellis;

namespace {

std::string unbase64(const std::string& in) {
  auto val = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    return c == '+' ? 62 : c == '/' ? 63 : -1;
  };
  std::string out;
  unsigned buf = 0;
  int bits = 0;
  for (char c : in) {
    const int v = val(c);
    if (v < 0) continue;
    buf = (buf << 6) | v;
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += static_cast<char>((buf >> bits) & 0xff);
    }
  }
  return out;
}

// The text of the element with `id` in `html`.
std::string element(const std::string& html, const std::string& id) {
  const auto at = html.find("id=\"" + id + "\">");
  if (at == std::string::npos) return "";
  const auto start = html.find('>', at) + 1;
  return html.substr(start, html.find("</script>", start) - start);
}

Toolpath sample() {
  Toolpath tp;
  Path a, b;
  a.points = {{0, 0, 0.2}, {10, 0, 0.2}, {10, 5, 0.2}};
  a.role = PathRole::Perimeter;
  a.temperature = 215;
  a.mixture = {0.25, 0.75};
  b.points = {{1, 1, 0.2}, {9, 4, 0.2}};
  b.role = PathRole::Infill;
  b.tool = 1;
  b.via = {{5, 2, 0.2}};  // the travel into b turns here
  tp.layers.push_back({0.2, {a, b}});
  b.via.clear();
  tp.layers.push_back({0.4, {b}});
  return tp;
}

}  // namespace

// The page carries each layer as one binary chunk with the layout data.js decodes: counts,
// float32 positions, path starts, ten float32 attributes per path (the last three the commanded
// mixture), role, tool and laser parameter set bytes, the travel corners (via) per path.
TEST(View, LayerChunksHoldTheToolpath) {
  Toolpath tp = sample();
  const Path& b = tp.layers[0].paths[1];
  tp.parameter_sets = {{"other", PathRole::Hatch, 0, 0}, {"b's set", b.role, b.power, b.speed}};
  const std::string html = viewer_html({view_scene(tp, "sample")}, "sample");
  const std::string l0 = unbase64(element(html, "tv-0-l0"));
  ASSERT_GE(l0.size(), 8u);
  std::uint32_t counts[2];
  std::memcpy(counts, l0.data(), 8);
  EXPECT_EQ(counts[0], 5u);  // points
  EXPECT_EQ(counts[1], 2u);  // paths
  const std::size_t pos = 8, first = pos + 5 * 12, attr = first + 2 * 4, role = attr + 2 * 40;
  const std::size_t vias = (role + 6 + 3) / 4 * 4;
  ASSERT_EQ(l0.size(), vias + 4 + 3 * 4 + 12);
  std::uint32_t v[4];
  std::memcpy(v, l0.data() + vias, sizeof v);
  EXPECT_EQ(v[0], 1u);  // one corner, b's: first_via = 0, 0, 1
  EXPECT_EQ(v[1], 0u);
  EXPECT_EQ(v[2], 0u);
  EXPECT_EQ(v[3], 1u);
  float corner[3];
  std::memcpy(corner, l0.data() + vias + 16, sizeof corner);
  EXPECT_EQ(corner[0], 5.0f);
  EXPECT_EQ(corner[1], 2.0f);
  // A layer without corners ends with vias = 0.
  const std::string l1 = unbase64(element(html, "tv-0-l1"));
  std::uint32_t none = 1;
  std::memcpy(&none, l1.data() + l1.size() - 4, 4);
  EXPECT_EQ(none, 0u);
  float p[15];
  std::memcpy(p, l0.data() + pos, sizeof p);
  EXPECT_EQ(p[3], 10.0f);
  EXPECT_EQ(p[14], 0.2f);
  std::uint32_t starts[2];
  std::memcpy(starts, l0.data() + first, 8);
  EXPECT_EQ(starts[1], 3u);
  float at[20];
  std::memcpy(at, l0.data() + attr, sizeof at);
  EXPECT_EQ(at[0], 0.25f);   // mixture of material 1
  EXPECT_EQ(at[2], 215.0f);  // temperature
  EXPECT_EQ(at[6], -1.0f);   // path a: two materials, no third
  EXPECT_EQ(at[7], 0.25f);   // commanded: as planned (a toolpath)
  EXPECT_EQ(at[10], -1.0f);  // path b: no mixture
  EXPECT_EQ(static_cast<int>(l0[role]), static_cast<int>(PathRole::Perimeter));
  EXPECT_EQ(static_cast<int>(l0[role + 3]), 1);  // tool of path b
  EXPECT_EQ(static_cast<int>(l0[role + 4]), 0);  // path a: in no set
  EXPECT_EQ(static_cast<int>(l0[role + 5]), 2);  // path b: set 1, as 1 + 1
  EXPECT_NE(element(html, "tv-0-meta").find("\"parameter_sets\":[\"other\",\"b's set\"]"),
            std::string::npos);
  EXPECT_FALSE(element(html, "tv-0-l1").empty());
  EXPECT_TRUE(element(html, "tv-0-l2").empty());
}

// Small parts: the page is the bundled template (< 2 MB) plus the data.
TEST(View, PageIsSmallAndSelfContained) {
  EXPECT_LT(viewer_template_size(), 2u << 20);
  const std::string html = viewer_html({view_scene(sample(), "sample")}, "a <title>");
  EXPECT_LT(html.size(), viewer_template_size() + 4096);
  EXPECT_EQ(html.find("http://"), html.find("http://www.w3.org"));  // no fetched resources
  EXPECT_EQ(html.find("src=\"http"), std::string::npos);
  EXPECT_NE(html.find("<title>a &lt;title&gt;</title>"), std::string::npos);
}

// Hostile strings (a G-code line echoed as a warning, a file name, a title) cannot change how the
// page parses: every embedded JSON block holds no `<`, `>` or `&`, the page has as many <script>
// tags as with harmless strings, and the JSON still reads back the strings as they were.
TEST(View, EmbeddedStringsCannotChangeHowThePageParses) {
  const std::string hostile[] = {"<!--<script>", "</script><script>alert(1)</script>",
                                 "<!-- a & b -->", "]]></title><img src=x onerror=alert(1)>"};
  auto page = [&](bool bad) {
    ViewScene s = view_scene(sample(), bad ? hostile[0] + "x.gcode" : "x.gcode");
    s.toolpath.source = bad ? hostile[2] : "source";
    for (const auto& h : hostile) s.warnings.push_back(bad ? h : "warning");
    s.warnings.push_back(bad ? "bad UTF-8 \xff\xfe" : "warning");
    return viewer_html({s}, bad ? hostile[1] + hostile[3] : "title");
  };
  const std::string good = page(false), html = page(true);
  auto count = [](const std::string& text, const std::string& what) {
    std::size_t n = 0;
    for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
    return n;
  };
  EXPECT_EQ(count(html, "<script"), count(good, "<script"));
  EXPECT_EQ(count(html, "</script"), count(good, "</script"));
  EXPECT_EQ(count(html, "<!--"), count(good, "<!--"));
  for (const char* id : {"tv-index", "tv-0-meta"}) {
    const std::string text = element(html, id);
    ASSERT_FALSE(text.empty()) << id;
    EXPECT_EQ(text.find_first_of("<>&"), std::string::npos) << id << ": " << text;
  }
  const auto index = nlohmann::json::parse(element(html, "tv-index"));
  EXPECT_EQ(index["title"], hostile[1] + hostile[3]);
  const auto meta = nlohmann::json::parse(element(html, "tv-0-meta"));
  EXPECT_EQ(meta["name"], hostile[0] + "x.gcode");
  EXPECT_EQ(meta["source"], hostile[2]);
  for (std::size_t i = 0; i < std::size(hostile); ++i) EXPECT_EQ(meta["warnings"][i], hostile[i]);
  EXPECT_EQ(meta["warnings"][4], "bad UTF-8 \xef\xbf\xbd\xef\xbf\xbd");  // U+FFFD each
}

TEST(View, UnknownFileKindIsAnErrorNamingTheFile) {
  const trellis::test::TempDir tmp("trellis_view");
  const std::string f = tmp.file("part.stp");
  write_file_atomic(f, "ISO-10303-21;");
  Diagnostics diag;
  try {
    load_view_scene(f, {}, diag);
    FAIL() << "no error";
  } catch (const ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("part.stp"), std::string::npos);
  }
  EXPECT_THROW(load_view_scene(tmp.file("missing.gcode"), {}, diag), IoError);
}

// The CLI: a bad input is exit code 2 and no page is left behind.
TEST(View, CliErrorLeavesNoPage) {
  const trellis::test::TempDir tmp("trellis_view_cli");
  const std::string out = tmp.file("v.html");
  const std::string cmd = std::string(TRELLIS_CLI) + " view " + tmp.file("missing.gcode") + " -o " +
                          out + " 2>/dev/null";
  const int rc = std::system(cmd.c_str());
  EXPECT_EQ(WEXITSTATUS(rc), 2);
  EXPECT_FALSE(std::filesystem::exists(out));
}

// Deviation from the design: every toolpath point's distance to the nearest strut, through the
// grid, equals the brute-force minimum over all struts (random struts and points, some outside
// the design's box).
TEST(View, DeviationIsTheDistanceToTheNearestStrut) {
  Graph g;
  std::uint32_t seed = 12345;
  auto rnd = [&] {
    seed = seed * 1664525u + 1013904223u;
    return (seed >> 8) / double(1 << 24);
  };
  for (int i = 0; i < 60; ++i) g.nodes.push_back({rnd() * 10, rnd() * 10, rnd() * 5});
  for (int i = 0; i < 80; ++i) {
    const auto a = static_cast<NodeId>(rnd() * 60), b = static_cast<NodeId>(rnd() * 60);
    if (a != b) g.edges.push_back({a, b, 0, false, 0});
  }
  Toolpath tp;
  Path p;
  for (int i = 0; i < 300; ++i) p.points.push_back({rnd() * 16 - 3, rnd() * 16 - 3, rnd() * 9 - 2});
  tp.layers.push_back({0, {p}});
  ViewScene s = view_scene(tp, "random");
  set_design(s, g);
  ASSERT_EQ(s.deviation.size(), p.points.size());
  ASSERT_EQ(s.design.size(), g.edges.size());
  for (std::size_t i = 0; i < p.points.size(); ++i) {
    double best = 1e300;
    for (const auto& e : g.edges)
      best = std::min(best, distance_to_segment(p.points[i], g.nodes[e.a], g.nodes[e.b]));
    EXPECT_NEAR(s.deviation[i], best, 1e-5) << i;
  }
}

// A `trellis check` report is a viewer input: its collisions become rings, the struts it names are
// flagged on the design, its counts become statistics; a report missing a count is an error
// naming the file.
TEST(View, CheckReportIsAnInput) {
  const trellis::test::TempDir tmp("trellis_view_check");
  const std::string f = tmp.file("check.json");
  write_file_atomic(f, R"({"ok": false, "paths": 3, "segments": 9, "struts": 4,
    "struts_printed_once": 4, "missing_struts": [], "repeated_struts": [], "off_design_segments": 0,
    "collisions": 5, "collision_list": [
      {"path": 2, "segment": 1, "strut": 3, "hit_strut": 0, "hit_path": 0, "tip": [0, 0, 1], "point": [1, 2, 3]},
      {"path": 2, "segment": 2, "strut": 3, "hit_strut": 1, "hit_path": 0, "tip": [0, 0, 1], "point": [4, 5, 6]}]})");
  Diagnostics diag;
  ViewScene s = load_view_scene(f, {}, diag);
  EXPECT_EQ(s.kind, "check");
  EXPECT_TRUE(s.checked);
  EXPECT_EQ(s.collisions, 5u);
  ASSERT_EQ(s.hits.size(), 2u);
  EXPECT_EQ(s.hits[1].path, 2);
  EXPECT_EQ(s.hits[1].segment, 2);
  EXPECT_EQ(s.hits[1].point.z, 6.0);
  Graph g;
  g.nodes = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  for (NodeId a = 0; a < 4; ++a)
    g.edges.push_back({a, static_cast<NodeId>((a + 1) % 4), 0, false, 0});
  set_design(s, g);
  ASSERT_EQ(s.design_flag.size(), 4u);
  EXPECT_EQ(std::vector<char>(s.design_flag.begin(), s.design_flag.end()),
            (std::vector<char>{1, 1, 0, 1}));
  const std::string html = viewer_html({s}, "check");
  EXPECT_FALSE(element(html, "tv-0-extras").empty());
  EXPECT_NE(html.find("\"collisions\":5"), std::string::npos);

  write_file_atomic(f, R"({"collision_list": [], "paths": 1})");
  try {
    load_view_scene(f, {}, diag);
    FAIL() << "no error";
  } catch (const ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("check.json"), std::string::npos) << e.what();
  }
}

namespace {

// Reads the packed layers (src/view/encode.cpp, pack_layers) back, as viewer/src/data.js does.
struct PackReader {
  const std::string& b;
  std::size_t at = 0;
  std::uint64_t varint() {
    std::uint64_t v = 0;
    for (int shift = 0;; shift += 7) {
      const auto c = static_cast<std::uint8_t>(b.at(at++));
      v |= std::uint64_t(c & 0x7f) << shift;
      if (!(c & 0x80)) return v;
    }
  }
  std::int64_t zigzag() {
    const std::uint64_t v = varint();
    return v & 1 ? -static_cast<std::int64_t>(v >> 1) - 1 : static_cast<std::int64_t>(v >> 1);
  }
  float f32() {
    float f;
    std::memcpy(&f, b.data() + at, 4);
    at += 4;
    return f;
  }
};

std::size_t count(const std::string& s, const std::string& what) {
  std::size_t n = 0;
  for (auto at = s.find(what); at != std::string::npos; at = s.find(what, at + 1)) ++n;
  return n;
}

}  // namespace

// A notebook view's layers, packed: every point back within half a 1 µm step, the counts, the
// attribute columns, roles, tools and travel corners as the per-layer chunks carry them.
TEST(View, PackedLayersHoldTheToolpath) {
  Toolpath tp = sample();
  tp.layers[0].paths[0].points[1] = {10.0004, -3.14159, 0.2};
  const std::string b = view_page::pack_layers(view_scene(tp, "sample"));
  ASSERT_EQ(b.substr(0, 4), "TVP1");
  double quantum;
  std::memcpy(&quantum, b.data() + 4, 8);
  EXPECT_EQ(quantum, 1e-3);
  PackReader r{b, 12};
  ASSERT_EQ(r.varint(), tp.layers.size());
  std::int64_t last[3] = {0, 0, 0}, last_via[3] = {0, 0, 0};
  for (const auto& layer : tp.layers) {
    std::size_t np = 0, nv = 0;
    for (const auto& p : layer.paths) np += p.points.size(), nv += p.via.size();
    ASSERT_EQ(r.varint(), np);
    ASSERT_EQ(r.varint(), layer.paths.size());
    ASSERT_EQ(r.varint(), nv);
    for (const auto& p : layer.paths) EXPECT_EQ(r.varint(), p.points.size());
    for (const auto& p : layer.paths)
      for (const auto& q : p.points)
        for (int k = 0; k < 3; ++k) {
          last[k] += r.zigzag();
          EXPECT_NEAR(last[k] * quantum, k == 0 ? q.x : k == 1 ? q.y : q.z, quantum / 2 + 1e-12);
        }
    for (int k = 0; k < 10; ++k)
      for (const auto& p : layer.paths) {
        const float v = r.f32();
        // Mixture, and the commanded one (the same as planned: no look-ahead to undo).
        if (k == 0 || k == 7) EXPECT_EQ(v, p.mixture.empty() ? -1.0f : float(p.mixture[0]));
        if (k == 2) EXPECT_EQ(v, float(p.temperature));
      }
    for (const auto& p : layer.paths) EXPECT_EQ(b.at(r.at++), static_cast<char>(p.role));
    for (const auto& p : layer.paths) EXPECT_EQ(b.at(r.at++), static_cast<char>(p.tool));
    for (std::size_t q = 0; q < layer.paths.size(); ++q) EXPECT_EQ(b.at(r.at++), 0);  // no sets
    if (nv > 0) {
      for (const auto& p : layer.paths) EXPECT_EQ(r.varint(), p.via.size());
      for (const auto& p : layer.paths)
        for (const auto& q : p.via)
          for (int k = 0; k < 3; ++k) {
            last_via[k] += r.zigzag();
            EXPECT_NEAR(last_via[k] * quantum, k == 0 ? q.x : k == 1 ? q.y : q.z, quantum / 2);
          }
    }
  }
  EXPECT_EQ(r.at, b.size());
}

// A notebook view is data only (no per-layer chunks, no script of the viewer), in one inert
// <template> that hostile names cannot close; the viewer script has a single </script>, its own.
TEST(View, NotebookViewIsDataOnlyAndCannotBeBrokenOutOf) {
  const std::string hostile = "</template><script>window.pwned=1</script><!--";
  const std::string view = viewer_notebook_view({view_scene(sample(), hostile)}, hostile);
  EXPECT_EQ(view.find("tv-0-l0"), std::string::npos);
  EXPECT_NE(view.find("id=\"tv-0-pack\""), std::string::npos);
  EXPECT_EQ(count(view, "</template>"), 1u);
  EXPECT_EQ(count(view, "<script"), 4u);  // index, meta, pack, and the call to the viewer
  EXPECT_EQ(view.find("<script>window.pwned"), std::string::npos);
  EXPECT_NE(view.find("data-points=\"7\""), std::string::npos);
  EXPECT_LT(view.size(), 3000u);
  const std::string script = viewer_notebook_script();
  EXPECT_EQ(count(script, "</script"), 1u);
  EXPECT_EQ(script.find("<!--"), std::string::npos);
  EXPECT_GT(script.size(), viewer_template_size());
  EXPECT_LT(script.size(), viewer_template_size() * 11 / 10);
}
