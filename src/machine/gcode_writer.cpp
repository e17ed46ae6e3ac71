#include "trellis/machine/gcode_writer.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <memory>
#include <numbers>
#include <utility>

#include "estimate_pipe.hpp"
#include "fast_number.hpp"
#include "gcode_lex.hpp"
#include "gcode_objects.hpp"
#include "text_out.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/machine/bgcode_writer.hpp"
#include "trellis/machine/gcode_reader.hpp"
#include "trellis/machine/machine_check.hpp"
#include "trellis/version.hpp"

namespace trellis {

double extrusion_for(double length, double layer, const MachineProfile& p) {
  return p.k * 4 * length * layer * p.extrusion_multiplier * p.nozzle_diameter /
         (std::numbers::pi * p.filament_diameter * p.filament_diameter);
}

std::string expand_template(const std::string& text, const MachineProfile& p,
                            const std::string& which) {
  std::string out;
  std::size_t pos = 0;
  while (pos < text.size()) {
    const auto open = text.find('{', pos);
    if (open == std::string::npos) {
      out.append(text, pos);
      break;
    }
    out.append(text, pos, open - pos);
    const auto close = text.find('}', open);
    if (close == std::string::npos) throw SettingError("unclosed '{' in template", {"", 0, which});
    const std::string key = text.substr(open + 1, close - open - 1);
    const SettingDecl* found = nullptr;
    for (const auto& d : machine_settings()) {
      const std::string full = d.key;
      if (key == full || key == full.substr(full.find('.') + 1)) found = &d;
    }
    if (!found) throw SettingError("unknown placeholder {" + key + "} in template", {"", 0, which});
    out += setting_text(p, *found);
    pos = close + 1;
  }
  return out;
}

namespace {

// "1h 2m 3s" as PrusaSlicer writes estimated times.
std::string duration_text(double seconds) {
  long s = std::lround(std::max(0.0, seconds));
  std::string out;
  if (s >= 86400) out += std::to_string(s / 86400) + "d ", s %= 86400;
  if (s >= 3600 || !out.empty()) out += std::to_string(s / 3600) + "h ", s %= 3600;
  if (s >= 60 || !out.empty()) out += std::to_string(s / 60) + "m ", s %= 60;
  return out + std::to_string(s) + "s";
}

// Appends v with at most `decimals` decimals, trailing zeros removed (fast, locale-free).
void append_fixed(std::string& out, double v, int decimals) {
  char buf[fastnum::kMaxChars];
  out.append(buf, static_cast<std::size_t>(fastnum::fixed(buf, v, decimals) - buf));
}

void append_fixed(fastnum::TextOut& out, double v, int decimals) {
  char* p = out.room(fastnum::kMaxChars);
  out.commit(fastnum::fixed(p, v, decimals));
}

// The F word's value: mm/s as a whole number of mm/min.
char* put_feed(char* p, double mm_per_s) {
  return std::to_chars(p, p + 24, std::lround(mm_per_s * 60)).ptr;
}

// The " F<mm/min>" words written so far, by feed in mm/s (a print uses a handful: printing,
// travel, Z, retraction), each formatted once; the value each reads back as beside it.
class FeedWords {
 public:
  struct Word {
    double mm_per_s = std::numeric_limits<double>::quiet_NaN();  // NaN: none yet (never equal)
    double f = 0;  // the value the word reads back as (mm/min)
    std::uint32_t len = 0;
    char text[40];  // " F" and the digits (put_uint may write 8 bytes past them)
  };
  const Word& get(double mm_per_s) {
    for (const Word& w : words_)
      if (w.mm_per_s == mm_per_s) return w;
    Word& w = words_[next_++ % words_.size()];
    const long long f = fastnum::llround(mm_per_s * 60);
    char* p = fastnum::lit(w.text, " F");
    p = f >= 0 ? fastnum::put_uint(p, static_cast<unsigned long long>(f))
               : std::to_chars(p, p + 24, f).ptr;
    w.len = static_cast<std::uint32_t>(p - w.text);
    w.f = static_cast<double>(f);
    w.mm_per_s = mm_per_s;
    return w;
  }

 private:
  std::array<Word, 4> words_;
  std::size_t next_ = 0;
};

// A G0/G1 line composed in one buffer (the writer's hot path), with the value each word reads
// back as, so the print-time estimate takes the move without parsing its text: fixed() writes
// q = llround(v * 10^d) as a decimal, which the reader's parser reads as q / 10^d, both exact
// doubles and the division correctly rounded (gcode_lex::scan_decimal), so the same double.
// Written in place at the end of the text (TextOut::room(kRoom)), each value rounded once for
// both its digits and the value it reads back as.
class MoveLine {
 public:
  static constexpr std::size_t kRoom = 6 * fastnum::kMaxChars;
  MoveLine(char* at, bool g1) : end_(at) {
    std::memcpy(end_, g1 ? "G1" : "G0", 2);
    end_ += 2;
  }

  template <int D>
  static constexpr double kScale = D == 3 ? 1e3 : 1e5;

  // " <letter><v>" with at most D decimals.
  template <int D>
  [[gnu::always_inline]] void word(char letter, double v) {
    long long q = 0;
    const bool rounded = fastnum::round_half_away(v * kScale<D>, q);
    word_q<D>(letter, v, rounded, q);
  }
  // The same with v * 10^D rounded already (`rounded`: round_half_away took it, giving q).
  // The common word (|v| below 1000) is written inline from digit tables: it is
  // readable (gcode_lex::kMaxValue is larger), so only its value is kept for the estimate.
  template <int D>
  [[gnu::always_inline]] void word_q(char letter, double v, bool rounded, long long q) {
    static_assert(D == 3 || D == 5);
    static_assert(gcode_lex::kMaxValue >= 1000);
    char* p = end_;  // a local: the bytes written through it cannot change it
    p[0] = ' ';
    p[1] = letter;
    if constexpr (D == 3) {
      if (rounded && q < fastnum::kFixed3Small && q > -fastnum::kFixed3Small) [[likely]] {
        end_ = fastnum::fixed3_small(p + 2, q);
        words_.set(letter, static_cast<double>(q) / kScale<D>);
        return;
      }
    } else {
      if (rounded && q < fastnum::kFixed5Small && q > -fastnum::kFixed5Small) [[likely]] {
        end_ = fastnum::fixed5_small(p + 2, q);
        words_.set(letter, static_cast<double>(q) / kScale<D>);
        return;
      }
    }
    word_rest(letter, v, rounded, q, D, kScale<D>);
  }
  // " F<mm/min>": a feed's word as FeedWords formatted it.
  [[gnu::always_inline]] void feed(const FeedWords::Word& w) {
    std::memcpy(end_, w.text, 32);  // (the room holds it: kRoom)
    end_ += w.len;
    take('F', w.f);
    readable_ = readable_ && w.f > 0;
  }
  void close() { *end_++ = '\n'; }

  // word_q's other values (large, or beyond round_half_away: printed as fixed_legacy prints
  // them, and read from the text by the estimate).
  [[gnu::noinline]] void word_rest(char letter, double v, bool rounded, long long q, int d,
                                   double scale) {
    if (!rounded) {
      end_ = fastnum::fixed_legacy(end_ + 2, v, d);
      readable_ = false;
      return;
    }
    end_ = fastnum::fixed_q(end_ + 2, q, d);
    take(letter, static_cast<double>(q) / scale);
  }

  const char* end() const { return end_; }
  const GcodeScanner::Words& words() const { return words_; }
  // Every value one the reader takes as it is (else the estimate reads the text, and refuses
  // the line as it would in a file).
  bool readable() const { return readable_; }

 private:
  [[gnu::always_inline]] void take(char letter, double v) {
    readable_ = readable_ && std::abs(v) <= gcode_lex::kMaxValue;
    words_.set(letter, v);
  }
  char* end_;
  GcodeScanner::Words words_;
  bool readable_ = true;
};

class Writer {
 public:
  // `stream`: the layers come from it (tp gives the source, job and labels only).
  // `box`: the points' extent when the caller has it (a whole toolpath: one pass over the points
  // fewer; about 2 % of writing), else the writer finds it.
  Writer(const MachineProfile& p, const Toolpath& tp, double lift,
         const std::vector<GcodeThumbnail>& thumbs, const LayerSource* stream = nullptr,
         std::size_t stream_layers = 0, const BBox3* box = nullptr, std::size_t points = 0)
      : p_(p),
        tp_(tp),
        thumbnails_(&thumbs),
        layers_(stream ? *stream : layers_of(tp)),
        layer_count_(stream ? stream_layers : tp.layers.size()),
        streamed_(stream != nullptr),
        lift_(lift) {
    down_flow_ = p.down_flow_table();
    e_axis_ = p.marlin_family() || (p.has_bath() && p.embedded_drive == EmbeddedDrive::Syringe);
    standby_ = p.standby_temperature;
    points_ = points;
    placement(box);
  }

