// Binary G-code out (machine/bgcode_writer.hpp): the file is walked here by hand, with a CRC-32
// of its own, independent of the reader; the G-code blocks hold exactly the text G-code the same
// toolpath writes, less the thumbnail comments, whose pictures are in the thumbnail blocks; the
// streamed writer packs the same bytes; machines without Prusa's firmware are refused; a failed
// write leaves the folder as it was.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "support/machines.hpp"
#include "support/temp_dir.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/machine/bgcode.hpp"
#include "trellis/machine/bgcode_writer.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/machine/machine_check.hpp"

using namespace trellis;
namespace fs = std::filesystem;

namespace {

// 30 layers of 12 paths: about 1 MB of text, many G-code blocks.
Toolpath print() {
  Toolpath tp;
  tp.source = "bgcode writer test";
  for (int l = 0; l < 30; ++l) {
    Layer layer;
    layer.z = 0.2 * (l + 1);
    for (int i = 0; i < 12; ++i) {
      Path p;
      for (int k = 0; k < 60; ++k)
        p.points.push_back({0.5 * k + 0.013 * i * l, 3.0 * i + 0.01 * k * (k % 7), layer.z});
      p.role = i % 3 ? PathRole::Infill : PathRole::Perimeter;
      layer.paths.push_back(p);
    }
    tp.layers.push_back(layer);
  }
  return tp;
}

MachineProfile prusa() {
  MachineProfile p = test::open_bed();
  p.name = "Prusa MK4S";
  p.firmware = Firmware::Prusa;
  p.printer_model = "MK4S";
  p.retract_length = 0.8;
  return p;
}

// Two pictures; the writer takes the bytes as they are.
std::vector<GcodeThumbnail> pictures() {
  return {{16, 16, std::string("\x89PNG\r\n\x1a\n small", 15)},
          {220, 124, std::string("\x89PNG\r\n\x1a\n") + std::string(3000, '\x7f')}};
}

std::uint32_t crc32_of(std::string_view d) {  // CRC-32 (ISO-HDLC), bit by bit
  std::uint32_t c = 0xFFFFFFFFu;
  for (const char ch : d) {
    c ^= static_cast<unsigned char>(ch);
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
  }
  return ~c;
}

std::uint32_t le(std::string_view d, std::size_t at, int n) {
  std::uint32_t v = 0;
  for (int i = n; i-- > 0;) v = (v << 8) | static_cast<unsigned char>(d[at + i]);
  return v;
}

struct Walked {
  std::vector<int> types;
  std::vector<std::size_t> sizes;  // uncompressed
};

// The file walked as the specification lays it out: "File header", then "Blocks" (header,
// parameters, data, CRC32 of the three).
Walked walk(std::string_view f) {
  Walked w;
  EXPECT_EQ(f.substr(0, 4), "GCDE");
  EXPECT_EQ(le(f, 4, 4), 1u);  // version
  EXPECT_EQ(le(f, 8, 2), 1u);  // CRC32
  std::size_t at = 10;
  while (at < f.size()) {
    const int type = static_cast<int>(le(f, at, 2));
    const std::uint32_t compression = le(f, at + 2, 2), size = le(f, at + 4, 4);
    const std::size_t header = compression ? 12 : 8;
    const std::size_t stored = compression ? le(f, at + 8, 4) : size;
    const std::size_t params = type == 5 ? 6 : 2;
    const std::size_t end = at + header + params + stored;
    if (end + 4 > f.size()) {
      ADD_FAILURE() << "block at " << at << " runs past the end";
      break;
    }
    EXPECT_EQ(le(f, end, 4), crc32_of(f.substr(at, end - at))) << "block at " << at;
    w.types.push_back(type);
    w.sizes.push_back(size);
    at = end + 4;
  }
  EXPECT_EQ(at, f.size());
  return w;
}

// The text without its thumbnail blocks (each framed by bare ";" lines), each of which must be
// there once.
std::string without_thumbnails(std::string text, const std::vector<GcodeThumbnail>& thumbnails) {
  for (const auto& t : thumbnails) {
    const std::string block = thumbnail_block(t);
    const std::size_t at = text.find(block);
    EXPECT_NE(at, std::string::npos) << t.width << "x" << t.height;
    if (at != std::string::npos) text.erase(at, block.size());
  }
  return text;
}

std::string value_of(const std::string& text, const std::string& key) {
  const std::size_t at = text.find("; " + key + " = ");
  if (at == std::string::npos) return "(none)";
  const std::size_t from = at + key.size() + 5;
  return text.substr(from, text.find('\n', from) - from);
}

std::string ini_value(const std::string& ini, const std::string& key) {
  const std::size_t at = ini.find(key + "=");
  if (at == std::string::npos) return "(none)";
  const std::size_t from = at + key.size() + 1;
  return ini.substr(from, ini.find('\n', from) - from);
}

}  // namespace

