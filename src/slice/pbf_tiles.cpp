// Periodic tiles of a PBF plan: where the part is the repeating sheet alone, a march takes the
// blocks of one period from tiles instead of marching them; layers a period apart along z share
// their tiles, and classes mirrored through the origin take each other's tiles turned.
#include <algorithm>
#include <cmath>
#include <numeric>

#include "pbf_internal.hpp"

namespace trellis::pbf_detail {

namespace {

// P, the layers in the sheet's period along z; 0: no sharing along z.
std::size_t z_period_layers(const Plan& p) {
  const PbfOptions& o = p.o;
  std::size_t zp = 0;
  if (p.sheet_period.x > 0 && o.test.z_tiles_budget > 0) {
    const double pz = p.design.phi.period().z, r = pz / o.layer, c = std::round(r);
    if (pz > 0 && std::isfinite(r) && c >= 1 && std::abs(r - c) <= 1e-9 * c)
      zp = static_cast<std::size_t>(c);
  }
  return zp;
}

// The design's sheet alone: no envelope, solids or clip boxes.
PbfDesign sheet_alone(const PbfDesign& design) {
  PbfDesign sheet_design = design;
  sheet_design.envelope = Field{};
  sheet_design.solids = Field{};
  sheet_design.clip.clear();
  return sheet_design;
}

}  // namespace

Vec2 sheet_period(const Plan& plan, PbfResult& result) {
  const PbfDesign& design = plan.design;
  const PbfOptions& o = plan.o;
  const std::vector<double>& zs = plan.zs;
  const BBox3& e = plan.extent;
  const Vec2 lo = plan.lo, hi = plan.hi;
  // A sheet of constant c (or thickness) around a φ that repeats along x and y repeats too.
  Vec2 sheet_period{0, 0};
  if (o.test.periodic_tiles && (design.thickness > 0 || plan.c_field.empty())) {
    const Vec3 p = design.phi.period();
    // A period wider than the part never repeats inside it, and a tile's grid spans a whole
    // period (a 947 mm cell on a 3 mm part was a 34 GB grid): no tiles then.
    if (p.x > 0 && p.y > 0 && p.x <= hi.x - lo.x && p.y <= hi.y - lo.y) sheet_period = {p.x, p.y};
  }
  // The tiles pay where the part is the sheet alone over much of its extent; elsewhere their
  // smaller blocks only cost (e.g. a lattice cut by another lattice, whose envelope is
  // negative only inside its own walls). Checked on 0.5 mm blocks of three layers: tiles when
  // at least 30% of the blocks are periodic.
  if (sheet_period.x > 0 && !zs.empty()) {
    Ctx probe(plan.part, design, plan.c_field, sheet_period);
    std::size_t periodic = 0, total = 0;
    const double step = 0.5;
    for (const double f : {0.25, 0.5, 0.75}) {
      const auto k = static_cast<std::size_t>(f * static_cast<double>(zs.size()));
      const double z = zs[std::min(zs.size() - 1, k)];
      for (double y = e.min.y; y < e.max.y; y += step)
        for (double x = e.min.x; x < e.max.x; x += step) {
          ++total;
          periodic += probe.periodic({x, y}, {x + step, y + step}, z);
        }
    }
    result.periodic_fraction =
        total ? static_cast<double>(periodic) / static_cast<double>(total) : 0;
    if (!(result.periodic_fraction >= 0.3)) sheet_period = {0, 0};
  }
  return sheet_period;
}

ZTiles::ZTiles(Plan& p, std::size_t last, PbfResult& result)
    : p_(p),
      last_(last),
      zp_(z_period_layers(p)),
      parity_(p.design.phi.inversion_parity()),
      sheet_design_(sheet_alone(p.design)),
      sheet_part_(zp_ ? sheet_design_.part() : Field{}),
      contexts_([this] { return Ctx(sheet_part_, sheet_design_, p_.c_field, p_.sheet_period); }),
      kept_(zp_) {
  if (zp_ && p.o.test.mirror_tiles && parity_ != 0) mirror_classes(p);
  result.mirror_tiles = mirror_;
}

// Classes mirrored through the origin (PbfOptions::test.mirror_tiles): with z_c + z_c' ≡ 0 modulo
// the period, i.e. c + c' + 1 ≡ N = −2·min z / layer (mod P), class c' is class c turned half
// a turn (Φ(x, y, −z) = Φ(−x, −y, z); φ itself keeps or changes its sign). The turn takes
// grid node k to node s − k (s = −2·lo in cells, modulo the period): tiles go onto tiles when
// s is a multiple of every march's tile side, so lo is moved down until it is.
void ZTiles::mirror_classes(Plan& p) {
  const Vec2 sheet_period = p.sheet_period;
  const double H = p.H, Hs = p.Hs, pad = p.pad;
  const std::size_t stride = p.stride;
  const BBox3& e = p.extent;
  Vec2& lo = p.lo;
  const std::size_t pxs = period_cells(sheet_period.x, Hs), pys = period_cells(sheet_period.y, Hs);
  const std::size_t pxc = period_cells(sheet_period.x, H), pyc = period_cells(sheet_period.y, H);
  const std::size_t tsx = pxs ? period_tile_side(pxs, p.mo_section.tile_block) : 0;
  const std::size_t tsy = pys ? period_tile_side(pys, p.mo_section.tile_block) : 0;
  const std::size_t tcx = pxc ? period_tile_side(pxc, p.mo_joint.tile_block) : 0;
  const std::size_t tcy = pyc ? period_tile_side(pyc, p.mo_joint.tile_block) : 0;
  const double n = -2 * e.min.z / p.o.layer, nr = std::round(n);
  if (tsx && tsy && tcx && tcy && std::abs(n - nr) <= 1e-9 * std::max(1.0, std::abs(n))) {
    // lo in section cells: a multiple of stride (a node of both grids) whose double is a
    // multiple of both marches' tile sides.
    auto unit = [&](std::size_t ts, std::size_t tc) {
      const std::size_t a = ts % 2 ? ts : ts / 2, b = (tc % 2 ? tc : tc / 2) * stride;
      return static_cast<double>(std::lcm(std::lcm(a, b), stride)) * Hs;
    };
    const double ux = unit(tsx, tcx), uy = unit(tsy, tcy);
    lo = {std::floor((e.min.x - pad) / ux) * ux, std::floor((e.min.y - pad) / uy) * uy};
    auto shift = [](double lo_, double h, std::size_t p) {
      const long long s = -2 * std::llround(lo_ / h), pp = static_cast<long long>(p);
      return static_cast<std::size_t>(((s % pp) + pp) % pp);
    };
    sx_s_ = shift(lo.x, Hs, pxs), sy_s_ = shift(lo.y, Hs, pys);
    sx_c_ = shift(lo.x, H, pxc), sy_c_ = shift(lo.y, H, pyc);
    mirror_n_ = static_cast<long long>(nr);
    mirror_ = true;
  }
}

// The class whose tiles, turned, are class c's: the mirror class when it comes first, else c.
std::size_t ZTiles::mirror_source(std::size_t c) const {
  if (!mirror_) return c;
  const auto p = static_cast<long long>(zp_);
  const auto m =
      static_cast<std::size_t>((((mirror_n_ - 1 - static_cast<long long>(c)) % p) + p) % p);
  return std::min(m, c);
}

std::shared_ptr<const ClassTiles> ZTiles::make(std::size_t c) {
  const PbfOptions& o = p_.o;
  auto out = std::make_shared<ClassTiles>();
  Ctx& cc = contexts_.local();
  const double z = p_.zs[c];
  const Vec2 lo = p_.lo;
  const Vec2 top = lo + p_.sheet_period;
  cc.grid.reset(lo, p_.Hs, static_cast<std::size_t>(std::llround(p_.sheet_period.x / p_.Hs)),
                static_cast<std::size_t>(std::llround(p_.sheet_period.y / p_.Hs)));
  cc.bounds.reset(z);
  if (!o.stl_route) {
    MarchOptions mo = p_.mo_section;
    mo.tiles_out = &out->section;
    march_section(p_, cc, z, lo, top, mo);
  }
  if (o.hybrid) {
    JointSection joint(cc, sheet_design_, o, p_.c_const, z);
    JointSection thin(cc, sheet_design_, o, p_.c_const, z, true);
    use_grid(p_, cc, joint, thin);
    MarchOptions mj = p_.mo_joint;
    if (o.beam_compensation <= 0) {
      mj.tiles_out = &out->joint;
      march_squares(joint, lo, top, 0.0, mj);
    } else if (p_.thin_walls_possible) {
      mj.tiles_out = &out->thin;
      march_squares(thin, lo, top, 0.0, mj);
    }
    MidSection mid(cc, z);
    MarchOptions mm = p_.mo_mid;
    mm.tiles_out = &out->mid;
    march_squares(mid, lo, top, 0.0, mm);
  }
  return std::shared_ptr<const ClassTiles>(std::move(out));
}

std::shared_ptr<const ClassTiles> ZTiles::get(std::size_t i) {
  const std::size_t zp = zp_;
  if (zp == 0 || p_.zs[i] != p_.extent.min.z + (static_cast<double>(i) + 0.5) * p_.o.layer)
    return nullptr;
  const std::size_t c = i % zp;
  {
    std::lock_guard lock(kept_mutex_);
    if (kept_[c]) return kept_[c];
  }
  std::shared_ptr<const ClassTiles> t;
  if (const std::size_t m = mirror_source(c); m < c) {
    std::shared_ptr<const ClassTiles> from;
    {
      std::lock_guard lock(kept_mutex_);
      from = kept_[m];
    }
    if (!from) from = make(m);
    const double H = p_.H, Hs = p_.Hs;
    auto turned = std::make_shared<ClassTiles>();
    turned->section = point_reflected_tiles(from->section, Hs, sx_s_, sy_s_, false);
    turned->thin = point_reflected_tiles(from->thin, H, sx_c_, sy_c_, false);
    turned->joint = point_reflected_tiles(from->joint, H, sx_c_, sy_c_, false);
    turned->mid = point_reflected_tiles(from->mid, H, sx_c_, sy_c_, parity_ < 0);
    t = std::move(turned);
    ++turned_classes_;
  } else {
    t = make(c);
  }
  if (i + zp < last_) {  // the class has a later layer in this run
    std::lock_guard lock(kept_mutex_);
    if (kept_[c]) return kept_[c];
    if (kept_bytes_ + t->bytes() <= p_.o.test.z_tiles_budget) {
      kept_[c] = t;
      kept_bytes_ += t->bytes();
    }
  }
  return t;
}

void ZTiles::release(std::size_t i) {
  if (zp_ == 0 || i + zp_ < last_) return;
  std::lock_guard lock(kept_mutex_);
  if (auto& k = kept_[i % zp_]) {
    kept_bytes_ -= k->bytes();
    k.reset();
  }
}

}  // namespace trellis::pbf_detail
