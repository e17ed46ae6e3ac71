// G-code reader (Marlin, RepRapFirmware and Klipper dialects): turns any slicer's G-code back into
// moves, and into the toolpath IR. Understands G0/G1, G2/G3 (arcs split within a chord
// tolerance), G90/G91, M82/M83, G92, G20/G21; tools: T<n>, Klipper ACTIVATE_EXTRUDER; nozzle
// temperatures per tool: M104/M109 S<t> [T<n>], RepRapFirmware M568 P<tool> S<t> and G10 P<tool>
// S<t>, Klipper SET_HEATER_TEMPERATURE HEATER=extruder[N] TARGET=<t>; mixtures: Marlin M165 and
// M163/M164, RepRapFirmware M567 P<tool> E<a>:<b>...; the comments of Cura (;LAYER:, ;TYPE:),
// PrusaSlicer (;LAYER_CHANGE, ;Z:, ;TYPE:, ;WIDTH:, ;HEIGHT:) and Trellis; the parts of a build
// plate: M486 S<id> [A"<label>"] / M486 S-1, Klipper EXCLUDE_OBJECT_START / _END NAME=<label>
// (read back as Path::part and Toolpath::part_labels). A move extrudes when E
// grows (or, for pneumatic files, while the valve command is in force). PrusaSlicer's binary
// G-code (.bgcode, machine/bgcode.hpp) is recognised by its magic and decoded on the fly.
//
// The reader streams: `GcodeScanner` calls a sink per move, so metrics over a 1 GB file run in
// constant memory; `read_gcode` builds the toolpath IR (paths split at travel and retraction).
// Bad lines (garbage words, numbers that do not parse, NaN, |value| > 1e6) are counted as
// warnings naming the line and skipped, or stop the read with a ParseError if asked.
#pragma once
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "trellis/core/diagnostics.hpp"
#include "trellis/machine/print_time.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

struct GcodeReadOptions {
  double arc_tolerance = 0.005;  // max chord error when splitting G2/G3 (mm)
  bool stop_on_error = false;    // throw ParseError at the first bad line instead of skipping it
  // Pneumatic: a line whose first words are these opens / closes the valve (whole words: "M3"
  // does not match "M300"). Left empty, a file Trellis wrote for a pneumatic machine supplies
  // them from its "; job:" header.
  std::string valve_on;
  std::string valve_off;
  // Bath machines with several nozzles: where each nozzle sits relative to nozzle 0,
  // "x,y;x,y;..." (embedded.tool_offsets). The writer moved the head to design - offset(tool), so
  // the reader reports head + offset(tool): where the nozzle in use was. Left empty, a file
  // Trellis wrote for a bath machine supplies them from its "; setting" header (none when its
  // embedded.firmware_offsets says the firmware applied them: the head XY is the nozzle's then).
  std::string tool_offsets;
  // The motion limits the print-time estimate starts from; the file's own M201 / M203 / M204 /
  // M205 lines, or our header's speed.acceleration and speed.jerk, replace them.
  MotionLimits limits;
  // Mixing machines: our G-code issues each mixture change `; mixture lookahead = L mm` of
  // printed path before it is deposited (machine/mixing_lag.hpp). The toolpath read gives each
  // path the mixture deposited there (the look-ahead undone, paths cut where that changes);
  // true: the mixture commanded while it was printed, as the file's lines say. Files without
  // that header line read the same either way. (`analyze`/`check --commanded-mixtures`.)
  bool commanded_mixtures = false;
};

// ;TYPE: comment names: PrusaSlicer's vocabulary for the roles it has (Perimeter, Internal infill,
// Solid infill, Wipe tower, Custom), Trellis' own for the rest (Strut, Contour, Handle); the
// reader also knows Cura's (WALL-OUTER, SKIN, FILL, ...). docs/gcode.md has the table.
const char* gcode_type_name(PathRole role);
// The ;TYPE: of a prime line drawn before the print (gcode.prime_line): machine preparation, read
// as GcodeSink::prime, not as a path.
inline constexpr std::string_view kPrimeLineType = "Prime line";
PathRole role_from_gcode_type(std::string_view type);

