#include "trellis/toolpath/order.hpp"

#include <algorithm>
#include <cmath>
#include <tuple>

namespace trellis {

namespace {

// The ends of the items not yet taken, in a uniform XY grid. Rebuilt over the remaining ends
// when half are gone, so a search never walks a grid that is mostly empty.
class EndGrid {
 public:
  EndGrid(const std::vector<OrderItem>& items, const std::vector<char>& taken)
      : items_(items), taken_(taken) {
    build();
  }

  // The nearest end to p among items not taken: (item, reversed), ties broken as documented.
  OrderStep nearest(Vec3 p) {
    if (remaining_ * 2 < built_with_) build();
    double best = 1e300;
    OrderStep pick{static_cast<std::size_t>(-1), false};
    const long cx = cell_x(p.x), cy = cell_y(p.y);
    auto visit = [&](long x, long y) {
      for (const std::size_t key : cells_[static_cast<std::size_t>(y * nx_ + x)]) {
        const std::size_t i = key / 2;
        if (taken_[i]) continue;
        const bool rev = key % 2 == 1;
        const double d = distance(p, rev ? items_[i].end : items_[i].start);
        if (std::tie(d, i, rev) < std::tie(best, pick.item, pick.reversed)) {
          best = d;
          pick = {i, rev};
        }
      }
    };
    // Rings of cells about p's cell, only their cells inside the grid (a ring's cells are
    // searched in any order: the pick is the least by (distance, item, reversed)); no more
    // rings once one lies beyond the best or the grid.
    visit(cx, cy);
    for (long r = 1;; ++r) {
      if (static_cast<double>(r - 1) * cell_ > best) break;
      if (cx - r < 0 && cy - r < 0 && cx + r >= nx_ && cy + r >= ny_) break;
      const long x0 = std::max(0L, cx - r), x1 = std::min(nx_ - 1, cx + r);
      if (cy - r >= 0)
        for (long x = x0; x <= x1; ++x) visit(x, cy - r);
      if (cy + r < ny_)
        for (long x = x0; x <= x1; ++x) visit(x, cy + r);
      for (long y = std::max(0L, cy - r + 1); y <= std::min(ny_ - 1, cy + r - 1); ++y) {
        if (cx - r >= 0) visit(cx - r, y);
        if (cx + r < nx_) visit(cx + r, y);
      }
    }
    return pick;
  }

  void took() { --remaining_; }

 private:
  void build() {
    double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
    std::size_t ends = 0;
    remaining_ = 0;
    for (std::size_t i = 0; i < items_.size(); ++i) {
      if (taken_[i]) continue;
      ++remaining_;
      for (const Vec3& q : {items_[i].start, items_[i].end}) {
        x0 = std::min(x0, q.x), y0 = std::min(y0, q.y);
        x1 = std::max(x1, q.x), y1 = std::max(y1, q.y);
      }
      ends += items_[i].reversible ? 2 : 1;
    }
    built_with_ = remaining_;
    x0_ = x0, y0_ = y0;
    const double w = std::max(x1 - x0, 1e-9), h = std::max(y1 - y0, 1e-9);
    cell_ = std::max(std::sqrt(w * h / static_cast<double>(std::max<std::size_t>(ends, 1))),
                     std::max(w, h) / 1024);
    cell_ = std::max(cell_, 1e-9);
    nx_ = std::clamp(static_cast<long>(w / cell_) + 1, 1L, 1025L);
    ny_ = std::clamp(static_cast<long>(h / cell_) + 1, 1L, 1025L);
    cells_.assign(static_cast<std::size_t>(nx_ * ny_), {});
    for (std::size_t i = 0; i < items_.size(); ++i) {
      if (taken_[i]) continue;
      add(2 * i, items_[i].start);
      if (items_[i].reversible) add(2 * i + 1, items_[i].end);
    }
  }
  void add(std::size_t key, Vec3 q) {
    cells_[static_cast<std::size_t>(cell_y(q.y) * nx_ + cell_x(q.x))].push_back(key);
  }
  long cell_x(double x) const {
    return std::clamp(static_cast<long>(std::floor((x - x0_) / cell_)), 0L, nx_ - 1);
  }
  long cell_y(double y) const {
    return std::clamp(static_cast<long>(std::floor((y - y0_) / cell_)), 0L, ny_ - 1);
  }

