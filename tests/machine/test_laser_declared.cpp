// Lasers that differ in every format (issue 43): each laser's values, skywriting included, read
// back exactly from the .cli (ASCII and binary), the 3MF toolpath and the toolpath JSON, for many
// generated machines; [lasers] lists of booleans and of the wrong length; the scan-time model
// charges a laser that skywrites its skywriting time per vector instead of its mark delay.
#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

#include "support/temp_dir.hpp"
#include "trellis/core/error.hpp"
#include "trellis/machine/cli.hpp"
#include "trellis/machine/laser.hpp"
#include "trellis/machine/toolpath_3mf.hpp"
#include "trellis/settings/settings.hpp"
#include "trellis/slice/pbf_lasers.hpp"
#include "trellis/toolpath/json.hpp"

using namespace trellis;

namespace {

// A machine of 2 to 4 lasers, each [lasers] list given or not at random, values at random, every
// laser's skywriting said (true or false at random).
LaserProfile random_machine(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> count(2, 4), coin(0, 1), q(1, 4000);
  LaserProfile prof;
  prof.lasers = count(rng);
  const auto n = static_cast<std::size_t>(prof.lasers);
  const auto list = [&](double scale) {
    std::vector<double> v;
    if (coin(rng))
      for (std::size_t l = 0; l < n; ++l) v.push_back(q(rng) * scale);
    return v;
  };
  LaserProfile::PerLaser& e = prof.each;
  e.contour_power = list(0.2), e.contour_speed = list(1);
  e.hatch_power = list(0.2), e.hatch_speed = list(1.5);
  e.spot_diameter = list(0.0000625), e.jump_speed = list(2);
  e.jump_delay = list(0.25), e.mark_delay = list(0.25), e.polygon_delay = list(0.125);
  e.laser_on_delay = list(0.0625), e.laser_off_delay = list(0.0625);
  e.skywriting_time = list(0.5);
  e.skywriting.clear();
  for (std::size_t l = 0; l < n; ++l) e.skywriting.push_back(coin(rng));
  prof.skywriting = coin(rng);
  prof.skywriting_time = q(rng) * 0.25;
  return prof;
}

// Paths on random lasers at their laser's contour or hatch power and speed, as pbf exposes them.
Toolpath on_lasers(unsigned seed, const std::vector<LaserParameters>& each) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> xy(-40, 40);
  std::uniform_int_distribution<int> count(1, 20), pts(2, 5), coin(0, 1);
  Toolpath tp;
  for (int i = 0; i < 6; ++i) {
    Layer layer;
    layer.z = 0.02 * (i + 1);
    for (int k = count(rng); k > 0; --k) {
      Path p;
      p.tool = static_cast<int>(rng() % each.size());
      p.role = coin(rng) ? PathRole::Hatch : PathRole::Contour;
      const LaserParameters& L = each[static_cast<std::size_t>(p.tool)];
      p.power = p.role == PathRole::Hatch ? L.hatch_power : L.contour_power;
      p.speed = p.role == PathRole::Hatch ? L.hatch_speed : L.contour_speed;
      for (int j = p.role == PathRole::Hatch ? 2 : pts(rng); j > 0; --j)
        p.points.push_back({xy(rng), xy(rng), layer.z});
      layer.paths.push_back(std::move(p));
    }
    tp.layers.push_back(std::move(layer));
  }
  return tp;
}

}  // namespace

