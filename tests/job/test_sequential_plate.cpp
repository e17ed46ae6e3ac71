// FDM plates printed part by part (plate.sequence = parts, issue 23): read back from the G-code,
// each part's extrusions are contiguous, in the job's order, and complete (the same moves and
// lengths as the plate printed per layer); no move passes over a finished part below its top;
// the streamed file is the whole run's. A part taller than the gantry clearance that is not last,
// parts closer than the clearance radius, a profile without clearances and sharding are refused
// (exit 2, the parts named, nothing written).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "support/cli_run.hpp"
#include "support/temp_dir.hpp"
#include "trellis/core/diagnostics.hpp"
#include "trellis/core/file.hpp"
#include "trellis/job/job.hpp"

namespace fs = std::filesystem;
using namespace trellis;

namespace {

const std::string kRoot = TRELLIS_SOURCE_DIR;

// Bracket (41 x 31 x 18 mm at 0.3 mm layers) in the middle, a 10 mm lattice tile 46.5 mm either
// side: the travel from the left tile to the right one crosses the bracket.
const double kCentres[3][2] = {{90, 60}, {18, 60}, {162, 60}};

fs::path job_file(const fs::path& dir, const std::string& sequence) {
  fs::create_directories(dir);
  const fs::path f = dir / "plate.toml";
  std::ofstream o(f);
  o << "[job]\nroute = \"slice\"\nname = \"plate\"\nmachine = \"" << kRoot
    << "/profiles/prusa_mk4s_lwpla.toml\"\n[extrusion]\nlayer_height = 0.3\n[slice]\nwalls = 1\n"
    << "infill = 0.2\nresolution = 0.2\n[plate]\nsequence = \"" << sequence << "\"\n";
  const char* inputs[3] = {"csg_bracket.vcad", "gyroid_lattice_tile.vcad",
                           "gyroid_lattice_tile.vcad"};
  const char* labels[3] = {"bracket", "left", "right"};
  for (int k = 0; k < 3; ++k)
    o << "[[part]]\nlabel = \"" << labels[k] << "\"\ninput = \"" << kRoot << "/examples/designs/"
      << inputs[k] << "\"\nx = " << kCentres[k][0] << "\ny = " << kCentres[k][1] << "\n";
  return f;
}

struct Move {
  double x0, y0, z0, x1, y1, z1;
  bool extrudes;
  int part;  // nearest part centre (extrusions)
};

// G0/G1 moves in absolute positions and E (M82, G92 E0 resets), as the writer emits them.
std::vector<Move> read_moves(const std::string& gcode) {
  std::vector<Move> out;
  double x = 0, y = 0, z = 0, e = 0;
  bool priming = false;  // the prime line along the bed's edge belongs to no part
  std::istringstream in(gcode);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(";TYPE:", 0) == 0) priming = line.rfind(";TYPE:Prime line", 0) == 0;
    if (line.rfind(";LAYER_CHANGE", 0) == 0) priming = false;
    if (line.rfind("G92", 0) == 0) {
      const auto at = line.find(" E");
      if (at != std::string::npos) e = std::stod(line.substr(at + 2));
      continue;
    }
    if (line.rfind("G0 ", 0) != 0 && line.rfind("G1 ", 0) != 0) continue;
    double nx = x, ny = y, nz = z, ne = e;
    std::istringstream words(line.substr(3));
    std::string w;
    while (words >> w) {
      if (w[0] == ';') break;
      const double v = std::stod(w.substr(1));
      if (w[0] == 'X') nx = v;
      if (w[0] == 'Y') ny = v;
      if (w[0] == 'Z') nz = v;
      if (w[0] == 'E') ne = v;
    }
    const bool xy = nx != x || ny != y;
    Move m{x, y, z, nx, ny, nz, xy && ne > e + 1e-9 && !priming, -1};
    if (m.extrudes) {
      double best = 1e300;
      for (int k = 0; k < 3; ++k) {
        const double d = std::hypot(nx - kCentres[k][0], ny - kCentres[k][1]);
        if (d < best) best = d, m.part = k;
      }
    }
    if (xy || nz != z) out.push_back(m);
    x = nx, y = ny, z = nz, e = ne;
  }
  return out;
}

