#include <gtest/gtest.h>

#include "trellis/core/error.hpp"
#include "trellis/toolpath/json.hpp"

using namespace trellis;

static Toolpath sample() {
  Toolpath tp;
  tp.source = "test";
  Layer l{0.2, {}};
  Path p;
  p.points = {{0, 0, 0.2}, {1.5, 0, 0.2}, {1.5, 2.25, 0.2}};
  p.role = PathRole::Contour;
  p.tool = 1;
  p.height = 0.2;
  p.mixture = {0.25, 0.75};
  l.paths.push_back(p);
  p.points = {{3, 3, 0.2}, {4, 4, 0.2}};
  p.role = PathRole::Strut;
  p.mixture.clear();
  l.paths.push_back(p);
  tp.layers.push_back(l);
  return tp;
}

TEST(ToolpathJson, RoundTripKeepsEverything) {
  const Toolpath a = sample();
  const Toolpath b = toolpath_from_json(toolpath_to_json(a), "mem");
  ASSERT_EQ(b.layers.size(), 1u);
  ASSERT_EQ(b.layers[0].paths.size(), 2u);
  EXPECT_EQ(b.source, "test");
  const Path& p = b.layers[0].paths[0];
  EXPECT_EQ(p.role, PathRole::Contour);
  EXPECT_EQ(p.tool, 1);
  EXPECT_EQ(p.mixture, (std::vector<double>{0.25, 0.75}));
  EXPECT_EQ(p.points, a.layers[0].paths[0].points);
  EXPECT_DOUBLE_EQ(b.extrusion_length(), a.extrusion_length());
}

TEST(ToolpathJson, LengthsAndTravel) {
  const Toolpath a = sample();
  EXPECT_DOUBLE_EQ(a.layers[0].paths[0].length(), 1.5 + 2.25);
  const auto t = travel_stats(a);
  EXPECT_EQ(t.moves, 1u);
  EXPECT_NEAR(t.length, std::hypot(1.5, 0.75), 1e-12);
}

TEST(ToolpathJson, BadInputNamesTheElement) {
  EXPECT_THROW(toolpath_from_json("{", "x.json"), ParseError);
  EXPECT_THROW(toolpath_from_json("{\"format\":\"other\"}", "x.json"), ParseError);
  try {
    toolpath_from_json(R"({"format":"trellis.toolpath","version":1,"layers":[{"z":0,"paths":[
        {"points":[[0,0,0],[1,"a",0]]}]}]})",
                       "x.json");
    FAIL();
  } catch (const ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("layers[0].paths[0].points[1]"), std::string::npos)
        << e.what();
  }
  try {
    toolpath_from_json("{\n\"format\": \n\"trellis.toolpath\",\n oops}", "x.json");
    FAIL();
  } catch (const ParseError& e) {
    EXPECT_EQ(e.where().line, 4) << e.what();
  }
}

TEST(ToolpathJson, ParameterSetsRoundTripAndNameTheirPaths) {
  Toolpath a = sample();
  a.layers[0].paths[0].power = 60;
  a.layers[0].paths[0].speed = 800;
  a.parameter_sets = {{"contour 2", PathRole::Contour, 60, 800},
                      {"downskin hatch", PathRole::Hatch, 60, 800}};
  const Toolpath b = toolpath_from_json(toolpath_to_json(a), "mem");
  EXPECT_EQ(b.parameter_sets, a.parameter_sets);
  // A set is its role, power and speed: the contour's, not the hatch's of the same values.
  EXPECT_EQ(parameter_set_of(b, b.layers[0].paths[0]), 0);
  EXPECT_EQ(parameter_set_of(b, b.layers[0].paths[1]), -1);
  EXPECT_EQ(toolpath_from_json(toolpath_to_json(sample()), "mem").parameter_sets.size(), 0u);
  for (const char* bad : {R"("parameter_sets": {})", R"("parameter_sets": [{"name": "a"}])",
                          R"("parameter_sets": [{"name": "a", "role": "laser"}])",
                          R"("parameter_sets": [{"name": "a", "role": "hatch", "power": "x"}])"}) {
    try {
      toolpath_from_json(
          std::string(R"({"format":"trellis.toolpath","version":1,)") + bad + R"(,"layers":[]})",
          "x.json");
      ADD_FAILURE() << bad;
    } catch (const ParseError& e) {
      EXPECT_NE(std::string(e.what()).find("parameter_sets"), std::string::npos) << e.what();
    }
  }
}