TEST(LasersDeclared, EveryFormatReadsBackEachLasersValuesWithSkywriting) {
  test::TempDir dir;
  int skywriting_said = 0, not_said = 0;
  for (unsigned seed = 1; seed <= 40; ++seed) {
    const LaserProfile prof = random_machine(seed);
    const std::vector<LaserParameters> each = laser_parameters(prof);
    ASSERT_EQ(each.size(), static_cast<std::size_t>(prof.lasers));
    for (std::size_t l = 0; l < each.size(); ++l) {
      // The per-laser switch wins over [timing]; the time is the list's, else [timing]'s.
      EXPECT_EQ(each[l].timing.skywriting, prof.each.skywriting[l] != 0);
      EXPECT_EQ(each[l].timing.skywriting_time, prof.each.skywriting_time.empty()
                                                    ? prof.skywriting_time
                                                    : prof.each.skywriting_time[l]);
      (each[l].timing.skywriting ? skywriting_said : not_said)++;
    }
    Toolpath tp = on_lasers(seed, each);
    const std::string where = "seed " + std::to_string(seed);
    for (const bool binary : {false, true})
      for (const bool plus : {false, true})
        EXPECT_EQ(read_cli(write_cli(tp, prof, {binary, plus}), "mem.cli").lasers, each)
            << where << " binary " << binary << " plus " << plus;
    Toolpath3mfOptions o;
    o.laser = &prof;
    const std::string pkg = dir.file("l.3mf");
    write_toolpath_3mf_file(pkg, tp, o);
    EXPECT_EQ(read_toolpath_3mf_file(pkg).lasers, each) << where << " 3mf";
    // The toolpath JSON carries the lasers it holds; written again, the same.
    tp.lasers = each;
    const Toolpath back = toolpath_from_json(toolpath_to_json(tp), "mem.json");
    EXPECT_EQ(back.lasers, each) << where << " json";
    EXPECT_EQ(toolpath_from_json(toolpath_to_json(back), "again.json").lasers, each) << where;
    // A 3MF written from the JSON read back (no profile): its lasers again.
    write_toolpath_3mf_file(pkg, back, Toolpath3mfOptions{});
    EXPECT_EQ(read_toolpath_3mf_file(pkg).lasers, each) << where << " json → 3mf";
  }
  EXPECT_GT(skywriting_said, 10);  // both kinds of laser were generated
  EXPECT_GT(not_said, 10);
}