  // Writes into `buffer`'s memory (its text cleared), which it returns.
  std::string run(GcodeStats& stats, std::string buffer = {}) {
    out_.adopt(std::move(buffer));
    out_.clear();
    std::size_t points = points_;
    if (points == 0)
      for (const auto& l : tp_.layers)
        for (const auto& path : l.paths) points += path.points.size();
    out_.reserve(points * 40 + 8192);
    fastnum::advise_huge_pages(out_.storage());
    start_estimate();
    plan_changes();
    label_objects();
    header();
    for (std::size_t li = 0; li < tp_.layers.size(); ++li) layer(li, tp_.layers[li]);
    footer();
    estimate_text();
    finish_estimate();
    insert_lines();
    stats_.bytes = out_.size();
    stats = stats_;
    return out_.take();
  }

  // The same bytes in bounded memory: the text without the M73 lines goes to `raw` as it is
  // written (flushed every MB), then `put` receives it again with the M73 lines in place;
  // `ready` (if given) first, with the stats known by then (all but bytes).
  // `later` (if given): the thumbnails, made beside the writing when the estimate is (then put
  // into the header as the text is copied out), else before it.
  void stream(GcodeStats& stats, std::FILE* raw, const ByteWriter& put,
              const std::function<void(const GcodeStats&)>& ready = {},
              const GcodeThumbnailMaker* later = nullptr) {
    constexpr std::size_t kFlush = std::size_t{1} << 20;
    raw_ = raw;
    out_.reserve(kFlush + (1u << 16));
    start_estimate();
    if (later) {
      if (pipe_) {
        late_thumbnails_ = true;
        pipe_->run([this, later] { made_thumbnails_ = (*later)(); });
      } else {
        made_thumbnails_ = (*later)();
      }
      thumbnails_ = &made_thumbnails_;
    }
    plan_changes();
    label_objects();
    header();
    layers_([&](std::size_t li, const Layer& l) {
      layer(li, l);
      if (out_.size() >= kFlush) flush_raw();
    });
    footer();
    flush_raw();
    finish_estimate();
    if (std::fflush(raw_) != 0)
      throw IoError(std::string("cannot write a temporary file: ") + std::strerror(errno));
    if (ready) ready(stats_);
    copy_with_progress(put);
    stats = stats_;
  }

 private:
  void line(const std::string& s) {
    out_ += s;
    out_ += '\n';
  }

  // The M73 line for a mark `t` seconds into a print of `total` seconds.
  static std::string progress_line(double t, double total) {
    const int percent = total > 0 ? static_cast<int>(std::floor(100 * t / total)) : 0;
    const long left = std::lround(std::ceil(std::max(0.0, total - t) / 60));
    return "M73 P" + std::to_string(std::min(percent, 99)) + " R" + std::to_string(left) + "\n";
  }

  // Streamed: the text so far to `raw_` (the time estimate has read it first).
  void flush_raw() {
    if (out_.empty()) return;
    estimate_text();
    if (std::fwrite(out_.data(), 1, out_.size(), raw_) != out_.size())
      throw IoError(std::string("cannot write a temporary file: ") + std::strerror(errno));
    flushed_ += out_.size();
    out_.clear();
    scanned_ = 0;
  }

  // The print-time estimate (machine/print_time.hpp) of the text, read as `trellis analyze`
  // reads the file, in order as it is written: the writer's own moves handed over as their
  // words (the values the text reads back as: GcodeScanner::plain_motion while the scanner reads
  // moves plainly, else GcodeScanner::move_words), everything else (the profile's start, end
  // and tool-change code, heaters, dwells, comments) as text.
  class TimeEstimate : public EstimatePipe::Reader {
   public:
    void text(std::string_view t) override {
      if (t.empty()) return;
      settle();
      scanner_.feed(t);
    }
    // False: not taken (the caller's text is read instead). While the scanner reads moves
    // plainly, the moves go straight to the estimate (GcodeScanner::plain_motion: what the
    // scanner does with them, without its sink's other events), the scanner given their end
    // state before it reads text again.
    bool move(const GcodeScanner::Words& w, int g) override {
      if (!own_) [[unlikely]] {
        if (!scanner_.plain_state(state_)) return scanner_.move_words(w, g);
        own_ = true;
      }
      GcodeScanner::plain_motion(state_, w, sink_.time);
      return true;
    }
    double elapsed() const override { return sink_.time.elapsed(); }
    void finish() {
      settle();
      scanner_.finish();
    }
    PrintTimeSink& sink() { return sink_; }

   private:
    void settle() {
      if (own_) scanner_.resume(state_);
      own_ = false;
    }
    GcodeScanner::MoveState state_;
    bool own_ = false;  // state_ is the scanner's (it has not been given back yet)
    PrintTimeSink sink_;
    Diagnostics ignored_;  // our own text: nothing to report
    GcodeScanner scanner_{sink_, {}, ignored_, "G-code being written"};
  };

  // With two threads the estimate reads beside the writing (estimate_pipe.hpp).
  void start_estimate() {
    if (EstimatePipe::worthwhile()) pipe_ = std::make_unique<EstimatePipe>(estimate_);
  }

  // The text written since the estimate last read, to it.
  void estimate_text() {
    if (scanned_ == out_.size()) return;  // (after a move the estimate took: nothing new)
    const std::string_view t = out_.view().substr(scanned_);
    pipe_ ? pipe_->text(t) : estimate_.text(t);
    scanned_ = out_.size();
  }

  // The time the estimate has reached at this point of the text (a progress mark, or an object
  // mark); beside the writing, a mark whose time finish_estimate fills in.
  double estimate_now(bool object_mark) {
    estimate_text();
    if (!pipe_) return estimate_.elapsed();
    pipe_->mark();
    mark_is_object_.push_back(object_mark);
    return 0;
  }

  // Appends the move line `m` (a G0 or G1 line) and hands its words to the estimate, or,
  // when a value is one the reader would refuse, leaves its text for the estimate to read.
  void put_move(const MoveLine& m, int g) {
    estimate_text();
    const std::size_t at = out_.size();
    out_.commit(m.end());
    if (!m.readable()) return;
    if (pipe_) {
      // (its text read instead if the move is not taken)
      pipe_->move(m.words(), g, out_.view().substr(at));
      scanned_ = out_.size();
    } else if (estimate_.move(m.words(), g)) {
      scanned_ = out_.size();
    }
  }

  // The estimate's totals, and each part's time.
  void finish_estimate() {
    estimate_text();
    if (pipe_) {
      const std::vector<double> times = pipe_->finish();
      pipe_.reset();
      std::size_t progress = 0, object = 0;
      for (std::size_t k = 0; k < times.size(); ++k)
        (mark_is_object_[k] ? object_marks_[object++].time : progress_marks_[progress++].second) =
            times[k];
    }
    estimate_.finish();
    PrintTimeSink& sink = estimate_.sink();
    stats_.print_time_s = sink.time.seconds();
    stats_.heating_s = sink.time.heating_s();
    // Each part's time: from each of its starts to the next mark (its end).
    for (std::size_t m = 0; m + 1 < object_marks_.size(); ++m) {
      const int part = object_marks_[m].part;
      if (part <= 0) continue;
      if (stats_.part_time_s.size() < static_cast<std::size_t>(part))
        stats_.part_time_s.resize(static_cast<std::size_t>(part));
      stats_.part_time_s[static_cast<std::size_t>(part - 1)] +=
          object_marks_[m + 1].time - object_marks_[m].time;
    }
  }

  // The lines that go in once the estimate is known, in the order of their offsets: M73
  // progress at every layer (if the firmware takes it) and the estimated time in the footer.
  std::vector<std::pair<std::size_t, std::string>> late_lines() const {
    std::vector<std::pair<std::size_t, std::string>> lines;
    if (late_thumbnails_ && !thumbnails_->empty()) {
      std::string blocks;
      for (const auto& t : *thumbnails_) blocks += thumbnail_block(t);
      lines.push_back({thumbnails_at_, std::move(blocks)});
    }
    if (p_.marlin_family())
      for (const auto& [at, t] : progress_marks_)
        lines.push_back({at, progress_line(t, stats_.print_time_s)});
    lines.push_back({estimate_at_, "; estimated printing time (normal mode) = " +
                                       duration_text(stats_.print_time_s) + "\n"});
    return lines;
  }

  // The raw text read back with the late lines inserted at their offsets (streamed writing).
  void copy_with_progress(const ByteWriter& put) {
    std::rewind(raw_);
    const auto lines = late_lines();
    std::string chunk(std::size_t{1} << 20, '\0');
    std::size_t at = 0, mark = 0;
    while (at < flushed_ || mark < lines.size()) {
      const std::size_t until = mark < lines.size() ? lines[mark].first : flushed_;
      if (at == until) {
        put(lines[mark].second);
        stats_.bytes += lines[mark].second.size();
        ++mark;
        continue;
      }
      const std::size_t n = std::fread(chunk.data(), 1, std::min(chunk.size(), until - at), raw_);
      if (n == 0)
        throw IoError(std::string("cannot read a temporary file: ") + std::strerror(errno));
      put(std::string_view(chunk.data(), n));
      at += n;
    }
    stats_.bytes += flushed_;
  }

  // The late lines inserted into the text in memory.
  void insert_lines() {
    const auto lines = late_lines();
    std::size_t added = 0;
    for (const auto& l : lines) added += l.second.size();
    // In place, from the back: each stretch moves up by the lines inserted before it (no second
    // buffer of the whole file).
    std::size_t end = out_.size();
    out_.resize(end + added);
    char* d = out_.data();
    std::size_t shift = added;
    for (std::size_t k = lines.size(); k-- > 0;) {
      const std::size_t at = lines[k].first;
      std::memmove(d + at + shift, d + at, end - at);
      shift -= lines[k].second.size();
      std::memcpy(d + at + shift, lines[k].second.data(), lines[k].second.size());
      end = at;
    }
  }

