// The `trellis._trellis` extension: the library's job runner, readers and writers for Python.
// Routes run with the GIL released on a worker thread; the calling thread waits, delivers
// progress to a Python callable and turns Ctrl-C into the library's cancel flag. Toolpaths and
// lattices are handed to numpy as whole arrays, never as per-point Python objects.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <thread>
#include <tuple>

#include "bindings.hpp"
#include "trellis/analysis/collisions.hpp"
#include "trellis/analysis/metrics.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/core/output_names.hpp"
#include "trellis/field/vcad.hpp"
#include "trellis/job/job.hpp"
#include "trellis/job/plate.hpp"
#include "trellis/lattice/io.hpp"
#include "trellis/machine/cli.hpp"
#include "trellis/machine/gcode_reader.hpp"
#include "trellis/machine/gcode_writer.hpp"
#include "trellis/machine/machine_check.hpp"
#include "trellis/render/render.hpp"
#include "trellis/toolpath/json.hpp"
#include "trellis/version.hpp"
#include "trellis/view/view.hpp"

namespace py = pybind11;
using namespace trellis;

namespace {

// Python errors (trellis/errors.py) with the library's file, line and element.
[[noreturn]] void raise_python(const char* cls, const Error& e) {
  py::object errors = py::module_::import("trellis.errors");
  py::object ex = errors.attr(cls)(e.what(), e.where().file, e.where().line, e.where().element);
  PyErr_SetObject(ex.get_type().ptr(), ex.ptr());
  throw py::error_already_set();
}

void translate(std::exception_ptr p) {
  try {
    if (p) std::rethrow_exception(p);
  } catch (const SettingError& e) {
    raise_python("SettingError", e);
  } catch (const GeometryError& e) {
    raise_python("GeometryError", e);
  } catch (const MachineError& e) {
    raise_python("MachineError", e);
  } catch (const Cancelled& e) {
    PyErr_SetString(PyExc_KeyboardInterrupt, e.what());
  } catch (const ParseError& e) {
    raise_python("InputError", e);
  } catch (const IoError& e) {
    raise_python("InputError", e);
  } catch (const Error& e) {
    raise_python("TrellisError", e);
  }
}

// A Python value as a setting value (numbers, bools, text, sequences of numbers).
SettingValue to_value(const std::string& name, const py::handle& v) {
  if (py::isinstance<py::bool_>(v)) return v.cast<bool>();
  if (py::isinstance<py::int_>(v) || (PyIndex_Check(v.ptr()) && !py::isinstance<py::array>(v))) {
    int overflow = 0;
    const long long n = PyLong_AsLongLongAndOverflow(
        py::int_(py::reinterpret_borrow<py::object>(v)).ptr(), &overflow);
    if (overflow != 0)
      throw SettingError(
          "integer " + std::string(py::str(v)) + " is beyond the range of a setting (±9.2e18)",
          {"", 0, name});
    return n;
  }
  if (py::isinstance<py::float_>(v)) return v.cast<double>();
  if (py::isinstance<py::str>(v)) return v.cast<std::string>();
  if (py::isinstance<py::array>(v) || py::isinstance<py::sequence>(v)) {
    std::vector<double> xs;
    for (const auto& x : py::iter(v)) {
      if (!py::isinstance<py::float_>(x) && !py::isinstance<py::int_>(x) &&
          !py::isinstance<py::array>(x))
        throw SettingError("expected numbers", {"", 0, name});
      xs.push_back(x.cast<double>());
    }
    return xs;
  }
  throw SettingError("unsupported value type " + std::string(py::str(v.get_type())), {"", 0, name});
}

}  // namespace