TEST(BgcodeWriter, GcodeBlocksHoldTheTextGcodeAndTheThumbnailsTheirPictures) {
  test::TempDir dir("bgcode_out");
  const Toolpath tp = print();
  const auto thumbs = pictures();
  const GcodeStats ts = write_gcode_file(dir.file("p.gcode"), tp, prusa(), thumbs);
  const GcodeStats bs = write_gcode_file(dir.file("p.bgcode"), tp, prusa(), thumbs);
  const std::string text = read_file(dir.file("p.gcode")), bin = read_file(dir.file("p.bgcode"));
  EXPECT_EQ(bs.bytes, bin.size());
  EXPECT_EQ(ts.print_time_s, bs.print_time_s);
  // Heatshrink 12/4 alone (no MeatPack) on this G-code: measured 2.6x smaller.
  EXPECT_LT(bin.size() * 2, text.size()) << "Heatshrink should shrink G-code text at least 2x";

  // The specification's order of blocks, each CRC right.
  const Walked w = walk(bin);
  ASSERT_GE(w.types.size(), 8u);
  EXPECT_EQ(std::vector<int>(w.types.begin(), w.types.begin() + 6),
            (std::vector<int>{0, 3, 5, 5, 4, 2}));
  std::size_t gcode_blocks = 0;
  for (std::size_t i = 6; i < w.types.size(); ++i) {
    EXPECT_EQ(w.types[i], 1);
    EXPECT_LE(w.sizes[i], std::size_t{1} << 16);
    ++gcode_blocks;
  }
  EXPECT_GT(gcode_blocks, 5u);

  // Our reader: G-code blocks end at line ends and join into the text, byte for byte.
  std::string gcode;
  std::vector<BgcodeBlockRead> pics;
  std::string print_ini, printer_ini;
  for (const auto& b : bgcode_blocks(bin, "p.bgcode")) {
    EXPECT_TRUE(b.checked);
    if (b.type == BgcodeBlock::Gcode) {
      // What Prusa's firmware decompresses (it refuses Deflate G-code blocks).
      EXPECT_EQ(b.compression, BgcodeCompression::Heatshrink12);
      EXPECT_EQ(b.data.back(), '\n');
      gcode += b.data;
    }
    if (b.type == BgcodeBlock::Thumbnail) pics.push_back(b);
    if (b.type == BgcodeBlock::PrintMetadata) print_ini = b.data;
    if (b.type == BgcodeBlock::PrinterMetadata) printer_ini = b.data;
  }
  EXPECT_NE(text.find("; thumbnail begin 220x124"), std::string::npos);
  EXPECT_EQ(gcode.find("; thumbnail begin"), std::string::npos);
  const std::string want = without_thumbnails(text, thumbs);
  const std::size_t differ =
      std::mismatch(gcode.begin(), gcode.begin() + std::min(gcode.size(), want.size()),
                    want.begin())
          .first -
      gcode.begin();
  EXPECT_TRUE(gcode == want) << "the G-code blocks differ from the text at byte " << differ << ":\n"
                             << gcode.substr(differ, 80) << "\n---\n"
                             << want.substr(differ, 80);
  ASSERT_EQ(pics.size(), thumbs.size());
  for (std::size_t i = 0; i < pics.size(); ++i) {
    EXPECT_EQ(pics[i].encoding, 0);  // PNG
    EXPECT_EQ(pics[i].width, thumbs[i].width);
    EXPECT_EQ(pics[i].height, thumbs[i].height);
    EXPECT_EQ(pics[i].data, thumbs[i].png);
  }
  // The metadata say what the text's footer says.
  for (const std::string& ini : {print_ini, printer_ini})
    for (const char* key : {"estimated printing time (normal mode)", "filament used [mm]"})
      EXPECT_EQ(ini_value(ini, key), value_of(text, key)) << key;
  EXPECT_EQ(ini_value(print_ini, "total layers count"), value_of(text, "total layers count"));
  EXPECT_EQ(ini_value(printer_ini, "nozzle_diameter"), "0.4");
  // The firmware's model check reads printer_model; a profile without one writes none.
  EXPECT_EQ(printer_ini.rfind("printer_model=MK4S\n", 0), 0u) << printer_ini;
  MachineProfile unnamed = prusa();
  unnamed.printer_model.clear();
  write_gcode_file(dir.file("u.bgcode"), tp, unnamed, thumbs);
  int printer_blocks = 0;
  for (const auto& b : bgcode_blocks(read_file(dir.file("u.bgcode")), "u.bgcode"))
    if (b.type == BgcodeBlock::PrinterMetadata) {
      ++printer_blocks;
      EXPECT_EQ(ini_value(b.data, "printer_model"), "(none)") << b.data;
    }
  EXPECT_EQ(printer_blocks, 1);
}