  void placement(const BBox3* known) {
    BBox3 box;
    if (known && !streamed_) {
      box = *known;
    } else {
      layers_([&](std::size_t, const Layer& l) {
        for (const auto& path : l.paths)
          for (const auto& q : path.points) box.add(q);
        if (streamed_) plan_tools_streamed(l);  // the same pass
      });
    }
    const Vec2 shift = placement_offset(box, p_);
    dx_ = shift.x;
    dy_ = shift.y;
    if (p_.has_bath())
      safe_z_ = std::max(p_.bath_surface, box.empty() ? 0.0 : box.max.z) + p_.travel_clearance;
  }

  // What the head's XY adds to a design XY for the tool in use (embedded: one nozzle per tool).
  // Nozzle t sits at head + offset(t) (embedded.tool_offsets), so the head goes to design -
  // offset(t); firmware that applies the offsets itself (embedded.firmware_offsets) is given the
  // design XY.
  Vec2 offset() const {
    if (!p_.has_bath() || p_.firmware_offsets) return {};
    return {-tool_offset_.x, -tool_offset_.y};
  }

  // Replaces {tool} and expands the other placeholders.
  std::string tool_template(const std::string& text, int tool, const char* which) const {
    std::string t = text;
    for (auto pos = t.find("{tool}"); pos != std::string::npos; pos = t.find("{tool}"))
      t.replace(pos, 6, std::to_string(tool));
    return expand_template(t, p_, which);
  }

  // Embedded: lift out of the bath, park the idle nozzle, select the next one.
  void change_tool(int tool) {
    if (tool == tool_) return;
    if (known_ && pos_.z < safe_z_) move_z(safe_z_);
    if (tool_ >= 0 && !p_.raise_idle.empty())
      line(tool_template(p_.raise_idle, tool_, "embedded.raise_idle"));
    if (!p_.tool_change.empty()) line(tool_template(p_.tool_change, tool, "embedded.tool_change"));
    tool_offset_ = p_.tool_offset(tool);
    tool_profile_ = p_;
    tool_profile_.pressure = p_.tool_pressure(tool);
    if (tool_ >= 0) ++stats_.tool_changes;  // the first selection is not a change
    tool_ = tool;
  }

  void header() {
    line(std::string("; generated by Trellis ") + TRELLIS_VERSION + " (" + to_string(p_.flavor) +
         ")");
    if (late_thumbnails_)
      thumbnails_at_ = flushed_ + out_.size();  // made beside the writing: put in late_lines
    else
      for (const auto& t : *thumbnails_) out_ += thumbnail_block(t);
    if (!tp_.source.empty()) line("; source: " + tp_.source);
    line(";LAYER_COUNT:" + std::to_string(layer_count_));
    // The job that made the file, for `trellis rerun`.
    for (std::size_t a = 0; a < tp_.job.size();) {
      const std::size_t b = std::min(tp_.job.find('\n', a), tp_.job.size());
      line("; job: " + tp_.job.substr(a, b - a));
      a = b + 1;
    }
    for (const auto& d : machine_settings()) {
      std::string v = setting_text(p_, d);
      for (auto& c : v)
        if (c == '\n') c = '|';
      line(std::string("; setting ") + d.key + " = " + v);
    }
    line("; placement offset = " + std::to_string(dx_) + ", " + std::to_string(dy_));
    // Readers undo the look-ahead to show the mixture deposited (machine/mixing_lag.hpp).
    if (stats_.lookahead > 0 && stats_.gradient_changes > 0) {
      std::string l = "; mixture lookahead = ";
      append_fixed(l, stats_.lookahead, 3);
      line(l + " mm (each mixture change is issued this far, in printed path, before its region)");
    }
    if (lift_ > 0) line("; placement lift = " + std::to_string(lift_));
    line("G21 ; millimetres");
    line("G90 ; absolute positions");
    if (e_axis_) line(p_.relative_e ? "M83 ; relative E" : "M82 ; absolute E");
    auto temp = [&](const char* cmd, double t) {
      out_ += cmd;
      append_fixed(out_, t, 1);
      out_ += '\n';
    };
    if (p_.bed_temperature > 0) {
      temp("M140 S", p_.bed_temperature);
      temp("M190 S", p_.bed_temperature);
    }
    if (p_.nozzle_temperature > 0 && !tools_used_.empty()) {
      // A tool changer: every tool the print uses starts heating now (the first to print
      // temperature, the others to standby if set), the first is waited for.
      for (std::size_t i = 0; i < tools_used_.size(); ++i)
        line(heat(tools_used_[i], i == 0 || standby_ <= 0 ? p_.nozzle_temperature : standby_,
                  false));
      line(heat(tools_used_[0], p_.nozzle_temperature, true));
    } else if (const double t = first_nozzle_temperature(); t > 0) {
      line(heat(-1, t, false));
      line(heat(-1, t, true));
    }
    const std::string start = expand_template(p_.start_gcode, p_, "gcode.start");
    if (!start.empty()) line(start);
    if (p_.fan_percent > 0) {
      line("M106 S" + std::to_string(static_cast<int>(std::lround(p_.fan_percent * 2.55))));
      fan_now_ = p_.fan_percent;
    }
    nozzle_now_ = tools_used_.empty()         ? first_nozzle_temperature()
                  : p_.nozzle_temperature > 0 ? p_.nozzle_temperature
                                              : -1;
    if (e_axis_) line("G92 E0");
    out_ += objects_.definitions;
    prime_line();
  }

  // gcode.prime_line: a line along the bed's front edge, 5 mm in (a round bed: the chord half-way
  // between its centre and its front), at the profile's layer height, before the first layer:
  // the nozzle primed (Marlin: Eq. 4's filament for a bead that long; pneumatic: the valve open
  // along it). Marked ";TYPE:Prime line": readers count it apart from the print's paths.
  void prime_line() {
    if (p_.prime_line <= 0 || p_.has_bath()) return;
    const double x0 = p_.origin == BedOrigin::Center ? -p_.bed_x / 2 : 0;
    const double y0 = p_.origin == BedOrigin::Center ? -p_.bed_y / 2 : 0;
    double xa = x0 + 5, y = y0 + 5;
    if (p_.bed_shape == BedShape::Circle) {
      const double r = p_.bed_x / 2, cx = x0 + p_.bed_x / 2, cy = y0 + p_.bed_y / 2;
      xa = cx - p_.prime_line / 2;
      y = cy - r / 2;
    }
    const double xb = xa + p_.prime_line, h = p_.layer_height;
    auto move = [&](const char* g, std::initializer_list<std::pair<char, double>> words, double f) {
      out_ += g;
      for (const auto& [letter, v] : words) {
        out_ += ' ';
        out_ += letter;
        append_fixed(out_, v, letter == 'E' ? 5 : 3);
      }
      out_ += " F";
      feed(f);
      out_ += '\n';
    };
    line(std::string(";TYPE:") + std::string(kPrimeLineType));
    move("G0", {{'X', xa}, {'Y', y}}, p_.travel_speed);
    move("G0", {{'Z', h}}, p_.z_speed);
    if (e_axis_) {
      const double e = extrusion_for(p_.prime_line, h, p_);
      e_ += e;
      stats_.prime_filament = e;
      move("G1", {{'X', xb}, {'E', p_.relative_e ? e : e_}}, p_.print_speed);
    } else {
      if (!p_.pressure_command.empty())
        line(expand_template(p_.pressure_command, p_, "pneumatic.pressure_command"));
      line(p_.valve_on);
      dwell(p_.pre_flow_dwell);
      move("G1", {{'X', xb}}, p_.print_speed);
      dwell(p_.post_flow_dwell);
      line(p_.valve_off);
    }
    const double up = h + std::max(p_.z_hop, 1.0);
    move("G0", {{'Z', up}}, p_.z_speed);
    // The travel to the first path is written as from an unknown place (up, across, down), as
    // without a prime line, and not counted as a travel between paths (readers do not count it).
    stats_.prime_length = p_.prime_line;
  }

  void footer() {
    if (p_.marlin_family() && p_.retract_length > 0 && printed_) retract();
    for (int t : tools_used_) line(heat(t, 0, false));  // idle tools too
    if (known_ && p_.has_bath()) {
      move_z(safe_z_);
    } else if (known_) {
      out_ += "G0 Z";
      append_fixed(out_, pos_.z + std::max(p_.z_hop, 1.0), 3);
      out_ += " F";
      feed(p_.z_speed);
      out_ += '\n';
    }
    if (p_.marlin_family()) line("M73 P100 R0");
    const std::string end = expand_template(p_.end_gcode, p_, "gcode.end");
    if (!end.empty()) line(end);
    // PrusaSlicer's closing statistics, read by printer front ends.
    if (e_axis_) {
      out_ += "; filament used [mm] = ";  // all the machine uses: the prime line's too
      append_fixed(out_, stats_.filament + stats_.prime_filament, 2);
      out_ += '\n';
    }
    estimate_at_ = flushed_ + out_.size();  // the estimated time goes here (late_lines)
    line("; total layers count = " + std::to_string(layer_count_));
    out_ += "; end: paths ";
    out_ += std::to_string(stats_.paths);
    out_ += ", filament ";
    append_fixed(out_, stats_.filament, 3);
    out_ += " mm\n";
  }

