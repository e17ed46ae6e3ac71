// Field.evaluate / sample / bounds / mesh: the .vcad text compiled once by the library's parser
// into the kernel's Field — the one the slicer evaluates — and held by the Python object. Long
// calls run through run_interruptible (GIL released, progress, Ctrl-C); sample and mesh refuse a
// grid beyond the memory budget before allocating it, with the estimate.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "trellis/core/budget.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/output_names.hpp"
#include "trellis/field/meshing.hpp"
#include "trellis/field/vcad.hpp"
#include "trellis/geom/mesh.hpp"

using namespace trellis;

namespace {

struct CompiledField {
  VcadDesign design;
};

using Doubles = py::array_t<double, py::array::c_style | py::array::forcecast>;

[[noreturn]] void bad(const std::string& element, const std::string& message) {
  throw ParseError(message, {"", 0, element});
}

Vec3 finite_point(const py::object& obj, const char* name) {
  const auto a = Doubles::ensure(obj);
  if (!a || a.ndim() != 1 || a.shape(0) != 3) bad(name, std::string(name) + " must be (x, y, z)");
  const Vec3 p{a.at(0), a.at(1), a.at(2)};
  if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
    bad(name, std::string(name) + " must be finite");
  return p;
}

BBox3 checked_box(const py::object& lo_obj, const py::object& hi_obj, double step) {
  BBox3 box;
  box.min = finite_point(lo_obj, "box[0]");
  box.max = finite_point(hi_obj, "box[1]");
  if (!(box.min.x < box.max.x && box.min.y < box.max.y && box.min.z < box.max.z))
    bad("box", "box must be (min, max) with min < max on every axis");
  if (!(step > 0) || !std::isfinite(step)) bad("step", "step must be a number > 0 (mm)");
  return box;
}

Budget budget(double max_memory_mb, bool force) {
  Budget b;
  b.memory = max_memory_mb > 0 ? max_memory_mb * 1e6 : 0;
  b.force = force;
  return b;
}

// The grid nodes lo, lo + step, … up to hi (with a rounding tolerance).
std::vector<double> axis(double lo, double hi, double step) {
  const auto n = static_cast<std::size_t>(std::floor((hi - lo) / step + 1e-9)) + 1;
  std::vector<double> xs(n);
  for (std::size_t i = 0; i < n; ++i) xs[i] = lo + static_cast<double>(i) * step;
  return xs;
}

py::array_t<double> vector_array(const std::vector<double>& v) {
  py::array_t<double> a(v.size());
  std::copy(v.begin(), v.end(), a.mutable_data());
  return a;
}

py::dict evaluate(const CompiledField& f, const py::object& points_obj,
                  const py::object& progress) {
  const auto points = Doubles::ensure(points_obj);
  if (!points || points.ndim() != 2 || points.shape(1) != 3)
    bad("points", "points must be an (n, 3) array of numbers");
  const auto n = static_cast<std::size_t>(points.shape(0));
  const std::size_t k = f.design.field.materials().size();
  py::array_t<double> distance(n);
  py::array_t<double> fractions({n, k});
  const double* in = points.data();
  for (std::size_t i = 0; i < 3 * n; ++i)
    if (!std::isfinite(in[i]))
      bad("points[" + std::to_string(i / 3) + "]",
          "point " + std::to_string(i / 3) + " is not finite");
  double* d = distance.mutable_data();
  double* fr = fractions.mutable_data();
  run_interruptible(
      [&](const RunContext& pr) {
        Evaluator ev(f.design.field);
        constexpr std::size_t kChunk = 8192;
        std::vector<Vec3> chunk;
        for (std::size_t s = 0; s < n; s += kChunk) {
          pr.check("evaluating the field");
          pr.report("evaluating", static_cast<double>(s) / static_cast<double>(n));
          const std::size_t e = std::min(n, s + kChunk);
          chunk.clear();
          for (std::size_t i = s; i < e; ++i)
            chunk.push_back({in[3 * i], in[3 * i + 1], in[3 * i + 2]});
          ev.values(chunk.data(), d + s, chunk.size());
          if (k > 0)
            for (std::size_t i = s; i < e; ++i) {
              const std::vector<double> m = ev.fractions(chunk[i - s]);
              std::copy(m.begin(), m.end(), fr + i * k);
            }
        }
        pr.report("evaluating", 1.0);
      },
      progress);
  py::dict out;
  out["distance"] = distance;
  out["fractions"] = fractions;
  return out;
}

py::dict sample(const CompiledField& f, const py::object& lo, const py::object& hi, double step,
                double max_memory_mb, bool force, const py::object& progress) {
  const BBox3 box = checked_box(lo, hi, step);
  const Vec3 span = box.max - box.min;
  const double cells = (std::floor(span.x / step) + 1) * (std::floor(span.y / step) + 1) *
                       (std::floor(span.z / step) + 1);
  const std::size_t k = f.design.field.materials().size();
  Estimate e;
  e.bytes = cells * 8 * static_cast<double>(1 + k);
  e.what = "sampling a field on " + std::to_string(static_cast<long long>(cells)) + " grid points";
  e.change = "the step (coarser) or the box (smaller)";
  check_budget(e, budget(max_memory_mb, force));
  const std::vector<double> xs = axis(box.min.x, box.max.x, step),
                            ys = axis(box.min.y, box.max.y, step),
                            zs = axis(box.min.z, box.max.z, step);
  const std::size_t nx = xs.size(), ny = ys.size(), nz = zs.size();
  py::array_t<double> distance({nx, ny, nz});
  py::array_t<double> fractions(std::vector<std::size_t>{nx, ny, nz, k});
  double* d = distance.mutable_data();
  double* fr = fractions.mutable_data();
  run_interruptible(
      [&](const RunContext& pr) {
        Evaluator ev(f.design.field);
        std::vector<double> slice(nx * ny);
        for (std::size_t c = 0; c < nz; ++c) {
          pr.check("sampling the field");
          pr.report("sampling", static_cast<double>(c) / static_cast<double>(nz));
          ev.values_grid(xs.data(), nx, ys.data(), ny, zs[c], slice.data());
          for (std::size_t j = 0; j < ny; ++j)
            for (std::size_t i = 0; i < nx; ++i) {
              const std::size_t at = (i * ny + j) * nz + c;
              d[at] = slice[j * nx + i];
              if (k > 0) {
                const std::vector<double> m = ev.fractions({xs[i], ys[j], zs[c]});
                std::copy(m.begin(), m.end(), fr + at * k);
              }
            }
        }
        pr.report("sampling", 1.0);
      },
      progress);
  py::dict out;
  out["distance"] = distance;
  out["fractions"] = fractions;
  out["x"] = vector_array(xs);
  out["y"] = vector_array(ys);
  out["z"] = vector_array(zs);
  out["origin"] = py::make_tuple(box.min.x, box.min.y, box.min.z);
  out["step"] = step;
  return out;
}

py::dict mesh(const CompiledField& f, const py::object& lo, const py::object& hi, double step,
              double max_memory_mb, bool force, const py::object& progress) {
  const BBox3 box = checked_box(lo, hi, step);
  RunContext context;
  context.budget = budget(max_memory_mb, force);
  context.check_budget(field_mesh_estimate(box, step));
  TriangleMesh m;
  run_interruptible(
      [&](const RunContext& c) { m = field_to_mesh(f.design.field, box, step, nullptr, c); },
      progress, context);
  py::array_t<double> vertices({m.vertices.size(), std::size_t(3)});
  py::array_t<std::int64_t> faces({m.triangles.size(), std::size_t(3)});
  auto V = vertices.mutable_unchecked<2>();
  auto F = faces.mutable_unchecked<2>();
  for (std::size_t i = 0; i < m.vertices.size(); ++i)
    V(i, 0) = m.vertices[i].x, V(i, 1) = m.vertices[i].y, V(i, 2) = m.vertices[i].z;
  for (std::size_t i = 0; i < m.triangles.size(); ++i)
    for (int c = 0; c < 3; ++c) F(i, c) = m.triangles[i][c];
  py::dict out;
  out["vertices"] = vertices;
  out["faces"] = faces;
  return out;
}

// A mesh from numpy arrays, faces checked against the vertices, as binary STL (atomically).
void write_stl_arrays(const py::object& vertices_obj, const py::object& faces_obj,
                      const std::string& path) {
  require_output_format(path, {{".stl", "binary STL"}}, "Mesh.write_stl", "the mesh", "path");
  const auto v = Doubles::ensure(vertices_obj);
  if (!v || v.ndim() != 2 || v.shape(1) != 3) bad("vertices", "vertices must be an (n, 3) array");
  const auto fa =
      py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(faces_obj);
  if (!fa || fa.ndim() != 2 || fa.shape(1) != 3)
    bad("faces", "faces must be an (m, 3) array of vertex indices");
  TriangleMesh m;
  const auto V = v.unchecked<2>();
  for (py::ssize_t i = 0; i < v.shape(0); ++i) m.vertices.push_back({V(i, 0), V(i, 1), V(i, 2)});
  const auto F = fa.unchecked<2>();
  for (py::ssize_t i = 0; i < fa.shape(0); ++i) {
    std::array<std::uint32_t, 3> t{};
    for (int c = 0; c < 3; ++c) {
      if (F(i, c) < 0 || F(i, c) >= v.shape(0))
        bad("faces[" + std::to_string(i) + "]", "face " + std::to_string(i) + " names vertex " +
                                                    std::to_string(F(i, c)) + " of " +
                                                    std::to_string(v.shape(0)));
      t[c] = static_cast<std::uint32_t>(F(i, c));
    }
    m.triangles.push_back(t);
  }
  write_stl(path, m);
}

}  // namespace

