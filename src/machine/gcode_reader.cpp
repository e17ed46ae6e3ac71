#include "trellis/machine/gcode_reader.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>

#include "gcode_lex.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/text.hpp"
#include "trellis/machine/bgcode.hpp"
#include "trellis/machine/mixing_lag.hpp"

namespace trellis {

using namespace gcode_lex;

namespace {

// Is `s` the command `cmd` (its words, then the end of the line, a blank or a comment)? Whole
// words: "M3" matches "M3 S1000" but not "M300".
bool is_command(std::string_view s, std::string_view cmd) {
  if (cmd.empty() || s.size() < cmd.size()) return false;
  for (std::size_t i = 0; i < cmd.size(); ++i)
    if (upper(s[i]) != upper(cmd[i])) return false;
  if (s.size() == cmd.size()) return true;
  const char next = s[cmd.size()];
  return next == ' ' || next == '\t' || next == ';' || next == '*' || next == '(';
}

// distance(a, b) > 1e-12 without the square root: the largest squared distance whose
// (correctly rounded, monotonic) square root is still <= 1e-12, found once.
const double kStillSquared = [] {
  double t = 1e-24;
  while (std::sqrt(t) > 1e-12) t = std::nextafter(t, 0.0);
  while (std::sqrt(std::nextafter(t, 1.0)) <= 1e-12) t = std::nextafter(t, 1.0);
  return t;
}();
bool moves(Vec3 a, Vec3 b) {
  const Vec3 d = b - a;
  return dot(d, d) > kStillSquared;
}

// A profile's valve command may carry a comment ("M3 ; pressure on"): the command is its words.
std::string command_words(std::string_view command) {
  return std::string(trim(command.substr(0, command.find(';'))));
}

}  // namespace

GcodeScanner::GcodeScanner(GcodeSink& sink, GcodeReadOptions options, Diagnostics& diag,
                           std::string origin)
    : sink_(sink), opt_(std::move(options)), diag_(diag), origin_(std::move(origin)) {
  for (std::string* v : {&opt_.valve_on, &opt_.valve_off}) *v = command_words(*v);
  header_valves_ = opt_.valve_on.empty() && opt_.valve_off.empty();
  header_offsets_ = opt_.tool_offsets.empty();
  if (!header_offsets_ && !parse_offsets(opt_.tool_offsets, tool_offsets_))
    throw SettingError("tool offsets \"" + opt_.tool_offsets + "\" are not \"x,y;x,y;...\"",
                       {origin_, 0, "embedded.tool_offsets"});
  update_offset();
  limits_ = opt_.limits;
  sink_.limits(limits_);
}

bool GcodeScanner::parse_offsets(std::string_view text, std::vector<Vec2>& out) {
  out.clear();
  text = trim(text);
  while (!text.empty()) {
    const auto semi = std::min(text.find(';'), text.size());
    const std::string_view item = trim(text.substr(0, semi));
    const auto comma = item.find(',');
    if (comma == std::string_view::npos) return false;
    const std::string_view a = trim(item.substr(0, comma)), b = trim(item.substr(comma + 1));
    double x = 0, y = 0;
    if (!parse_number(a.data(), a.data() + a.size(), x) ||
        !parse_number(b.data(), b.data() + b.size(), y) || !std::isfinite(x) || !std::isfinite(y))
      return false;
    out.push_back({x, y});
    text = semi < text.size() ? trim(text.substr(semi + 1)) : std::string_view{};
  }
  return true;
}

void GcodeScanner::update_offset() {
  const bool apply = !header_offsets_ || (bath_header_ && !firmware_offsets_);
  const Vec2 o = apply && static_cast<std::size_t>(tool_) < tool_offsets_.size()
                     ? tool_offsets_[static_cast<std::size_t>(tool_)]
                     : Vec2{};
  offset_ = {o.x, o.y, 0};
}

// Our header's "; setting key = value" lines that reading needs: the bath machine's nozzle
// offsets and the motion limits of the time estimate.
void GcodeScanner::header_setting(std::string_view key, std::string_view value) {
  double v = 0;
  const bool number =
      parse_number(value.data(), value.data() + value.size(), v) && std::isfinite(v) && v >= 0;
  if (key == "machine.flavor") {
    bath_header_ = value == "embedded";
    reprap_header_ = value == "reprap";
  } else if (key == "embedded.tool_offsets" && header_offsets_) {
    if (!parse_offsets(value, tool_offsets_)) bad("unreadable embedded.tool_offsets in the header");
  } else if (key == "embedded.firmware_offsets") {
    firmware_offsets_ = value == "true";
  } else if (key == "speed.acceleration" && number && v > 0 && limits_.acceleration == 0) {
    limits_.acceleration = v;
    sink_.limits(limits_);
  } else if (key == "speed.jerk" && number) {
    limits_.jerk[0] = limits_.jerk[1] = v;
    sink_.limits(limits_);
  } else {
    return;
  }
  update_offset();
}

void GcodeScanner::bad(const std::string& what) {
  if (opt_.stop_on_error) throw ParseError(what, {origin_, line_no_});
  diag_.warn("gcode_bad_line",
             origin_ + ":" + std::to_string(line_no_) + ": " + what + " (line skipped)");
}

// A TOML string value as Trellis writes it in a "; job:" header line: 'literal' or "basic".
static std::string toml_string_value(std::string_view v) {
  v = trim(v);
  if (v.size() < 2 || (v.front() != '\'' && v.front() != '"') || v.back() != v.front()) return {};
  const bool basic = v.front() == '"';
  v = v.substr(1, v.size() - 2);
  if (!basic) return std::string(v);
  std::string out;
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (v[i] == '\\' && i + 1 < v.size()) ++i;
    out += v[i];
  }
  return out;
}

