// Every output checked against the machine before it is written (machine capabilities are
// profile settings): a part bigger than the bed, a tool the machine lacks, a mixture on a
// machine without a mixing hotend, a bath route on an in-air machine, a graded design without
// a strategy, limits of temperature, speed and laser power — exit 2, named, and no file.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "support/cli_run.hpp"
#include "support/gcode_replay.hpp"

namespace fs = std::filesystem;

namespace {

const std::string kRoot = TRELLIS_SOURCE_DIR;
const std::string kEnder = kRoot + "/profiles/ender3_s1_pro_tpu.toml";
const std::string kMixing = kRoot + "/profiles/geeetech_mizar_m_mixing.toml";
const std::string kBath = kRoot + "/profiles/embedded_aero_410um.toml";
const std::string kBathTwo = kRoot + "/profiles/embedded_aero_two_nozzle.toml";
const std::string kFresh = kRoot + "/profiles/fresh_nonplanar_2syringe.toml";
const std::string kLaser = kRoot + "/profiles/pbf_316l_25um.toml";

fs::path work() {
  return trellis::test::scratch("trellis_cli_machine");
}
std::string at(const std::string& name) {
  return (work() / name).string();
}
trellis::test::CliRun run(const std::string& args) {
  return trellis::test::run_cli(args, work());
}

std::string write(const std::string& name, const std::string& text) {
  std::ofstream(work() / name) << text;
  return at(name);
}

// Exit 2, the message names every `words`, and none of `files` exists.
void expect_refused(const trellis::test::CliRun& r, std::initializer_list<const char*> words,
                    std::initializer_list<std::string> files) {
  EXPECT_EQ(r.code, 2) << r.err;
  for (const char* w : words) EXPECT_NE(r.err.find(w), std::string::npos) << w << "\n" << r.err;
  for (const auto& f : files) EXPECT_FALSE(fs::exists(f)) << f;
}

}  // namespace

TEST(MachineCheck, PartBiggerThanTheBedIsRefusedOnEveryRoute) {
  // slice: a 506 x 500 mm plate on the 220 mm Ender.
  const std::string big = write("big.vcad", "rectprism(506, 500, 0.6);\n");
  expect_refused(run("slice " + big + " --machine " + kEnder + " -o " + at("big.gcode") +
                     " --report " + at("big.json")),
                 {"machine.bed_x", "220", "X"}, {at("big.gcode"), at("big.json")});
  // The same plate fits a larger bed.
  const std::string small = write("small.vcad", "rectprism(50, 40, 0.6);\n");
  auto ok = run("slice " + small + " --machine " + kEnder + " -o " + at("small.gcode"));
  ASSERT_EQ(ok.code, 0) << ok.err;
  // ... unless placed off the bed.
  expect_refused(run("slice " + small + " --machine " + kEnder + " -o " + at("off.gcode") +
                     " --set placement.offset_x=100"),
                 {"placement.offset_x"}, {at("off.gcode")});
  // plan (GIPPO) with G-code: neither the G-code nor the toolpath is written.
  ASSERT_EQ(
      run("lattice2d --pattern square --size 300,300 --cell 10 -o " + at("sq.lattice.json")).code,
      0);
  expect_refused(run("plan gippo " + at("sq.lattice.json") + " --iterations 2 --machine " + kEnder +
                     " -o " + at("sq.toolpath.json") + " --gcode " + at("sq.gcode")),
                 {"machine.bed_x"}, {at("sq.gcode"), at("sq.toolpath.json")});
  // gcode: a toolpath JSON made elsewhere.
  ASSERT_EQ(run("plan euler " + at("sq.lattice.json") + " -o " + at("sq2.json")).code, 0);
  expect_refused(run("gcode " + at("sq2.json") + " --machine " + kEnder + " -o " + at("sq2.gcode")),
                 {"machine.bed_x"}, {at("sq2.gcode")});
  // A circular bed (a delta, origin at the centre): 150 mm across holds a 100 mm square's
  // corners only up to 106 mm diagonal.
  ASSERT_EQ(
      run("lattice2d --pattern square --size 100,100 --cell 10 -o " + at("sq3.lattice.json")).code,
      0);
  ASSERT_EQ(run("plan euler " + at("sq3.lattice.json") + " -o " + at("sq3.json")).code, 0);
  const std::string delta =
      " --set machine.bed_shape=circle --set machine.origin=center --set machine.bed_x=150";
  ASSERT_EQ(
      run("gcode " + at("sq3.json") + " --machine " + kEnder + delta + " -o " + at("d1.gcode"))
          .code,
      0);
  expect_refused(run("gcode " + at("sq3.json") + " --machine " + kEnder + delta +
                     " --set machine.bed_x=130 -o " + at("d2.gcode")),
                 {"circle of diameter 130"}, {at("d2.gcode")});
  // On the centred bed the part is centred at X0 Y0.
  double lo = 1e9, hi = -1e9;
  for (const auto& d : trellis::test::replay_gcode(trellis::read_file(at("d1.gcode"))).deposits) {
    lo = std::min({lo, d.x0, d.x1});
    hi = std::max({hi, d.x0, d.x1});
  }
  EXPECT_NEAR(lo, -hi, 1e-6);
  // pbf: a 120 mm part on the 100 mm plate.
  expect_refused(run("pbf --machine " + kLaser + " --size 120,10,0.1 -o " + at("big.cli")),
                 {"laser.build_x", "100"}, {at("big.cli")});
}