TEST(BgcodeWriter, EveryCompressionReadsBackToTheSameText) {
  const std::string text = write_gcode(print(), prusa());
  for (const auto c : {BgcodeCompression::None, BgcodeCompression::Deflate,
                       BgcodeCompression::Heatshrink11, BgcodeCompression::Heatshrink12}) {
    std::string bytes;
    BgcodeWriter w([&](std::string_view piece) { bytes.append(piece); }, {c, 20000});
    w.start({}, {});
    w.gcode(text);
    w.finish();
    walk(bytes);  // sizes and CRCs as the specification lays them out
    std::string gcode;
    for (const auto& b : bgcode_blocks(bytes, "c.bgcode"))
      if (b.type == BgcodeBlock::Gcode) {
        EXPECT_EQ(b.compression, c);
        gcode += b.data;
      }
    EXPECT_TRUE(gcode == text) << "compression " << static_cast<int>(c);
    if (c != BgcodeCompression::None) EXPECT_LT(bytes.size() * 2, text.size());
  }
}

// Lines MeatPack cannot simply pack: spaces it may not drop, glued words, lower case, comments
// (UTF-8 too), empty lines, a line longer than a block, no newline at the end.
std::string awkward_lines() {
  return "G1X5Y5\nG28 X Y\nM104 S200 ; heat\n\n; X and E in a comment\nG1 X1 Y2 E.5\n"
         "g1 x1\nG1  X1\nG1 X1 \nT0\nG1 E-.8 F2100\n; 25 \xC2\xB5m\nG92 E0\nG1 X1 E1e-3\n;" +
         std::string(2500, 'a') + "\nG1 X12.5 Y0.\nG1 X9";
}

TEST(BgcodeWriter, MeatPackBlocksReadBackAsTheTextAndDecodeIndependently) {
  test::TempDir dir("bgcode_meatpack");
  const std::string gcode = write_gcode(print(), prusa());
  for (const std::size_t block : {std::size_t{20000}, std::size_t{1000}}) {
    const std::string text = gcode + awkward_lines();
    std::string bytes;
    BgcodeWriter w([&](std::string_view piece) { bytes.append(piece); },
                   {BgcodeCompression::Heatshrink12, block, true});
    w.start({}, {});
    w.gcode(text);
    w.finish();
    walk(bytes);
    std::string read, fresh;
    for (const auto& b : bgcode_blocks(bytes, "m.bgcode"))
      if (b.type == BgcodeBlock::Gcode) {
        EXPECT_EQ(b.encoding, kBgcodeMeatPackComments);
        read += b.data;
      }
    EXPECT_TRUE(read == text) << "block size " << block;
    // Each block decodes on its own, with a decoder that saw no earlier block.
    std::string_view rest = text;
    std::size_t at = 0, blocks = 0;
    while (at < text.size()) {
      std::size_t take = std::min(block, text.size() - at);
      if (at + take < text.size())
        if (const std::size_t nl = rest.substr(0, take).rfind('\n'); nl != std::string::npos)
          take = nl + 1;
      const std::string piece(rest.substr(0, take));
      const std::string packed = meatpack_encode(piece, at > 0 && text[at - 1] != '\n');
      std::string one;
      MeatPackDecoder().feed(packed, one);
      EXPECT_TRUE(one == piece) << "block " << blocks;
      // More than half the text: PrusaSlicer's decoder then never grows its buffer (meatpack.cpp).
      EXPECT_GT(packed.size() * 2, piece.size()) << "block " << blocks;
      at += take, rest.remove_prefix(take), ++blocks;
    }
    // The independent decoder (tests/machine/bgcode_encode.py, Marlin's format), once: the
    // small blocks, the most block starts.
    if (block != 1000) continue;
    const std::string file = dir.file("m.bgcode"), out = dir.file("m.gcode");
    { std::ofstream(file, std::ios::binary) << bytes; }
    const std::string cmd = "/usr/bin/python3 " + std::string(TRELLIS_SOURCE_DIR) +
                            "/tests/machine/bgcode_encode.py --decode " + file + " " + out;
    ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
    EXPECT_TRUE(read_file(out) == text) << "block size " << block;
  }
  // The writer's own G-code packs to under 3/4 of its bytes (spaces dropped, digits in nibbles).
  EXPECT_LT(meatpack_encode(gcode).size() * 4, gcode.size() * 3);
  EXPECT_THROW(meatpack_encode("G1 X1\n; \xFF\n"), std::invalid_argument);
}