void GcodeScanner::comment(std::string_view c) {
  c = trim(c);
  // Our own pneumatic and bath files name their valve commands in the job header ("; job:
  // flavor = 'pneumatic'" or 'embedded' in [machine], then "; job: valve_on = 'M3 ; valve open'"
  // in [pneumatic]): a reader given none takes them from there, so the file reads back as
  // written.
  if (header_valves_ && starts_with(c, "job: ")) {
    const std::string_view kv = trim(c.substr(5));
    const auto eq = kv.find('=');
    if (eq != std::string_view::npos) {
      const std::string_view key = trim(kv.substr(0, eq));
      const std::string value = toml_string_value(kv.substr(eq + 1));
      if (key == "flavor") {
        pneumatic_header_ = value == "pneumatic" || value == "embedded";
      } else if (pneumatic_header_ && (key == "valve_on" || key == "valve_off")) {
        (key == "valve_on" ? opt_.valve_on : opt_.valve_off) = command_words(value);
      }
    }
    return;
  }
  if (starts_with(c, "mixture lookahead = ")) {
    const std::string_view v = trim(c.substr(20));
    const std::string_view num = v.substr(0, v.find(' '));
    double mm = 0;
    if (parse_number(num.data(), num.data() + num.size(), mm) && std::isfinite(mm) && mm >= 0 &&
        mm < kMaxValue)
      sink_.mixture_lookahead(mm);
    return;
  }
  if (starts_with(c, "setting ")) {
    const std::string_view kv = c.substr(8);
    const auto eq = kv.find(" = ");
    if (eq != std::string_view::npos)
      header_setting(trim(kv.substr(0, eq)), trim(kv.substr(eq + 3)));
    return;
  }
  if (starts_with(c, "LAYER:") || starts_with(c, "LAYER_CHANGE")) {
    priming_ = false;
    sink_.layer_change(std::nan(""));
  } else if (starts_with(c, "TYPE:")) {
    priming_ = trim(c.substr(5)) == kPrimeLineType;
    if (!priming_) sink_.role(role_from_gcode_type(c.substr(5)));
  } else if (starts_with(c, "WIDTH:") || starts_with(c, "HEIGHT:")) {
    const bool w = c[0] == 'W';
    const std::string_view v = trim(c.substr(w ? 6 : 7));
    double mm = 0;
    if (parse_number(v.data(), v.data() + v.size(), mm) && std::isfinite(mm) && mm > 0 &&
        mm < kMaxValue) {
      if (w)
        sink_.width(mm);
      else
        sink_.height(mm);
    }
  }
}

