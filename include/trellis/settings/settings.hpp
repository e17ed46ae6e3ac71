// One settings schema for every route. Each user-visible setting is declared once (dotted key,
// kind, unit, range, choices, one-line doc, CLI flag) in src/settings/schema.cpp, bound to the
// member of the typed params struct that uses it; its default is that member's initialiser, so
// no default exists in two places. CLI flags, job keys, `--help`, `trellis settings`,
// docs/settings.md, output headers and rerun all come from the declarations.
//
// Values arrive in layers — built-in default < machine/laser profile < job file < command line —
// each remembering where it came from, so an error names the file:line or the flag.
#pragma once
#include <functional>
#include <map>
#include <string>
#include <variant>
#include <vector>

#include "trellis/settings/config.hpp"

namespace trellis {

enum class SettingKind { Number, Integer, Bool, Choice, Text, Numbers };

using SettingValue = std::variant<double, long long, bool, std::string, std::vector<double>>;

struct Setting {
  std::string key;  // "section.name"
  SettingKind kind = SettingKind::Number;
  std::string unit;  // "mm", "mm/s", "" ...
  std::string doc;   // one line
  std::string flag;  // long CLI flag without dashes ("layer-height"); empty = job key / --set only
  double min = -1e300, max = 1e300;  // inclusive range of a number (each number of a list)
  bool positive = false;             // the range excludes min itself (> min)
  std::vector<std::string> choices;  // Choice
  int count = 0;                     // Numbers: exact count (0 = any)
  std::vector<std::pair<std::string, long long>> names;  // Integer: named values ("none" = 0)
  bool whole = false;                                    // Numbers: each a whole number
  // Numbers: each true or false, held as 1 or 0 (a TOML list of booleans, "true,false" as text,
  // or 1 and 0 are read); a per-laser switch such as lasers.skywriting.
  bool flags = false;
  // Settings whose value by default follows another one (e.g. the bead width follows the
  // nozzle): unset, the route derives it; this text says from what.
  std::string derived;
  // When the setting is used at all (empty: whenever its route reads its section). Terms joined
  // by "; " must all hold; a term's alternatives are joined by " or "; each is `key=a|b`,
  // `key!=a|b`, `key>n` (a number), `key` (given or not empty), `route=a|b`, or a fact of the run
  // `@gcode` (G-code is written), `@preview` (PNG previews are), `@input` (a design or lattice
  // file is read), `@report`, `@3mf` (the output is 3MF), `@job` (a job file is run), and of the
  // toolpath written:
  // `@graded` (paths carry mixtures), `@tools` (several tools), `@process` (process values); each
  // negated with a leading `!`. A setting the user gives where this does not hold is refused,
  // naming the reason (unused_reason); docs/settings.md prints it.
  std::string when;
  std::function<SettingValue(const Config&)> get;
  std::function<void(Config&, const SettingValue&)> set;

  std::string section() const { return key.substr(0, key.find('.')); }
  // The built-in default as text ("" when derived).
  std::string default_text() const;
  std::string range_text() const;  // "0.001 .. 10", "one of max, min", ...
};

// Every setting, in declaration order (grouped by section).
const std::vector<Setting>& all_settings();
const Setting* find_setting(const std::string& key);
// The known key nearest to `key` (edit distance), for "did you mean" hints; empty if none close.
std::string nearest_setting(const std::string& key);
// A library message as the command line says it: every setting key in `message` that has a flag
// becomes `--flag (key)` (library messages name keys, which are also Python's keyword arguments;
// the flag is the command line's own name for them). A key already written so is left alone.
std::string with_flags(const std::string& message);
// Sections in declaration order, with a one-line description each.
const std::vector<std::pair<std::string, std::string>>& setting_sections();

// The text of a value, shortest round-trip for numbers ("0.148", "4e-07", "1,2,3" for lists).
std::string value_text(const SettingValue& v);

struct SettingOrigin {
  std::string source;  // "profiles/x.toml", "job.toml", "--layer-height", "--set", "output header"
  long line = 0;
};

// The layered values of one run. Later `set` calls win, so apply layers in precedence order.
class Settings {
 public:
  struct Entry {
    SettingValue value;
    SettingOrigin origin;
  };

