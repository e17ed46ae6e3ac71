#include "progress_display.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace trellis::cli {

namespace {

constexpr double kShowAfter = 1.0;    // s: a terminal shows runs longer than this
constexpr double kRedrawEvery = 0.1;  // s between terminal redraws
constexpr double kLineEvery = 1.0;    // s between plain lines
constexpr double kEtaAfter = 0.3;     // s of a stage before its ETA is guessed

std::string duration_text(double s) {
  if (s < 60) return fmt::format("{:.0f} s", std::max(1.0, std::ceil(s)));
  if (s < 3600) return fmt::format("{:.0f} min {:02.0f} s", std::floor(s / 60), std::fmod(s, 60.0));
  return fmt::format("{:.0f} h {:02.0f} min", std::floor(s / 3600), std::fmod(s / 60, 60.0));
}

}  // namespace

ProgressMode progress_mode(int asked) {
  if (asked == 0) return ProgressMode::Off;
  if (::isatty(2)) return ProgressMode::Terminal;
  return asked > 0 ? ProgressMode::Lines : ProgressMode::Off;
}

void add_progress_flag(CLI::App* cmd, int& asked) {
  cmd->add_flag_callback(
      "--progress", [&asked] { asked = 1; },
      "progress on stderr (stage, %, ETA) also into a pipe or log, a line per update with the "
      "estimates made before the run (by default: on a terminal only); run.progress");
  cmd->add_flag_callback(
      "--no-progress", [&asked] { asked = 0; }, "no progress on stderr, not even on a terminal");
}

ProgressMode progress_mode(const Settings& settings) {
  const Settings::Entry* e = settings.find("run.progress");
  return progress_mode(e ? (std::get<bool>(e->value) ? 1 : 0) : -1);
}

ProgressDisplay::ProgressDisplay(ProgressMode mode, std::string label)
    : mode_(mode), label_(std::move(label)) {}

ProgressDisplay::~ProgressDisplay() {
  finish();
}

Progress ProgressDisplay::progress() {
  Progress p;
  if (mode_ == ProgressMode::Off) return p;
  p.report = [this](const std::string& stage, double fraction) { report(stage, fraction); };
  p.estimate = [this](const Estimate& e) { estimate(e); };
  return p;
}

RunContext ProgressDisplay::context(Diagnostics& diag) {
  RunContext c;
  c.progress = progress();
  c.diagnostics = &diag;
  return c;
}

void ProgressDisplay::report(const std::string& stage, double fraction) {
  if (mode_ == ProgressMode::Off) return;
  const double now = std::chrono::duration<double>(Clock::now() - start_).count();
  std::lock_guard lock(mutex_);
  fraction = std::clamp(std::isfinite(fraction) ? fraction : 0.0, 0.0, 1.0);
  if (fraction > 1 - 1e-9) fraction = 1;  // sums of shares that fall short by rounding
  // A new stage, or the same stage run again (a fraction falling back to its start): its clock
  // restarts. Otherwise a fraction below the last (threads finishing out of order) is ignored.
  const bool restart =
      stage != stage_ || (fraction_ >= 1 && fraction < 1) || fraction < fraction_ - 0.5;
  if (restart) {
    stage_ = stage;
    stage_start_ = now;
    stage_start_fraction_ = fraction;
    fraction_ = fraction;
  } else if (fraction <= fraction_) {
    return;
  } else {
    fraction_ = fraction;
  }
  const bool final = fraction_ >= 1;
  const bool new_name = stage_ != shown_stage_;
  if (mode_ == ProgressMode::Terminal) {
    if (now < kShowAfter || now - drawn_at_ < kRedrawEvery) return;
  } else if (!new_name && now - drawn_at_ < kLineEvery &&
             !(final && shown_stage_ == stage_ && shown_fraction_ < 1)) {
    return;
  }
  draw(now, final);
}

void ProgressDisplay::draw(double now, bool final) {
  const double in_stage = now - stage_start_;
  std::string eta;
  // The stage's rate since its first report (which may come part-way, as from worker threads).
  const double done = fraction_ - stage_start_fraction_;
  if (!final && done > 0 && in_stage >= kEtaAfter)
    eta = "  ETA " + duration_text(in_stage * (1 - fraction_) / done);
  const std::string text =
      fmt::format("{}: {} {:3.0f}%{}", label_, stage_, std::floor(fraction_ * 100), eta);
  if (mode_ == ProgressMode::Terminal) {
    // Carriage return, the text, then erase the rest of the line (a shorter line over a longer).
    std::fprintf(stderr, "\r%s\033[K", text.c_str());
    line_open_ = true;
  } else {
    std::fprintf(stderr, "%s\n", text.c_str());
  }
  std::fflush(stderr);
  drawn_at_ = now;
  shown_stage_ = stage_;
  shown_fraction_ = fraction_;
}

void ProgressDisplay::estimate(const Estimate& e) {
  if (mode_ != ProgressMode::Lines) return;
  std::lock_guard lock(mutex_);
  std::fprintf(stderr, "%s: estimate %.3g s, %.0f MB: %s\n", label_.c_str(), e.seconds,
               std::ceil(e.bytes / 1e6), e.what.c_str());
  std::fflush(stderr);
}

void ProgressDisplay::finish() {
  std::lock_guard lock(mutex_);
  if (mode_ == ProgressMode::Terminal && line_open_) {
    std::fputs("\r\033[K", stderr);
    std::fflush(stderr);
  }
  line_open_ = false;
}

}  // namespace trellis::cli
