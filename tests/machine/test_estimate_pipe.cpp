// The print-time estimate read beside the writing (src/machine/estimate_pipe.hpp) and the
// thumbnails made beside the streamed writing: for many generated prints, every flavour, with
// and without build-plate parts (their times come from marks), the bytes and stats of one thread
// and of two are the same, whole and streamed; and the pipe reads everything in order when no
// worker ever comes for it.
#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <tbb/task_arena.h>
#include <tbb/task_group.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "../../src/machine/estimate_pipe.hpp"
#include "support/machines.hpp"
#include "trellis/machine/gcode_writer.hpp"

namespace trellis {
namespace {

Toolpath random_print(std::mt19937& rng, int parts) {
  std::uniform_real_distribution<double> xy(-80, 80), speed(5, 150);
  Toolpath tp;
  for (int k = 0; k < parts; ++k) tp.part_labels.push_back("part " + std::to_string(k + 1));
  const int layers = 2 + static_cast<int>(rng() % 30);
  const PathRole roles[] = {PathRole::Perimeter, PathRole::Infill, PathRole::Skin};
  for (int i = 0; i < layers; ++i) {
    Layer l;
    l.z = 0.2 * (i + 1);
    const int paths = 1 + static_cast<int>(rng() % 40);
    for (int j = 0; j < paths; ++j) {
      Path p;
      p.role = roles[rng() % 3];
      if (rng() % 2) p.speed = speed(rng);
      if (parts > 0) p.part = 1 + static_cast<int>(rng() % parts);
      const int points = 2 + static_cast<int>(rng() % 60);
      for (int q = 0; q < points; ++q) p.points.push_back({xy(rng), xy(rng), l.z});
      l.paths.push_back(std::move(p));
    }
    tp.layers.push_back(std::move(l));
  }
  return tp;
}

struct Written {
  std::string whole, streamed, late;  // write_gcode; write_gcode_stream with made / late pictures
  GcodeStats whole_stats, streamed_stats, late_stats;
};

std::string read_all(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

Written write_on(int threads, const Toolpath& tp, const MachineProfile& p,
                 const std::vector<GcodeThumbnail>& pictures) {
  Written w;
  tbb::task_arena arena(threads);
  arena.execute([&] {
    w.whole = write_gcode(tp, p, &w.whole_stats, pictures);
    const LayerSource layers = layers_of(tp);
    const std::string path = ::testing::TempDir() + "/estimate_pipe.gcode";
    w.streamed_stats = write_gcode_stream(path, tp, tp.layers.size(), layers, p, pictures);
    w.streamed = read_all(path);
    w.late_stats = write_gcode_stream(path, tp, tp.layers.size(), layers, p,
                                      GcodeThumbnailMaker([&] { return pictures; }));
    w.late = read_all(path);
    std::remove(path.c_str());
  });
  return w;
}

void expect_same_stats(const GcodeStats& a, const GcodeStats& b, const std::string& what) {
  EXPECT_EQ(a.bytes, b.bytes) << what;
  EXPECT_EQ(a.print_time_s, b.print_time_s) << what;
  EXPECT_EQ(a.heating_s, b.heating_s) << what;
  EXPECT_EQ(a.part_time_s, b.part_time_s) << what;
}

TEST(EstimatePipe, TwoThreadsWriteTheBytesOfOne) {
  std::mt19937 rng(40);
  const std::vector<GcodeThumbnail> pictures = {{2, 2, std::string(300, 'p')},
                                                {3, 1, std::string(70, 'q')}};
  int checked = 0;
  for (int c = 0; c < 24; ++c) {
    MachineProfile p = test::open_bed();
    p.flavor = c % 3 == 0 ? Flavor::Marlin : c % 3 == 1 ? Flavor::Klipper : Flavor::RepRap;
    p.relative_e = c % 2 == 0;
    const Toolpath tp = random_print(rng, c % 4 == 0 ? 0 : 1 + c % 3);
    const Written one = write_on(1, tp, p, pictures), two = write_on(2, tp, p, pictures);
    const std::string what = "case " + std::to_string(c);
    EXPECT_EQ(one.whole, two.whole) << what;
    EXPECT_EQ(one.streamed, two.streamed) << what;
    EXPECT_EQ(one.late, two.late) << what;
    EXPECT_EQ(one.streamed, one.whole) << what;  // streamed: write_gcode's bytes
    EXPECT_EQ(two.late, two.whole) << what;      // thumbnails made beside, put in the header
    expect_same_stats(one.whole_stats, two.whole_stats, what);
    expect_same_stats(one.streamed_stats, two.streamed_stats, what);
    expect_same_stats(one.late_stats, two.late_stats, what);
    EXPECT_GT(two.whole_stats.print_time_s, 0) << what;
    EXPECT_NE(two.late.find("; thumbnail begin 2x2"), std::string::npos) << what;
    ++checked;
  }
  EXPECT_EQ(checked, 24);
}

// A reader that records what it is given, as the inline estimate would read it.
struct Log : EstimatePipe::Reader {
  std::string read;
  int moves = 0;
  bool refuse = false;  // moves not taken: their text is read instead
  void text(std::string_view t) override { read += t; }
  bool move(const GcodeScanner::Words& w, int g) override {
    if (refuse) return false;
    read += "<G" + std::to_string(g) + " X" + std::to_string(w.value['X' - 'A']) + ">";
    ++moves;
    return true;
  }
  double elapsed() const override { return moves; }
};

// Holds one of the arena's threads (when `hold`) from construction until release(): the pipe
// then finds no worker to read beside the writer.
class HeldWorker {
 public:
  explicit HeldWorker(bool hold) {
    if (!hold) return;
    other_.run([this] {
      started_ = true;
      while (!release_) std::this_thread::yield();
    });
    for (int i = 0; i < 1000 && !started_; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  void release() {
    release_ = true;
    other_.wait();
  }

 private:
  std::atomic<bool> started_{false}, release_{false};
  tbb::task_group other_;
};

// Everything handed over is read once, in order, with the marks' times — when a worker reads
// beside, and when none comes (an arena whose only other slot is busy: the writer reads it
// itself after a while).
TEST(EstimatePipe, ReadsEverythingInOrderWithOrWithoutAWorker) {
  for (int mode = 0; mode < 3; ++mode) {
    Log log, expected;
    log.refuse = expected.refuse = mode == 2;
    std::vector<double> times, expected_times;
    tbb::task_arena arena(2);
    arena.execute([&] {
      // Mode 1: the arena's other thread held by other work before the pipe starts, until the
      // writer has handed over far more than the queue holds.
      HeldWorker other(mode == 1);
      EstimatePipe pipe(log);
      if (mode == 1) {
        for (int i = 0; i < 200000; ++i) {
          GcodeScanner::Words w;
          w.set('X', i);
          const std::string line = "G1 X" + std::to_string(i) + "\n";
          pipe.move(w, 1, line);
          if (!expected.move(w, 1)) expected.text(line);
        }
      }
      for (int i = 0; i < 5000; ++i) {
        const std::string t = "; text " + std::to_string(i) + "\n";
        pipe.text(t);
        expected.text(t);
        GcodeScanner::Words w;
        w.set('X', 0.5 * i);
        const std::string line = "G0 X" + std::to_string(0.5 * i) + "\n";
        pipe.move(w, 0, line);
        if (!expected.move(w, 0)) expected.text(line);
        if (i % 100 == 0) {
          pipe.mark();
          expected_times.push_back(expected.elapsed());
        }
      }
      times = pipe.finish();
      other.release();
    });
    EXPECT_EQ(log.read, expected.read) << "mode " << mode;
    EXPECT_EQ(times, expected_times) << "mode " << mode;
  }
}

// Work beside the reading (the thumbnails) runs exactly once, done by the reading task while it
// waits or by the writer at finish(), with the reading still in order — with a worker, with none
// (the arena's other slot held), and when the work is handed over before or after the text; an
// exception it throws comes out of finish(). Mode 4: three threads (a third may take the work).
TEST(EstimatePipe, WorkBesideRunsOnceOnEitherThread) {
  for (int mode = 0; mode < 5; ++mode) {
    Log log, expected;
    std::vector<double> times;
    std::atomic<int> ran{0};
    bool threw = false;
    std::optional<tbb::global_control> wide;
    if (mode == 4) wide.emplace(tbb::global_control::max_allowed_parallelism, 3);
    tbb::task_arena arena(mode == 4 ? 3 : 2);
    arena.execute([&] {
      HeldWorker other(mode == 1);  // mode 1: no worker for the pipe
      EstimatePipe pipe(log);
      auto side = [&] {
        std::this_thread::sleep_for(std::chrono::milliseconds(mode == 2 ? 20 : 1));
        ++ran;
        if (mode == 3) throw std::runtime_error("beside");
      };
      if (mode != 2) pipe.run(side);
      for (int i = 0; i < 100000; ++i) {
        GcodeScanner::Words w;
        w.set('X', i);
        const std::string line = "G1 X" + std::to_string(i) + "\n";
        pipe.move(w, 1, line);
        if (!expected.move(w, 1)) expected.text(line);
        if (i % 1000 == 0) {
          const std::string t = std::string(i % 3000 == 0 ? 300000 : 10, 'c') + "\n";
          pipe.text(t);  // some texts longer than a batch
          expected.text(t);
        }
      }
      if (mode == 2) pipe.run(side);
      pipe.mark();
      try {
        times = pipe.finish();
      } catch (const std::runtime_error& e) {
        threw = std::string(e.what()) == "beside";
      }
      other.release();
    });
    EXPECT_EQ(ran.load(), 1) << "mode " << mode;
    EXPECT_EQ(threw, mode == 3) << "mode " << mode;
    if (mode != 3) {
      EXPECT_EQ(log.read, expected.read) << "mode " << mode;
      EXPECT_EQ(times, std::vector<double>{expected.elapsed()}) << "mode " << mode;
    }
  }
}

}  // namespace
}  // namespace trellis