// A .cli laser line as Trellis wrote it before skywriting was per laser still reads (no
// skywriting); a skywriting word other than on/off, or a line cut short, is refused by line.
TEST(LasersDeclared, CliLaserLinesOldAndMalformed) {
  LaserProfile prof = random_machine(7);
  prof.each.skywriting = std::vector<double>(static_cast<std::size_t>(prof.lasers), 1);
  Toolpath tp = on_lasers(7, laser_parameters(prof));
  const std::string bytes = write_cli(tp, prof, {false, true});
  const std::size_t at = bytes.find("; skywriting on ");
  ASSERT_NE(at, std::string::npos) << bytes.substr(0, 2000);
  std::string old = bytes;
  for (std::size_t k; (k = old.find("; skywriting on ")) != std::string::npos;)
    old.erase(k, old.find("//", k) - k);
  const Toolpath back = read_cli(old, "old.cli");
  ASSERT_EQ(back.lasers.size(), static_cast<std::size_t>(prof.lasers));
  for (const LaserParameters& l : back.lasers) EXPECT_FALSE(l.timing.skywriting);
  for (const std::string& bad :
       {std::string("; skywriting yes "), std::string("; skywriting on x")}) {
    std::string b = bytes;
    b.replace(at, std::string("; skywriting on ").size(), bad);
    try {
      read_cli(b, "bad.cli");
      FAIL() << bad << " was read";
    } catch (const ParseError& e) {
      EXPECT_NE(std::string(e.what()).find("skywriting on or off"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("bad.cli"), std::string::npos) << e.what();
    }
  }
}

// The toolpath JSON's lasers: a value left out, negative, of the wrong type or unknown is an error
// naming lasers[i].key.
TEST(LasersDeclared, JsonLasersAreCheckedByElement) {
  Toolpath tp = on_lasers(3, laser_parameters(random_machine(3)));
  tp.lasers = laser_parameters(random_machine(3));
  const std::string good = toolpath_to_json(tp);
  const auto expect_refused = [&](const std::string& from, const std::string& to,
                                  const std::string& element) {
    std::string text = good;
    const std::size_t k = text.find(from);
    ASSERT_NE(k, std::string::npos) << from;
    text.replace(k, from.size(), to);
    try {
      toolpath_from_json(text, "t.json");
      FAIL() << to << " was read";
    } catch (const ParseError& e) {
      EXPECT_EQ(e.where().element, element) << e.what();
    }
  };
  expect_refused("\"mark_delay\":", "\"mark_delai\":", "lasers[0]");  // missing mark_delay
  expect_refused("\"skywriting\":", "\"skywriting\": 1, \"x\":", "lasers[0].skywriting");
  expect_refused("\"jump_delay\":", "\"jump_delay\": -1, \"y\":", "lasers[0].jump_delay");
  expect_refused(
      "\"laser_on_delay\":", "\"laser_on_delay\": 0, \"spin\": 1, \"z\":", "lasers[0].spin");
}

// [lasers] skywriting from TOML: a list of true/false (or 1/0), one per laser; another length is
// refused naming lasers.skywriting; numbers other than 0 and 1 are refused by the schema.
TEST(LasersDeclared, SkywritingListsInProfiles) {
  const std::string head = "[laser]\nlasers = 2\n[lasers]\n";
  Settings s;
  s.load_toml(head + "skywriting = [false, true]\nskywriting_time = [100, 220]\n", "p.toml");
  const std::vector<LaserParameters> each = laser_parameters(s.config().laser);
  ASSERT_EQ(each.size(), 2u);
  EXPECT_FALSE(each[0].timing.skywriting);
  EXPECT_TRUE(each[1].timing.skywriting);
  EXPECT_EQ(each[1].timing.skywriting_time, 220);
  Settings t;
  t.set_text("lasers.skywriting", "true,false", {"--set"});
  EXPECT_EQ(std::get<std::vector<double>>(t.find("lasers.skywriting")->value),
            (std::vector<double>{1, 0}));
  Settings three;
  three.load_toml(head + "skywriting = [true, true, false]\n", "p.toml");
  try {
    laser_parameters(three.config().laser);
    FAIL() << "3 skywriting values for 2 lasers were taken";
  } catch (const SettingError& e) {
    EXPECT_EQ(e.where().element, "lasers.skywriting");
  }
  Settings bad;
  EXPECT_THROW(bad.load_toml(head + "skywriting = [2, 0]\n", "p.toml"), SettingError);
  EXPECT_THROW(bad.load_toml(head + "skywriting = [\"on\", true]\n", "p.toml"), SettingError);
}

// One laser skywriting: its time grows by (skywriting time − mark delay) per path it scans, the
// other lasers' times do not change; every laser skywriting the same as timing.skywriting.
TEST(LasersDeclared, ALaserThatSkywritesCostsItsSkywritingTimePerVector) {
  for (unsigned seed = 1; seed <= 20; ++seed) {
    LaserProfile prof = random_machine(seed);
    const auto n = static_cast<std::size_t>(prof.lasers);
    prof.each.skywriting.assign(n, 0);
    prof.skywriting = false;
    const std::vector<LaserParameters> base = laser_parameters(prof);
    const Toolpath tp = on_lasers(seed, base);
    std::vector<ScanTiming> timings;
    for (const auto& l : base) timings.push_back(l.timing);
    const std::vector<double> before = laser_times(tp, timings).totals();
    const std::size_t sky = seed % n;
    prof.each.skywriting[sky] = 1;
    std::vector<ScanTiming> after_timings;
    for (const auto& l : laser_parameters(prof)) after_timings.push_back(l.timing);
    const std::vector<double> after = laser_times(tp, after_timings).totals();
    std::vector<std::size_t> paths(n, 0);
    for (const auto& l : tp.layers)
      for (const auto& p : l.paths) ++paths[static_cast<std::size_t>(p.tool)];
    ASSERT_EQ(after.size(), n);
    for (std::size_t l = 0; l < n; ++l) {
      const double want =
          l == sky
              ? before[l] + static_cast<double>(paths[l]) *
                                (base[l].timing.skywriting_time - base[l].timing.mark_delay) * 1e-6
              : before[l];
      EXPECT_NEAR(after[l], want, 1e-9 * (1 + want)) << "seed " << seed << " laser " << l;
    }
  }
}
