// Every event a G-code scanner reports (GcodeSink), as text with every bit of every number (%a),
// for tests that compare two readings of one file event by event.
#pragma once
#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

#include "trellis/machine/gcode_reader.hpp"

namespace trellis::test {

class LogSink : public GcodeSink {
 public:
  std::string log;
  void layer_change(double z) override { put("layer", {z}); }
  void extrude(Vec3 a, Vec3 b, double e, double f) override {
    put("extrude", {a.x, a.y, a.z, b.x, b.y, b.z, e, f});
  }
  void travel(Vec3 a, Vec3 b, double f) override {
    put("travel", {a.x, a.y, a.z, b.x, b.y, b.z, f});
  }
  void retract() override { put("retract", {}); }
  void tool_change(int t) override { put("tool", {static_cast<double>(t)}); }
  void role(PathRole r) override { put("role", {static_cast<double>(r)}); }
  void mixture(const std::vector<double>& m) override { put("mixture", m); }
  void mixture_lookahead(double mm) override { put("lookahead", {mm}); }
  void temperature(double t) override { put("temperature", {t}); }
  void width(double w) override { put("width", {w}); }
  void height(double h) override { put("height", {h}); }
  void dwell(double s) override { put("dwell", {s}); }
  void motion(Vec3 a, Vec3 b, double de, double f) override {
    put("motion", {a.x, a.y, a.z, b.x, b.y, b.z, de, f});
  }
  void limits(const MotionLimits& l) override {
    std::vector<double> v{l.acceleration, l.travel_acceleration, l.retract_acceleration};
    for (int i = 0; i < 4; ++i)
      v.insert(v.end(), {l.max_acceleration[i], l.max_feed[i], l.jerk[i]});
    put("limits", v);
  }
  void heater(int h, double c, bool w) override {
    put("heater", {static_cast<double>(h), c, static_cast<double>(w)});
  }
  void home() override { put("home", {}); }
  void prime(Vec3 a, Vec3 b, double e, double f) override {
    put("prime", {a.x, a.y, a.z, b.x, b.y, b.z, e, f});
  }
  void object(std::string_view l) override { log += "object '" + std::string(l) + "'\n"; }

 private:
  void put(const char* what, const std::vector<double>& v) {
    log += what;
    char buf[40];
    for (double x : v) log += (std::snprintf(buf, sizeof buf, " %a", x), buf);
    log += '\n';
  }
};

}  // namespace trellis::test