void bind_fields(py::module_& m) {
  py::class_<CompiledField, std::shared_ptr<CompiledField>>(m, "CompiledField")
      .def_property_readonly("materials",
                             [](const CompiledField& f) { return f.design.field.materials(); })
      .def_property_readonly("has_root", [](const CompiledField& f) { return f.design.has_root; })
      .def("bounds",
           [](const CompiledField& f) {
             const BBox3 b = f.design.field.extent();
             return py::make_tuple(py::make_tuple(b.min.x, b.min.y, b.min.z),
                                   py::make_tuple(b.max.x, b.max.y, b.max.z));
           })
      .def("evaluate", &evaluate, py::arg("points"), py::arg("progress") = py::none())
      .def("sample", &sample, py::arg("lo"), py::arg("hi"), py::arg("step"),
           py::arg("max_memory") = 0.0, py::arg("force") = false, py::arg("progress") = py::none())
      .def("mesh", &mesh, py::arg("lo"), py::arg("hi"), py::arg("step"),
           py::arg("max_memory") = 0.0, py::arg("force") = false, py::arg("progress") = py::none());
  m.def("compile_vcad", [](const std::string& text, const std::string& name) {
    auto f = std::make_shared<CompiledField>();
    f->design = parse_vcad(text, name);
    return f;
  });
  m.def("write_stl", &write_stl_arrays, py::arg("vertices"), py::arg("faces"), py::arg("path"));
}