// What the scanner reports. Positions are absolute, in mm.
class GcodeSink {
 public:
  virtual ~GcodeSink() = default;
  virtual void layer_change(double z) {}  // from a layer comment
  virtual void extrude(Vec3 a, Vec3 b, double e, double feed_mm_s) {}
  virtual void travel(Vec3 a, Vec3 b, double feed_mm_s) {}
  virtual void retract() {}  // E went back
  virtual void tool_change(int tool) {}
  virtual void role(PathRole role) {}  // from a ;TYPE: comment
  virtual void mixture(const std::vector<double>& fractions) {}
  // From our header's "; mixture lookahead = L mm": each mixture change was issued L mm of
  // printed path before the region it is for (machine/mixing_lag.hpp undoes it).
  virtual void mixture_lookahead(double mm) {}
  virtual void temperature(double celsius) {}  // nozzle temperature of the tool in use
  virtual void width(double mm) {}             // from a ;WIDTH: comment
  virtual void height(double mm) {}            // from a ;HEIGHT: comment
  virtual void dwell(double seconds) {}        // G4 P<ms> / S<s>: the machine waits
  // Every move as the machine makes it (machine XYZ, E change, feed), E-only moves too: what the
  // print-time estimate needs; `extrude` / `travel` report the same moves as nozzle positions.
  virtual void motion(Vec3 a, Vec3 b, double de, double feed_mm_s) {}
  virtual void limits(const MotionLimits& limits) {}  // the motion limits now in force
  // A heater's target (heater: tool number, or PrintTimeEstimator::kBed) and waits for heaters
  // (heater kAllHeaters: every one; celsius NaN: its target as set).
  static constexpr int kAllHeaters = -2;
  virtual void heater(int heater, double celsius, bool wait) {}
  // A homing move (G28): the machine stops; the position is the home position after it.
  virtual void home() {}
  // Moves that prime the nozzle before the print (our ";TYPE:Prime line"): not a path of the
  // print; reported here instead of as `extrude`.
  virtual void prime(Vec3 a, Vec3 b, double e, double feed_mm_s) {}
  // The moves that follow belong to the labelled part (build plates: M486 S<id> A"<label>",
  // Klipper EXCLUDE_OBJECT_START NAME=<label>); an empty label: to no part (M486 S-1,
  // EXCLUDE_OBJECT_END).
  virtual void object(std::string_view label) {}
};

// Every event to two sinks: one pass feeding, e.g., a counter and the toolpath builder.
class TeeSink : public GcodeSink {
 public:
  TeeSink(GcodeSink& a, GcodeSink& b) : a_(a), b_(b) {}
  void layer_change(double z) override { a_.layer_change(z), b_.layer_change(z); }
  void extrude(Vec3 p, Vec3 q, double e, double f) override {
    a_.extrude(p, q, e, f), b_.extrude(p, q, e, f);
  }
  void travel(Vec3 p, Vec3 q, double f) override { a_.travel(p, q, f), b_.travel(p, q, f); }
  void retract() override { a_.retract(), b_.retract(); }
  void tool_change(int t) override { a_.tool_change(t), b_.tool_change(t); }
  void role(PathRole r) override { a_.role(r), b_.role(r); }
  void mixture(const std::vector<double>& m) override { a_.mixture(m), b_.mixture(m); }
  void mixture_lookahead(double mm) override { a_.mixture_lookahead(mm), b_.mixture_lookahead(mm); }
  void temperature(double t) override { a_.temperature(t), b_.temperature(t); }
  void width(double w) override { a_.width(w), b_.width(w); }
  void height(double h) override { a_.height(h), b_.height(h); }
  void object(std::string_view l) override { a_.object(l), b_.object(l); }
  void dwell(double s) override { a_.dwell(s), b_.dwell(s); }
  void motion(Vec3 p, Vec3 q, double e, double f) override {
    a_.motion(p, q, e, f), b_.motion(p, q, e, f);
  }
  void limits(const MotionLimits& l) override { a_.limits(l), b_.limits(l); }
  void heater(int h, double c, bool w) override { a_.heater(h, c, w), b_.heater(h, c, w); }
  void home() override { a_.home(), b_.home(); }
  void prime(Vec3 p, Vec3 q, double e, double f) override {
    a_.prime(p, q, e, f), b_.prime(p, q, e, f);
  }