void run_interruptible(const std::function<void(const RunContext&)>& fn, const py::object& callback,
                       RunContext context) {
  std::atomic<bool> cancel{false};
  std::mutex m;
  std::condition_variable cv;
  bool done = false;
  std::string stage;
  double fraction = -1;
  Progress& progress = context.progress;
  progress.cancel = &cancel;
  progress.report = [&](const std::string& s, double f) {
    std::lock_guard<std::mutex> lock(m);
    stage = s, fraction = f;
  };
  std::exception_ptr error, worker_error;
  std::thread worker([&] {
    try {
      fn(context);
    } catch (...) {
      worker_error = std::current_exception();
    }
    std::lock_guard<std::mutex> lock(m);
    done = true;
    cv.notify_all();
  });
  bool interrupted = false;
  for (;;) {
    std::string s;
    double f = -1;
    bool finished = false;
    {
      py::gil_scoped_release release;
      std::unique_lock<std::mutex> lock(m);
      cv.wait_for(lock, std::chrono::milliseconds(50), [&] { return done; });
      finished = done;
      s = stage, f = fraction;
      fraction = -1;
    }
    if (f >= 0 && !callback.is_none()) {
      try {
        callback(s, f);
      } catch (py::error_already_set&) {
        cancel = true;  // the callback raised: stop, then re-raise below
        interrupted = true;
        error = std::current_exception();
      }
    }
    if (finished) break;
    if (PyErr_CheckSignals() != 0) {  // Ctrl-C: the KeyboardInterrupt is now pending
      cancel = true;
      interrupted = true;
      error = nullptr;
      break;
    }
    if (interrupted) break;  // the progress callback raised
  }
  {
    py::gil_scoped_release release;
    worker.join();
  }
  // Interrupted: the worker's own error (it was cancelled) is not the news.
  if (interrupted) {
    if (error) std::rethrow_exception(error);  // what the callback raised
    throw py::error_already_set();             // the pending KeyboardInterrupt
  }
  if (worker_error) std::rethrow_exception(worker_error);
}

namespace {

// Runs a job interruptibly; its files, summary, warnings and in-memory results as a dict.
py::dict run_job_dict(const Job& job, const py::object& progress) {
  Diagnostics diag;
  JobResult r;
  RunContext context;
  context.diagnostics = &diag;
  run_interruptible([&](const RunContext& c) { r = run_job(job, c); }, progress, context);
  py::dict d;
  d["files"] = r.files;
  d["summary"] = r.summary;
  d["exit_code"] = r.exit_code;
  py::list warnings;
  for (const auto& msg : diag.messages()) warnings.append(py::make_tuple(msg.kind, msg.text));
  d["warnings"] = warnings;
  d["toolpath"] =
      r.toolpath ? py::object(py::cast(std::make_shared<Toolpath>(*r.toolpath))) : py::none();
  d["lattice"] = r.lattice ? py::object(py::cast(std::make_shared<Graph>(*r.lattice))) : py::none();
  return d;
}

// What a reader run writes: the command's -o, --report and --preview.
struct ReadOutputs {
  std::string output, report, preview;
};

// A reader run from Python as its command runs it (its row of the route table): the Job built under
// the GIL, then run interruptibly (Ctrl-C, progress) as the routes are.
JobResult run_read(const std::string& route, const py::object& design, const py::object& print,
                   const std::string& machine, const py::dict& settings, const ReadOutputs& out,
                   Diagnostics& diag, const py::object& progress) {
  Job job;
  job.route = route;
  if (!route_spec(route, {"", 0, "route"}).reads)
    throw SettingError(
        "'" + route + "' makes its output: run it with trellis." + route + "() or trellis.run_job",
        {"", 0, "route"});
  job.machine = machine;
  job.output = out.output;
  job.report = out.report;
  job.preview = out.preview;
  if (py::isinstance<Graph>(design))
    job.design_graph = design.cast<std::shared_ptr<Graph>>();
  else if (!design.is_none())
    job.design = design.cast<std::string>();
  if (py::isinstance<Toolpath>(print))
    job.print = print.cast<std::shared_ptr<Toolpath>>();
  else if (py::isinstance<py::str>(print))
    job.inputs = {print.cast<std::string>()};
  else
    job.inputs = print.cast<std::vector<std::string>>();
  for (const auto& [k, v] : settings) {
    const auto key = k.cast<std::string>();
    job.settings.set(key, to_value(key, v), {"keyword " + key});
  }
  JobResult r;
  RunContext context;
  context.diagnostics = &diag;
  run_interruptible([&](const RunContext& c) { r = run_job(job, c); }, progress, context);
  return r;
}

std::vector<std::string> flag_keys(const std::vector<std::string>& sections) {
  std::vector<std::string> out;
  for (const auto& s : all_settings())
    if (std::find(sections.begin(), sections.end(), s.section()) != sections.end())
      out.push_back(s.key);
  return out;
}

}  // namespace