void GcodeScanner::feed(std::string_view text) {
  std::size_t pos = 0;
  // Plain moves are lexed up to the last newline (lex_move needs one ahead).
  const char* const last_nl = gcode_lex::last_newline(text.data(), text.data() + text.size());
  const std::size_t lexed = last_nl ? static_cast<std::size_t>(last_nl - text.data()) + 1 : 0;
  while (pos < text.size()) {
    // Valve commands may be learnt from the header on the way (comment()): checked per line.
    if (pos < lexed && partial_.empty() && opt_.valve_on.empty() && opt_.valve_off.empty()) {
      if (const char* next = simple_move(text.data() + pos)) {
        pos = static_cast<std::size_t>(next - text.data());
        continue;
      }
    }
    const auto nl = text.find('\n', pos);
    if (nl == std::string_view::npos) {
      partial_.append(text.substr(pos));
      return;
    }
    if (!partial_.empty()) {
      partial_.append(text.substr(pos, nl - pos));
      line(partial_);
      partial_.clear();
    } else {
      line(text.substr(pos, nl - pos));
    }
    pos = nl + 1;
  }
}

const char* GcodeScanner::simple_move(const char* s) {
  Words w;
  const char* next = lex_move(s, w);
  if (next == nullptr) return nullptr;
  ++line_no_;
  apply_move(w, s[1] - '0');
  return next;
}

bool GcodeScanner::move_words(const Words& words, int g) {
  if (!partial_.empty()) return false;
  ++line_no_;
  apply_move(words, g);
  return true;
}

bool GcodeScanner::plain_state(MoveState& s) const {
  if (!partial_.empty() || !abs_pos_ || inches_) return false;
  s = {pos_, e_, feed_, abs_e_, line_no_};
  return true;
}

void GcodeScanner::resume(const MoveState& s) {
  pos_ = s.pos;
  e_ = s.e;
  feed_ = s.feed;
  line_no_ = s.lines;
}

// apply_move() with unit 1, absolute X Y Z, g 0 or 1 and F > 0: the same arithmetic.
void GcodeScanner::plain_motion(MoveState& s, const Words& w, PrintTimeEstimator& time) {
  auto has = [&](char letter) { return (w.seen >> (letter - 'A')) & 1u; };
  auto word = [&](char letter) { return w.value[letter - 'A']; };
  ++s.lines;
  if (has('F')) s.feed = word('F') / 60;
  Vec3 to = s.pos;
  double e_to = s.e;
  if (has('X')) to.x = word('X');
  if (has('Y')) to.y = word('Y');
  if (has('Z')) to.z = word('Z');
  if (has('E')) e_to = s.absolute_e ? word('E') : s.e + word('E');
  const double de = e_to - s.e;
  if (moves(s.pos, to) || std::abs(de) > 1e-12) time.move(s.pos, to, de, s.feed);
  s.pos = to;
  s.e = e_to;
}

void GcodeScanner::finish() {
  if (!partial_.empty()) {
    line(partial_);
    partial_.clear();
  }
}

