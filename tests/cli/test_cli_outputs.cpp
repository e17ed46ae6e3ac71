// Every output name each route accepts is written in the format its extension names (issue 43):
// each accepted extension is written and read back with that format's reader, the formats of one
// route holding the same thing (layers and length, triangles, struts); a name for another format
// exits 2 naming the file and the extensions it may have, with nothing written.
#include <gtest/gtest.h>

#include <cctype>
#include <cmath>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "support/cli_run.hpp"
#include "trellis/core/diagnostics.hpp"
#include "trellis/geom/mesh_io.hpp"
#include "trellis/job/job.hpp"
#include "trellis/lattice/io.hpp"
#include "trellis/machine/cli.hpp"
#include "trellis/toolpath/json.hpp"

namespace fs = std::filesystem;
using namespace trellis;

namespace {

fs::path dir() {
  static const fs::path d = test::scratch("trellis_cli_outputs_test");
  return d;
}

std::string in_dir(const std::string& name) {
  return (dir() / name).string();
}

test::CliRun run(const std::string& args) {
  return test::run_cli(args, dir());
}

std::string profile(const std::string& name) {
  return std::string(TRELLIS_SOURCE_DIR) + "/profiles/" + name;
}

// What a file holds, as its format's reader reads it back: toolpaths by layers and length,
// meshes by triangles and extent, lattices by struts.
struct Held {
  std::size_t count = 0;  // layers, triangles or struts
  double size = 0;        // scanned or extruded length (mm), or the mesh's extent (mm)
};

Held toolpath_held(const Toolpath& tp) {
  return {tp.layers.size(), tp.extrusion_length()};
}

std::string lower_ext(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

// The G-code names hold the same program; other formats of a route hold the same paths (a G-code
// adds the machine's start and end moves, so it is compared with G-code only).
bool gcode_name(const std::string& ext) {
  const std::string e = lower_ext("x" + ext);
  return e == ".gcode" || e == ".nc" || e == ".g" || e == ".gco" || e == ".bgcode";
}

Held read_back(const std::string& path) {
  const std::string ext = lower_ext(path);
  Diagnostics diag;
  if (ext == ".cli") return toolpath_held(read_cli_file(path, &diag));
  if (ext == ".stl" || ext == ".obj") {
    const TriangleMesh m = read_mesh(path);
    const BBox3 b = bounds(m);
    return {m.triangles.size(), norm(b.max - b.min)};
  }
  // .json, .3mf and the G-code names: as `trellis analyze` and `check` read prints.
  return toolpath_held(read_print(path, nullptr, nullptr, diag));
}

Held read_mesh_back(const std::string& path) {
  const TriangleMesh m = read_mesh(path);
  const BBox3 b = bounds(m);
  return {m.triangles.size(), norm(b.max - b.min)};
}

Held read_lattice_back(const std::string& path) {
  Diagnostics diag;
  const Graph g = read_lattice(path, {}, diag);
  return {g.edges.size(), g.total_length()};
}

// Runs `command` with `flag NAME.ext` for each accepted extension, reads each back and expects
// the same count and size (within `tol` relative) from all; each refused extension exits 2 with
// the file named, "name it so", and nothing written.
void check_names(const std::string& what,
                 const std::function<std::string(const std::string&)>& command,
                 const std::vector<std::string>& accepted, const std::vector<std::string>& refused,
                 const std::function<Held(const std::string&)>& reader, double tol) {
  std::vector<Held> held;
  for (const std::string& ext : accepted) {
    const std::string out = in_dir(what + "_ok" + ext);
    const test::CliRun r = run(command(out));
    ASSERT_EQ(r.code, 0) << what << " " << ext << ": " << r.err;
    ASSERT_TRUE(fs::exists(out)) << what << " " << ext;
    Held h;
    ASSERT_NO_THROW(h = reader(out)) << what << " " << ext << " does not read back as " << ext;
    EXPECT_GT(h.count, 0u) << what << " " << ext;
    EXPECT_GT(h.size, 0) << what << " " << ext;
    held.push_back(h);
  }
  for (std::size_t k = 1; k < held.size(); ++k)
    for (std::size_t j = 0; j < k; ++j) {
      if (gcode_name(accepted[k]) != gcode_name(accepted[j])) continue;
      EXPECT_EQ(held[k].count, held[j].count)
          << what << ": " << accepted[k] << " vs " << accepted[j];
      EXPECT_NEAR(held[k].size, held[j].size, tol * held[j].size)
          << what << ": " << accepted[k] << " vs " << accepted[j];
    }
  for (const std::string& ext : refused) {
    const std::string out = in_dir(what + "_never" + ext);
    const test::CliRun r = run(command(out));
    EXPECT_EQ(r.code, 2) << what << " " << ext << ": " << r.out;
    EXPECT_NE(r.err.find(out), std::string::npos) << what << " " << ext << ": " << r.err;
    EXPECT_NE(r.err.find("name it so"), std::string::npos) << what << " " << ext << ": " << r.err;
    EXPECT_FALSE(fs::exists(out)) << what << " " << ext;
  }
}

// A small lattice and its plan, the inputs of the routes after them.
const std::string& lattice() {
  static const std::string path = [] {
    const std::string p = in_dir("in_lattice.json");
    EXPECT_EQ(run("lattice2d --pattern square --cell 1 --size 4,4 -o " + p).code, 0);
    return p;
  }();
  return path;
}

const std::string& plan() {
  static const std::string path = [] {
    const std::string p = in_dir("in_plan.json");
    EXPECT_EQ(run("plan euler " + lattice() + " -o " + p).code, 0);
    return p;
  }();
  return path;
}

}  // namespace

TEST(CliOutputs, LatticesAreJsonOr3mf) {
  check_names(
      "lattice2d",
      [](const std::string& o) { return "lattice2d --pattern square --cell 1 --size 4,4 -o " + o; },
      {".json"}, {".3mf", ".obj", ".csv", ""}, read_lattice_back, 1e-9);
  // The 3MF beam lattice holds 32-bit floats.
  check_names(
      "lattice3d",
      [](const std::string& o) {
        return "lattice3d --cell-type octet --cell 7 --count 1,1,1 -o " + o;
      },
      {".json", ".3mf"}, {".obj", ".stl", ".txt"}, read_lattice_back, 1e-6);
}

TEST(CliOutputs, PlansAreToolpathJsonAndTheirGcodeIsGcodeOr3mf) {
  check_names(
      "plan", [](const std::string& o) { return "plan euler " + lattice() + " -o " + o; },
      {".json"}, {".gcode", ".3mf", ".cli"}, read_back, 1e-9);
  const std::string machine = profile("ender3_s1_pro_tpu.toml");
  check_names(
      "plan_gcode",
      [&](const std::string& o) {
        return "plan euler " + lattice() + " -o " + in_dir("plan_tp.json") + " --machine " +
               machine + " --gcode " + o;
      },
      {".gcode", ".nc", ".g", ".gco", ".GCODE", ".3mf"}, {".json", ".stl", ".txt"}, read_back,
      1e-3);
  check_names(
      "gcode",
      [&](const std::string& o) {
        return "gcode " + plan() + " --machine " + machine + " -o " + o;
      },
      {".gcode", ".nc", ".3mf"}, {".json", ".cli", ".txt", ""}, read_back, 1e-3);
  // Binary G-code with Prusa's firmware, read back like the text.
  check_names(
      "gcode_prusa",
      [&](const std::string& o) {
        return "gcode " + plan() + " --machine " + profile("prusa_mk4s_lwpla.toml") + " -o " + o;
      },
      {".gcode", ".bgcode"}, {".json"}, read_back, 1e-3);
}

TEST(CliOutputs, SlicesAndNonplanarPrintsAreGcodeOr3mf) {
  const std::string design =
      std::string(TRELLIS_SOURCE_DIR) + "/examples/designs/fgm_column5_ring_radial.vcad";
  const std::string machine = profile("ender3_s1_pro_tpu.toml");
  check_names(
      "slice",
      [&](const std::string& o) {
        return "slice " + design + " --machine " + machine + " -o " + o +
               " --layer-height 0.5 --set extrusion.nozzle_diameter=0.8 --bead-width 0.4 --walls 1 "
               "--infill 0 --strategy none";
      },
      {".gcode", ".3mf"}, {".json", ".stl", ".cli"}, read_back, 2e-3);
  const std::string surface = in_dir("in_surface.stl");
  ASSERT_EQ(run("surface m-curve -o " + surface).code, 0);
  const std::string fresh = profile("fresh_nonplanar_2syringe.toml");
  check_names(
      "nonplanar",
      [&](const std::string& o) {
        return "nonplanar " + surface + " --machine " + fresh + " --layers 2 --angles 0 -o " + o;
      },
      {".gcode", ".3mf"}, {".stl", ".json", ".obj"}, read_back, 2e-3);
}

TEST(CliOutputs, LaserBuildsAreCliOr3mfAndTheirToolpathJson) {
  const std::string base = "pbf --cell 2.5 --size 3,3,0.2 ";
  check_names(
      "pbf", [&](const std::string& o) { return base + "-o " + o; }, {".cli", ".3mf", ".CLI"},
      {".json", ".gcode", ".stl", ""}, read_back, 1e-4);
  check_names(
      "pbf_toolpath",
      [&](const std::string& o) {
        return base + "-o " + in_dir("pbf_main.cli") + " --toolpath " + o;
      },
      {".json"}, {".cli", ".3mf"}, read_back, 1e-9);
  check_names(
      "pbf_report",
      [&](const std::string& o) { return base + "-o " + in_dir("pbf_r.cli") + " --report " + o; },
      {}, {".txt", ".csv"}, read_back, 0);
}

// The test surfaces are meshes (a real OBJ, not STL bytes under that name); the angle test is a
// toolpath or a print.
TEST(CliOutputs, SurfacesAreStlObjOr3mfMeshes) {
  check_names(
      "surface", [](const std::string& o) { return "surface miura -o " + o; },
      {".stl", ".obj", ".3mf", ".OBJ"}, {".json", ".gcode", ".txt", ""}, read_mesh_back, 1e-6);
  // An OBJ of v/f lines, every triangle's vertices within the file's.
  const std::string obj = read_file(in_dir("surface_ok.obj"));
  EXPECT_EQ(obj.find("solid"), std::string::npos);
  EXPECT_NE(obj.find("\nv "), std::string::npos);
  EXPECT_NE(obj.find("\nf "), std::string::npos);
  check_names(
      "angle_test", [](const std::string& o) { return "surface angle-test -o " + o; }, {".json"},
      {".stl", ".obj"}, read_back, 0);
  check_names(
      "angle_test_gcode",
      [](const std::string& o) {
        return "surface angle-test --machine " + profile("ender3_s1_pro_tpu.toml") + " -o " + o;
      },
      {".gcode", ".3mf"}, {".stl"}, read_back, 1e-3);
  check_names(
      "walls", [](const std::string& o) { return "walls " + lattice() + " -o " + o; },
      {".stl", ".obj", ".3mf"}, {".json", ".gcode"}, read_mesh_back, 1e-6);
}

TEST(CliOutputs, ReadersWriteHtmlPngAndJsonReports) {
  check_names(
      "view", [](const std::string& o) { return "view " + plan() + " -o " + o; }, {".html", ".htm"},
      {".png", ".json"},
      [](const std::string& p) {
        return Held{read_file(p).find("<html") != std::string::npos ? 1u : 0u, 1};
      },
      0);
  check_names(
      "render", [](const std::string& o) { return "render " + plan() + " --layer 0 -o " + o; },
      {".png"}, {".html", ".jpg"},
      [](const std::string& p) {
        return Held{read_file(p).rfind("\x89PNG", 0) == 0 ? 1u : 0u, 1};
      },
      0);
  check_names(
      "analyze_report", [](const std::string& o) { return "analyze " + plan() + " --report " + o; },
      {".json"}, {".txt"},
      [](const std::string& p) {
        return Held{read_file(p).front() == '{' ? 1u : 0u, 1};
      },
      0);
}
