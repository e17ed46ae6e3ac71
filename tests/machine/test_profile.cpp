#include <gtest/gtest.h>

#include <filesystem>
#include <set>
#include <sstream>

#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/machine/profile.hpp"
#include "trellis/settings/settings.hpp"

using namespace trellis;

namespace {
void expect_setting_error(const std::string& toml, long line, const std::string& what) {
  try {
    machine_profile_from_toml(toml, "p.toml");
    ADD_FAILURE() << "no error for " << toml;
  } catch (const SettingError& e) {
    EXPECT_EQ(e.where().line, line) << e.what();
    EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("p.toml"), std::string::npos) << e.what();
  }
}
}  // namespace

TEST(Profile, ReadsSettingsOverDefaults) {
  const auto p = machine_profile_from_toml(
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
  expect_setting_error("[speed]\nshort_path_segments = 2.5\n", 2, "expected a whole number");
  expect_setting_error("[machine]\nflavor = \"smoothie\"\n", 2,
                       "'smoothie' is not allowed (one of marlin");
  expect_setting_error("[speed\nprint = 1\n", 1, "");
  expect_setting_error("[temperature]\nnozzle = nan\n", 2, "out of range");
}

TEST(Profile, OverridesUseTheSameRules) {
  const MachineProfile p = machine_profile_from_toml(
      "", "p.toml", {"speed.print=33", "gcode.start=G28 X Y", "extrusion.relative_e=true"});
  EXPECT_DOUBLE_EQ(p.print_speed, 33);
  EXPECT_EQ(p.start_gcode, "G28 X Y");
  EXPECT_TRUE(p.relative_e);
  for (const char* bad : {"speed.print", "speed.prnt=3", "speed.print=abc", "speed.print=0"})
    EXPECT_THROW(machine_profile_from_toml("", "p.toml", {bad}), SettingError) << bad;
}

TEST(Profile, ShippedProfilesLoad) {
  for (const char* name : {"ender3_s1_pro_tpu.toml", "pneumatic_pcl_27g.toml"}) {
    const auto p = load_machine_profile(std::string(TRELLIS_SOURCE_DIR) + "/profiles/" + name);
    EXPECT_FALSE(p.name.empty());
  }
}

// Every key the shipped machine profiles (written by hand) use is a setting of the schema: the
// profiles are read line by line here, not through the schema.
TEST(Profile, ShippedProfileKeysAreSettings) {
  std::set<std::string> shipped;
  for (const auto& entry :
       std::filesystem::directory_iterator(std::string(TRELLIS_SOURCE_DIR) + "/profiles")) {
    std::istringstream in(read_file(entry.path().string()));
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
    EXPECT_NO_THROW(load_machine_profile(entry.path().string())) << entry.path();
  }
  EXPECT_GT(shipped.size(), 40u);
  for (const auto& key : shipped) EXPECT_NE(find_setting(key), nullptr) << key;
}