  const std::vector<OrderItem>& items_;
  const std::vector<char>& taken_;
  std::vector<std::vector<std::size_t>> cells_;
  double x0_ = 0, y0_ = 0, cell_ = 1;
  long nx_ = 1, ny_ = 1;
  std::size_t remaining_ = 0, built_with_ = 0;
};

// 2-opt on the sequence: reversing a run of items also reverses each item in it.
void two_opt(const std::vector<OrderItem>& items, std::vector<OrderStep>& order, Vec3 from) {
  const std::size_t n = order.size();
  if (n < 3) return;
  // Each step's first and last point as printed, and the travel from each step to the next
  // (link[k]: step k to k + 1), kept with the order: a reversed run's inner links are its old
  // links read backwards (distance is symmetric, to the bit), the two at its ends are measured.
  std::vector<Vec3> s(n), e(n);
  for (std::size_t k = 0; k < n; ++k) {
    const OrderItem& it = items[order[k].item];
    s[k] = order[k].reversed ? it.end : it.start;
    e[k] = order[k].reversed ? it.start : it.end;
  }
  std::vector<double> link(n - 1);
  for (std::size_t k = 0; k + 1 < n; ++k) link[k] = distance(e[k], s[k + 1]);
  // fixed_before[k]: items before k that cannot be reversed, so a run i..j can be reversed
  // only when fixed_before[j + 1] == fixed_before[i].
  std::vector<std::size_t> fixed_before(n + 1, 0);
  bool any_fixed = false;
  for (std::size_t k = 0; k < n; ++k) {
    fixed_before[k + 1] = fixed_before[k] + (items[order[k].item].reversible ? 0 : 1);
    any_fixed = any_fixed || !items[order[k].item].reversible;
  }
  const std::size_t window = n > 2000 ? 64 : n;
  for (int pass = 0; pass < 20; ++pass) {
    bool improved = false;
    for (std::size_t i = 0; i + 1 < n; ++i) {
      const Vec3 before = i == 0 ? from : e[i - 1];
      double to_first = distance(before, s[i]);
      for (std::size_t j = i + 1; j < n && j - i <= window; ++j) {
        if (any_fixed && fixed_before[j + 1] != fixed_before[i]) break;
        double old_cost = to_first;
        double new_cost = distance(before, e[j]);
        if (j + 1 < n) {
          old_cost += link[j];
          new_cost += distance(s[i], s[j + 1]);
        }
        if (new_cost < old_cost - 1e-9) {
          const auto first = static_cast<long>(i), last = static_cast<long>(j) + 1;
          std::reverse(order.begin() + first, order.begin() + last);
          std::reverse(s.begin() + first, s.begin() + last);
          std::reverse(e.begin() + first, e.begin() + last);
          std::reverse(link.begin() + first, link.begin() + last - 1);
          for (std::size_t k = i; k <= j; ++k) {
            order[k].reversed = !order[k].reversed;
            std::swap(s[k], e[k]);
          }
          if (j + 1 < n) link[j] = distance(e[j], s[j + 1]);
          if (i > 0) link[i - 1] = distance(e[i - 1], s[i]);
          to_first = distance(before, s[i]);
          improved = true;
        }
      }
    }
    if (!improved) break;
  }
}

}  // namespace

std::vector<OrderStep> order_by_travel(const std::vector<OrderItem>& items, Vec3 from) {
  const std::size_t n = items.size();
  std::vector<OrderStep> order;
  order.reserve(n);
  std::vector<char> taken(n, 0);
  EndGrid grid(items, taken);
  Vec3 at = from;
  for (std::size_t step = 0; step < n; ++step) {
    const OrderStep pick = grid.nearest(at);
    taken[pick.item] = 1;
    grid.took();
    order.push_back(pick);
    at = pick.reversed ? items[pick.item].start : items[pick.item].end;
  }
  two_opt(items, order, from);
  return order;
}

double order_travel(const std::vector<OrderItem>& items, const std::vector<OrderStep>& order,
                    Vec3 from) {
  double len = 0;
  Vec3 at = from;
  for (const OrderStep& s : order) {
    const OrderItem& it = items[s.item];
    len += distance(at, s.reversed ? it.end : it.start);
    at = s.reversed ? it.start : it.end;
  }
  return len;
}

}  // namespace trellis