 private:
  GcodeSink& a_;
  GcodeSink& b_;
};

class GcodeScanner {
 public:
  GcodeScanner(GcodeSink& sink, GcodeReadOptions options, Diagnostics& diag,
               std::string origin = "gcode");
  // Feeds one line (without the newline).
  void line(std::string_view text);
  // Feeds a block of text; a trailing partial line is kept until the next call or finish().
  void feed(std::string_view text);
  void finish();
  long lines() const { return line_no_; }

  // The words of a move, by letter (a bit each in `seen`).
  struct Words {
    double value[26];
    std::uint32_t seen = 0;
    void set(char letter, double v) {
      seen |= 1u << (letter - 'A');
      value[letter - 'A'] = v;
    }
  };
  // One "G<g> ..." line (g 0 or 1) given as its words, by a writer that has just formatted it:
  // read as feed() reads that line, without the text. The values must be those the text reads
  // back as, each finite and within the reader's range. False (nothing read) while a partial
  // line is pending: the caller feeds the text instead.
  bool move_words(const Words& words, int g);

  // A writer resolving its own moves for a time estimate (gcode_writer.cpp): the state a G0/G1
  // reads and changes. plain_state() gives it while moves read plainly (no partial line pending,
  // absolute X Y Z in millimetres; false otherwise: hand over the words or the text instead);
  // the writer applies its moves to it with plain_motion() and gives it back with resume()
  // before the scanner reads anything else.
  struct MoveState {
    Vec3 pos;
    double e = 0, feed = 0;
    bool absolute_e = true;
    long lines = 0;
  };
  bool plain_state(MoveState& s) const;
  void resume(const MoveState& s);
  // What move_words(words, g) does for a G0/G1 from a plain state, for a sink that reads the
  // motion only (PrintTimeSink): the motion given to `time`, `s` moved. The words as for
  // move_words, F > 0.
  static void plain_motion(MoveState& s, const Words& words, PrintTimeEstimator& time);

 private:
  void bad(const std::string& what);
  void comment(std::string_view c);
  void move(std::string_view args, int g);
  void apply_move(const Words& words, int g);
  // The common line "G0 "/"G1 " + plain words, read in one pass from `s` (a line start before
  // a newline of its buffer): the position after its newline, or null if the line is not that
  // simple (anything else, or anything to report): line() reads it then.
  const char* simple_move(const char* s);
  void arc(Vec3 target, double e_target, double i, double j, double r, bool has_r, bool cw,
           double feed);
  void segment(Vec3 to, double e_to, double feed);
  void mcode(int code, std::string_view args);
  void extended(std::string_view s);  // Klipper-style NAME KEY=VALUE commands
  void set_temperature(int tool, double celsius);
  void select_tool(int tool);
  void set_mixture(int tool, std::vector<double> mix);
  void header_setting(std::string_view key, std::string_view value);
  static bool parse_offsets(std::string_view text, std::vector<Vec2>& out);
  void update_offset();
  void limit_command(int code, std::string_view args);

  GcodeSink& sink_;
  GcodeReadOptions opt_;
  Diagnostics& diag_;
  std::string origin_;
  std::string partial_;
  long line_no_ = 0;
  Vec3 pos_;
  double e_ = 0, feed_ = 0;
  bool abs_pos_ = true, abs_e_ = true, inches_ = false, valve_ = false;
  bool header_valves_ = false;     // no valve commands given: take them from our job header
  bool pneumatic_header_ = false;  // the header's flavor is 'pneumatic' or 'embedded'

