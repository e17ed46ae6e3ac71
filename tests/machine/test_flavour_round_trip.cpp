// Our G-code in every flavour, read back (read_print: placement and tool offsets undone), gives
// the same paths, roles, bead sizes, tools, mixtures and temperatures. Every machine profile in
// profiles/ that writes G-code is one case, so a new profile or flavour is covered when it lands.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <set>

#include "support/temp_dir.hpp"
#include "trellis/job/job.hpp"
#include "trellis/machine/gcode_writer.hpp"

using namespace trellis;
namespace fs = std::filesystem;

namespace {

// Two layers of paths with every role, several widths and heights, and (optionally) mixtures
// and two tools.
Toolpath sample(bool mixtures, bool tools) {
  const PathRole roles[] = {PathRole::Strut,  PathRole::Perimeter, PathRole::Infill,
                            PathRole::Skin,   PathRole::Contour,   PathRole::Purge,
                            PathRole::Handle, PathRole::Other};
  Toolpath tp;
  for (int l = 0; l < 2; ++l) {
    Layer layer;
    layer.z = 0.3 * (l + 1);
    for (int i = 0; i < 8; ++i) {
      Path p;
      for (int k = 0; k < 4; ++k)
        p.points.push_back({3.0 * k + 0.5 * i, 4.0 * i + 0.25 * k, layer.z});
      p.role = roles[i];
      p.width = i % 3 ? 0.3 + 0.1 * (i % 3) : 0;
      p.height = i % 2 ? 0.25 : 0;
      if (mixtures) p.mixture = {0.25 * (i % 5), 1 - 0.25 * (i % 5)};
      if (tools) p.tool = i % 2;
      layer.paths.push_back(p);
    }
    tp.layers.push_back(layer);
  }
  return tp;
}

std::vector<fs::path> gcode_profiles() {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(fs::path(TRELLIS_SOURCE_DIR) / "profiles")) {
    Settings st;
    st.load_toml_file(e.path().string());
    if (st.has("machine.flavor")) out.push_back(e.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

Settings load(const fs::path& profile, const std::string& gradient_mode = "") {
  Settings st;
  st.load_toml_file(profile.string());
  const SettingOrigin o{"test"};
  // Geometry changes the writer makes on purpose (path ends pushed past nodes, mixture changes
  // issued early inside a path) are covered by their own tests.
  st.set_text("embedded.node_overlap", "0", o);
  st.set_text("gradient.lookahead", "0", o);
  if (!gradient_mode.empty()) st.set_text("gradient.mode", gradient_mode, o);
  return st;
}

Toolpath round_trip(const Toolpath& tp, const Settings& st, const std::string& file) {
  const MachineProfile m = st.config().machine;
  write_gcode_file(file, tp, m);
  Diagnostics d;
  Toolpath back = read_print(file, &st, nullptr, d);
  EXPECT_EQ(d.total(), 0u) << file << (d.total() ? ": " + d.messages().front().text : "");
  return back;
}

void expect_same_paths(const Toolpath& a, const Toolpath& b, const MachineProfile& m,
                       const std::string& what) {
  ASSERT_EQ(a.layers.size(), b.layers.size()) << what;
  for (std::size_t l = 0; l < a.layers.size(); ++l) {
    ASSERT_EQ(a.layers[l].paths.size(), b.layers[l].paths.size()) << what << " layer " << l;
    for (std::size_t i = 0; i < a.layers[l].paths.size(); ++i) {
      const Path& p = a.layers[l].paths[i];
      const Path& q = b.layers[l].paths[i];
      const std::string at = what + " layer " + std::to_string(l) + " path " + std::to_string(i);
      ASSERT_EQ(p.points.size(), q.points.size()) << at;
      for (std::size_t k = 0; k < p.points.size(); ++k)
        EXPECT_LE(distance(p.points[k], q.points[k]), 1e-3) << at;
      EXPECT_EQ(p.role, q.role) << at;
      EXPECT_DOUBLE_EQ(q.width, p.width > 0 ? p.width : m.nozzle_diameter) << at;
      EXPECT_DOUBLE_EQ(q.height, p.height > 0 ? p.height : m.layer_height) << at;
    }
  }
}

}  // namespace

TEST(FlavourRoundTrip, EveryProfileReadsBackPathsRolesAndBeads) {
  test::TempDir dir("flavours");
  const auto profiles = gcode_profiles();
  ASSERT_GE(profiles.size(), 5u);
  std::set<std::string> flavours;
  for (const auto& profile : profiles) {
    const Settings st = load(profile);
    const MachineProfile m = st.config().machine;
    flavours.insert(to_string(m.flavor));
    const Toolpath tp = sample(false, false);
    const Toolpath back = round_trip(tp, st, dir.file(profile.stem().string() + ".gcode"));
    expect_same_paths(tp, back, m, profile.filename().string());
    for (const auto& l : back.layers)
      for (const auto& p : l.paths) {
        EXPECT_EQ(p.tool, 0) << profile;
        // The profile's nozzle temperature (header M104) reaches every path.
        EXPECT_EQ(p.temperature, m.nozzle_temperature) << profile;
      }
  }
  EXPECT_TRUE(flavours.count("marlin") && flavours.count("reprap") && flavours.count("klipper") &&
              flavours.count("pneumatic") && flavours.count("embedded"));
}

TEST(FlavourRoundTrip, MixturesToolsAndTemperaturesOfGradedPaths) {
  test::TempDir dir("flavours_graded");
  int cases = 0;
  std::set<std::string> modes_seen;
  for (const auto& profile : gcode_profiles()) {
    const MachineProfile base = load(profile).config().machine;
    if (!base.marlin_family()) continue;  // marlin, reprap, klipper
    // The ways this machine can make a mixture (the writer refuses the others).
    std::vector<std::string> modes = {"temperature"};
    if (base.mixing_inputs >= 2) modes.push_back("mixing");
    if (base.tool_count >= 2) modes.push_back("tools");
    for (const std::string& mode : modes) {
      modes_seen.insert(mode);
      const Settings st = load(profile, mode);
      const MachineProfile m = st.config().machine;
      const Toolpath tp = sample(true, false);
      const std::string what = profile.filename().string() + " " + mode;
      const Toolpath back = round_trip(tp, st, dir.file(profile.stem().string() + mode + ".gcode"));
      expect_same_paths(tp, back, m, what);
      for (std::size_t l = 0; l < tp.layers.size() && l < back.layers.size(); ++l)
        for (std::size_t i = 0; i < tp.layers[l].paths.size() && i < back.layers[l].paths.size();
             ++i) {
          const Path& p = tp.layers[l].paths[i];
          const Path& q = back.layers[l].paths[i];
          const double a = p.mixture[0];
          if (mode == "mixing") {
            ASSERT_EQ(q.mixture.size(), p.mixture.size()) << what;
            for (std::size_t k = 0; k < p.mixture.size(); ++k)
              EXPECT_NEAR(q.mixture[k], p.mixture[k], 1e-4) << what;
          } else if (mode == "tools") {
            EXPECT_EQ(q.tool,
                      static_cast<int>(std::lround((1 - a) * (m.gradient_tool_count() - 1))))
                << what;
          } else {
            // M104 S is written to 0.1 °C.
            EXPECT_NEAR(q.temperature, a * m.temperature_a + (1 - a) * m.temperature_b, 0.05 + 1e-9)
                << what;
          }
          ++cases;
        }
    }
  }
  EXPECT_GT(cases, 100);
  EXPECT_EQ(modes_seen.size(), 3u);  // the profiles cover mixing, tools and temperature
}

TEST(FlavourRoundTrip, ToolsOfMultiNozzleMachines) {
  // Embedded machines carry a nozzle per tool with its own XY offset: the tools come back, and
  // the points come back in design coordinates once the offsets are undone.
  test::TempDir dir("flavours_tools");
  int machines = 0;
  for (const auto& profile : gcode_profiles()) {
    const Settings st = load(profile);
    const MachineProfile m = st.config().machine;
    // Multi-nozzle bath machines (offsets) and tool changers of every firmware (T<n>, Klipper's
    // ACTIVATE_EXTRUDER; heaters in each one's commands).
    const bool bath = m.flavor == Flavor::Embedded && !m.tool_offsets.empty();
    const bool changer = m.marlin_family() && m.tool_count >= 2;
    if (!bath && !changer) continue;
    ++machines;
    const Toolpath tp = sample(false, true);
    const Toolpath back = round_trip(tp, st, dir.file(profile.stem().string() + ".gcode"));
    expect_same_paths(tp, back, m, profile.filename().string());
    for (std::size_t l = 0; l < tp.layers.size() && l < back.layers.size(); ++l)
      for (std::size_t i = 0; i < tp.layers[l].paths.size() && i < back.layers[l].paths.size(); ++i)
        EXPECT_EQ(back.layers[l].paths[i].tool, tp.layers[l].paths[i].tool) << profile;
  }
  EXPECT_GE(machines, 4);  // two bath machines, the Prusa XL (Marlin), the E3D (RepRapFirmware)
}