  void feed(double mm_per_s) { out_.commit(put_feed(out_.room(fastnum::kMaxChars), mm_per_s)); }

  void layer(std::size_t li, const Layer& l) {
    progress_marks_.push_back({flushed_ + out_.size(), estimate_now(false)});
    out_ += ";LAYER:";
    out_ += std::to_string(li);
    out_ += "\n;Z:";
    append_fixed(out_, l.z, 3);
    out_ += '\n';
    if (e_axis_ && !p_.relative_e && e_ != 0 && !retracted_) {
      line("G92 E0");
      e_ = 0;
    }
    for (std::size_t pi = 0; pi < l.paths.size(); ++pi) {
      if (!tp_.part_labels.empty()) enter_object(l.paths[pi].part);
      chain(l.paths, pi);
      print_path(l.paths[pi]);
    }
    enter_object(0);
  }

  // Build plates: the parts' names for the firmware (gcode_objects.hpp), their times from 0.
  void label_objects() {
    objects_ = gcode_objects(tp_.part_labels, layers_, p_, {dx_, dy_}, stats_.warnings);
    stats_.part_time_s.assign(tp_.part_labels.size(), 0.0);
  }

  // Build plates: the end of the part being printed and the start of `part` (0: none), when
  // it changes (gcode_objects.hpp); the time in between goes to the part's estimate.
  void enter_object(int part) {
    if (part == object_) return;
    if (object_ > 0 && objects_.style != ObjectStyle::None) out_ += objects_.end(object_);
    object_marks_.push_back({flushed_ + out_.size(), part, estimate_now(true)});
    if (part > 0 && objects_.style != ObjectStyle::None) out_ += objects_.start(part);
    object_ = part;
  }

  // A bead split into joined paths (process fields) is one bead: priming at its start only,
  // post-flow at its end only, the short-path factor by its whole segment count.
  void chain(const std::vector<Path>& paths, std::size_t pi) {
    next_joined_ = pi + 1 < paths.size() && paths[pi + 1].joined;
    if (paths[pi].joined && pi > 0) return;  // chain_segments_ counted at the chain's start
    // Each cut added one point: the bead's own segments are the pieces' less the cuts.
    chain_segments_ = paths[pi].segments();
    for (std::size_t k = pi + 1; k < paths.size() && paths[k].joined; ++k)
      chain_segments_ += paths[k].segments() - 1;
  }

  // The temperature the print starts at: the first path's own (a process field) or the profile's.
  double first_nozzle_temperature() const {
    if (streamed_) return first_temperature_ > 0 ? first_temperature_ : p_.nozzle_temperature;
    for (const auto& l : tp_.layers)
      for (const auto& p : l.paths)
        if (p.points.size() >= 2) return p.temperature > 0 ? p.temperature : p_.nozzle_temperature;
    return p_.nozzle_temperature;
  }

  // A path's own nozzle temperature (then the temperature.settle dwell before it extrudes) and
  // fan, where they change; its flow multiplies E. A path without its own, after one with, goes
  // back to the profile's.
  void process_commands(const Path& path) {
    path_flow_ = path.flow > 0 ? path.flow : 1.0;
    const double t = path.temperature > 0 ? path.temperature
                     : own_temperature_   ? p_.nozzle_temperature
                                          : 0.0;
    if (t > 0 && t != nozzle_now_) {
      line(heat(last_tool_ >= 0 ? last_tool_ : -1, t, false));
      nozzle_now_ = t;
      ++stats_.temperature_changes;
      dwell(p_.settle_time);
      stats_.settle_time_s += p_.settle_time;
    }
    own_temperature_ = own_temperature_ || path.temperature > 0;
    const double fan = path.fan >= 0 ? path.fan : own_fan_ ? p_.fan_percent : -1.0;
    if (fan >= 0 && fan != fan_now_) {
      const long s = std::lround(std::clamp(fan, 0.0, 100.0) * 2.55);
      line(s == 0 ? std::string("M107") : "M106 S" + std::to_string(s));
      fan_now_ = fan;
      ++stats_.fan_changes;
    }
    own_fan_ = own_fan_ || path.fan >= 0;
  }

  // "G1 E<e> F<retraction speed>": filament only (`de` mm, relative or added to E).
  void filament_move(double de) {
    e_ += de;
    MoveLine m(out_.room(MoveLine::kRoom), true);
    m.word<5>('E', p_.relative_e ? de : e_);
    m.feed(feeds_.get(p_.retract_speed));
    m.close();
    put_move(m, 1);
  }

  void retract() {
    filament_move(-p_.retract_length);
    retracted_ = true;
    ++stats_.retractions;
  }

  void unretract() {
    filament_move(p_.retract_length);
    retracted_ = false;
  }

  void move_z(double z) {
    MoveLine m(out_.room(MoveLine::kRoom), false);
    m.word<3>('Z', z);
    m.feed(feeds_.get(p_.z_speed));
    m.close();
    put_move(m, 0);
    pos_.z = z;
  }

  // Embedded: straight up out of the bath, across above everything, straight down.
  void travel_embedded(Vec3 q) {
    if (known_ && distance_xy(pos_, q) < 1e-9 && std::abs(pos_.z - q.z) < 1e-9) return;
    const double d = known_ ? distance_xy(pos_, q) : 0;
    // A short hop inside the bath (e.g. to the next non-planar layer) stays in it.
    if (known_ && printed_ && pos_.z < safe_z_ - 1e-9 && distance(pos_, q) <= p_.bath_travel)
      return move_xy(q, d, true);
    if (!known_ || pos_.z < safe_z_ - 1e-9) move_z(safe_z_);
    move_xy(q, d);
    known_ = true;
    move_z(q.z);
  }

  // The horizontal part of a travel (the tool's XY offset added), counted in the stats; with
  // `with_z` the move goes straight to q's height as well.
  // `more`: a further leg of a travel through `via` points, already counted as one move.
  void move_xy(Vec3 q, double d, bool with_z = false, bool more = false) {
    const Vec2 o = offset();
    MoveLine m(out_.room(MoveLine::kRoom), false);
    m.word<3>('X', q.x + dx_ + o.x);
    m.word<3>('Y', q.y + dy_ + o.y);
    if (with_z) {
      m.word<3>('Z', q.z);
      pos_.z = q.z;
    }
    m.feed(feeds_.get(p_.travel_speed));
    m.close();
    put_move(m, 0);
    if (known_) {
      if (!more) ++stats_.travel_moves;
      stats_.travel_length += d;
    }
    pos_.x = q.x;
    pos_.y = q.y;
  }

  // To q, through `via` (the linking stage's route, slice/link.hpp). A travel kept inside the
  // part retracts and lifts only beyond retraction.inside_max; any other from min_travel on.
  void travel_to(Vec3 q, const std::vector<Vec3>& via = {}, bool inside = false) {
    // A path that starts where the last one ended, whose last move was too short to write: no
    // travel to the point it was to reach (the next move prints from where the nozzle is).
    if (std::exchange(silent_, false) && via.empty() && distance(silent_to_, q) < 1e-9) return;
    if (p_.has_bath()) return travel_embedded(q);
    double d = 0;
    if (known_) {
      Vec3 at = pos_;
      for (const Vec3& v : via) d += distance_xy(at, v), at = v;
      d += distance_xy(at, q);
    }
    if (known_ && d < 1e-9 && std::abs(pos_.z - q.z) < 1e-9) return;
    const bool far =
        known_ && d >= p_.min_travel && (!inside || (p_.inside_max > 0 && d > p_.inside_max));
    if (p_.marlin_family() && far && printed_ && p_.retract_length > 0) retract();
    const double hop = far ? p_.z_hop : 0;
    const double safe_z = std::max(known_ ? std::max(pos_.z, q.z) + hop : q.z + std::max(hop, 1.0),
                                   std::exchange(rise_to_, 0.0));
    if (!known_ || safe_z > pos_.z + 1e-9) move_z(safe_z);
    bool more = false;
    if (known_)
      for (const Vec3& v : via) move_xy(v, distance_xy(pos_, v), false, std::exchange(more, true));
    move_xy(q, known_ ? distance_xy(pos_, q) : 0, false, more);
    if (std::abs(pos_.z - q.z) > 1e-9) move_z(q.z);
    known_ = true;
    if (retracted_) unretract();
  }

  void dwell(double seconds) {
    if (seconds <= 0) return;
    out_ += "G4 P";
    out_ += std::to_string(std::lround(seconds * 1000));
    out_ += '\n';
  }

  void extra_filament(double mm) {
    if (mm <= 0) return;
    filament_move(mm);
    stats_.filament += mm;
  }