TEST(BgcodeWriter, TheEncodingSettingChoosesMeatPackOrText) {
  test::TempDir dir("bgcode_encoding");
  MachineProfile p = prusa();
  for (const auto e : {GcodeEncoding::MeatPack, GcodeEncoding::None}) {
    p.binary_encoding = e;
    const std::string file = dir.file(e == GcodeEncoding::None ? "t.bgcode" : "m.bgcode");
    write_gcode_file(file, print(), p, {});
    std::string gcode;
    for (const auto& b : bgcode_blocks(read_file(file), file))
      if (b.type == BgcodeBlock::Gcode) {
        EXPECT_EQ(b.encoding, e == GcodeEncoding::None ? 0 : kBgcodeMeatPackComments);
        gcode += b.data;
      }
    EXPECT_TRUE(gcode == write_gcode(print(), p));
  }
  EXPECT_LT(fs::file_size(dir.file("m.bgcode")), fs::file_size(dir.file("t.bgcode")));
}

TEST(BgcodeWriter, StreamedLayersPackTheSameBytes) {
  test::TempDir dir("bgcode_stream");
  const Toolpath tp = print();
  Toolpath meta;
  meta.source = tp.source;
  write_gcode_file(dir.file("whole.bgcode"), tp, prusa(), pictures());
  const GcodeStats s = write_gcode_stream(dir.file("streamed.bgcode"), meta, tp.layers.size(),
                                          layers_of(tp), prusa(), pictures());
  const std::string whole = read_file(dir.file("whole.bgcode"));
  EXPECT_EQ(s.bytes, whole.size());
  EXPECT_TRUE(read_file(dir.file("streamed.bgcode")) == whole);
}

TEST(BgcodeWriter, MachinesWithoutPrusasFirmwareAreRefused) {
  test::TempDir dir("bgcode_refused");
  MachineProfile klipper = prusa();
  klipper.name = "Voron";
  klipper.flavor = Flavor::Klipper;
  klipper.firmware = Firmware::None;
  try {
    write_gcode_file(dir.file("v.bgcode"), print(), klipper);
    FAIL() << "binary G-code written for a Klipper machine";
  } catch (const MachineError& e) {
    const std::string m = e.what();
    for (const char* w : {"machine.firmware", "klipper", "Voron", ".bgcode"})
      EXPECT_NE(m.find(w), std::string::npos) << w << ": " << m;
  }
  Toolpath meta;
  EXPECT_THROW(write_gcode_stream(dir.file("v.bgcode"), meta, 30, layers_of(print()), klipper),
               MachineError);
  // gcode.binary on an output named otherwise: refused, naming the setting.
  MachineProfile binary = prusa();
  binary.binary_gcode = true;
  try {
    write_gcode_file(dir.file("p.gcode"), print(), binary);
    FAIL() << "binary G-code written into a .gcode file";
  } catch (const SettingError& e) {
    EXPECT_NE(std::string(e.what()).find("gcode.binary"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(fs::is_empty(dir.path()));
  // Text G-code for the same machine is fine.
  EXPECT_NO_THROW(write_gcode_file(dir.file("v.gcode"), print(), klipper));
}

TEST(BgcodeWriter, AFailedStreamedWriteLeavesTheFolderAsItWas) {
  test::TempDir dir("bgcode_fail");
  const std::string target = dir.file("p.bgcode");
  { std::ofstream(target) << "the old file"; }
  const Toolpath tp = print();
  int visits = 0;
  const LayerSource failing = [&](const LayerVisitor& visit) {
    ++visits;
    for (std::size_t i = 0; i < tp.layers.size(); ++i) {
      if (visits > 2 && i == 20) throw std::runtime_error("the slicer failed at layer 20");
      visit(i, tp.layers[i]);
    }
  };
  Toolpath meta;
  EXPECT_THROW(write_gcode_stream(target, meta, tp.layers.size(), failing, prusa(), pictures()),
               std::runtime_error);
  EXPECT_GT(visits, 2);
  EXPECT_EQ(read_file(target), "the old file");
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir.path())) ++files;
  EXPECT_EQ(files, 1u) << "a temporary was left behind";
}
