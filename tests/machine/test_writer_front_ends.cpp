// What printer front ends and viewers read from our G-code: thumbnails, layer count, feature
// types, bead sizes and M73 progress, in PrusaSlicer's formats.
#include <gtest/gtest.h>

#include <regex>
#include <sstream>

#include "trellis/job/job.hpp"
#include "trellis/machine/gcode_reader.hpp"
#include "trellis/machine/gcode_writer.hpp"

using namespace trellis;

namespace {

Toolpath layers(int n) {
  Toolpath tp;
  for (int l = 0; l < n; ++l) {
    Layer layer;
    layer.z = 0.2 * (l + 1);
    for (int i = 0; i < 3; ++i) {
      Path p;
      p.points = {{0, 3.0 * i, layer.z}, {20, 3.0 * i, layer.z}, {20, 3.0 * i + 2, layer.z}};
      p.role = i == 0 ? PathRole::Perimeter : PathRole::Infill;
      layer.paths.push_back(p);
    }
    tp.layers.push_back(layer);
  }
  return tp;
}

std::string unbase64(const std::string& s) {
  std::string out;
  int bits = 0;
  unsigned v = 0;
  for (char c : s) {
    int d;
    if (c >= 'A' && c <= 'Z')
      d = c - 'A';
    else if (c >= 'a' && c <= 'z')
      d = c - 'a' + 26;
    else if (c >= '0' && c <= '9')
      d = c - '0' + 52;
    else if (c == '+')
      d = 62;
    else if (c == '/')
      d = 63;
    else
      break;  // '=' padding
    v = (v << 6) | static_cast<unsigned>(d);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += static_cast<char>((v >> bits) & 0xFF);
    }
  }
  return out;
}

unsigned be32(const std::string& s, std::size_t at) {
  return (static_cast<unsigned char>(s[at]) << 24) | (static_cast<unsigned char>(s[at + 1]) << 16) |
         (static_cast<unsigned char>(s[at + 2]) << 8) | static_cast<unsigned char>(s[at + 3]);
}

}  // namespace

TEST(FrontEnds, Base64MatchesTheStandard) {
  // RFC 4648 test vectors.
  EXPECT_EQ(base64(""), "");
  EXPECT_EQ(base64("f"), "Zg==");
  EXPECT_EQ(base64("fo"), "Zm8=");
  EXPECT_EQ(base64("foo"), "Zm9v");
  EXPECT_EQ(base64("foob"), "Zm9vYg==");
  EXPECT_EQ(base64("fooba"), "Zm9vYmE=");
  EXPECT_EQ(base64("foobar"), "Zm9vYmFy");
}

TEST(FrontEnds, ThumbnailsArePngsOfTheStatedSizeInPrusaSlicersBlock) {
  MachineProfile m;
  m.thumbnails = "16x16,220x124";
  const Toolpath tp = layers(3);
  const std::string g = write_gcode(tp, m, nullptr, gcode_thumbnails(tp, m));
  const std::regex block(
      R"(; thumbnail begin (\d+)x(\d+) (\d+)\n((?:; [A-Za-z0-9+/=]{1,78}\n)+); thumbnail end\n)");
  int found = 0;
  for (auto it = std::sregex_iterator(g.begin(), g.end(), block); it != std::sregex_iterator();
       ++it) {
    const auto& mt = *it;
    std::string b64;
    std::istringstream rows(mt[4].str());
    for (std::string row; std::getline(rows, row);) b64 += row.substr(2);
    EXPECT_EQ(b64.size(), std::stoul(mt[3].str()));  // LEN counts the base64 characters
    const std::string png = unbase64(b64);
    ASSERT_GT(png.size(), 24u);
    EXPECT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
    EXPECT_EQ(png.substr(12, 4), "IHDR");
    EXPECT_EQ(be32(png, 16), std::stoul(mt[1].str()));
    EXPECT_EQ(be32(png, 20), std::stoul(mt[2].str()));
    ++found;
  }
  EXPECT_EQ(found, 2);
  // Before any command, as PrusaSlicer writes them.
  EXPECT_LT(g.find("; thumbnail begin"), g.find("\nG"));
  // Empty = none; a malformed size is a setting error naming the key.
  m.thumbnails = "";
  EXPECT_TRUE(gcode_thumbnails(tp, m).empty());
  m.thumbnails = "220x";
  try {
    gcode_thumbnails(tp, m);
    FAIL();
  } catch (const SettingError& e) {
    EXPECT_NE(std::string(e.what()).find("gcode.thumbnails"), std::string::npos) << e.what();
  }
}

TEST(FrontEnds, LayerCountTypesAndBeadSizes) {
  MachineProfile m;
  const std::string g = write_gcode(layers(4), m);
  EXPECT_NE(g.find(";LAYER_COUNT:4\n"), std::string::npos);
  EXPECT_NE(g.find("; total layers count = 4\n"), std::string::npos);
  EXPECT_NE(g.find("; estimated printing time (normal mode) = "), std::string::npos);
  // A ;TYPE: before the first extrusion of each role change, PrusaSlicer's names.
  std::istringstream in(g);
  std::string type;
  int types = 0;
  bool width = false, height = false;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind(";TYPE:", 0) == 0) type = line.substr(6), ++types;
    width |= line == ";WIDTH:0.4";
    height |= line == ";HEIGHT:0.2";
    if (line.rfind("G1 X", 0) == 0 && line.find(" E") != std::string::npos)
      ASSERT_TRUE(type == "Perimeter" || type == "Internal infill") << line;
  }
  EXPECT_EQ(types, 8);  // perimeter, infill per layer
  EXPECT_TRUE(width && height);
  EXPECT_EQ(role_from_gcode_type(gcode_type_name(PathRole::Purge)), PathRole::Purge);
  for (int r = 0; r < 8; ++r)
    EXPECT_EQ(role_from_gcode_type(gcode_type_name(static_cast<PathRole>(r))),
              static_cast<PathRole>(r));
}

TEST(FrontEnds, M73ProgressOnlyWhereTheFirmwareTakesIt) {
  MachineProfile m;
  const std::string g = write_gcode(layers(5), m);
  std::istringstream in(g);
  std::vector<std::pair<int, int>> progress;
  std::size_t first_layer = g.find(";LAYER:0"), first_m73 = g.find("M73 ");
  for (std::string line; std::getline(in, line);) {
    int p = 0, r = 0;
    if (std::sscanf(line.c_str(), "M73 P%d R%d", &p, &r) == 2) progress.push_back({p, r});
  }
  ASSERT_EQ(progress.size(), 6u);  // every layer, and the end
  EXPECT_LT(first_m73, first_layer);
  EXPECT_EQ(progress.front().first, 0);
  EXPECT_EQ(progress.back(), std::make_pair(100, 0));
  for (std::size_t i = 1; i < progress.size(); ++i) {
    EXPECT_GT(progress[i].first, progress[i - 1].first);    // percent done grows
    EXPECT_LE(progress[i].second, progress[i - 1].second);  // minutes left shrink
  }
  for (const char* f : {"pneumatic", "embedded"}) {
    MachineProfile other;
    other.flavor = flavor_from_string(f);
    EXPECT_EQ(write_gcode(layers(2), other).find("M73"), std::string::npos) << f;
  }
}