  // The command(s) that make a mixture, by gradient.mode: a mixing hotend (Marlin M165; letters
  // A B C D H I are its mix factors for up to six inputs), the nearest of N tools (tool 0 holds
  // material A), or a nozzle temperature linear in the mixture (foaming filament), with the
  // flow compensation of the FGM paper's Eq. 3 (PLA) or Eq. 4 (TPU) as M221.
  std::string gradient_command(const std::vector<double>& mix) const {
    // check_for_machine has refused mixtures the machine cannot make.
    std::string c;
    const double a = std::clamp(mix[0], 0.0, 1.0);
    if (p_.gradient_mode == GradientMode::Tools) {
      c = select_tool(tool_of(mix));
    } else if (p_.gradient_mode == GradientMode::Temperature) {
      const double t = a * p_.temperature_a + (1 - a) * p_.temperature_b;
      c = heat(-1, t, false);
      if (p_.flow_model != FlowModel::None) {
        const double f =
            p_.flow_model == FlowModel::Pla
                ? 100 * (8.35479e-6 * t * t * t - 5.37075e-3 * t * t + 1.13374 * t - 77.814)
                : 100 * (3.09637e-4 * t * t - 1.38401e-1 * t + 15.9560);
        c += "\nM221 T0 S";
        append_fixed(c, f, 1);
      }
    } else {
      c = mixing_command(mix);
    }
    return c;
  }

  // Heaters and tools in the firmware's own words (machine.flavor): Marlin M104/M109 [T<n>];
  // RepRapFirmware M568 P<n> S<t> A2 (tool heater active at t; A0 off) and M116 P<n> to wait;
  // Klipper SET_HEATER_TEMPERATURE HEATER=extruder[<n>] and TEMPERATURE_WAIT (within 1 °C
  // below the target). `tool` -1: the one tool of a single-tool machine.
  std::string heat(int tool, double t, bool wait) const {
    std::string c;
    if (p_.flavor == Flavor::RepRap) {
      const std::string n = std::to_string(std::max(tool, 0));
      if (t <= 0) return "M568 P" + n + " A0";
      c = "M568 P" + n + " S";
      append_fixed(c, t, 1);
      c += " A2";
      if (wait) c += "\nM116 P" + n;
    } else if (p_.flavor == Flavor::Klipper) {
      const std::string h = tool <= 0 ? "extruder" : "extruder" + std::to_string(tool);
      c = "SET_HEATER_TEMPERATURE HEATER=" + h + " TARGET=";
      append_fixed(c, t, 1);
      if (wait && t > 0) {
        c += "\nTEMPERATURE_WAIT SENSOR=" + h + " MINIMUM=";
        append_fixed(c, t - 1, 1);
      }
    } else {
      c = wait ? "M109" : "M104";
      if (tool >= 0) c += " T" + std::to_string(tool);
      c += " S";
      append_fixed(c, t, 1);
    }
    return c;
  }
  std::string select_tool(int tool) const {
    if (p_.flavor == Flavor::Klipper)
      return std::string("ACTIVATE_EXTRUDER EXTRUDER=extruder") +
             (tool > 0 ? std::to_string(tool) : std::string());
    return "T" + std::to_string(tool);
  }

  // Tool changers: the tool that prints a mixture (tool 0 = material A … the last = B).
  int tool_of(const std::vector<double>& mix) const {
    const int n = std::max(1, p_.gradient_tool_count());
    const double a = std::clamp(mix[0], 0.0, 1.0);
    return static_cast<int>(std::lround((1 - a) * (n - 1)));
  }

  // A tool change: the tool left goes to standby (if set), the new one is selected and waited
  // for at its printing temperature (it was heated in the header, so the wait is short).
  std::string tool_change_command(const std::string& select, int tool) {
    if (std::find(tools_used_.begin(), tools_used_.end(), tool) == tools_used_.end())
      tools_used_.push_back(tool);
    std::string c;
    if (last_tool_ >= 0 && standby_ > 0) c += heat(last_tool_, standby_, false) + '\n';
    c += select;
    if (p_.nozzle_temperature > 0) c += '\n' + heat(tool, p_.nozzle_temperature, true);
    nozzle_now_ = p_.nozzle_temperature > 0 ? p_.nozzle_temperature : -1;
    last_tool_ = tool;
    return c;
  }

  // A mixing hotend's command in the profile's dialect (gradient.dialect): Marlin M165 (mix
  // factors A B C D H I for up to six inputs), Marlin M163/M164 (each input's factor, then the
  // mix stored into virtual tool 0, the active one), RepRapFirmware M567 (tool 0's mix ratio
  // E<a>:<b>…) or the profile's template (gradient.template: {a} {b} {c} … each input's share,
  // other {setting} placeholders as in gcode.start), e.g. a Klipper fork's mixing macro.
  std::string mixing_command(const std::vector<double>& mix) const {
    static constexpr char kLetters[] = {'A', 'B', 'C', 'D', 'H', 'I'};
    std::string c;
    const MixingDialect d = p_.gradient_dialect;
    if (d == MixingDialect::M163) {
      for (std::size_t i = 0; i < mix.size(); ++i) {
        c += "M163 S" + std::to_string(i) + " P";
        append_fixed(c, mix[i], 4);
        c += '\n';
      }
      return c + "M164 S0";
    }
    if (d == MixingDialect::M567) {
      c = "M567 P0 E";
      for (std::size_t i = 0; i < mix.size(); ++i) {
        if (i) c += ':';
        append_fixed(c, mix[i], 4);
      }
      return c;
    }
    if (d == MixingDialect::Template) {
      if (p_.gradient_template.empty())
        throw SettingError(
            "gradient.dialect = template needs gradient.template (e.g. "
            "\"M567 P0 E{a}:{b}\")",
            {"", 0, "gradient.template"});
      std::string t = p_.gradient_template;
      for (std::size_t i = 0; i < mix.size() && i < 6; ++i) {
        const std::string key = std::string("{") + static_cast<char>('a' + i) + "}";
        std::string v;
        append_fixed(v, mix[i], 4);
        for (auto pos = t.find(key); pos != std::string::npos; pos = t.find(key, pos + v.size()))
          t.replace(pos, key.size(), v);
      }
      return expand_template(t, p_, "gradient.template");
    }
    c = "M165";
    for (std::size_t i = 0; i < mix.size() && i < 6; ++i) {
      c += ' ';
      c += kLetters[i];
      append_fixed(c, mix[i], 4);
    }
    return c;
  }

  // Where each mixture change is issued: before the path that needs it, or, with a look-ahead
  // L, at the point L mm of printed path earlier (a segment split there), so the dead volume is
  // purged by the time the region starts. Computed once over the whole print.
  struct Change {
    std::size_t path, segment;  // before point `segment` of `path` (1-based), at fraction t
    double t;
    std::string command;
    double target =
        -1;  // streamed: printed length to locate in `path` when it is printed (-1: none)
  };
  // Streamed layers, one at a time: the tools used, whether a prime tower is there, and what the
  // look-ahead needs (each printed path's printed length before it; each path's mixture
  // command), not the paths.
  void plan_tools_streamed(const Layer& l) {
    layer_first_.push_back(streamed_paths_);
    select_tools_ = p_.marlin_family() && p_.tool_count > 1;
    for (const auto& p : l.paths) {
      if (p.points.size() < 2) continue;
      if (!first_seen_) first_seen_ = true, first_temperature_ = p.temperature;
      tower_ = tower_ || p.role == PathRole::Purge;
      // The printed lengths serve the look-ahead only: none with a tower or a tool changer (each
      // change right before its path), so a print split into millions of pieces keeps nothing
      // per path.
      const bool ahead = streamed_lookahead() > 0;
      if (!ahead) starts_ = {};
      if (select_tools_ && p.mixture.empty() &&
          std::find(tools_used_.begin(), tools_used_.end(), p.tool) == tools_used_.end())
        tools_used_.push_back(p.tool);
      const std::size_t k = streamed_paths_++;
      if (ahead) {
        if (starts_.empty()) starts_.push_back(0);
        starts_.push_back(starts_.back() + p.length());
      }
      if (p.mixture.empty()) continue;
      std::string c = gradient_command(p.mixture);  // kept only when it changes
      if (wanted_.empty() || wanted_.back().command != c)
        wanted_.push_back({k, std::move(c), tool_of(p.mixture)});
    }
  }

  // The change of path k (mixture command c, tool `tool`) issued `lookahead` mm of printed
  // length earlier; `start`: printed length before each path. Its segment is located now when
  // `path_of` gives the paths, else when that path is printed (locate_changes).
  void plan_change(std::size_t k, const std::string& c, int tool, const std::vector<double>& start,
                   double lookahead, bool tools, const std::vector<const Path*>* path_of) {
    ++stats_.gradient_changes;
    // Locate printed length start[k] - L.
    const double target = lookahead > 0 ? std::max(0.0, start[k] - lookahead) : 0.0;
    std::size_t j = k;
    if (lookahead > 0)
      j = static_cast<std::size_t>(std::upper_bound(start.begin(), start.begin() + k + 1, target) -
                                   start.begin()) -
          1;
    Change ch{j, 1, 0, tools ? tool_change_command(c, tool) : c};
    if (j < k) {
      ch.target = target;
      if (path_of) locate(ch, *(*path_of)[j], start[j]);
    }
    changes_.push_back(std::move(ch));
  }

