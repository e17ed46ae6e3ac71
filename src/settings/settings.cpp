#include "trellis/settings/settings.hpp"

#include <fmt/format.h>
#include <toml++/toml.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <set>
#include <sstream>

#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"

namespace trellis {

namespace {

std::string number_text(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

std::string kind_name(SettingKind k) {
  switch (k) {
    case SettingKind::Number:
      return "number";
    case SettingKind::Integer:
      return "integer";
    case SettingKind::Bool:
      return "true/false";
    case SettingKind::Choice:
      return "choice";
    case SettingKind::Text:
      return "text";
    case SettingKind::Numbers:
      return "list of numbers";
  }
  return "";
}

// The type a setting is written as: its kind, and a list of switches (Setting::flags) as such.
std::string type_name(const Setting& s) {
  return s.flags ? "list of true/false" : kind_name(s.kind);
}

std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

Where where_of(const Setting& s, const SettingOrigin& o) {
  if (o.source.rfind("--", 0) == 0) return {"", 0, o.source + " (" + s.key + ")"};
  return {o.source, o.line, s.key};
}

void check_number(const Setting& s, double v, const SettingOrigin& o) {
  const bool ok = std::isfinite(v) && (s.positive ? v > s.min : v >= s.min) && v <= s.max;
  if (!ok)
    throw SettingError(fmt::format("{} is out of range: {}", number_text(v), s.range_text()),
                       where_of(s, o));
}

// Parses a list "1,2,3" (commas or spaces). An empty element ("1,,2", "1,2,") is refused, not
// skipped: "0,90," read as two angles hid a value left out.
std::vector<double> parse_numbers(const Setting& s, const std::string& text,
                                  const SettingOrigin& o) {
  std::vector<double> out;
  std::string item;
  bool after_comma = false;  // a separator came after the last number: one must follow
  auto empty_element = [&] {
    throw SettingError("'" + text + "' has an empty element (expected " + s.range_text() + ")",
                       where_of(s, o));
  };
  auto flush = [&] {
    if (item.empty()) return;
    double v = 0;
    if (s.flags && (item == "true" || item == "false")) {
      out.push_back(item == "true" ? 1 : 0);
      item.clear();
      after_comma = false;
      return;
    }
    const auto r = std::from_chars(item.data(), item.data() + item.size(), v);
    if (r.ec != std::errc() || r.ptr != item.data() + item.size())
      throw SettingError("'" + item + "' is not a number (expected " + s.range_text() + ")",
                         where_of(s, o));
    out.push_back(v);
    item.clear();
    after_comma = false;
  };
  for (char c : text) {
    if (c == ',' || c == ';') {
      if (item.empty() && (out.empty() || after_comma)) empty_element();
      flush();
      after_comma = true;
    } else if (c == ' ' || c == '\t') {
      flush();
    } else {
      item += c;
    }
  }
  if (item.empty() && after_comma) empty_element();
  flush();
  return out;
}

// Every default, built once.
const Config& defaults() {
  static const Config c;
  return c;
}

}  // namespace

std::string Setting::default_text() const {
  if (!derived.empty()) return "";
  return value_text(get(defaults()));
}

std::string Setting::range_text() const {
  switch (kind) {
    case SettingKind::Number:
    case SettingKind::Integer:
    case SettingKind::Numbers: {
      std::string r;
      if (flags) return count ? fmt::format("{} of true or false", count) : "true or false, each";
      if (kind == SettingKind::Numbers)
        r = count == 1 ? std::string(whole ? "1 whole number, " : "1 number, ")
            : count    ? fmt::format("{} {}numbers, each ", count, whole ? "whole " : "")
                       : std::string(whole ? "whole numbers, each " : "numbers, each ");
      const bool open_top = max >= 1e299, open_bottom = min <= -1e299;
      for (const auto& [name, v] : names) r = name + " (= " + std::to_string(v) + ") or " + r;
      if (positive && open_top) return r + "> " + number_text(min);
      if (open_bottom && open_top) return r + "any finite number";
      return r + (positive ? "> " + number_text(min) + " and <= " : number_text(min) + " .. ") +
             number_text(max) + (unit.empty() || unit == "path" ? "" : " " + unit);
    }
    case SettingKind::Bool:
      return "true or false";
    case SettingKind::Choice: {
      std::string r = "one of ";
      for (std::size_t i = 0; i < choices.size(); ++i)
        r += (i ? ", " : "") + (choices[i].empty() ? std::string("\"\"") : choices[i]);
      return r;
    }
    case SettingKind::Text:
      return unit == "path" ? "a file path" : "text";
  }
  return "";
}

const Setting* find_setting(const std::string& key) {
  static const auto index = [] {
    std::map<std::string, const Setting*> m;
    for (const auto& s : all_settings()) m[s.key] = &s;
    return m;
  }();
  const auto it = index.find(key);
  return it == index.end() ? nullptr : it->second;
}

std::string with_flags(const std::string& message) {
  // A key is [a-z0-9_] words joined by one dot; it stands alone when the characters around it
  // could not continue it (a letter, digit, '_', '-', '.', '/' or a file name before it).
  auto word = [](char ch) { return std::isalnum(static_cast<unsigned char>(ch)) || ch == '_'; };
  std::string out;
  out.reserve(message.size());
  std::size_t i = 0;
  while (i < message.size()) {
    const char ch = message[i];
    const bool boundary = i == 0 || !(word(message[i - 1]) || message[i - 1] == '.' ||
                                      message[i - 1] == '-' || message[i - 1] == '/');
    if (!boundary || !std::islower(static_cast<unsigned char>(ch))) {
      out += ch;
      ++i;
      continue;
    }
    std::size_t j = i;
    while (j < message.size() && word(message[j])) ++j;
    const Setting* s = nullptr;
    std::size_t end = j;
    if (j + 1 < message.size() && message[j] == '.' && word(message[j + 1])) {
      std::size_t k = j + 1;
      while (k < message.size() && word(message[k])) ++k;
      // Not a key when it goes on as a file name or a longer dotted name.
      const bool longer = k < message.size() &&
                          (message[k] == '.' || message[k] == '/' || message[k] == '-') &&
                          k + 1 < message.size() && word(message[k + 1]);
      if (!longer) {
        s = find_setting(message.substr(i, k - i));
        end = k;
      }
    }
    const std::string key = message.substr(i, end - i);
    if (s && !s->flag.empty()) {
      const std::string flag = "--" + s->flag;
      // Already "--flag (key)" or "key (--flag)": left as it is.
      const bool written =
          (out.size() >= flag.size() + 2 &&
           out.compare(out.size() - flag.size() - 2, flag.size() + 2, flag + " (") == 0) ||
          message.compare(end, flag.size() + 2, " (" + flag) == 0;
      out += written ? key : flag + " (" + key + ")";
    } else {
      out += key;
    }
    i = end;
  }
  return out;
}

std::string nearest_setting(const std::string& key) {
  std::string best;
  std::size_t best_d = std::max<std::size_t>(3, key.size() / 3) + 1;
  for (const auto& s : all_settings()) {
    const std::size_t d = edit_distance(key, s.key);
    const std::string tail = s.key.substr(s.key.find('.') + 1);
    const std::size_t d2 = key.find('.') == std::string::npos ? edit_distance(key, tail) : d;
    if (std::min(d, d2) < best_d) best_d = std::min(d, d2), best = s.key;
  }
  return best;
}

std::string value_text(const SettingValue& v) {
  return std::visit(
      [](const auto& x) -> std::string {
        using T = std::decay_t<decltype(x)>;
        if constexpr (std::is_same_v<T, double>)
          return number_text(x);
        else if constexpr (std::is_same_v<T, long long>)
          return std::to_string(x);
        else if constexpr (std::is_same_v<T, bool>)
          return x ? "true" : "false";
        else if constexpr (std::is_same_v<T, std::string>)
          return x;
        else {
          std::string out;
          for (std::size_t i = 0; i < x.size(); ++i) out += (i ? "," : "") + number_text(x[i]);
          return out;
        }
      },
      v);
}

void Settings::set(const std::string& key, SettingValue value, const SettingOrigin& origin) {
  const Setting* s = find_setting(key);
  if (!s) {
    const std::string near = nearest_setting(key);
    throw SettingError("unknown setting" + (near.empty() ? "" : " (did you mean " + near + "?)") +
                           "; `trellis settings` lists them all",
                       {origin.source.rfind("--", 0) == 0 ? "" : origin.source, origin.line,
                        origin.source.rfind("--", 0) == 0 ? origin.source + " " + key : key});
  }
  // Coerce and check by kind.
  switch (s->kind) {
    case SettingKind::Number:
      if (auto* i = std::get_if<long long>(&value)) value = static_cast<double>(*i);
      if (!std::holds_alternative<double>(value))
        throw SettingError("expected a number (" + s->range_text() + ")", where_of(*s, origin));
      check_number(*s, std::get<double>(value), origin);
      break;
    case SettingKind::Integer:
      if (auto* t = std::get_if<std::string>(&value))
        for (const auto& [name, v] : s->names)
          if (*t == name) {
            value = v;
            break;
          }
      if (auto* d = std::get_if<double>(&value))
        if (std::isfinite(*d) && std::floor(*d) == *d && std::abs(*d) < 9e15)
          value = static_cast<long long>(*d);
      if (!std::holds_alternative<long long>(value))
        throw SettingError("expected a whole number (" + s->range_text() + ")",
                           where_of(*s, origin));
      check_number(*s, static_cast<double>(std::get<long long>(value)), origin);
      break;
    case SettingKind::Bool:
      if (!std::holds_alternative<bool>(value))
        throw SettingError("expected true or false", where_of(*s, origin));
      break;
    case SettingKind::Choice:
      if (!std::holds_alternative<std::string>(value) ||
          std::find(s->choices.begin(), s->choices.end(), std::get<std::string>(value)) ==
              s->choices.end())
        throw SettingError((std::holds_alternative<std::string>(value)
                                ? "'" + std::get<std::string>(value) + "' is not allowed"
                                : std::string("expected a name")) +
                               " (" + s->range_text() + ")",
                           where_of(*s, origin));
      break;
    case SettingKind::Text:
      if (!std::holds_alternative<std::string>(value))
        throw SettingError("expected a string", where_of(*s, origin));
      break;
    case SettingKind::Numbers: {
      if (auto* b = std::get_if<bool>(&value); b && s->flags)
        value = std::vector<double>{*b ? 1.0 : 0.0};
      if (auto* d = std::get_if<double>(&value)) value = std::vector<double>{*d};
      if (auto* i = std::get_if<long long>(&value))
        value = std::vector<double>{static_cast<double>(*i)};
      if (!std::holds_alternative<std::vector<double>>(value))
        throw SettingError("expected " + s->range_text(), where_of(*s, origin));
      const auto& xs = std::get<std::vector<double>>(value);
      if ((s->count && xs.size() != static_cast<std::size_t>(s->count)) || xs.empty())
        throw SettingError(fmt::format("expected {} (got {} value(s))", s->range_text(), xs.size()),
                           where_of(*s, origin));
      for (double x : xs) {
        check_number(*s, x, origin);
        if (s->whole && std::floor(x) != x)
          throw SettingError(number_text(x) + " is not a whole number", where_of(*s, origin));
      }
      break;
    }
  }
  entries_[key] = {std::move(value), origin};
}

void Settings::set_text(const std::string& key, const std::string& text,
                        const SettingOrigin& origin) {
  const Setting* s = find_setting(key);
  if (!s) return set(key, text, origin);  // throws "unknown setting"
  switch (s->kind) {
    case SettingKind::Number:
    case SettingKind::Integer: {
      std::string t = text;
      t.erase(0, t.find_first_not_of(" \t"));
      t.erase(t.find_last_not_of(" \t") + 1);
      for (const auto& [name, v] : s->names)
        if (t == name) return set(key, v, origin);
      double v = 0;
      const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
      if (t.empty() || r.ec != std::errc() || r.ptr != t.data() + t.size())
        throw SettingError("'" + text + "' is not a number (expected " + s->range_text() + ")",
                           where_of(*s, origin));
      if (s->kind == SettingKind::Integer) {
        if (std::floor(v) != v || std::abs(v) > 9e15)
          throw SettingError(
              "'" + text + "' is not a whole number (expected " + s->range_text() + ")",
              where_of(*s, origin));
        return set(key, static_cast<long long>(v), origin);
      }
      return set(key, v, origin);
    }
    case SettingKind::Bool:
      if (text == "true" || text == "1" || text == "yes" || text == "on")
        return set(key, true, origin);
      if (text == "false" || text == "0" || text == "no" || text == "off")
        return set(key, false, origin);
      throw SettingError("'" + text + "' is not true or false", where_of(*s, origin));
    case SettingKind::Numbers:
      return set(key, parse_numbers(*s, text, origin), origin);
    default:
      return set(key, text, origin);
  }
}

namespace {

SettingValue value_of(const toml::node& n, const Setting& s, const SettingOrigin& o) {
  if (n.is_floating_point()) return *n.value<double>();
  if (n.is_integer()) return static_cast<long long>(*n.value<std::int64_t>());
  if (n.is_boolean()) return *n.value<bool>();
  if (n.is_string()) {
    // A list written as a string ("1,2,3") is fine for lists.
    if (s.kind == SettingKind::Numbers) return parse_numbers(s, *n.value<std::string>(), o);
    return *n.value<std::string>();
  }
  if (const auto* arr = n.as_array()) {
    std::vector<double> xs;
    for (const auto& x : *arr) {
      if (s.flags && x.is_boolean()) {
        xs.push_back(*x.value<bool>() ? 1 : 0);
        continue;
      }
      if (!x.is_number()) throw SettingError("expected " + s.range_text(), where_of(s, o));
      xs.push_back(*x.value<double>());
    }
    return xs;
  }
  throw SettingError("expected " + type_name(s), where_of(s, o));
}

void walk(Settings& out, const toml::table& t, const std::string& prefix, const std::string& origin,
          const std::vector<std::string>& skip) {
  for (const auto& [k, node] : t) {
    const std::string name(k.str());
    if (prefix.empty() && std::find(skip.begin(), skip.end(), name) != skip.end()) continue;
    const std::string key = prefix.empty() ? name : prefix + "." + name;
    const SettingOrigin o{origin, static_cast<long>(node.source().begin.line)};
    if (const auto* sub = node.as_table()) {
      walk(out, *sub, key, origin, skip);
      continue;
    }
    const Setting* s = find_setting(key);
    if (!s) {
      out.set(key, std::string(), o);  // throws with the nearest key
      continue;
    }
    out.set(key, value_of(node, *s, o), o);
  }
}

}  // namespace

void Settings::load_toml(const std::string& text, const std::string& origin,
                         const std::vector<std::string>& skip) {
  toml::table table;
  try {
    table = toml::parse(text, origin);
  } catch (const toml::parse_error& e) {
    throw SettingError(std::string(e.description()),
                       {origin, static_cast<long>(e.source().begin.line)});
  }
  walk(*this, table, "", origin, skip);
}

void Settings::load_toml_file(const std::string& path, const std::vector<std::string>& skip) {
  load_toml(read_file(path), path, skip);
}

const Settings::Entry* Settings::find(const std::string& key) const {
  const auto it = entries_.find(key);
  return it == entries_.end() ? nullptr : &it->second;
}

SettingValue Settings::value(const std::string& key) const {
  if (const Entry* e = find(key)) return e->value;
  const Setting* s = find_setting(key);
  if (!s) throw SettingError("unknown setting", {"", 0, key});
  return s->get(defaults());
}

std::string Settings::origin_text(const std::string& key) const {
  const Entry* e = find(key);
  if (!e) return "default";
  if (e->origin.line > 0) return e->origin.source + ":" + std::to_string(e->origin.line);
  return e->origin.source;
}

Config Settings::config() const {
  Config c;
  for (const auto& [key, e] : entries_) find_setting(key)->set(c, e.value);
  c.aero.seed = c.plan.gippo.seed;
  // The periodic method's cell is the made lattice's unless given.
  if (!find("aero.cell_type")) c.aero.periodic.cell = c.lattice3d.cells.cell;
  if (!find("aero.cell")) c.aero.periodic.size = c.lattice3d.cells.size;
  // machine.name names printer and laser profiles alike. Every output's job header records it,
  // the default too; the printer's default name read back from a laser build's header (merge,
  // rerun) names no laser, so the laser keeps its own default.
  if (c.machine.name != MachineProfile{}.name) c.laser.name = c.machine.name;
  return c;
}

MachineProfile machine_profile_from_toml(const std::string& text, const std::string& origin,
                                         const std::vector<std::string>& sets) {
  Settings st;
  st.load_toml(text, origin);
  for (const auto& s : sets) {
    const auto eq = s.find('=');
    if (eq == std::string::npos)
      throw SettingError("expected section.key=value, got '" + s + "'", {"", 0, "--set"});
    st.set_text(s.substr(0, eq), s.substr(eq + 1), {"--set"});
  }
  MachineProfile p = st.config().machine;
  try {
    validate(p);
  } catch (const SettingError& e) {
    const std::string& key = e.where().element;
    const Settings::Entry* given = st.find(key);
    throw SettingError(
        e.message(), {given ? given->origin.source : origin, given ? given->origin.line : 0, key});
  }
  return p;
}

MachineProfile load_machine_profile(const std::string& path, const std::vector<std::string>& sets) {
  return machine_profile_from_toml(read_file(path), path, sets);
}

void check_rules(const Config& c, const Settings& st, const std::vector<std::string>& sections) {
  auto uses = [&](const std::string& sec) {
    return std::find(sections.begin(), sections.end(), sec) != sections.end();
  };
  auto where = [&](const std::string& a, const std::string& b) {
    return Where{"", 0,
                 a + " (" + st.origin_text(a) + ") and " + b + " (" + st.origin_text(b) + ")"};
  };
  const double nozzle = c.machine.nozzle_diameter;
  const bool fdm = c.machine.marlin_family();  // Marlin, RepRapFirmware, Klipper
  // In air (FDM: Marlin, RepRapFirmware, Klipper) a bead taller than 0.8 × the nozzle does not
  // bond; in a bath or from a syringe the bead is a strut as thick as the nozzle, so the rule is
  // FDM's only.
  if (uses("extrusion") && fdm && c.machine.layer_height > 0.8 * nozzle + 1e-12)
    throw SettingError(
        fmt::format("layer height {} mm is more than 0.8 × the nozzle ({} mm): the "
                    "bead would not bond; lower the layer height or use a larger nozzle",
                    number_text(c.machine.layer_height), number_text(nozzle)),
        where("extrusion.layer_height", "extrusion.nozzle_diameter"));
  // A mixing hotend's command must be one the firmware has: Marlin M165 or M163/M164,
  // RepRapFirmware M567; Klipper has no mixing command (a macro: gradient.dialect = template).
  const MachineProfile& m = c.machine;
  if (uses("gradient") && m.gradient_mode == GradientMode::Mixing && m.mixing_inputs > 1 &&
      m.gradient_dialect != MixingDialect::Template && m.marlin_family()) {
    const Flavor f = m.flavor;
    const MixingDialect d = m.gradient_dialect;
    const bool ok =
        (f == Flavor::Marlin && (d == MixingDialect::M165 || d == MixingDialect::M163)) ||
        (f == Flavor::RepRap && d == MixingDialect::M567);
    const std::string has = f == Flavor::Marlin   ? "m165 or m163"
                            : f == Flavor::RepRap ? "m567"
                                                  : "";
    if (!ok)
      throw SettingError(
          fmt::format("{} has no {} command for a mixing hotend; use "
                      "gradient.dialect = {}",
                      f == Flavor::Marlin   ? "Marlin"
                      : f == Flavor::RepRap ? "RepRapFirmware"
                                            : "Klipper",
                      d == MixingDialect::M165   ? "M165"
                      : d == MixingDialect::M163 ? "M163/M164"
                                                 : "M567",
                      !has.empty() ? has + " (or template with a macro)"
                                   : "template with gradient.template naming your macro"),
          where("gradient.dialect", "machine.flavor"));
  }
  auto bead_rule = [&](const char* key, double w) {
    if (!st.has(key)) return;
    if (w < 0.5 * nozzle - 1e-12 || w > 2.5 * nozzle + 1e-12)
      throw SettingError(fmt::format("bead width {} mm is outside 0.5 .. 2.5 × the nozzle ({} mm)",
                                     number_text(w), number_text(nozzle)),
                         where(key, "extrusion.nozzle_diameter"));
  };
  if (uses("slice")) bead_rule("slice.bead_width", c.slice.planar.bead_width);
  if (uses("nonplanar")) bead_rule("nonplanar.bead_width", c.nonplanar.params.width);
  if (uses("lattice2d") && c.lattice2d.handles && c.lattice2d.region.shape == RegionShape::Circle)
    throw SettingError("tensile handles need a rectangle region",
                       where("lattice2d.handles", "lattice2d.region"));
}

std::string settings_toml(const Settings& st, const std::vector<std::string>& sections,
                          const std::function<bool(const Setting&)>& keep) {
  std::string out;
  for (const auto& [sec, _] : setting_sections()) {
    if (std::find(sections.begin(), sections.end(), sec) == sections.end()) continue;
    std::string body;
    for (const auto& s : all_settings()) {
      if (s.section() != sec) continue;
      if (!s.derived.empty() && !st.has(s.key)) continue;
      if (keep && !keep(s)) continue;
      const SettingValue v = st.value(s.key);
      if (const auto* xs = std::get_if<std::vector<double>>(&v); xs && xs->empty()) continue;
      const std::string name = s.key.substr(sec.size() + 1);
      std::string val;
      if (std::holds_alternative<std::string>(v)) {
        std::ostringstream os;
        os << toml::value<std::string>(std::get<std::string>(v));
        val = os.str();
      } else if (const auto* xs = std::get_if<std::vector<double>>(&v)) {
        val = "[";
        for (std::size_t i = 0; i < xs->size(); ++i) {
          std::string n = number_text((*xs)[i]);
          if (s.flags) n = (*xs)[i] != 0 ? "true" : "false";
          if (!s.flags && n.find_first_of(".en") == std::string::npos) n += ".0";
          val += (i ? ", " : "") + n;
        }
        val += "]";
      } else if (const auto* d = std::get_if<double>(&v)) {
        val = number_text(*d);
        if (val.find_first_of(".en") == std::string::npos) val += ".0";
        if (val == "inf" || val == "-inf" || val == "nan") val = "0.0";
      } else {
        val = value_text(v);
      }
      body += name + " = " + val + "\n";
    }
    if (!body.empty()) out += "[" + sec + "]\n" + body;
  }
  return out;
}

std::string settings_reference(const std::vector<std::string>& sections) {
  std::string out;
  for (const auto& [sec, what] : setting_sections()) {
    if (!sections.empty() && std::find(sections.begin(), sections.end(), sec) == sections.end())
      continue;
    out += "[" + sec + "] " + what + "\n";
    for (const auto& s : all_settings()) {
      if (s.section() != sec) continue;
      std::string line = "  " + s.key;
      if (line.size() < 30) line.resize(30, ' ');
      std::string def = s.derived.empty() ? s.default_text() : "";
      for (auto& ch : def)
        if (ch == '\n') ch = ' ';
      if (def.size() > 40) def = def.substr(0, 37) + "...";
      out += line + " " + s.doc + (s.unit.empty() || s.unit == "path" ? "" : " [" + s.unit + "]") +
             "\n" + std::string(31, ' ') +
             "default: " + (s.derived.empty() ? (def.empty() ? "\"\"" : def) : s.derived) + "; " +
             s.range_text() + (s.flag.empty() ? "" : "; flag --" + s.flag) + "\n";
      if (!s.when.empty()) out += std::string(31, ' ') + "used when " + when_text(s.when) + "\n";
    }
  }
  return out;
}

namespace {

std::vector<std::string> split_on(const std::string& text, const std::string& sep) {
  std::vector<std::string> out;
  std::size_t at = 0;
  for (;;) {
    const std::size_t next = text.find(sep, at);
    out.push_back(text.substr(at, next == std::string::npos ? std::string::npos : next - at));
    if (next == std::string::npos) return out;
    at = next + sep.size();
  }
}

const char* fact_words(const std::string& fact) {
  if (fact == "gcode") return "G-code is written";
  if (fact == "preview") return "PNG previews are written";
  if (fact == "input") return "a design or lattice file is read";
  if (fact == "report") return "a report is written";
  if (fact == "3mf") return "the output is 3MF";
  if (fact == "mesh") return "the input is a mesh (STL, OBJ, 3MF)";
  if (fact == "bgcode") return "the G-code output is binary (.bgcode)";
  if (fact == "job") return "a job file is run (trellis run)";
  if (fact == "graded") return "the toolpath carries mixtures (a graded design)";
  if (fact == "tools") return "the toolpath uses several tools";
  if (fact == "process") return "the toolpath carries process values (a process field)";
  return nullptr;
}

std::string fact_negated(const std::string& fact) {
  if (fact == "gcode") return "no G-code is written";
  if (fact == "preview") return "no PNG previews are written";
  if (fact == "input") return "no design or lattice file is read";
  if (fact == "report") return "no report is written";
  if (fact == "mesh") return "the input is not a mesh";
  return std::string("not: ") + fact_words(fact);
}

// One alternative of a term: whether it holds, and its words ("lattice2d.pattern = voronoi").
struct Alternative {
  bool holds = false;
  std::string words, here;  // `here`: the value in force, for the reason
};

std::string value_in_force(const UseContext& use, const std::string& key) {
  if (key == "route") return use.route;
  if (!use.settings || !find_setting(key)) return "";
  try {
    return value_text(use.settings->value(key));
  } catch (const std::exception&) {
    return "";  // a derived setting left unset
  }
}

Alternative evaluate(const std::string& alt, const UseContext& use) {
  Alternative a;
  if (!alt.empty() && (alt[0] == '@' || (alt.size() > 1 && alt[0] == '!' && alt[1] == '@'))) {
    const bool negated = alt[0] == '!';
    const std::string fact = alt.substr(negated ? 2 : 1);
    const char* w = fact_words(fact);
    if (!w) throw std::logic_error("unknown fact in a setting's `when`: " + alt);
    const bool has = std::find(use.facts.begin(), use.facts.end(), fact) != use.facts.end();
    const bool unknown =
        std::find(use.unknown.begin(), use.unknown.end(), fact) != use.unknown.end();
    a.holds = unknown || has != negated;
    a.words = negated ? fact_negated(fact) : std::string(w);
    return a;
  }
  const std::size_t ne = alt.find("!="), eq = alt.find('='), gt = alt.find('>');
  if (ne != std::string::npos || eq != std::string::npos) {
    const bool negated = ne != std::string::npos;
    const std::string key = alt.substr(0, negated ? ne : eq);
    const std::string list = alt.substr(negated ? ne + 2 : eq + 1);
    a.here = value_in_force(use, key);
    bool any = false;
    for (const auto& v : split_on(list, "|")) any |= v == a.here;
    a.holds = any != negated;
    std::string shown = list;
    for (std::size_t i = 0; (i = shown.find('|', i)) != std::string::npos;)
      shown.replace(i, 1, " or "), i += 4;
    if (shown.empty()) shown = "''";
    a.words = key + (negated ? " is not " : " = ") + shown;
    return a;
  }
  if (gt != std::string::npos) {
    const std::string key = alt.substr(0, gt);
    a.here = value_in_force(use, key);
    double v = 0;
    try {
      v = std::stod(a.here);
    } catch (const std::exception&) {
    }
    a.holds = v > std::stod(alt.substr(gt + 1));
    a.words = key + " > " + alt.substr(gt + 1);
    return a;
  }
  a.here = value_in_force(use, alt);
  a.holds = !a.here.empty();
  a.words = alt + " is given";
  return a;
}

}  // namespace

std::string unused_reason(const Setting& s, const UseContext& use) {
  if (s.when.empty()) return "";
  for (const auto& term : split_on(s.when, "; ")) {
    bool holds = false;
    std::string words, here;
    for (const auto& alt : split_on(term, " or ")) {
      const Alternative a = evaluate(alt, use);
      holds |= a.holds;
      words += (words.empty() ? "" : " or ") + a.words;
      if (!a.here.empty() && here.empty()) here = a.here;
    }
    if (!holds)
      return "it is used only when " + words +
             (here.empty() ? std::string() : " (here " + here + ")");
  }
  return "";
}

bool route_uses(const Setting& s, const std::string& route, const Settings* choices) {
  if (s.when.empty()) return true;
  UseContext use;
  use.route = route;
  use.settings = choices;
  for (const auto& term : split_on(s.when, "; ")) {
    const auto alts = split_on(term, " or ");
    const bool only_route = std::all_of(alts.begin(), alts.end(), [&](const std::string& a) {
      if (a.rfind("route=", 0) == 0 || a.rfind("route!=", 0) == 0) return true;
      const std::size_t op = a.find_first_of("!=>");
      return choices && op != std::string::npos && a[0] != '@' && a[0] != '!' &&
             choices->has(a.substr(0, op));
    });
    if (only_route && !unused_reason(Setting{.key = s.key, .when = term}, use).empty())
      return false;
  }
  return true;
}

std::string when_text(const std::string& when) {
  std::string out;
  for (const auto& term : split_on(when, "; ")) {
    std::string words;
    for (const auto& alt : split_on(term, " or ")) {
      UseContext none;
      words += (words.empty() ? "" : " or ") + evaluate(alt, none).words;
    }
    out += (out.empty() ? "" : "; ") + words;
  }
  return out;
}

std::string settings_markdown() {
  std::string out =
      "# Settings\n\n"
      "Generated from the schema (`src/settings/schema.cpp`) by `trellis settings --markdown`;\n"
      "a test fails when this file is stale. Every setting can be given in a machine or laser\n"
      "profile, in a job file (`[section]` tables), with `--set section.key=value` on any\n"
      "command, or with its flag where the command has one. Precedence: built-in default <\n"
      "profile < job file < command line.\n\n";
  for (const auto& [sec, what] : setting_sections()) {
    out += "## [" + sec + "] " + what +
           "\n\n| key | type | unit | default | range | flag | what |\n"
           "|---|---|---|---|---|---|---|\n";
    for (const auto& s : all_settings()) {
      if (s.section() != sec) continue;
      std::string def = s.derived.empty() ? s.default_text() : "(" + s.derived + ")";
      for (auto& ch : def)
        if (ch == '\n' || ch == '|') ch = ' ';
      std::string range = s.range_text();
      for (auto& ch : range)
        if (ch == '|') ch = '/';
      std::string doc = s.doc;
      if (!s.when.empty()) doc += " (used when " + when_text(s.when) + ")";
      for (auto& ch : doc)
        if (ch == '|') ch = '/';
      out += "| `" + s.key + "` | " + type_name(s) + " | " + s.unit + " | `" + def + "` | " +
             range + " | " + (s.flag.empty() ? "" : "`--" + s.flag + "`") + " | " + doc + " |\n";
    }
    out += "\n";
  }
  return out;
}

}  // namespace trellis
