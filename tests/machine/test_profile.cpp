#include <gtest/gtest.h>

#include <filesystem>
#include <set>
#include <sstream>

#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/machine/profile.hpp"

using namespace trellis;

namespace {
void expect_setting_error(const std::string& toml, long line, const std::string& what) {
  try {
    profile_from_toml(toml, "p.toml");
    ADD_FAILURE() << "no error for " << toml;
  } catch (const SettingError& e) {
    EXPECT_EQ(e.where().line, line) << e.what();
    EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("p.toml"), std::string::npos) << e.what();
  }
}
}  // namespace

TEST(Profile, ReadsSettingsOverDefaults) {
  const auto p = profile_from_toml(
      "[extrusion]\nnozzle_diameter = 0.2\nrelative_e = true\n[speed]\nprint = 15\n", "p.toml");
  EXPECT_DOUBLE_EQ(p.nozzle_diameter, 0.2);
  EXPECT_TRUE(p.relative_e);
  EXPECT_DOUBLE_EQ(p.print_speed, 15);
  EXPECT_DOUBLE_EQ(p.filament_diameter, 1.75);
}

TEST(Profile, UnknownKeysWrongTypesAndRangesNameFileAndLine) {
  expect_setting_error("[extrusion]\nnozzle_diameter = 0.2\nnozle = 3\n", 3,
                       "extrusion.nozle: unknown setting");
  expect_setting_error("[speed]\n\nprint = \"fast\"\n", 3, "expected a number");
  expect_setting_error("[speed]\nprint = -1\n", 2, "out of range");
  expect_setting_error("[speed]\nshort_path_segments = 2.5\n", 2, "expected an integer");
  expect_setting_error("[machine]\nflavor = \"smoothie\"\n", 0, "unknown flavor");
  expect_setting_error("[speed\nprint = 1\n", 1, "");
  expect_setting_error("[temperature]\nnozzle = nan\n", 2, "out of range");
}

TEST(Profile, OverridesUseTheSameRules) {
  MachineProfile p;
  apply_override(p, "speed.print=33");
  apply_override(p, "gcode.start=G28 X Y");
  apply_override(p, "extrusion.relative_e=true");
  EXPECT_DOUBLE_EQ(p.print_speed, 33);
  EXPECT_EQ(p.start_gcode, "G28 X Y");
  EXPECT_TRUE(p.relative_e);
  EXPECT_THROW(apply_override(p, "speed.print"), SettingError);
  EXPECT_THROW(apply_override(p, "speed.prnt=3"), SettingError);
  EXPECT_THROW(apply_override(p, "speed.print=abc"), SettingError);
  EXPECT_THROW(apply_override(p, "speed.print=0"), SettingError);
}

TEST(Profile, ShippedProfilesLoad) {
  for (const char* name : {"ender3_s1_pro_tpu.toml", "pneumatic_pcl_27g.toml"}) {
    const auto p = load_profile(std::string(TRELLIS_SOURCE_DIR) + "/profiles/" + name);
    EXPECT_FALSE(p.name.empty());
  }
}

// The help is checked against sources that do not come from the settings table: every key the
// shipped machine profiles (written by hand) use is listed, and every listed key, with the
// default the help prints, is accepted by the profile reader as a real setting.
TEST(Profile, HelpListsEverySettingAndOnlyRealOnes) {
  const std::string help = settings_help();
  std::set<std::string> shipped;
  for (const auto& entry :
       std::filesystem::directory_iterator(std::string(TRELLIS_SOURCE_DIR) + "/profiles")) {
    const std::string text = read_file(entry.path().string());
    try {
      profile_from_toml(text, entry.path().string());
    } catch (const SettingError&) {
      continue;  // a laser profile, read by the laser reader
    }
    std::istringstream in(text);
    std::string line, section;
    while (std::getline(in, line)) {
      const std::string t = line.substr(0, line.find('#'));
      if (t.starts_with("[")) section = t.substr(1, t.find(']') - 1);
      const auto eq = t.find('=');
      if (eq == std::string::npos || section.empty() || t.starts_with(" ")) continue;
      std::string key = t.substr(0, eq);
      key.erase(key.find_last_not_of(' ') + 1);
      if (!key.empty()) shipped.insert(section + "." + key);
    }
  }
  EXPECT_GT(shipped.size(), 20u);
  for (const auto& key : shipped) EXPECT_NE(help.find("  " + key + " "), std::string::npos) << key;

  std::istringstream lines(help);
  std::string line;
  std::size_t listed = 0;
  while (std::getline(lines, line)) {
    if (!line.starts_with("  ")) continue;
    const std::string key = line.substr(2, line.find(' ', 2) - 2);
    const auto d = line.rfind("(default: ");
    ASSERT_NE(d, std::string::npos) << line;
    std::string value = line.substr(d + 10, line.size() - d - 11);
    if (value == "\"\"") value.clear();
    MachineProfile p;
    EXPECT_NO_THROW(apply_override(p, key + "=" + value)) << line;
    ++listed;
  }
  EXPECT_GE(listed, shipped.size());
}
