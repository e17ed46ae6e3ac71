// Binary G-code: files made by an independent encoder (tests/machine/bgcode_encode.py, written
// from the specification) must read into the same moves as their text twin, for every
// compression (none, Deflate, Heatshrink 11/4 and 12/4) and G-code encoding (text, MeatPack,
// MeatPack with comments, with and without MeatPack's no-spaces mode).
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

#include "support/temp_dir.hpp"
#include "trellis/core/error.hpp"
#include "trellis/machine/bgcode.hpp"
#include "trellis/machine/gcode_reader.hpp"
#include "trellis/machine/gcode_writer.hpp"

using namespace trellis;

namespace {

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// A print with what a reader must keep apart: two tools with their own temperatures, mixtures,
// roles, widths, an arc and two layers (our writer's output plus hand-written dialect lines).
std::string twin_text() {
  Toolpath tp;
  for (int l = 0; l < 3; ++l) {
    Layer layer;
    layer.z = 0.2 * (l + 1);
    for (int i = 0; i < 6; ++i) {
      Path p;
      for (int k = 0; k < 5; ++k)
        p.points.push_back({1.0 * k + 0.123 * i, 2.0 * i + 0.01 * k * k, layer.z});
      p.role = i % 2 ? PathRole::Infill : PathRole::Perimeter;
      p.mixture = {0.25 * (i % 5), 1 - 0.25 * (i % 5)};
      p.width = 0.4 + 0.05 * (i % 3);
      layer.paths.push_back(p);
    }
    tp.layers.push_back(layer);
  }
  MachineProfile m;
  m.mixing_inputs = 2;
  m.retract_length = 0.8;
  m.nozzle_temperature = 210;
  std::string text = write_gcode(tp, m);
  text +=
      ";LAYER_CHANGE\n;Z:1\nM104 T1 S235\nT1\n;TYPE:External perimeter\n;WIDTH:0.45\n"
      "G1 X5 Y5 Z1 F3000\nG1 X10 Y5 E101\nG2 X15 Y5 I2.5 J0 E102\nT0\nG1 X20 Y20 E103\n";
  return text;
}

Toolpath read_file(const std::string& path) {
  Toolpath tp;
  auto builder = make_toolpath_builder(tp);
  Diagnostics d;
  scan_gcode_file(path, *builder, {}, d);
  EXPECT_EQ(d.total(), 0u) << path << (d.total() ? d.messages().front().text : "");
  return tp;
}

std::vector<const Path*> flat(const Toolpath& tp) {
  std::vector<const Path*> out;
  for (const auto& l : tp.layers)
    for (const auto& p : l.paths) out.push_back(&p);
  return out;
}

// Same moves: paths, points, E, tool, temperature and mixture; with comments kept also roles,
// widths and layers.
void expect_same(const Toolpath& text, const Toolpath& bin, bool comments,
                 const std::string& what) {
  const auto a = flat(text), b = flat(bin);
  ASSERT_EQ(a.size(), b.size()) << what;
  ASSERT_GT(a.size(), 10u);
  for (std::size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i]->points.size(), b[i]->points.size()) << what << " path " << i;
    for (std::size_t k = 0; k < a[i]->points.size(); ++k)
      ASSERT_EQ(distance(a[i]->points[k], b[i]->points[k]), 0.0) << what << " path " << i;
    EXPECT_DOUBLE_EQ(a[i]->filament, b[i]->filament) << what;
    EXPECT_EQ(a[i]->tool, b[i]->tool) << what;
    EXPECT_EQ(a[i]->temperature, b[i]->temperature) << what;
    EXPECT_EQ(a[i]->mixture, b[i]->mixture) << what;
    if (comments) {
      EXPECT_EQ(a[i]->role, b[i]->role) << what;
      EXPECT_EQ(a[i]->width, b[i]->width) << what;
    }
  }
  if (comments) EXPECT_EQ(text.layers.size(), bin.layers.size()) << what;
}

const std::string kEncoder = std::string(TRELLIS_SOURCE_DIR) + "/tests/machine/bgcode_encode.py";

void encode(const std::string& in, const std::string& out, int compression, int encoding,
            const std::string& extra = "") {
  const std::string cmd = "/usr/bin/python3 " + kEncoder + " " + in + " " + out + " " +
                          std::to_string(compression) + " " + std::to_string(encoding) + " " +
                          extra;
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
}

}  // namespace

TEST(Bgcode, ReadsIntoTheSameMovesAsItsTextTwin) {
  test::TempDir dir("bgcode");
  const std::string text_path = dir.file("twin.gcode");
  { std::ofstream(text_path) << twin_text(); }
  const Toolpath text = read_file(text_path);
  // The twin exercises what it should.
  bool tool1 = false, mixed = false, hot = false;
  for (const Path* p : flat(text)) {
    tool1 |= p->tool == 1;
    mixed |= p->mixture.size() == 2;
    hot |= p->temperature == 235;
  }
  ASSERT_TRUE(tool1 && mixed && hot);
  for (int compression = 0; compression <= 3; ++compression)
    for (int encoding = 0; encoding <= 2; ++encoding)
      for (const std::string extra : {"", "--no-spaces"}) {
        if (encoding == 0 && !extra.empty()) continue;
        const std::string what = "compression " + std::to_string(compression) + " encoding " +
                                 std::to_string(encoding) + " " + extra;
        const std::string bin = dir.file("twin_" + std::to_string(compression) +
                                         std::to_string(encoding) + extra + ".bgcode");
        encode(text_path, bin, compression, encoding, extra + " --block-size 3000");
        // Blocks hold compressed data (the encoders really ran).
        if (compression) EXPECT_LT(slurp(bin).size(), slurp(text_path).size()) << what;
        expect_same(text, read_file(bin), encoding != 1, what);
        // The in-memory reader agrees with the streaming one.
        Diagnostics d;
        const Toolpath mem = read_gcode(slurp(bin), {}, d, "mem");
        expect_same(text, mem, encoding != 1, what + " (in memory)");
      }
}