// Whether segment (x0,y0)-(x1,y1) meets the box [lo, hi] (Liang–Barsky).
bool crosses(const Move& m, const double lo[2], const double hi[2]) {
  double t0 = 0, t1 = 1;
  const double p[2] = {m.x0, m.y0}, d[2] = {m.x1 - m.x0, m.y1 - m.y0};
  for (int a = 0; a < 2; ++a) {
    if (std::abs(d[a]) < 1e-12) {
      if (p[a] < lo[a] || p[a] > hi[a]) return false;
      continue;
    }
    double ta = (lo[a] - p[a]) / d[a], tb = (hi[a] - p[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta), t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

std::string run(const fs::path& file, const fs::path& out, bool keep) {
  Job job = load_job(file.string(), out.string(), {"output.png=false"});
  job.keep_toolpath = keep;
  Diagnostics diag;
  run_job(job, diag);
  return read_file(job.output);
}

int cli(const std::string& args, std::string& err) {
  static const test::TempDir dir("trellis_seq_plate");
  const test::CliRun r = test::run_cli(args, dir.path());
  err = r.err;
  return r.code;
}

TEST(SequentialPlate, EachPartWholeInTurnNeverBelowAFinishedPartsTop) {
  const test::TempDir tmp("trellis_sequential_plate");
  const fs::path dir = tmp.path();
  const std::string seq = run(job_file(dir / "seq", "parts"), dir / "seq" / "out", true);
  EXPECT_TRUE(seq == run(job_file(dir / "seq", "parts"), dir / "seq" / "stream", false))
      << "streamed sequential plate differs from the whole run";
  const std::string per_layer =
      run(job_file(dir / "layers", "layers"), dir / "layers" / "out", true);
  const std::vector<Move> moves = read_moves(seq), reference = read_moves(per_layer);

  // Contiguous, in the job's order: the part of the extrusions changes twice, 0 → 1 → 2.
  std::vector<int> order;
  for (const Move& m : moves)
    if (m.extrudes && (order.empty() || order.back() != m.part)) order.push_back(m.part);
  EXPECT_EQ(order, (std::vector<int>{0, 1, 2}));
  // Complete: the same extrusion moves and lengths per part as the plate printed per layer.
  for (int k = 0; k < 3; ++k) {
    std::size_t n[2] = {0, 0};
    double len[2] = {0, 0};
    for (int f = 0; f < 2; ++f)
      for (const Move& m : f ? reference : moves)
        if (m.extrudes && m.part == k) ++n[f], len[f] += std::hypot(m.x1 - m.x0, m.y1 - m.y0);
    EXPECT_GT(n[0], 100u) << "part " << k;
    EXPECT_EQ(n[0], n[1]) << "part " << k;
    EXPECT_NEAR(len[0], len[1], 1e-6 * len[1]) << "part " << k;
  }
  // Once a part's last extrusion is done, no move over its footprint goes below its top.
  struct Done {
    double lo[2] = {1e300, 1e300}, hi[2] = {-1e300, -1e300}, top = 0;
    std::size_t last = 0;
  } done[3];
  for (std::size_t i = 0; i < moves.size(); ++i)
    if (moves[i].extrudes) {
      Done& d = done[moves[i].part];
      d.lo[0] = std::min({d.lo[0], moves[i].x0, moves[i].x1});
      d.lo[1] = std::min({d.lo[1], moves[i].y0, moves[i].y1});
      d.hi[0] = std::max({d.hi[0], moves[i].x0, moves[i].x1});
      d.hi[1] = std::max({d.hi[1], moves[i].y0, moves[i].y1});
      d.top = std::max(d.top, moves[i].z1);
      d.last = i;
    }
  EXPECT_NEAR(done[0].top, 18.0, 1e-9) << "the bracket is the tall part in the middle";
  std::size_t over = 0;
  for (int k = 0; k < 3; ++k)
    for (std::size_t i = done[k].last + 1; i < moves.size(); ++i)
      if (crosses(moves[i], done[k].lo, done[k].hi)) {
        ++over;
        EXPECT_GE(std::min(moves[i].z0, moves[i].z1), done[k].top - 1e-9)
            << "move " << i << " passes over finished part " << k << " below its top";
      }
  EXPECT_GT(over, 0u) << "the layout must make a travel cross a finished part";
  fs::remove_all(dir);
}

TEST(SequentialPlate, RefusedWhereTheMachineDoesNotAllowIt) {
  const test::TempDir tmp("trellis_sequential_refused");
  const fs::path dir = tmp.path();
  const std::string job = job_file(dir, "parts").string();
  const std::string out = (dir / "out").string();
  std::string err;
  // The 18 mm bracket is printed first: above a 10 mm gantry clearance.
  EXPECT_EQ(cli("run " + job + " -o " + out + " --set machine.extruder_clearance_height=10", err),
            2);
  EXPECT_NE(err.find("part 'bracket'"), std::string::npos) << err;
  EXPECT_NE(err.find("not printed last"), std::string::npos) << err;
  // 46.5 mm apart against a 50 mm radius.
  EXPECT_EQ(cli("run " + job + " -o " + out + " --set machine.extruder_clearance_radius=50", err),
            2);
  EXPECT_NE(err.find("'bracket'"), std::string::npos) << err;
  EXPECT_NE(err.find("'left'"), std::string::npos) << err;
  EXPECT_NE(err.find("extruder_clearance_radius = 50"), std::string::npos) << err;
  // A profile without clearances.
  EXPECT_EQ(cli("run " + job + " -o " + out + " --set machine.extruder_clearance_radius=0", err),
            2);
  EXPECT_NE(err.find("extruder clearance"), std::string::npos) << err;
  // Sharding a part-by-part plate.
  EXPECT_EQ(cli("run " + job + " -o " + out + " --shard 1/2", err), 2);
  EXPECT_NE(err.find("does not shard"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(out) && !fs::is_empty(out)) << "nothing is written";
  fs::remove_all(dir);
}

}  // namespace