void GcodeScanner::line(std::string_view text) {
  ++line_no_;
  std::string_view s = trim(text);
  if (is_command(s, opt_.valve_on)) valve_ = true;
  if (is_command(s, opt_.valve_off)) valve_ = false;
  // The comment (memchr-fast); a checksum (*) or a parenthesised comment ends the words too, which
  // the word loops check as they go.
  if (const auto semi = s.find(';'); semi != std::string_view::npos) {
    comment(s.substr(semi + 1));
    s = trim(s.substr(0, semi));
  }
  if (s.empty()) return;
  // Fast path for the bulk of any file: "G0 " / "G1 ".
  if (s.size() > 2 && (s[0] == 'G' || s[0] == 'g') && (s[1] == '0' || s[1] == '1') && s[2] == ' ')
    return move(s.substr(2), s[1] - '0');
  if (s[0] == '*' || s[0] == '(') return;
  if (s[0] == 'N' || s[0] == 'n') {  // line number
    std::size_t k = 1;
    while (k < s.size() && is_digit(s[k])) ++k;
    s = trim(s.substr(k));
    if (s.empty()) return;
  }
  const char c = upper(s[0]);
  std::size_t k = 1;
  while (k < s.size() && (is_digit(s[k]) || s[k] == '.')) ++k;
  if (k == 1) {
    // A Klipper command or macro: an upper-case name of letters, digits and '_' (TEMPERATURE_WAIT,
    // M-less names that start with T, G or M too).
    const auto name_end = std::min(s.find_first_of(" \t"), s.size());
    const bool klipper_name =
        name_end >= 3 && (is_alpha(s[1]) || s[1] == '_') &&
        std::all_of(s.begin(), s.begin() + static_cast<long>(name_end), [](char ch) {
          return (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') || ch == '_';
        });
    if (klipper_name) return extended(s);
    if (c == 'T' || c == 'G' || c == 'M')
      return bad("command '" + std::string(s.substr(0, 20)) + "' has no number");
    if (is_alpha(c) && k < s.size() && (is_alpha(s[k]) || s[k] == '_'))
      return extended(s);     // Klipper: NAME KEY=VALUE ...
    if (is_alpha(c)) return;  // a bare parameter line: ignore
    return bad("unreadable line '" + std::string(s.substr(0, 40)) + "'");
  }
  double code = 0;
  if (!parse_number(s.data() + 1, s.data() + k, code))
    return bad("unreadable command '" + std::string(s.substr(0, k)) + "'");
  const std::string_view args = s.substr(k);
  if (c == 'G') {
    if (code == 0 || code == 1 || code == 2 || code == 3) return move(args, static_cast<int>(code));
    if (code == 90)
      abs_pos_ = true;
    else if (code == 91)
      abs_pos_ = false;
    else if (code == 20)
      inches_ = true;
    else if (code == 21)
      inches_ = false;
    else if (code == 92)
      move(args, 92);
    else if (code == 28) {  // home: the named axes (all when none) at 0
      const bool x = !param(args, "X").empty(), y = !param(args, "Y").empty(),
                 z = !param(args, "Z").empty(), all = !x && !y && !z;
      if (all || x) pos_.x = 0;
      if (all || y) pos_.y = 0;
      if (all || z) pos_.z = 0;
      sink_.home();
    } else if (code == 4) {  // dwell: G4 P<milliseconds> or S<seconds> (Marlin, RRF, Klipper)
      double ms = 0, sec = 0;
      const std::string_view pv = param(args, "P"), sv = param(args, "S");
      if (!pv.empty() &&
          (!parse_number(pv.data(), pv.data() + pv.size(), ms) || !(ms >= 0) || ms > 1e9))
        return bad("bad dwell '" + std::string(args.substr(0, 40)) + "'");
      if (!sv.empty() &&
          (!parse_number(sv.data(), sv.data() + sv.size(), sec) || !(sec >= 0) || sec > 1e6))
        return bad("bad dwell '" + std::string(args.substr(0, 40)) + "'");
      if (ms + sec > 0) sink_.dwell(ms / 1000 + sec);
    } else if (code == 10 && !param(args, "P").empty()) {  // RepRapFirmware G10 P<tool> S<t>
      double tool = 0, t = 0;
      const std::string_view pv = param(args, "P"), sv = param(args, "S");
      const std::string_view sn = sv.substr(0, sv.find(':'));
      if (!parse_number(pv.data(), pv.data() + pv.size(), tool) || tool < 0 || tool > 255)
        return bad("bad tool in '" + std::string(args.substr(0, 40)) + "'");
      if (sv.empty()) return;
      if (!parse_number(sn.data(), sn.data() + sn.size(), t) || t < 0 || t > 1000)
        return bad("bad temperature in '" + std::string(args.substr(0, 40)) + "'");
      sink_.heater(static_cast<int>(tool), t, false);
      set_temperature(static_cast<int>(tool), t);
    }
  } else if (c == 'M') {
    // No firmware has M-codes past 9999; a longer number is no command we know (and no int).
    if (code > 9999) return bad("unknown command '" + std::string(s.substr(0, 20)) + "'");
    mcode(static_cast<int>(code), args);
  } else if (c == 'T') {
    if (code < 0 || code > 255) return bad("tool number out of range");
    select_tool(static_cast<int>(code));
  }
}

void GcodeScanner::move(std::string_view args, int g) {
  Words w;
  int n = 0;
  const char* const end = args.data() + args.size();
  std::size_t p = 0;
  while (p < args.size()) {
    while (p < args.size() && (args[p] == ' ' || args[p] == '\t')) ++p;
    if (p >= args.size() || args[p] == '*' || args[p] == '(') break;
    const char letter = upper(args[p]);
    if (!is_alpha(letter)) return bad("unexpected '" + std::string(1, args[p]) + "'");
    const char* b = args.data() + p + 1;
    // The number runs to the next blank or letter (G-code has no exponents). Fast path: a plain
    // decimal, parsed in the same pass that finds its end.
    double v = 0;
    const char* e = scan_decimal(b, end, v);
    bool ok = e != nullptr &&
              (e == end || *e == ' ' || *e == '\t' || is_alpha(*e) || *e == '*' || *e == '(');
    if (!ok) {
      e = b;
      while (e < end && *e != ' ' && *e != '\t' && *e != '*' && *e != '(' && !is_alpha(*e)) ++e;
      ok = parse_number(b, e, v);
    }
    const std::size_t q = static_cast<std::size_t>(e - args.data());
    if (!ok || !std::isfinite(v) || std::abs(v) > kMaxValue)
      return bad("bad number in '" + std::string(args.substr(p, std::min<std::size_t>(q - p, 30))) +
                 "'");
    // "X1e308": an exponent (which G-code has not) or X1 and E308? Neither is read as the other.
    if (e + 1 < end && (*e == 'e' || *e == 'E') &&
        (is_digit(e[1]) || ((e[1] == '-' || e[1] == '+') && e + 2 < end && is_digit(e[2]))))
      return bad("'" + std::string(args.substr(p, std::min<std::size_t>(q - p + 6, 30))) +
                 "': a number with an exponent, or two words without a space between them");
    const std::uint32_t bit = 1u << (letter - 'A');
    if (w.seen & bit) return bad(std::string("the word ") + letter + " appears twice");
    if (n == 16) return bad("too many words");
    ++n;
    w.seen |= bit;
    w.value[letter - 'A'] = v;
    p = q;
  }
  apply_move(w, g);
}

void GcodeScanner::apply_move(const Words& w, int g) {
  const double unit = inches_ ? 25.4 : 1.0;
  auto has = [&](char letter) { return (w.seen >> (letter - 'A')) & 1u; };
  auto word = [&](char letter) { return w.value[letter - 'A'] * unit; };
  if (g == 92) {
    if (has('X')) pos_.x = word('X');
    if (has('Y')) pos_.y = word('Y');
    if (has('Z')) pos_.z = word('Z');
    if (has('E')) e_ = word('E');
    return;
  }
  if (has('F')) {
    if (word('F') <= 0) return bad("feed rate must be > 0");
    feed_ = word('F') / 60;
  }
  Vec3 to = pos_;
  double e_to = e_;
  if (has('X')) to.x = abs_pos_ ? word('X') : pos_.x + word('X');
  if (has('Y')) to.y = abs_pos_ ? word('Y') : pos_.y + word('Y');
  if (has('Z')) to.z = abs_pos_ ? word('Z') : pos_.z + word('Z');
  if (has('E')) e_to = abs_e_ ? word('E') : e_ + word('E');
  if (g == 2 || g == 3)
    return arc(to, e_to, has('I') ? word('I') : 0, has('J') ? word('J') : 0,
               has('R') ? word('R') : 0, has('R'), g == 2, feed_);
  const bool valve_extrudes = !opt_.valve_on.empty() && valve_ && g == 1;
  const double de = e_to - e_;
  const bool moved = moves(pos_, to);
  if (moved || std::abs(de) > 1e-12) sink_.motion(pos_, to, de, feed_);
  if (moved) {
    if ((de > 1e-12 || valve_extrudes) && priming_)
      sink_.prime(pos_ + offset_, to + offset_, std::max(de, 0.0), feed_);
    else if (de > 1e-12 || valve_extrudes)
      sink_.extrude(pos_ + offset_, to + offset_, std::max(de, 0.0), feed_);
    else
      sink_.travel(pos_ + offset_, to + offset_, feed_);
    if (de < -1e-12) sink_.retract();
  } else if (de < -1e-12) {
    sink_.retract();
  }
  pos_ = to;
  e_ = e_to;
}

void GcodeScanner::arc(Vec3 to, double e_to, double ci, double cj, double r, bool has_r, bool cw,
                       double feed) {
  const Vec3 from = pos_;
  Vec2 c;
  if (has_r) {
    // Centre from the radius (negative R = the long way round).
    const double dx = to.x - from.x, dy = to.y - from.y, d = std::hypot(dx, dy);
    if (d < 1e-12 || std::abs(r) < d / 2 - 1e-9)
      return bad("arc radius too small for its end points");
    const double h = std::sqrt(std::max(0.0, r * r - d * d / 4));
    const double sgn = (cw ? 1 : -1) * (r < 0 ? -1 : 1);
    c = {from.x + dx / 2 + sgn * h * dy / d, from.y + dy / 2 - sgn * h * dx / d};
  } else {
    c = {from.x + ci, from.y + cj};
  }
  const double radius = std::hypot(from.x - c.x, from.y - c.y);
  if (radius < 1e-9) return bad("arc with zero radius");
  const double a0 = std::atan2(from.y - c.y, from.x - c.x);
  const double a1 = std::atan2(to.y - c.y, to.x - c.x);
  double sweep = a1 - a0;
  if (cw) {
    while (sweep >= -1e-12) sweep -= 2 * std::numbers::pi;
  } else {
    while (sweep <= 1e-12) sweep += 2 * std::numbers::pi;
  }
  if (std::abs(sweep) > 2 * std::numbers::pi)
    sweep += cw ? 2 * std::numbers::pi : -2 * std::numbers::pi;
  // At most 10,000 chords per arc: below the tolerance for any radius up to ~1 m.
  const double step = 2 * std::acos(std::clamp(1 - opt_.arc_tolerance / radius, -1.0, 1.0));
  const int pieces =
      std::clamp(static_cast<int>(std::ceil(std::abs(sweep) / std::max(step, 1e-6))), 1, 10000);
  const double e0 = e_;
  for (int k = 1; k <= pieces; ++k) {
    const double t = static_cast<double>(k) / pieces;
    const double a = a0 + sweep * t;
    const Vec3 q = k == pieces ? to
                               : Vec3{c.x + radius * std::cos(a), c.y + radius * std::sin(a),
                                      from.z + (to.z - from.z) * t};
    const double e_k = e0 + (e_to - e0) * t;
    const double de = e_k - e_;
    sink_.motion(pos_, q, de, feed);
    if ((de > 1e-12 || (!opt_.valve_on.empty() && valve_)) && priming_)
      sink_.prime(pos_ + offset_, q + offset_, std::max(de, 0.0), feed);
    else if (de > 1e-12 || (!opt_.valve_on.empty() && valve_))
      sink_.extrude(pos_ + offset_, q + offset_, std::max(de, 0.0), feed);
    else
      sink_.travel(pos_ + offset_, q + offset_, feed);
    pos_ = q;
    e_ = e_k;
  }
}

namespace {

// Builds the toolpath IR: a path per run of connected extrusions with one tool and role.
class ToolpathBuilder : public GcodeSink {
 public:
  explicit ToolpathBuilder(Toolpath& tp) : tp_(tp) {}

  void layer_change(double) override {
    close();
    commented_ = true;
    if (tp_.layers.empty() || !tp_.layers.back().paths.empty()) new_layer_ = true;
  }
  void extrude(Vec3 a, Vec3 b, double e, double feed) override {
    // No travel or retraction since the last extrusion, which ended here: the same run.
    const bool joined = running_ && distance(last_end_, a) <= 1e-9;
    running_ = true;
    last_end_ = b;
    if (path_ && distance(path_->points.back(), b) >= 0 &&
        distance(path_->points.back(), a) < 1e-9) {
      path_->points.push_back(b);
      path_->filament += e;
      return;
    }
    close();
    Layer& layer = layer_for(a.z);
    Path p;
    p.joined = joined;
    // The travel's corners in XY (a Z hop adds none) become the path's via points.
    for (const Vec3& v : travel_) {
      const Vec3 last = p.via.empty() ? travel_from_ : p.via.back();
      if (distance_xy(v, last) > 1e-9 && distance_xy(v, a) > 1e-9) p.via.push_back(v);
    }
    travel_.clear();
    p.points = {a, b};
    p.tool = tool_;
    p.role = role_;
    p.mixture = mixture_;
    p.temperature = temperature_;
    p.width = width_;
    p.height = height_;
    p.speed = feed;
    p.filament = e;
    p.part = part_;
    layer.paths.push_back(std::move(p));
    path_ = &layer.paths.back();
  }
  void travel(Vec3 a, Vec3 b, double) override {
    if (path_ || travel_.empty()) travel_from_ = a, travel_.clear();
    close();
    running_ = false;
    travel_.push_back(b);
  }
  void retract() override {
    close();
    running_ = false;
  }
  void mixture_lookahead(double mm) override { lookahead_ = mm; }
  double lookahead() const { return lookahead_; }
  void tool_change(int tool) override {
    close();
    tool_ = tool;
  }
  void role(PathRole r) override {
    close();
    role_ = r;
  }
  void mixture(const std::vector<double>& m) override {
    close();
    mixture_ = m;
  }
  void temperature(double t) override {
    close();
    temperature_ = t;
  }
  void width(double w) override {
    if (w != width_) close();
    width_ = w;
  }
  void height(double h) override {
    if (h != height_) close();
    height_ = h;
  }
  void object(std::string_view label) override {
    close();
    if (label.empty()) {
      part_ = 0;
      return;
    }
    const auto& labels = tp_.part_labels;
    const auto it = std::find(labels.begin(), labels.end(), label);
    if (it == labels.end()) tp_.part_labels.emplace_back(label);
    part_ = static_cast<int>(std::find(labels.begin(), labels.end(), label) - labels.begin()) + 1;
  }

 private:
  void close() { path_ = nullptr; }

  Layer& layer_for(double z) {
    const bool by_z =
        !commented_ && !tp_.layers.empty() && std::abs(tp_.layers.back().z - z) > 1e-4;
    if (tp_.layers.empty() || new_layer_ || by_z) {
      tp_.layers.push_back({z, {}});
      new_layer_ = false;
    }
    return tp_.layers.back();
  }

  Toolpath& tp_;
  Path* path_ = nullptr;
  Vec3 travel_from_;          // where the travel since the last extrusion began
  std::vector<Vec3> travel_;  // its moves' ends
  int tool_ = 0, part_ = 0;
  PathRole role_ = PathRole::Strut;
  std::vector<double> mixture_;
  double temperature_ = 0, width_ = 0, height_ = 0;
  bool commented_ = false, new_layer_ = false;
  bool running_ = false;  // extruding since the last travel or retraction, ending at last_end_
  Vec3 last_end_;
  double lookahead_ = 0;
};

// The builder's layers handed on as each is complete (the builder adds to the last one only).
class LayerStreamer : public GcodeSink {
 public:
  explicit LayerStreamer(const LayerVisitor& visit) : visit_(visit) {}
  void extrude(Vec3 a, Vec3 b, double e, double feed) override {
    builder_.extrude(a, b, e, feed);
    if (tp_.layers.size() > 1) hand_on(tp_.layers.size() - 1);
  }
  void layer_change(double z) override { builder_.layer_change(z); }
  void travel(Vec3 a, Vec3 b, double feed) override { builder_.travel(a, b, feed); }
  void retract() override { builder_.retract(); }
  void tool_change(int tool) override { builder_.tool_change(tool); }
  void role(PathRole r) override { builder_.role(r); }
  void mixture(const std::vector<double>& m) override { builder_.mixture(m); }
  void mixture_lookahead(double mm) override { builder_.mixture_lookahead(mm); }
  void temperature(double t) override { builder_.temperature(t); }
  void width(double w) override { builder_.width(w); }
  void height(double h) override { builder_.height(h); }
  void object(std::string_view label) override { builder_.object(label); }
  void finish() { hand_on(tp_.layers.size()); }

 private:
  // The first n layers to `visit`, then out of the toolpath. The last layer moves to the front:
  // its paths (which the builder points into) stay where they are.
  void hand_on(std::size_t n) {
    for (std::size_t k = 0; k < n; ++k) visit_(handed_++, tp_.layers[k]);
    tp_.layers.erase(tp_.layers.begin(), tp_.layers.begin() + static_cast<std::ptrdiff_t>(n));
  }
  const LayerVisitor& visit_;
  Toolpath tp_;
  ToolpathBuilder builder_{tp_};
  std::size_t handed_ = 0;
};

// The builder's mixtures settled as `options` says (gcode_reader.hpp: read_gcode_file).
void settle_mixtures(GcodeRead& r, const GcodeReadOptions& options, bool keep_commanded) {
  if (options.commanded_mixtures || !(r.mixture_lookahead > 0)) return;
  auto commanded = deposit_mixtures(r.toolpath, r.mixture_lookahead);
  if (keep_commanded)
    r.commanded = std::move(commanded);
  else
    merge_joined_pieces(r.toolpath);
}

}  // namespace

void PrintTimeSink::heater(int h, double celsius, bool wait) {
  if (!wait) return time.set_target(h, celsius);
  if (h == kAllHeaters) return time.wait_all();
  time.wait_for(h, celsius);
}

std::unique_ptr<GcodeSink> make_toolpath_builder(Toolpath& toolpath) {
  return std::make_unique<ToolpathBuilder>(toolpath);
}

Toolpath read_gcode(std::string_view text, const GcodeReadOptions& options, Diagnostics& diag,
                    const std::string& origin) {
  GcodeRead r;
  r.toolpath.source = origin;
  ToolpathBuilder builder(r.toolpath);
  GcodeScanner scanner(builder, options, diag, origin);
  if (is_bgcode(text))
    scanner.feed(bgcode_to_text(text, origin));
  else
    scanner.feed(text);
  scanner.finish();
  r.mixture_lookahead = builder.lookahead();
  settle_mixtures(r, options, false);
  return std::move(r.toolpath);
}

GcodeRead read_gcode_file(const std::string& path, const GcodeReadOptions& options,
                          Diagnostics& diag, GcodeSink* also, bool keep_commanded) {
  GcodeRead r;
  r.toolpath.source = path;
  ToolpathBuilder builder(r.toolpath);
  if (also) {
    TeeSink both(*also, builder);
    scan_gcode_file(path, both, options, diag);
  } else {
    scan_gcode_file(path, builder, options, diag);
  }
  r.mixture_lookahead = builder.lookahead();
  settle_mixtures(r, options, keep_commanded);
  return r;
}

void scan_gcode_layers(const std::string& path, const GcodeReadOptions& options, Diagnostics& diag,
                       const LayerVisitor& visit) {
  LayerStreamer streamer(visit);
  scan_gcode_file(path, streamer, options, diag);
  streamer.finish();
}

std::string read_gcode_header(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError("cannot open", {path});
  std::string header, line;
  while (header.size() < (64u << 20) && std::getline(in, line)) {
    const auto first = line.find_first_not_of(" \t\r");
    if (first != std::string::npos && line[first] != ';') break;
    header += line;
    header += '\n';
  }
  return header;
}

}  // namespace trellis