  // The segment and fraction of `path` (printed length `at` before it) where ch.target falls.
  static void locate(Change& ch, const Path& path, double at) {
    const auto& pts = path.points;
    for (std::size_t i = 1; i < pts.size(); ++i) {
      const double len = distance(pts[i - 1], pts[i]);
      if (at + len >= ch.target) {
        ch.segment = i;
        ch.t = len > 0 ? (ch.target - at) / len : 0;
        break;
      }
      at += len;
    }
    ch.target = -1;
  }

  // Streamed: how far ahead a change is issued, in printed length (0 with a prime tower, which
  // flushes after the change, or a tool changer, which swaps tools between paths).
  double streamed_lookahead() const {
    return tower_ || p_.gradient_mode == GradientMode::Tools ? 0.0 : p_.lookahead;
  }

  // Streamed: the changes falling inside the path about to be printed, located on it.
  void locate_changes(const Path& path) {
    for (std::size_t c = next_change_; c < changes_.size() && changes_[c].path == path_index_; ++c)
      if (changes_[c].target >= 0) locate(changes_[c], path, starts_[path_index_]);
  }

  void plan_changes() {
    // A prime tower flushes the dead volume after the change (FGM paper A.1: look-ahead for
    // Strategy 2 *or* a purge tower for Strategy 1), and a tool changer swaps tools between
    // paths: both issue each change right before its path.
    const bool tools = p_.gradient_mode == GradientMode::Tools;
    if (streamed_) {
      const double lookahead = streamed_lookahead();
      stats_.lookahead = lookahead;
      // (Consecutive wanted commands differ: plan_tools_streamed keeps only changes.)
      std::vector<std::size_t> at;
      for (const auto& w : wanted_) {
        plan_change(w.path, w.command, w.tool, starts_, lookahead, tools, nullptr);
        at.push_back(w.path);
      }
      wanted_ = {};
      warn_lookahead_start(starts_, at, layer_first_, lookahead);
      return;
    }
    std::vector<const Path*> paths;
    bool tower = false;
    for (const auto& l : tp_.layers)
      for (const auto& p : l.paths)
        if (p.points.size() >= 2) {
          paths.push_back(&p);
          tower = tower || p.role == PathRole::Purge;
        }
    // Paths carrying a tool of their own on a multi-tool Marlin machine: the tools they use,
    // in order, heated in the header (tool_change_command records them again when printing).
    select_tools_ = p_.marlin_family() && p_.tool_count > 1;
    if (select_tools_) {
      for (const Path* p : paths)
        if (p->mixture.empty() &&
            std::find(tools_used_.begin(), tools_used_.end(), p->tool) == tools_used_.end())
          tools_used_.push_back(p->tool);
    }
    const double lookahead = tower || tools ? 0.0 : p_.lookahead;
    stats_.lookahead = lookahead;
    // Printed length before each path (needed only when some path carries a mixture).
    const bool mixtures =
        std::any_of(paths.begin(), paths.end(), [](const Path* p) { return !p->mixture.empty(); });
    std::vector<double> start(mixtures ? paths.size() + 1 : 0, 0);
    if (mixtures)
      for (std::size_t k = 0; k < paths.size(); ++k) start[k + 1] = start[k] + paths[k]->length();
    std::string last;
    std::vector<std::size_t> at;  // the paths a change is planned for
    for (std::size_t k = 0; k < paths.size(); ++k) {
      if (paths[k]->mixture.empty()) continue;
      const std::string c = gradient_command(paths[k]->mixture);
      if (c == last) continue;
      last = c;
      plan_change(k, c, tool_of(paths[k]->mixture), start, lookahead, tools, &paths);
      at.push_back(k);
    }
    if (lookahead > 0 && !at.empty()) {
      std::vector<std::size_t> layer_first;  // first printed path of each layer
      std::size_t n = 0;
      for (const auto& l : tp_.layers) {
        layer_first.push_back(n);
        for (const auto& p : l.paths) n += p.points.size() >= 2;
      }
      warn_lookahead_start(start, at, layer_first, lookahead);
    }
  }

  // Every change planned within the first `lookahead` mm of printed path is issued at the start
  // (nothing is printed before it to run ahead on): the mixture the last of them sets is deposited
  // from the start to the first change planned beyond, and the gradient planned there is lost.
  // Warned when that takes a whole layer or more (a part shorter than a few look-aheads; on a
  // larger part it is a piece of the first layer, which the report's gradient error counts);
  // `start`: printed length before each path, `at`: the paths changes are planned for,
  // `layer_first`: each layer's first path.
  void warn_lookahead_start(const std::vector<double>& start, const std::vector<std::size_t>& at,
                            const std::vector<std::size_t>& layer_first, double lookahead) {
    if (!(lookahead > 0) || at.size() < 2 || start.empty()) return;
    std::size_t lost = 0;  // changes after the first issued at the start
    while (lost + 1 < at.size() && start[at[lost + 1]] <= lookahead) ++lost;
    if (lost == 0) return;
    const double total = start.back();
    const double one = lost + 1 < at.size() ? start[at[lost + 1]] : total;
    const std::size_t next = lost + 1 < at.size() ? at[lost + 1] : start.size() - 1;
    // The layers it covers: whole ones, and part of the one it ends in.
    const auto last = static_cast<std::size_t>(
        std::upper_bound(layer_first.begin(), layer_first.end(), next == 0 ? 0 : next - 1) -
        layer_first.begin());
    const bool whole = next == start.size() - 1 ||
                       std::binary_search(layer_first.begin(), layer_first.end(), next);
    if (last <= 1 && !whole) return;  // part of the first layer
    const std::string layers = whole ? fmt::format("layers 1 to {} of {}", last, layer_first.size())
                                     : fmt::format("layers 1 to {} of {} and part of layer {}",
                                                   last - 1, layer_first.size(), last);
    stats_.warnings.emplace_back(
        "lookahead_exceeds_start",
        fmt::format("the mixing look-ahead (gradient.lookahead = {:.0f} mm) swallows the start of "
                    "this graded print ({:.0f} mm of path in all): the {} mixture changes "
                    "planned in its first {:.0f} mm are all issued before it starts, so the first "
                    "{:.0f} mm of "
                    "path ({}) are deposited in one mixture and their gradient "
                    "is lost; a part shorter than a few look-aheads cannot carry its gradient in "
                    "its first layers: print it larger or beside other parts, or lower "
                    "gradient.lookahead if the mixing chamber's dead volume allows",
                    lookahead, total, lost + 1, lookahead, one, layers));
  }

  // Emits the changes due before point `segment` of the current path at fraction <= t.
  void emit_changes(std::size_t segment, double t) {
    while (next_change_ < changes_.size() && changes_[next_change_].path == path_index_ &&
           (changes_[next_change_].segment < segment ||
            (changes_[next_change_].segment == segment && changes_[next_change_].t <= t))) {
      line(changes_[next_change_].command);
      ++next_change_;
    }
  }

  void print_path(const Path& input) {
    if (input.points.size() < 2) return;
    if (!input.joined) ++stats_.paths;
    const bool embedded = p_.has_bath();
    if (embedded) change_tool(input.tool);
    // A multi-tool Marlin machine printing a path with a tool of its own (no mixture that
    // chose the tool): select it at the path's start, heated as every tool change is.
    if (select_tools_ && input.mixture.empty() && input.tool != last_tool_)
      line(tool_change_command(select_tool(input.tool), input.tool));
    Path path_copy;
    const Path* pp = &input;
    if (embedded && p_.node_overlap > 0) {  // each path end pushed past its end node
      path_copy = input;
      extend_path_ends(path_copy, p_.node_overlap);
      pp = &path_copy;
    }
    const Path& path = *pp;
    rise_over_finished_parts(path);
    travel_to(path.points.front(), path.joined ? std::vector<Vec3>{} : path.via, path.inside);
    feature_comments(path);
    if (streamed_) locate_changes(path);
    emit_changes(1, 0.0);
    process_commands(path);
    const bool marlin = e_axis_;  // E per segment (Marlin, or an embedded syringe pump)
    const MachineProfile& pressure_profile = embedded ? tool_profile_ : p_;
    if (path.joined) {
    } else if (marlin) {
      extra_filament(p_.pre_flow);
    } else {
      if (!p_.pressure_command.empty())
        line(expand_template(p_.pressure_command, pressure_profile, "pneumatic.pressure_command"));
      line(p_.valve_on);
    }
    if (!path.joined) dwell(p_.pre_flow_dwell);
    double speed = path.speed > 0 ? path.speed : p_.print_speed;
    if (chain_segments_ < static_cast<std::size_t>(p_.short_path_segments))
      speed *= p_.short_path_factor;
    const double layer = path.height > 0 ? path.height : p_.layer_height;
    bool first = true;
    for (std::size_t i = 1; i < path.points.size(); ++i) {
      // A change issued inside this segment (look-ahead): print up to it, issue it, go on.
      while (next_change_ < changes_.size() && changes_[next_change_].path == path_index_ &&
             changes_[next_change_].segment == i && changes_[next_change_].t < 1) {
        const double t = changes_[next_change_].t;
        if (t > 0) {
          const Vec3 a = path.points[i - 1], b = path.points[i];
          print_move(a + (b - a) * t, layer, speed, first, marlin);
        }
        line(changes_[next_change_].command);
        ++next_change_;
      }
      print_move(path.points[i], layer, speed, first, marlin);
      if (embedded && i + 1 < path.points.size()) dwell(p_.node_dwell);
    }
    if (!next_joined_) {
      if (marlin) extra_filament(p_.post_flow);
      dwell(p_.post_flow_dwell);
      if (!marlin) line(p_.valve_off);
    }
    emit_changes(SIZE_MAX, 0.0);  // any left for this path (rounding at its very end)
    ++path_index_;
    printed_ = true;
  }