  int tool_ = 0;
  std::vector<double> tool_temp_;              // per tool, NaN = not set
  std::vector<std::vector<double>> tool_mix_;  // RepRapFirmware M567: per tool
  std::vector<double> m163_;                   // Marlin M163 weights before M164
  std::vector<std::string> object_labels_;     // M486: labels by object id (A"<label>")
  double reported_temp_ = std::nan("");
  // Bath machines: each nozzle's offset (options or header) and the one of the tool in use.
  std::vector<Vec2> tool_offsets_;
  bool header_offsets_ = false;  // no offsets given: take them from our header
  bool bath_header_ = false, firmware_offsets_ = false;
  bool reprap_header_ = false;  // RepRapFirmware's M203 is in mm/min
  Vec3 offset_;
  bool priming_ = false;  // inside our ";TYPE:Prime line" block
  MotionLimits limits_;
};

// A sink estimating the print time (machine/print_time.hpp) of what a scanner reads.
class PrintTimeSink : public GcodeSink {
 public:
  explicit PrintTimeSink(const MotionLimits& limits = {}) : time(limits) {}
  void dwell(double seconds) override { time.dwell(seconds); }
  void motion(Vec3 a, Vec3 b, double de, double feed) override { time.move(a, b, de, feed); }
  void limits(const MotionLimits& l) override { time.set_limits(l); }
  void heater(int heater, double celsius, bool wait) override;
  void home() override { time.flush(); }
  PrintTimeEstimator time;
};

// A sink that builds the toolpath IR into `toolpath` (paths split at travel, retraction, tool,
// role and mixture changes; layers by comment, else by the Z of the extrusion). A path that
// continues the previous one's run (split by a change of tool, role, mixture, ... with no travel
// or retraction between) is `joined`: a path of `trellis analyze` is a run, not a piece. The
// mixtures are the commanded ones; read_gcode and read_gcode_file settle them as options say.
std::unique_ptr<GcodeSink> make_toolpath_builder(Toolpath& toolpath);

// A G-code print read into the IR, with what its header said about the mixtures.
struct GcodeRead {
  Toolpath toolpath;
  double mixture_lookahead = 0;  // mm, from "; mixture lookahead" (0: none recorded)
  // Read as deposited and asked for: the commanded mixture of every path, in print order.
  std::vector<std::vector<double>> commanded;
};

// Whole text to the toolpath IR (layers by comment, else by Z of the extrusion), mixtures as
// `options.commanded_mixtures` says.
Toolpath read_gcode(std::string_view text, const GcodeReadOptions& options, Diagnostics& diag,
                    const std::string& origin = "gcode");
// A file to the toolpath IR, streamed, every event also fed to `also` when given (a counter:
// one pass for both). Mixtures as `options.commanded_mixtures` says; read as deposited, a
// path cut only where the commanded mixture changed is one path again (the planned one), unless
// `keep_commanded`: then the pieces stay, each with its commanded mixture in
// GcodeRead::commanded (the viewer shows either).
GcodeRead read_gcode_file(const std::string& path, const GcodeReadOptions& options,
                          Diagnostics& diag, GcodeSink* also = nullptr,
                          bool keep_commanded = false);
// A file read layer by layer: the layers read_gcode_file builds, each handed to `visit` once
// complete and then let go (memory: a chunk and a layer). The mixtures are the commanded ones:
// a file with a mixture look-ahead read as deposited needs the whole toolpath (read_gcode_file).
void scan_gcode_layers(const std::string& path, const GcodeReadOptions& options, Diagnostics& diag,
                       const LayerVisitor& visit);
// The comment lines a file begins with (up to its first command; at most 64 MB): our header.
std::string read_gcode_header(const std::string& path);
// Streams a file through a sink in fixed-size chunks (constant memory).
void scan_gcode_file(const std::string& path, GcodeSink& sink, const GcodeReadOptions& options,
                     Diagnostics& diag);

}  // namespace trellis