TEST(MachineCheck, ToolsTheMachineLacksAreRefused) {
  // A two-material AERO lattice on the one-nozzle bath machine, then on the two-nozzle one.
  ASSERT_EQ(run("lattice3d --cell-type bcc --cell 5 --count 2,2,2 --materials xy-plane -o " +
                at("two.json"))
                .code,
            0);
  expect_refused(run("plan aero " + at("two.json") + " --machine " + kBath + " -o " +
                     at("two.tp.json") + " --gcode " + at("two.nc")),
                 {"tool 1", "machine.tools = 1"}, {at("two.nc"), at("two.tp.json")});
  const auto ok = run("plan aero " + at("two.json") + " --machine " + kBathTwo + " -o " +
                      at("two2.tp.json") + " --gcode " + at("two2.nc"));
  EXPECT_EQ(ok.code, 0) << ok.err;
}

TEST(MachineCheck, MixturesNeedAMixingHotendAndGradientsAStrategy) {
  const std::string graded = write("graded.vcad",
                                   "fgrade([\"0.5 + x/24\", \"0.5 - x/24\"], [\"a\", \"b\"]) {\n"
                                   "  rectprism(20, 10, 0.6);\n}\n");
  // --strategy 2 on the single-nozzle Ender: no M165 written, refused.
  expect_refused(run("slice " + graded + " --machine " + kEnder + " -o " + at("g.gcode") +
                     " --strategy 2 --colors 4 --set extrusion.nozzle_diameter=0.4"),
                 {"no mixing hotend", "machine.mixing_inputs = 1"}, {at("g.gcode")});
  // A graded design sliced without a strategy: refused, with the way to print one material.
  expect_refused(run("slice " + graded + " --machine " + kMixing + " -o " + at("n.gcode")),
                 {"graded", "--strategy (slice.strategy) = none"}, {at("n.gcode")});
  auto r = run("slice " + graded + " --machine " + kMixing + " -o " + at("one.gcode") +
               " --strategy none");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(trellis::read_file(at("one.gcode")).find("M165"), std::string::npos);
  r = run("slice " + graded + " --machine " + kMixing + " -o " + at("mix.gcode") +
          " --strategy 2 --colors 4");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(trellis::read_file(at("mix.gcode")).find("M165"), std::string::npos);
  // Tools mode needs the tools: five wanted, the Ender has one.
  expect_refused(run("slice " + graded + " --machine " + kEnder + " -o " + at("t.gcode") +
                     " --strategy 2 --colors 4 --set extrusion.nozzle_diameter=0.4 "
                     "--set gradient.mode=tools --set gradient.tools=5"),
                 {"gradient.tools = 5", "machine.tools"}, {at("t.gcode")});
}