PYBIND11_MODULE(_trellis, m) {
  m.doc() = "Trellis: toolpaths for architected materials (the C++ core).";
  py::register_exception_translator(&translate);

  m.def("version", [] { return std::string(trellis::version()); });
  // The routes that make (python/trellis builds a function from each row); the readers, rows of
  // the same table (RouteSpec::reads), have their own functions on read_json: reader_names.
  m.def("route_names", [] {
    std::vector<std::string> names;
    for (const RouteSpec& r : route_specs())
      if (!r.reads) names.push_back(r.name);
    return names;
  });
  m.def("route_sections", &route_sections);
  // The route table (job/job.hpp RouteSpec) as python/trellis builds its functions and stubs
  // from it: each route's input, choice setting and the outputs it writes.
  m.def("routes", [] {
    py::list out;
    for (const RouteSpec& r : route_specs()) {
      if (r.reads) continue;
      py::dict d;
      d["name"] = r.name;
      d["input"] = r.input;
      d["sections"] = r.sections;
      d["choice"] = r.choice;
      d["shards"] = r.shards;
      d["plates"] = r.plates;
      // The job's outputs it writes, the first the one the function's `output` argument names:
      // the main one and its toolpath (a plan's: its toolpath, its G-code beside it), the report
      // and the previews.
      std::vector<std::string> outputs;
      if (r.gcode_beside_toolpath)
        outputs = {"toolpath", "gcode"};
      else if (r.report)
        outputs = {"output", "toolpath"};
      else
        outputs = {"output"};
      if (r.report) outputs.push_back("report");
      if (r.preview) outputs.push_back("preview");
      d["outputs"] = outputs;
      out.append(d);
    }
    return out;
  });
  // keyword -> setting key of a route's Python function (job.hpp route_keywords).
  m.def(
      "route_keywords",
      [](const std::string& route, const std::string& choice) {
        py::dict d;
        for (const auto& [name, key] : route_keywords(route_spec(route), choice))
          d[py::str(name)] = key;
        return d;
      },
      py::arg("route"), py::arg("choice") = "");
  m.def("settings", [] {
    py::list out;
    for (const auto& s : all_settings()) {
      py::dict d;
      d["key"] = s.key;
      d["section"] = s.section();
      const char* kinds[] = {"number", "integer", "bool", "choice", "text", "numbers"};
      // A list of switches (lasers.skywriting: true or false per laser) as such.
      d["kind"] = s.flags ? "flags" : kinds[static_cast<int>(s.kind)];
      d["unit"] = s.unit;
      d["doc"] = s.doc;
      d["flag"] = s.flag;
      d["default"] = s.derived.empty() ? py::cast(s.default_text()) : py::none();
      d["derived"] = s.derived;
      d["when"] = s.when.empty() ? std::string() : when_text(s.when);
      d["when_terms"] = s.when;  // as the schema writes it: "key=a|b or route=x; @fact"
      d["range"] = s.range_text();
      d["choices"] = s.choices;
      out.append(d);
    }
    return out;
  });

  // run(route, input, outputs: dict, machine, settings: dict key -> value, origins: dict key ->
  // name, command, progress) -> dict(files, summary, toolpath arrays, lattice arrays)
  m.def(
      "run",
      [](const std::string& route, const std::string& input,
         const std::map<std::string, std::string>& outputs, const std::string& machine,
         const py::dict& settings, const std::string& command, const py::object& progress) {
        Job job;
        job.route = route;
        route_sections(route);  // throws for an unknown route
        job.input = input;
        job.machine = machine;
        job.command = command;
        if (!machine.empty()) job.settings.load_toml_file(machine);
        const auto keys = flag_keys(route_sections(route));
        for (const auto& [k, v] : settings) {
          const auto key = k.cast<std::string>();
          if (key == "run.progress")
            throw SettingError(
                "run.progress is the command line's progress display; give "
                "progress=callable(stage, fraction) to the call instead",
                {"", 0, key});
          if (std::find(keys.begin(), keys.end(), key) == keys.end()) {
            if (!find_setting(key))
              job.settings.set(key, std::string(), {"keyword " + key});  // throws: unknown
            throw SettingError(
                "the " + route + " route does not read [" + key.substr(0, key.find('.')) + "]",
                {"", 0, key});
          }
          job.settings.set(key, to_value(key, v), {"keyword " + key});
        }
        for (const auto& [name, path] : outputs) {
          if (name == "output")
            job.output = path;
          else if (name == "report")
            job.report = path;
          else if (name == "toolpath")
            job.toolpath = path;
          else if (name == "gcode")
            job.gcode = path;
          else if (name == "lattice")
            job.lattice = path;
          else if (name == "preview")
            job.preview = path;
          else
            throw SettingError("unknown output '" + name + "'", {"", 0, name});
        }
        job.name = job.output.empty() ? route : std::filesystem::path(job.output).stem().string();
        return run_job_dict(job, progress);
      },
      py::arg("route"), py::arg("input"), py::arg("outputs"), py::arg("machine"),
      py::arg("settings"), py::arg("command"), py::arg("progress"));

  m.def("run_job_file", [](const std::string& path, const std::string& output_dir,
                           const std::vector<std::string>& sets, const py::object& progress) {
    return run_job_dict(load_job(path, output_dir, sets), progress);
  });

  // Exact sharding (job/plate.hpp), for trellis.distributed: shard "K/N" of a job file → the
  // files it wrote (the shard and its manifest, last); merge of the manifests → the output.
  m.def("run_shard", [](const std::string& path, const std::string& output_dir,
                        const std::vector<std::string>& sets, const std::string& shard) {
    Job job = load_job(path, output_dir, sets);
    std::tie(job.shard, job.shards) = parse_shard(shard);
    // The plan route says itself what of it shards (not aero; euler and gippo need G-code).
    require_shards(route_spec(job.route), {"", 0, "shard"});
    Diagnostics diag;
    py::gil_scoped_release release;
    return run_job(job, diag, {}).files;
  });
  m.def("merge_shards", [](const std::vector<std::string>& manifests, const std::string& out) {
    Diagnostics diag;
    py::gil_scoped_release release;
    return merge_shards(manifests, out, diag).files;
  });

  m.def("rerun", [](const std::string& path, const std::string& out) {
    const Job job = rerun_job(path, out);
    Diagnostics diag;
    py::gil_scoped_release release;
    return run_job(job, diag, {}).files;
  });

  // The rule of every output's name (core/output_names.hpp require_output_format) for the writers
  // of python/trellis (Field.mesh(stl=) checks its name before the mesh is made): formats as
  // (extension, format) pairs.
  m.def(
      "require_output_format",
      [](const std::string& path, const std::vector<std::pair<std::string, std::string>>& formats,
         const std::string& writer, const std::string& what, const std::string& element) {
        std::vector<OutputFormat> f;
        for (const auto& [ext, format] : formats) f.push_back({ext, format});
        require_output_format(path, f, writer, what, element);
      },
      py::arg("path"), py::arg("formats"), py::arg("writer"), py::arg("what"), py::arg("element"));

  m.def("viewer_notebook_script", &viewer_notebook_script,
        "the viewer's script for a notebook page, sent once before the views");

  py::class_<Toolpath, std::shared_ptr<Toolpath>>(m, "Toolpath")
      .def_property_readonly("layer_count", [](const Toolpath& t) { return t.layers.size(); })
      .def_property_readonly("path_count", &Toolpath::path_count)
      .def_property_readonly("point_count",
                             [](const Toolpath& t) {
                               std::size_t n = 0;
                               for (const auto& l : t.layers)
                                 for (const auto& p : l.paths) n += p.points.size();
                               return n;
                             })
      .def_property_readonly("extrusion_length", &Toolpath::extrusion_length)
      .def_readonly("source", &Toolpath::source)
      .def_property_readonly(
          "lasers",
          [](const Toolpath& t) {
            // The lasers the build file declares (Toolpath::lasers), laser 1 first: each a dict of
            // the [lasers] keys.
            py::list out;
            for (const LaserParameters& l : t.lasers) {
              const ScanTiming& s = l.timing;
              py::dict d;
              d["contour_power"] = l.contour_power;
              d["contour_speed"] = l.contour_speed;
              d["hatch_power"] = l.hatch_power;
              d["hatch_speed"] = l.hatch_speed;
              d["spot_diameter"] = l.spot_diameter;
              d["jump_speed"] = s.jump_speed;
              d["jump_delay"] = s.jump_delay;
              d["mark_delay"] = s.mark_delay;
              d["polygon_delay"] = s.polygon_delay;
              d["laser_on_delay"] = s.laser_on_delay;
              d["laser_off_delay"] = s.laser_off_delay;
              d["skywriting"] = s.skywriting;
              d["skywriting_time"] = s.skywriting_time;
              out.append(d);
            }
            return out;
          },
          "the lasers that differ as the build file declares them, laser 1 first (a dict each, "
          "keyed as [lasers]); empty when it declares none")
      .def("arrays", &toolpath_arrays, "every point and path attribute as numpy arrays (one copy)")
      .def("to_json", [](const Toolpath& t) { return toolpath_to_json(t); })
      .def(
          "view_html",
          [](const Toolpath& t, const std::string& title) {
            return viewer_html({view_scene(t, title)}, title);
          },
          py::arg("title") = "toolpath",
          "the interactive viewer page (trellis view) of this toolpath")
      .def(
          "save_view",
          [](const Toolpath& t, const std::string& path, const std::string& title) {
            // Named for the page written in it, as `trellis view -o` is; written atomically.
            require_output_format(path, {{".html", "HTML"}, {".htm", "HTML"}}, "Toolpath.save_view",
                                  "the viewer page", "path");
            write_file_atomic(path, viewer_html({view_scene(t, title)}, title));
          },
          py::arg("path"), py::arg("title") = "toolpath",
          "writes the viewer page (view_html) to `path`, named .html or .htm")
      .def(
          "view_notebook",
          [](const Toolpath& t, const std::string& title) {
            return viewer_notebook_view({view_scene(t, title)}, title);
          },
          py::arg("title") = "toolpath",
          "this toolpath's view in a notebook: data only, shown by viewer_notebook_script()")
      .def(
          "png",
          [](const Toolpath& t, std::size_t layer, int size) {
            if (layer >= t.layers.size())
              throw SettingError(
                  "layer " + std::to_string(layer) + " of " + std::to_string(t.layers.size()),
                  {"", 0, "layer"});
            if (size < 16 || size > 8000)
              throw SettingError(
                  "size " + std::to_string(size) + " px: expected 16..8000 (as output.image_size)",
                  {"", 0, "size"});
            // Rendered into a private folder (mode 0700, unpredictable name) and read back.
            std::string dir =
                (std::filesystem::temp_directory_path() / "trellis_png_XXXXXX").string();
            if (!::mkdtemp(dir.data()))
              throw IoError("cannot create a private temporary folder in " + dir);
            struct Remove {
              std::string dir;
              ~Remove() {
                std::error_code ec;
                std::filesystem::remove_all(dir, ec);
              }
            } remove{dir};
            const std::string tmp = dir + "/layer.png";
            RenderOptions ro;
            ro.size_px = size;
            render_layer_png(t, layer, tmp, ro);
            return py::bytes(read_file(tmp));
          },
          py::arg("layer") = 0, py::arg("size") = 600);

  py::class_<Graph, std::shared_ptr<Graph>>(m, "Lattice")
      .def_property_readonly("node_count", [](const Graph& g) { return g.nodes.size(); })
      .def_property_readonly("edge_count", [](const Graph& g) { return g.edges.size(); })
      .def_property_readonly("total_length", &Graph::total_length)
      .def("arrays", &lattice_arrays)
      .def("to_json", [](const Graph& g) { return lattice_to_json(g); })
      .def("write", [](const Graph& g, const std::string& path) { write_lattice(path, g); });

  m.def(
      "lattice_from_arrays",
      [](const py::object& nodes, const py::object& edges, const py::object& material) {
        return std::make_shared<Graph>(lattice_from_arrays(nodes, edges, material));
      },
      py::arg("nodes"), py::arg("edges"), py::arg("material") = py::none());
  m.def(
      "toolpath_from_arrays",
      [](const py::object& points, const py::object& path_offsets, const py::object& layer_offsets,
         const py::object& layer_z, const py::dict& attributes) {
        return std::make_shared<Toolpath>(
            toolpath_from_arrays(points, path_offsets, layer_offsets, layer_z, attributes));
      },
      py::arg("points"), py::arg("path_offsets"), py::arg("layer_offsets"), py::arg("layer_z"),
      py::arg("attributes"));
  bind_fields(m);
  m.def(
      "read_lattice",
      [](const std::string& path, double merge_tolerance) {
        Diagnostics diag;
        return std::make_shared<Graph>(read_lattice(path, {merge_tolerance, true}, diag));
      },
      py::arg("path"), py::arg("merge_tolerance") = CleanOptions{}.merge_tolerance);
  m.def(
      "read_toolpath",
      [](const std::string& path, bool commanded_mixtures) {
        const auto ext = std::filesystem::path(path).extension().string();
        if (ext == ".json") return std::make_shared<Toolpath>(read_toolpath(path));
        if (ext == ".cli" || ext == ".CLI") return std::make_shared<Toolpath>(read_cli_file(path));
        Diagnostics diag;
        return std::make_shared<Toolpath>(
            read_print(path, nullptr, nullptr, diag, commanded_mixtures));
      },
      py::arg("path"), py::arg("commanded_mixtures") = false);
  m.def("toolpath_from_json", [](const std::string& text) {
    return std::make_shared<Toolpath>(toolpath_from_json(text, "<string>"));
  });
  // The reader routes (RouteSpec::reads) as the CLI runs them (read_run): `design` a file, a
  // Lattice or None; `print` a file, a Toolpath (analyze: measured as planned, no filament or
  // retractions, which the machine's G-code adds; check: in design coordinates) or a list of files
  // (compare, view); `settings` key -> value (python/trellis: keywords); the files to write as
  // the command's -o, --report and --preview. read_run returns a dict: report (the report JSON, for
  // json.loads), the files written, summary (what the command prints), warnings (kind, text) and
  // exit_code; interruptible, with progress to `progress(stage, fraction)`.
  m.def(
      "read_run",
      [](const std::string& route, const py::object& design, const py::object& print,
         const std::string& machine, const py::dict& settings, const std::string& output,
         const std::string& report, const std::string& preview, const py::object& progress) {
        Diagnostics diag;
        const JobResult r = run_read(route, design, print, machine, settings,
                                     {output, report, preview}, diag, progress);
        py::dict d;
        d["report"] = r.report_json;
        d["files"] = r.files;
        d["summary"] = r.summary;
        d["exit_code"] = r.exit_code;
        py::list warnings;
        for (const auto& msg : diag.messages()) warnings.append(py::make_tuple(msg.kind, msg.text));
        d["warnings"] = warnings;
        return d;
      },
      py::arg("route"), py::arg("design"), py::arg("print"), py::arg("machine"),
      py::arg("settings"), py::arg("output") = "", py::arg("report") = "", py::arg("preview") = "",
      py::arg("progress") = py::none());
  // The readers: the rows of the route table that read prints back.
  m.def("reader_names", [] {
    std::vector<std::string> names;
    for (const RouteSpec& r : route_specs())
      if (r.reads) names.push_back(r.name);
    return names;
  });
  m.def("reader_sections", [](const std::string& name) { return route_spec(name).sections; });
  m.def("reader_keys", [](const std::string& name) {
    const RouteSpec& r = route_spec(name);
    std::vector<std::string> keys;
    for (const auto& s : all_settings())
      if (!s.flag.empty() && route_reads(r, s)) keys.push_back(s.key);
    return keys;
  });
  // Parses .vcad text (errors with line and column); returns the design's bounds if it has a root.
  m.def("parse_vcad", [](const std::string& text, const std::string& name) {
    const VcadDesign d = parse_vcad(text, name);
    py::dict out;
    out["has_root"] = d.has_root;
    return out;
  });
  m.def("cli_bytes",
        [](const Toolpath& t, const std::string& machine, const py::dict& settings, bool binary) {
          Settings st;
          if (!machine.empty()) st.load_toml_file(machine);
          for (const auto& [k, v] : settings) {
            const auto key = k.cast<std::string>();
            st.set(key, to_value(key, v), {"keyword " + key});
          }
          return py::bytes(write_cli(t, st.config().laser, CliWriteOptions{binary, true}));
        });
  m.def("gcode_text", [](const Toolpath& t, const std::string& machine, const py::dict& settings) {
    Settings st;
    if (!machine.empty()) st.load_toml_file(machine);
    for (const auto& [k, v] : settings) {
      const auto key = k.cast<std::string>();
      st.set(key, to_value(key, v), {"keyword " + key});
    }
    return write_gcode(t, st.config().machine, nullptr, gcode_thumbnails(t, st.config().machine));
  });
}