  // Sets `key` from text (CLI flags, --set, headers), parsed by the setting's kind and checked
  // against its range; errors name the key, the origin and the allowed values.
  void set_text(const std::string& key, const std::string& text, const SettingOrigin& origin);
  void set(const std::string& key, SettingValue value, const SettingOrigin& origin);
  // Reads a TOML document of [section] tables of settings (a profile or a job's settings).
  // `skip` lists top-level tables that are not settings (e.g. "job"). Unknown keys are errors
  // naming file:line with the nearest known key.
  void load_toml(const std::string& text, const std::string& origin,
                 const std::vector<std::string>& skip = {});
  void load_toml_file(const std::string& path, const std::vector<std::string>& skip = {});

  bool has(const std::string& key) const { return entries_.count(key) != 0; }
  const Entry* find(const std::string& key) const;
  const std::map<std::string, Entry>& entries() const { return entries_; }

  // Defaults with every set value applied, then cross-setting rules checked.
  Config config() const;
  // The value in force: set, or the default (throws for a derived setting that is unset).
  SettingValue value(const std::string& key) const;
  // Where the value in force came from ("default" when unset).
  std::string origin_text(const std::string& key) const;

 private:
  std::map<std::string, Entry> entries_;
};

// What a run is, for Setting::when: its route, the facts ("gcode", "preview", "input", "report",
// "3mf") and the settings in force.
struct UseContext {
  std::string route;
  std::vector<std::string> facts;
  std::vector<std::string>
      unknown;  // facts not known yet (the toolpath's, before it is made): they hold
  const Settings* settings = nullptr;
};
// Why `s` has no effect in this run ("" when it is used): e.g. "it is used only when
// lattice2d.pattern = voronoi (here honeycomb)".
std::string unused_reason(const Setting& s, const UseContext& use);
// Whether `route` uses `s` at all: every term of its `when` that names only the route holds (the
// other terms depend on the run). The reader routes' flags and their --set follow it.
// With `choices` (settings fixed before the run, such as plan.planner for Python's
// plan(planner, ...)), terms that name only the route and those settings count too.
bool route_uses(const Setting& s, const std::string& route, const Settings* choices = nullptr);
// `when` as words for documentation ("lattice2d.pattern = voronoi; G-code is written").
std::string when_text(const std::string& when);

// A machine profile read through the schema, the one loader: TOML text (or a file) of [section]
// tables, `sets` ("section.key=value") over it, the profile's own rules checked
// (machine/profile.hpp validate). SettingErrors name the file and line, or the --set.
MachineProfile machine_profile_from_toml(const std::string& text, const std::string& origin,
                                         const std::vector<std::string>& sets = {});
MachineProfile load_machine_profile(const std::string& path,
                                    const std::vector<std::string>& sets = {});

// Checks the rules between settings (layer height vs nozzle, bead width vs nozzle, ...), naming
// where the offending values came from. Route-specific rules take the sections the route uses.
void check_rules(const Config& config, const Settings& settings,
                 const std::vector<std::string>& sections);

// TOML text of every setting of `sections` with its value in force, one [section] table each,
// keys in declaration order. Derived settings that are unset are left out, and so are those
// `keep` (when given) turns down.
std::string settings_toml(const Settings& settings, const std::vector<std::string>& sections,
                          const std::function<bool(const Setting&)>& keep = {});

// `trellis settings [SECTION...]`: every setting with unit, default, range and doc.
std::string settings_reference(const std::vector<std::string>& sections = {});
// docs/settings.md, generated (a test fails when the file in the repo is stale).
std::string settings_markdown();

}  // namespace trellis