  // A plate printed part by part: the travel to the next part, which starts lower than what is
  // printed, first rises above every finished part (plus the Z hop, at least 1 mm), so the nozzle
  // never passes over one below its top. Per-layer plates and single parts never start lower.
  void rise_over_finished_parts(const Path& path) {
    if (path.part == 0) return;
    if (path.part != sequence_part_ && path.points.front().z < finished_top_ - 1e-9)
      rise_to_ = finished_top_ + std::max(p_.z_hop, 1.0);
    sequence_part_ = path.part;
    for (const Vec3& q : path.points) finished_top_ = std::max(finished_top_, q.z);
  }

  // ;TYPE:, ;WIDTH:, ;HEIGHT: as PrusaSlicer writes them: before the path, when they change.
  void feature_comments(const Path& path) {
    const char* type = gcode_type_name(path.role);
    if (type != last_type_) {
      out_ += ";TYPE:";
      out_ += type;
      out_ += '\n';
      last_type_ = type;
    }
    const double w = path.width > 0 ? path.width : p_.nozzle_diameter;
    const double h = path.height > 0 ? path.height : p_.layer_height;
    if (w != last_width_) {
      out_ += ";WIDTH:";
      append_fixed(out_, w, 4);
      out_ += '\n';
      last_width_ = w;
    }
    if (h != last_height_) {
      out_ += ";HEIGHT:";
      append_fixed(out_, h, 4);
      out_ += '\n';
      last_height_ = h;
    }
  }

  // Whether a move from pos_ to q writes nothing new at the output's precision: the same X, Y
  // and Z to 3 decimals, or (with E) a move within two units of the last place (2 µm) whose E
  // rounds to the one before (`e`: this move's E). Written, it reads back as a zero-length
  // extrusion or as a travel that splits the path. Longer moves are always written (a tiny
  // extrusion.k may round every E to the one before: leaving those out would cut corners).
  // `qx`, `qy`: the new X and Y (with the placement and tool offsets) times 10^3 rounded as
  // fastnum::llround rounds them; `len`: distance(pos_, q).
  bool silent_move(Vec3 q, Vec2 o, double e, bool marlin, long long qx, long long qy,
                   double len) const {
    auto same = [](double a, double b, double scale) {
      return fastnum::llround(a * scale) == fastnum::llround(b * scale);
    };
    if (qx == fastnum::llround((pos_.x + dx_ + o.x) * 1e3) &&
        qy == fastnum::llround((pos_.y + dy_ + o.y) * 1e3) && same(q.z, pos_.z, 1e3))
      return true;
    if (!marlin || len >= 2e-3) return false;
    return p_.relative_e ? fastnum::llround(e * 1e5) == 0 : same(e_ + e, e_, 1e5);
  }

  // One extruding move to q. A move too short to write (silent_move) is left out: its length and
  // filament go into the next one.
  void print_move(Vec3 q, double layer, double speed, bool& first, bool marlin) {
    {
      const double len = distance(pos_, q);
      const double flow = down_factor(q);
      const Vec2 o = offset();
      const double e = marlin ? extrusion_for(len, layer, p_) * flow * path_flow_ : 0.0;
      // X and Y rounded once, for the silent-move test and for their words.
      const double x = q.x + dx_ + o.x, y = q.y + dy_ + o.y;
      long long qx = 0, qy = 0;
      const bool rx = fastnum::round_half_away(x * 1e3, qx),
                 ry = fastnum::round_half_away(y * 1e3, qy);
      if (silent_move(q, o, e, marlin, rx ? qx : std::llround(x * 1e3),
                      ry ? qy : std::llround(y * 1e3), len)) {
        silent_ = true;
        silent_to_ = q;
        return;
      }
      silent_ = false;
      MoveLine m(out_.room(MoveLine::kRoom), true);
      m.word_q<3>('X', x, rx, qx);
      m.word_q<3>('Y', y, ry, qy);
      if (std::abs(q.z - pos_.z) > 1e-9) m.word<3>('Z', q.z);
      if (marlin) {
        e_ += e;
        stats_.filament += e;
        m.word<5>('E', p_.relative_e ? e : e_);
      }
      // Pneumatic flow is set by pressure, not by E: the same flow over more length thins the
      // bead, so a steep descent is printed faster instead.
      const double f = marlin ? speed : speed / flow;
      if (first || f != last_feed_) {
        m.feed(feeds_.get(f));
        first = false;
        last_feed_ = f;
      }
      m.close();
      put_move(m, 1);
      stats_.print_length += len;
      pos_ = q;
    }
  }

  const MachineProfile& p_;
  const Toolpath& tp_;
  const std::vector<GcodeThumbnail>* thumbnails_;
  bool late_thumbnails_ = false;  // streamed: made beside the writing, put in as it is copied out
  std::vector<GcodeThumbnail> made_thumbnails_;
  std::size_t thumbnails_at_ = 0;  // offset of the thumbnails in the text (late_thumbnails_)
  LayerSource layers_;             // tp_'s layers, or the streamed ones
  std::size_t layer_count_ = 0;
  bool streamed_ = false;
  std::size_t points_ = 0;    // points of the whole toolpath, when the caller counted them
  bool tower_ = false;        // streamed: a prime tower is printed
  int sequence_part_ = 0;     // plates: the part printed last
  double finished_top_ = 0;   // plates: highest point printed so far
  double rise_to_ = 0;        // the next travel's least height (0 = none)
  std::FILE* raw_ = nullptr;  // streamed: the text so far, without M73 lines
  std::size_t flushed_ = 0;   // bytes already in raw_
  std::vector<std::pair<std::size_t, double>> progress_marks_;  // (byte offset, time so far)
  TimeEstimate estimate_;
  std::unique_ptr<EstimatePipe> pipe_;  // the estimate reading beside the writing, or none
  std::vector<bool> mark_is_object_;    // beside: each mark's kind, in order (estimate_now)
  std::size_t scanned_ = 0;             // out_'s text up to here is in the estimate
  std::string_view last_type_;
  double last_width_ = -1, last_height_ = -1;
  double lift_ = 0;  // Z added to every point (placement.lift), in the header for readers
  fastnum::TextOut out_;
  GcodeObjects objects_;  // build plates: parts labelled for the firmware
  int object_ = 0;        // the part whose moves are being written (Path::part), 0 = none
  // Where the part being printed changes (offset in the text, to that part, 0 = none, and the
  // estimated time there): each part's time comes from these.
  struct ObjectMark {
    std::size_t at;
    int part;
    double time;
  };
  std::vector<ObjectMark> object_marks_;
  std::size_t estimate_at_ = 0;  // offset of the footer's estimated time
  std::vector<Change> changes_;  // mixture changes in print order
  // Streamed: printed length before each printed path (and after the last), and the paths
  // carrying a mixture (index, command, tool) until the changes are planned.
  struct Wanted {
    std::size_t path;
    std::string command;
    int tool;
  };
  std::vector<double> starts_;      // streamed, with a look-ahead: printed length before each path
  std::size_t streamed_paths_ = 0;  // streamed: printed paths planned
  std::vector<std::size_t> layer_first_;  // streamed: the first printed path of each layer
  std::vector<Wanted> wanted_;
  std::vector<int> tools_used_;  // tool changers: tools in order of first use
  int last_tool_ = -1;
  bool select_tools_ = false;  // multi-tool Marlin: T for each path's own tool
  double standby_ =
      0;  // °C for idle tools (temperature.standby), 0 = they stay at printing temperature
  std::size_t next_change_ = 0, path_index_ = 0;
  GcodeStats stats_;
  double dx_ = 0, dy_ = 0;
  bool silent_ = false;  // the last printing move was left out (silent_move): it was to silent_to_
  Vec3 silent_to_;
  double e_ = 0;
  Vec3 pos_;
  bool known_ = false, printed_ = false, retracted_ = false;
  double safe_z_ = 0;                                 // embedded: travel height
  int tool_ = -1;                                     // embedded: tool in use
  Vec2 tool_offset_;                                  // ... its XY offset
  MachineProfile tool_profile_;                       // ... the profile with its pressure
  std::vector<std::pair<double, double>> down_flow_;  // (descent deg, factor), by angle
  double last_feed_ = -1;
  FeedWords feeds_;  // the F words of the move lines
  // Process fields: the nozzle temperature and fan last set, the current path's flow factor,
  // and the bead (chain of joined paths) being written.
  double nozzle_now_ = -1, fan_now_ = -1, path_flow_ = 1;
  bool own_temperature_ = false, own_fan_ = false;  // some path had its own
  // Streamed: the first printed path's own temperature (0 = none), found by the placement pass.
  double first_temperature_ = 0;
  bool first_seen_ = false;
  bool next_joined_ = false;
  std::size_t chain_segments_ = 0;
  bool e_axis_ =
      false;  // moves carry E                              // F of the previous printing move