TEST(Bgcode, MeatPackDecodesHandPackedBytes) {
  // "G1 X1\n": G=13 1=1, ' '=11 X=14, 1=1 '\n'=12 (first character in the low nibble).
  // "M1\n": M is not packable (0xF low nibble, then the byte), '\n' then padding.
  const std::string bytes = "\xff\xff\xfb\x1d\xeb\xc1\x1fM\xbc";
  MeatPackDecoder mp;
  std::string out;
  mp.feed(bytes, out);
  EXPECT_EQ(out, "G1 X1\nM1\n");
  // No-spaces mode: code 11 is E.
  MeatPackDecoder ns;
  std::string out2;
  ns.feed(std::string("\xff\xff\xfb\xff\xff\xf7\x1d\x1e\x1b\x0c", 10), out2);
  EXPECT_EQ(out2, "G1 X1 E1\n");  // the spaces between words put back
}

TEST(Bgcode, HeatshrinkBackReferencesAndLiterals) {
  // window 4, lookahead 3: "ab" as literals, then a back-reference distance 2 count 5: "ababababa"
  // bits: 1 01100001 1 01100010 0 0001 100, then zero padding
  const unsigned char raw[] = {0b10110000, 0b11011000, 0b10000011, 0b00000000};
  const std::string data(reinterpret_cast<const char*>(raw), sizeof raw);
  EXPECT_EQ(heatshrink_decode(data, 4, 3, 7), "abababa");
  EXPECT_THROW(heatshrink_decode(data, 4, 3, 9), ParseError);  // the stream ends early
}

TEST(Bgcode, HeatshrinkReferencesBeforeTheStartReadZeros) {
  // heatshrink's decoder starts from a zero-filled window: distance 3 count 2 at the start gives
  // two zero bytes. bits: 0 0010 001, 1 01100001, then zero padding.
  const unsigned char raw[] = {0b00010001, 0b10110000, 0b10000000};
  const std::string data(reinterpret_cast<const char*>(raw), sizeof raw);
  EXPECT_EQ(heatshrink_decode(data, 4, 3, 3), std::string("\0\0a", 3));
}

TEST(Bgcode, HeatshrinkEncoderRoundTripsAndShrinksGcode) {
  std::string noise(50000, '\0');
  std::uint32_t x = 12345;
  for (auto& c : noise) c = static_cast<char>((x = x * 1664525u + 1013904223u) >> 24);
  std::string runs;  // long periodic runs: overlapping copies at every distance up to 40
  for (int p = 1; p <= 40; ++p)
    for (int k = 0; k < 500; ++k) runs += static_cast<char>('a' + (k % p) % 26);
  const std::string gcode = twin_text() + twin_text();
  for (const auto& [w, l] : std::vector<std::pair<int, int>>{{4, 3}, {8, 4}, {11, 4}, {12, 4}})
    for (const std::string& in :
         {std::string(), std::string("G"), std::string(70000, '\0'), noise, runs, gcode}) {
      const std::string packed = heatshrink_encode(in, w, l);
      EXPECT_TRUE(heatshrink_decode(packed, w, l, in.size()) == in)
          << w << "/" << l << ", " << in.size() << " bytes";
      EXPECT_LE(packed.size(), in.size() * 9 / 8 + 1);  // at worst a literal per byte
    }
  EXPECT_LT(heatshrink_encode(gcode, 12, 4).size() * 2, gcode.size());
  // The independent decoder (tests/machine/bgcode_encode.py) reads our encoder's bytes.
  test::TempDir dir("heatshrink");
  const std::string in = dir.file("in.bin"), out = dir.file("out.bin");
  { std::ofstream(in, std::ios::binary) << heatshrink_encode(gcode, 12, 4); }
  const std::string cmd = "/usr/bin/python3 " + kEncoder + " --heatshrink-decode " + in + " " +
                          out + " 12 4 " + std::to_string(gcode.size());
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  EXPECT_TRUE(slurp(out) == gcode);
}

TEST(Bgcode, DamagedFilesAreNamedErrors) {
  test::TempDir dir("bgcode_bad");
  const std::string text_path = dir.file("t.gcode"), bin = dir.file("t.bgcode");
  { std::ofstream(text_path) << twin_text(); }
  encode(text_path, bin, 1, 0);
  std::string bytes = slurp(bin);
  // A flipped byte in the last block: its CRC no longer matches.
  std::string flipped = bytes;
  flipped[flipped.size() - 10] ^= 0x20;
  try {
    bgcode_to_text(flipped, "t.bgcode");
    FAIL() << "a damaged block was read";
  } catch (const ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("CRC32"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("t.bgcode"), std::string::npos) << e.what();
  }
  // Cut short: the message says where.
  EXPECT_THROW(bgcode_to_text(bytes.substr(0, bytes.size() - 7), "t.bgcode"), ParseError);
  // Wrong version.
  std::string v2 = bytes;
  v2[4] = 2;
  EXPECT_THROW(bgcode_to_text(v2, "t.bgcode"), ParseError);
}
