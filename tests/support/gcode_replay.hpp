// An independent, minimal G-code replayer for tests: it knows nothing of Trellis's writer and
// recovers the deposited segments from the text alone (G0/G1, G90/G91, M82/M83, G92; extrusion
// when E increases, or while a named valve command is active for pneumatic files). A prime line
// (";TYPE:Prime line" up to the next ";TYPE:" or ";LAYER") primes the nozzle before the print:
// its moves are not deposits of the print (prime_deposits counts them).
#pragma once
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

namespace trellis::test {

struct Deposit {
  double x0, y0, z0, x1, y1, z1;
  double e;  // filament for this move (0 for pneumatic)
};

struct Replay {
  std::vector<Deposit> deposits;
  std::size_t extrusion_starts = 0;  // deposits not continuing the previous one
  double travel_length = 0;
  std::size_t prime_deposits = 0;  // extruding moves of prime lines
};

inline Replay replay_gcode(const std::string& text, const std::string& valve_on = "",
                           const std::string& valve_off = "") {
  Replay r;
  double x = 0, y = 0, z = 0, e = 0;
  bool abs_pos = true, abs_e = true, valve = false, last_was_deposit = false, priming = false;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(";TYPE:", 0) == 0) priming = line == ";TYPE:Prime line";
    if (line.rfind(";LAYER", 0) == 0) priming = false;
    if (!valve_on.empty() && line.rfind(valve_on, 0) == 0) valve = true;
    if (!valve_off.empty() && line.rfind(valve_off, 0) == 0) valve = false;
    const auto semi = line.find(';');
    if (semi != std::string::npos) line.resize(semi);
    std::istringstream words(line);
    std::string w;
    std::string cmd;
    double nx = x, ny = y, nz = z, ne = e;
    bool has_e = false;
    while (words >> w) {
      const char c = static_cast<char>(std::toupper(static_cast<unsigned char>(w[0])));
      if (c == 'G' || c == 'M') {
        cmd = w;
        continue;
      }
      const double v = std::stod(w.substr(1));
      if (c == 'X') nx = abs_pos ? v : x + v;
      if (c == 'Y') ny = abs_pos ? v : y + v;
      if (c == 'Z') nz = abs_pos ? v : z + v;
      if (c == 'E') {
        ne = abs_e ? v : e + v;
        has_e = true;
      }
    }
    if (cmd == "G90")
      abs_pos = true;
    else if (cmd == "G91")
      abs_pos = false;
    else if (cmd == "M82")
      abs_e = true;
    else if (cmd == "M83")
      abs_e = false;
    else if (cmd == "G92") {
      if (has_e) e = ne;
      continue;
    } else if (cmd == "G0" || cmd == "G1") {
      const bool moved = nx != x || ny != y || nz != z;
      const bool extruding = (has_e && ne > e + 1e-9) || (valve_on.size() && valve && cmd == "G1");
      if (moved && extruding && priming) {
        ++r.prime_deposits;
      } else if (moved && extruding) {
        if (!last_was_deposit) ++r.extrusion_starts;
        r.deposits.push_back({x, y, z, nx, ny, nz, has_e ? ne - e : 0});
        last_was_deposit = true;
      } else if (moved) {
        r.travel_length += std::hypot(nx - x, ny - y);
        last_was_deposit = false;
      } else if (has_e && ne < e) {
        last_was_deposit = false;  // retraction
      }
      x = nx;
      y = ny;
      z = nz;
      e = ne;
    }
  }
  return r;
}

}  // namespace trellis::test