TEST(MachineCheck, BathRoutesNeedABathMachine) {
  expect_refused(run("nonplanar --height-fn \"0.1*x\" --domain 0,0,10,10 --layers 2 --machine " +
                     kEnder + " -o " + at("np.gcode")),
                 {"nonplanar", "support bath", "machine.flavor = marlin", "fresh_nonplanar"},
                 {at("np.gcode")});
  auto r = run("nonplanar --height-fn \"0.1*x\" --domain 0,0,10,10 --layers 2 --machine " + kFresh +
               " -o " + at("np_ok.gcode"));
  EXPECT_EQ(r.code, 0) << r.err;
  ASSERT_EQ(run("lattice3d --cell-type bcc --cell 5 --count 2,2,2 -o " + at("one.json")).code, 0);
  expect_refused(run("plan aero " + at("one.json") + " --machine " + kEnder + " -o " +
                     at("air.tp.json") + " --gcode " + at("air.gcode")),
                 {"plan aero", "support bath"}, {at("air.gcode"), at("air.tp.json")});
  // The reverse prints (planar layers in a bath), with a warning.
  ASSERT_EQ(
      run("lattice2d --pattern square --size 10,10 --cell 2 -o " + at("flat.lattice.json")).code,
      0);
  r = run("plan gippo " + at("flat.lattice.json") + " --iterations 2 --machine " + kBath + " -o " +
          at("flat.tp.json") + " --gcode " + at("flat.nc") + " --report " + at("flat.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("support bath"), std::string::npos) << r.err;
  EXPECT_NE(trellis::read_file(at("flat.json")).find("planar_in_bath"), std::string::npos);
}

TEST(MachineCheck, TemperaturesSpeedsAndPowersWithinTheMachinesLimits) {
  const std::string part = write("p.vcad", "rectprism(20, 20, 0.6);\n");
  expect_refused(run("slice " + part + " --machine " + kEnder + " -o " + at("hot.gcode") +
                     " --set temperature.nozzle=320"),
                 {"temperature.nozzle = 320", "temperature.max_nozzle = 300"}, {at("hot.gcode")});
  expect_refused(
      run("slice " + part + " --machine " + kEnder + " -o " + at("fast.gcode") + " --speed 400"),
      {"--speed (speed.print) = 400", "speed.max = 250"}, {at("fast.gcode")});
  expect_refused(run("pbf --machine " + kLaser + " --size 2.5,2.5,0.1 -o " + at("p.cli") +
                     " --set laser.hatch_power=250"),
                 {"laser.hatch_power = 250", "laser.max_power = 200"}, {at("p.cli")});
}

TEST(MachineCheck, APartBelowTheBedIsLiftedOntoItOrRefused) {
  // A surface from z = -2 to 0: lifted by 2 mm so that its lowest point is on the bed.
  auto r = run("nonplanar --height-fn \"0.2*x-2\" --domain 0,0,10,10 --layers 1 --machine " +
               kFresh + " -o " + at("low.gcode"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("lifted by 2.000 mm"), std::string::npos) << r.err;
  const std::string g = trellis::read_file(at("low.gcode"));
  EXPECT_NE(g.find("; placement lift = 2"), std::string::npos);
  double low = 1e9;
  for (const auto& d : trellis::test::replay_gcode(g).deposits) low = std::min({low, d.z0, d.z1});
  EXPECT_GE(low, -1e-9);
  EXPECT_LT(low, 0.5);
  expect_refused(run("nonplanar --height-fn \"0.2*x-2\" --domain 0,0,10,10 --layers 1 --machine " +
                     kFresh + " -o " + at("low2.gcode") + " --set placement.lift=false"),
                 {"Z -"}, {at("low2.gcode")});
}