  // Flow factor of a move from pos_ to q (1 unless it descends steeply).
  double down_factor(Vec3 q) const {
    if (down_flow_.empty() || q.z >= pos_.z) return 1.0;
    const double run = std::hypot(q.x - pos_.x, q.y - pos_.y);
    const double deg = std::atan2(pos_.z - q.z, run) * 180.0 / 3.14159265358979323846;
    double f = 1.0;
    for (const auto& [angle, factor] : down_flow_)
      if (deg >= angle - 1e-9) f = factor;
    return f;
  }
};

std::string lift_warning(double lift) {
  return fmt::format(
      "the toolpath reaches Z {:.3f} mm, below the bed: lifted by {:.3f} mm so that "
      "its lowest point is at Z 0 (placement.lift = false refuses instead)",
      -lift, lift);
}

// The metadata blocks of a binary G-code: PrusaSlicer's keys where it has one, with the values
// the text's header and footer give (so a reader of either sees the same numbers).
BgcodeMetadata bgcode_metadata(const MachineProfile& p, const GcodeStats& s, std::size_t layers) {
  const auto value = [&](const char* key) {
    for (const auto& d : machine_settings())
      if (std::string(d.key) == key) return setting_text(p, d);
    throw std::logic_error(std::string("no machine setting ") + key);
  };
  BgcodeMetadata m;
  m.file = {{"Producer", std::string("Trellis ") + TRELLIS_VERSION}};
  // "printer_model" first, where PrusaSlicer puts it (the firmware's model check).
  if (!p.printer_model.empty()) m.printer.push_back({"printer_model", p.printer_model});
  m.printer.insert(m.printer.end(), {{"nozzle_diameter", value("extrusion.nozzle_diameter")},
                                     {"layer_height", value("extrusion.layer_height")},
                                     {"temperature", value("temperature.nozzle")},
                                     {"bed_temperature", value("temperature.bed")}});
  const std::string time = duration_text(s.print_time_s);
  std::string filament;
  append_fixed(filament, s.filament + s.prime_filament, 2);
  for (auto* block : {&m.printer, &m.print}) {
    block->push_back({"filament used [mm]", filament});
    block->push_back({"estimated printing time (normal mode)", time});
  }
  m.print.push_back({"total layers count", std::to_string(layers)});
  for (const auto& d : machine_settings()) {
    std::string v = setting_text(p, d);
    for (auto& c : v)
      if (c == '\n') c = '|';
    m.slicer.push_back({d.key, v});
  }
  return m;
}

}  // namespace

std::string write_gcode(const Toolpath& toolpath, const MachineProfile& profile, GcodeStats* stats,
                        const std::vector<GcodeThumbnail>& thumbnails) {
  std::string out;
  write_gcode_into(out, toolpath, profile, stats, thumbnails);
  return out;
}

void write_gcode_into(std::string& out, const Toolpath& toolpath, const MachineProfile& profile,
                      GcodeStats* stats, const std::vector<GcodeThumbnail>& thumbnails) {
  if (toolpath.path_count() == 0) throw GeometryError("the toolpath has no paths to write");
  GcodeStats s;
  // Each path's extent and the point count in one pass, shared by the lift, the machine check,
  // the placement and the buffer's size (the union of the paths' extents in order is the
  // extent of the points in order, signed zeros alike).
  BBox3 box;
  std::size_t points = 0;
  std::vector<BBox3> extents;
  extents.reserve(toolpath.path_count());
  for (const auto& l : toolpath.layers)
    for (const auto& path : l.paths) {
      points += path.points.size();
      extents.push_back(path_extent(path.points));
      const BBox3& e = extents.back();
      if (std::isnan(e.min.x)) {
        for (const auto& q : path.points) box.add(q);
      } else if (!path.points.empty()) {
        box.add(e.min);
        box.add(e.max);
      }
    }
  // Below the bed: lifted onto it (placement.lift), a copy only then.
  const double lift = placement_lift(box, profile);
  Toolpath lifted;
  const Toolpath* tp = &toolpath;
  if (lift > 0) {
    lifted = toolpath;
    for (auto& l : lifted.layers) {
      l.z += lift;
      for (auto& path : l.paths)
        for (auto& q : path.points) q.z += lift;
    }
    tp = &lifted;
    if (const double below = lift - (profile.has_bath() ? profile.floor_z : 0); below > 0)
      s.warnings.emplace_back("lifted", lift_warning(below));
    // z + lift is monotone in z, so the lifted extent is the extent lifted, exactly.
    box.min.z += lift;
    box.max.z += lift;
    for (auto& e : extents) e.min.z += lift, e.max.z += lift;
  }
  for (auto& w :
       check_for_machine(layers_of(*tp), profile.center ? box : BBox3{}, profile, &extents))
    s.warnings.emplace_back(w.kind, w.message);
  auto warnings = std::move(s.warnings);
  out = Writer(profile, *tp, lift, thumbnails, nullptr, 0, &box, points).run(s, std::move(out));
  warnings.insert(warnings.end(), s.warnings.begin(), s.warnings.end());  // the writer's own
  s.warnings = std::move(warnings);
  if (stats) *stats = s;
}

namespace {

// write_gcode_stream with the thumbnails made (`made`) or to make (`later`).
GcodeStats write_stream(const std::string& path, const Toolpath& meta, std::size_t layer_count,
                        const LayerSource& layers, const MachineProfile& profile,
                        const std::vector<GcodeThumbnail>& made, const GcodeThumbnailMaker* later) {
  BBox3 box;
  std::size_t paths = 0;
  layers([&](std::size_t, const Layer& l) {
    paths += l.paths.size();
    for (const auto& path : l.paths)
      for (const auto& q : path.points) box.add(q);
  });
  if (paths == 0) throw GeometryError("the toolpath has no paths to write");
  GcodeStats s;
  const double lift = placement_lift(box, profile);
  LayerSource placed = layers;
  if (lift > 0) {
    placed = [&layers, lift](const LayerVisitor& visit) {
      layers([&](std::size_t i, const Layer& l) {
        Layer up = l;
        up.z += lift;
        for (auto& path : up.paths)
          for (auto& q : path.points) q.z += lift;
        visit(i, up);
      });
    };
    box.min.z += lift;
    box.max.z += lift;
    if (const double below = lift - (profile.has_bath() ? profile.floor_z : 0); below > 0)
      s.warnings.emplace_back("lifted", lift_warning(below));
  }
  for (auto& w : check_for_machine(placed, box, profile))
    s.warnings.emplace_back(w.kind, w.message);
  auto warnings = std::move(s.warnings);
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> raw(temporary_file(), &std::fclose);
  const bool binary = binary_gcode_output(path, profile);
  write_file_atomic_with(path, [&](const ByteWriter& put) {
    if (!binary) {
      Writer(profile, meta, lift, made, &placed, layer_count).stream(s, raw.get(), put, {}, later);
      return;
    }
    // The pictures go into thumbnail blocks; the text, once its print metadata is known, into
    // G-code blocks as it is copied out of the temporary file.
    const std::vector<GcodeThumbnail> thumbnails = later ? (*later)() : made;
    BgcodeWriter packer(put, bgcode_options(profile));
    const std::vector<GcodeThumbnail> none;
    Writer(profile, meta, lift, none, &placed, layer_count)
        .stream(
            s, raw.get(), [&](std::string_view text) { packer.gcode(text); },
            [&](const GcodeStats& known) {
              packer.start(bgcode_metadata(profile, known, layer_count), thumbnails);
            });
    packer.finish();
    s.bytes = packer.bytes();
  });
  warnings.insert(warnings.end(), s.warnings.begin(), s.warnings.end());  // the writer's own
  s.warnings = std::move(warnings);
  return s;
}

}  // namespace

GcodeStats write_gcode_stream(const std::string& path, const Toolpath& meta,
                              std::size_t layer_count, const LayerSource& layers,
                              const MachineProfile& profile,
                              const std::vector<GcodeThumbnail>& thumbnails) {
  return write_stream(path, meta, layer_count, layers, profile, thumbnails, nullptr);
}

GcodeStats write_gcode_stream(const std::string& path, const Toolpath& meta,
                              std::size_t layer_count, const LayerSource& layers,
                              const MachineProfile& profile,
                              const GcodeThumbnailMaker& thumbnails) {
  return write_stream(path, meta, layer_count, layers, profile, {}, &thumbnails);
}

GcodeStats write_gcode_file(const std::string& path, const Toolpath& toolpath,
                            const MachineProfile& profile,
                            const std::vector<GcodeThumbnail>& thumbnails) {
  GcodeStats s;
  if (!binary_gcode_output(path, profile)) {
    write_file_atomic(path, write_gcode(toolpath, profile, &s, thumbnails));
    return s;
  }
  const std::string text = write_gcode(toolpath, profile, &s, {});
  write_file_atomic_with(path, [&](const ByteWriter& put) {
    BgcodeWriter packer(put, bgcode_options(profile));
    packer.start(bgcode_metadata(profile, s, toolpath.layers.size()), thumbnails);
    packer.gcode(text);
    packer.finish();
    s.bytes = packer.bytes();
  });
  return s;
}

}  // namespace trellis
