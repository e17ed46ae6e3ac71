// numpy arrays <-> the IR: toolpaths and lattices as whole arrays (one copy each way).
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "trellis/core/error.hpp"
#include "trellis/toolpath/check.hpp"

using namespace trellis;

py::dict toolpath_arrays(const Toolpath& tp) {
  std::size_t npaths = 0, npoints = 0;
  for (const auto& l : tp.layers)
    for (const auto& p : l.paths) ++npaths, npoints += p.points.size();
  py::array_t<double> points({npoints, std::size_t(3)});
  py::array_t<std::int64_t> path_offsets(npaths + 1), layer_offsets(tp.layers.size() + 1);
  py::array_t<double> layer_z(tp.layers.size());
  py::array_t<std::int32_t> role(npaths), tool(npaths);
  py::array_t<double> width(npaths), height(npaths), speed(npaths), power(npaths),
      temperature(npaths);
  std::size_t mix_n = 0;
  for (const auto& l : tp.layers)
    for (const auto& p : l.paths) mix_n = std::max(mix_n, p.mixture.size());
  py::array_t<double> mixture({npaths, mix_n});
  auto P = points.mutable_unchecked<2>();
  auto PO = path_offsets.mutable_unchecked<1>();
  auto LO = layer_offsets.mutable_unchecked<1>();
  auto LZ = layer_z.mutable_unchecked<1>();
  auto R = role.mutable_unchecked<1>();
  auto T = tool.mutable_unchecked<1>();
  auto W = width.mutable_unchecked<1>(), H = height.mutable_unchecked<1>(),
       S = speed.mutable_unchecked<1>(), PW = power.mutable_unchecked<1>(),
       TE = temperature.mutable_unchecked<1>();
  auto MX = mixture.mutable_unchecked<2>();
  {
    py::gil_scoped_release release;
    std::size_t k = 0, j = 0;
    for (std::size_t li = 0; li < tp.layers.size(); ++li) {
      LO(li) = static_cast<std::int64_t>(j);
      LZ(li) = tp.layers[li].z;
      for (const auto& p : tp.layers[li].paths) {
        PO(j) = static_cast<std::int64_t>(k);
        R(j) = static_cast<std::int32_t>(p.role);
        T(j) = p.tool;
        W(j) = p.width, H(j) = p.height, S(j) = p.speed, PW(j) = p.power, TE(j) = p.temperature;
        for (std::size_t c = 0; c < mix_n; ++c)
          MX(j, c) = c < p.mixture.size() ? p.mixture[c] : 0.0;
        for (const auto& q : p.points) {
          P(k, 0) = q.x, P(k, 1) = q.y, P(k, 2) = q.z;
          ++k;
        }
        ++j;
      }
    }
    PO(j) = static_cast<std::int64_t>(k);
    LO(tp.layers.size()) = static_cast<std::int64_t>(j);
  }
  py::dict d;
  d["points"] = points;
  d["path_offsets"] = path_offsets;
  d["layer_offsets"] = layer_offsets;
  d["layer_z"] = layer_z;
  d["role"] = role;
  d["tool"] = tool;
  d["width"] = width;
  d["height"] = height;
  d["speed"] = speed;
  d["power"] = power;
  d["temperature"] = temperature;
  d["mixture"] = mixture;
  return d;
}

py::dict lattice_arrays(const Graph& g) {
  py::array_t<double> nodes({g.nodes.size(), std::size_t(3)});
  py::array_t<std::int64_t> edges({g.edges.size(), std::size_t(2)});
  py::array_t<std::int32_t> material(g.edges.size());
  auto N = nodes.mutable_unchecked<2>();
  auto E = edges.mutable_unchecked<2>();
  auto M = material.mutable_unchecked<1>();
  for (std::size_t i = 0; i < g.nodes.size(); ++i)
    N(i, 0) = g.nodes[i].x, N(i, 1) = g.nodes[i].y, N(i, 2) = g.nodes[i].z;
  for (std::size_t i = 0; i < g.edges.size(); ++i)
    E(i, 0) = g.edges[i].a, E(i, 1) = g.edges[i].b, M(i) = g.edges[i].material;
  py::dict d;
  d["nodes"] = nodes;
  d["edges"] = edges;
  d["material"] = material;
  return d;
}

// A lattice from numpy arrays, checked: shapes, finite coordinates, edge indices in range.
Graph lattice_from_arrays(const py::object& nodes_obj, const py::object& edges_obj,
                          const py::object& material_obj) {
  const auto nodes =
      py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(nodes_obj);
  if (!nodes || nodes.ndim() != 2 || nodes.shape(1) != 3)
    throw SettingError("nodes must be an (n, 3) array of numbers", {"", 0, "nodes"});
  const py::array e_arr = py::array::ensure(edges_obj);
  if (!e_arr || e_arr.ndim() != 2 || e_arr.shape(1) != 2)
    throw SettingError("edges must be an (m, 2) array of node indices", {"", 0, "edges"});
  if (!py::dtype::of<std::int64_t>().kind() ||
      (e_arr.dtype().kind() != 'i' && e_arr.dtype().kind() != 'u'))
    throw SettingError(
        "edges must be integers (got dtype " + std::string(py::str(e_arr.dtype())) + ")",
        {"", 0, "edges"});
  const auto edges =
      py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(e_arr);
  if (nodes.shape(0) == 0)
    throw SettingError("no nodes: a lattice needs at least one strut", {"", 0, "nodes"});
  Graph g;
  const auto N = nodes.unchecked<2>();
  for (py::ssize_t i = 0; i < nodes.shape(0); ++i) {
    const Vec3 p{N(i, 0), N(i, 1), N(i, 2)};
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) ||
        std::abs(p.x) > kMaxCoordinate || std::abs(p.y) > kMaxCoordinate ||
        std::abs(p.z) > kMaxCoordinate)
      throw SettingError("node " + std::to_string(i) +
                             " is not finite or beyond ±1e6 mm (as the file readers refuse)",
                         {"", 0, "nodes[" + std::to_string(i) + "]"});
    g.nodes.push_back(p);
  }
  if (edges.shape(0) == 0)
    throw SettingError("no edges: a lattice needs at least one strut", {"", 0, "edges"});
  const auto E = edges.unchecked<2>();
  std::vector<int> materials;
  if (!material_obj.is_none()) {
    const py::array m_arr = py::array::ensure(material_obj);
    if (m_arr && m_arr.dtype().kind() != 'i' && m_arr.dtype().kind() != 'u')
      throw SettingError("material must be integers 0..255 (got dtype " +
                             std::string(py::str(m_arr.dtype())) + ")",
                         {"", 0, "material"});
    const auto m =
        py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(m_arr);
    if (!m || m.ndim() != 1 || m.shape(0) != edges.shape(0))
      throw SettingError("material must be an (m,) array, one per edge", {"", 0, "material"});
    for (py::ssize_t i = 0; i < m.shape(0); ++i) {
      if (m.at(i) < 0 || m.at(i) > 255)
        throw SettingError("material " + std::to_string(m.at(i)) + " of edge " + std::to_string(i) +
                               ": expected an integer 0..255 (as the file readers)",
                           {"", 0, "material[" + std::to_string(i) + "]"});
      materials.push_back(static_cast<int>(m.at(i)));
    }
  }
  for (py::ssize_t i = 0; i < edges.shape(0); ++i) {
    const auto a = E(i, 0), b = E(i, 1);
    if (a < 0 || b < 0 || a >= nodes.shape(0) || b >= nodes.shape(0))
      throw SettingError("edge " + std::to_string(i) + " names node " +
                             std::to_string(a < 0 || a >= nodes.shape(0) ? a : b) + " of " +
                             std::to_string(nodes.shape(0)),
                         {"", 0, "edges[" + std::to_string(i) + "]"});
    Edge e;
    e.a = static_cast<NodeId>(a), e.b = static_cast<NodeId>(b);
    e.material = materials.empty() ? 0 : materials[static_cast<std::size_t>(i)];
    g.edges.push_back(e);
  }
  return g;
}

namespace {

[[noreturn]] void bad(const std::string& element, const std::string& message) {
  throw ParseError(message, {"", 0, element});
}

// An integer array of one dimension (offsets): integers only, as lattice edges.
std::vector<std::int64_t> int_vector(const py::object& obj, const char* name) {
  const py::array a = py::array::ensure(obj);
  if (!a || a.ndim() != 1) bad(name, std::string(name) + " must be a 1-d array of integers");
  if (a.size() > 0 && a.dtype().kind() != 'i' && a.dtype().kind() != 'u')
    bad(name, std::string(name) + " must be integers (got dtype " +
                  std::string(py::str(a.dtype())) + ")");
  const auto v = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(a);
  return {v.data(), v.data() + v.size()};
}

// Offsets into `count` items: first 0, last `count`, never decreasing.
void check_offsets(const std::vector<std::int64_t>& o, std::int64_t count, const char* name,
                   const char* items) {
  if (o.size() < 2)
    bad(name, std::string(name) + " needs at least 2 entries (0 and the number of " + items + ")");
  if (o.front() != 0) bad(std::string(name) + "[0]", std::string(name) + " must start at 0");
  for (std::size_t i = 1; i < o.size(); ++i)
    if (o[i] < o[i - 1])
      bad(std::string(name) + "[" + std::to_string(i) + "]",
          std::string(name) + " must not decrease: " + std::to_string(o[i]) + " after " +
              std::to_string(o[i - 1]));
  if (o.back() != count)
    bad(std::string(name) + "[" + std::to_string(o.size() - 1) + "]",
        std::string(name) + " must end at the number of " + items + " (" + std::to_string(count) +
            "), not " + std::to_string(o.back()));
}

// A per-path number: a scalar for every path or an (n_paths,) array.
std::vector<double> per_path(const py::object& obj, const char* name, std::size_t n,
                             const char* per = "path") {
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(obj);
  if (!a || py::isinstance<py::str>(obj))
    bad(name, std::string(name) + " must be a number or an array of numbers, one per " + per);
  if (a.ndim() == 0) return std::vector<double>(n, *a.data());
  if (a.ndim() != 1 || static_cast<std::size_t>(a.shape(0)) != n)
    bad(name, std::string(name) + " must be a number or an array of " + std::to_string(n) +
                  " numbers, one per " + per + " (got shape " +
                  std::string(py::str(py::tuple(a.attr("shape")))) + ")");
  return {a.data(), a.data() + n};
}

PathRole role_of(const py::handle& v, const std::string& element) {
  if (py::isinstance<py::str>(v)) {
    try {
      return path_role_from_string(v.cast<std::string>());
    } catch (const Error& e) {
      bad(element, e.message());
    }
  }
  if (PyIndex_Check(v.ptr()) && !py::isinstance<py::bool_>(v)) {
    const long long code = py::int_(py::reinterpret_borrow<py::object>(v)).cast<long long>();
    if (code < 0 || code >= static_cast<long long>(kPathRoleCount))
      bad(element, "role code " + std::to_string(code) + ": expected 0.." +
                       std::to_string(kPathRoleCount - 1) + " (trellis.ROLES)");
    return static_cast<PathRole>(code);
  }
  bad(element,
      "role must be a name (trellis.ROLES) or its index, got " + std::string(py::str(py::repr(v))));
}

std::vector<PathRole> roles(const py::object& obj, std::size_t n) {
  if (py::isinstance<py::str>(obj) || (PyIndex_Check(obj.ptr()) && !py::isinstance<py::array>(obj)))
    return std::vector<PathRole>(n, role_of(obj, "role"));
  // A list keeps its names and indices apart (numpy would make ["infill", 6] all strings).
  const bool sequence = py::isinstance<py::list>(obj) || py::isinstance<py::tuple>(obj);
  const py::array a = sequence ? py::array() : py::array::ensure(obj);
  if (!sequence && !a)
    bad("role", "role must be a name, an index or an array of them, one per path");
  if (!sequence && a.ndim() == 0)
    return std::vector<PathRole>(n, role_of(a.attr("item")(), "role"));
  const std::size_t count = sequence ? py::len(obj) : static_cast<std::size_t>(a.shape(0));
  if ((!sequence && a.ndim() != 1) || count != n)
    bad("role", "role must be one name or index, or " + std::to_string(n) +
                    " of them, one per path (got " + std::to_string(count) + ")");
  std::vector<PathRole> out;
  out.reserve(n);
  const py::list items = sequence ? py::list(obj) : py::list(a.attr("tolist")());
  for (std::size_t i = 0; i < n; ++i)
    out.push_back(role_of(items[i], "role[" + std::to_string(i) + "]"));
  return out;
}

// Mixture fractions: none, one (k,) row for every path, or (n_paths, k); a row of zeros is no
// mixture (as Toolpath.arrays() pads paths without one).
std::vector<std::vector<double>> mixtures(const py::object& obj, std::size_t n) {
  std::vector<std::vector<double>> out(n);
  if (obj.is_none()) return out;
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(obj);
  if (!a || (a.ndim() != 1 && a.ndim() != 2) ||
      (a.ndim() == 2 && static_cast<std::size_t>(a.shape(0)) != n))
    bad("mixture", "mixture must be a (k,) row of fractions for every path or (n_paths, k) = (" +
                       std::to_string(n) + ", k)");
  const std::size_t k = static_cast<std::size_t>(a.shape(a.ndim() - 1));
  for (std::size_t i = 0; i < n; ++i) {
    const double* row = a.data() + (a.ndim() == 2 ? i * k : 0);
    if (std::any_of(row, row + k, [](double v) { return v != 0; })) out[i].assign(row, row + k);
  }
  return out;
}

}  // namespace

Toolpath toolpath_from_arrays(const py::object& points_obj, const py::object& path_offsets_obj,
                              const py::object& layer_offsets_obj, const py::object& layer_z_obj,
                              const py::dict& attributes) {
  const auto points =
      py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(points_obj);
  if (!points || points.ndim() != 2 || points.shape(1) != 3)
    bad("points", "points must be an (n, 3) array of numbers");
  const auto npoints = static_cast<std::int64_t>(points.shape(0));
  const std::vector<std::int64_t> po = path_offsets_obj.is_none()
                                           ? std::vector<std::int64_t>{0, npoints}
                                           : int_vector(path_offsets_obj, "path_offsets");
  check_offsets(po, npoints, "path_offsets", "points");
  const std::size_t npaths = po.size() - 1;
  const std::vector<std::int64_t> lo =
      layer_offsets_obj.is_none() ? std::vector<std::int64_t>{0, static_cast<std::int64_t>(npaths)}
                                  : int_vector(layer_offsets_obj, "layer_offsets");
  check_offsets(lo, static_cast<std::int64_t>(npaths), "layer_offsets", "paths");
  const std::size_t nlayers = lo.size() - 1;
  std::vector<double> layer_z;
  if (!layer_z_obj.is_none()) {
    layer_z = per_path(layer_z_obj, "layer_z", nlayers, "layer");
    for (std::size_t i = 0; i < nlayers; ++i)
      if (!std::isfinite(layer_z[i]) || std::abs(layer_z[i]) > 1e6)
        bad("layer_z[" + std::to_string(i) + "]", "layer_z is not finite or beyond ±1e6 mm");
  }
  auto attr = [&](const char* name) {
    return attributes.contains(name) ? py::reinterpret_borrow<py::object>(attributes[name])
                                     : py::object(py::float_(0.0));
  };
  const std::vector<PathRole> role =
      attributes.contains("role") ? roles(attr("role"), npaths) : std::vector<PathRole>(npaths);
  const std::vector<double> tool = per_path(attr("tool"), "tool", npaths),
                            width = per_path(attr("width"), "width", npaths),
                            height = per_path(attr("height"), "height", npaths),
                            speed = per_path(attr("speed"), "speed", npaths),
                            power = per_path(attr("power"), "power", npaths),
                            temperature = per_path(attr("temperature"), "temperature", npaths);
  const auto mixture =
      mixtures(attributes.contains("mixture") ? attr("mixture") : py::object(py::none()), npaths);
  const auto P = points.unchecked<2>();
  Toolpath tp;
  tp.source = "Toolpath.from_arrays";
  tp.layers.resize(nlayers);
  for (std::size_t li = 0; li < nlayers; ++li) {
    Layer& layer = tp.layers[li];
    double zmin = 0;
    bool any = false;
    for (auto j = static_cast<std::size_t>(lo[li]); j < static_cast<std::size_t>(lo[li + 1]); ++j) {
      const std::string at = "[" + std::to_string(j) + "]";
      if (!(std::abs(tool[j]) <= 1e6 && tool[j] == std::floor(tool[j])))
        bad("tool" + at, "tool of path " + std::to_string(j) + " must be a whole number >= 0");
      Path p;
      p.role = role[j];
      p.tool = static_cast<int>(tool[j]);
      p.width = width[j], p.height = height[j], p.speed = speed[j], p.power = power[j];
      p.temperature = temperature[j];
      p.mixture = mixture[j];
      for (auto k = po[j]; k < po[j + 1]; ++k) p.points.push_back({P(k, 0), P(k, 1), P(k, 2)});
      if (const auto problem = path_problem(p)) {
        if (problem->attribute == "points") {
          if (p.points.size() < 2)
            bad("path_offsets" + at, "path " + std::to_string(j) + " has " +
                                         std::to_string(p.points.size()) +
                                         " points: a path needs at least 2");
          bad("points[" + std::to_string(po[j] + static_cast<std::int64_t>(problem->index)) + "]",
              "point " + std::to_string(problem->index) + " of path " + std::to_string(j) + " " +
                  problem->message);
        }
        if (problem->attribute == "mixture")
          bad("mixture[" + std::to_string(j) + ", " + std::to_string(problem->index) + "]",
              "mixture of path " + std::to_string(j) + " " + problem->message);
        bad(problem->attribute + at,
            problem->attribute + " of path " + std::to_string(j) + " " + problem->message);
      }
      for (const Vec3& q : p.points) zmin = any ? std::min(zmin, q.z) : q.z, any = true;
      layer.paths.push_back(std::move(p));
    }
    layer.z = layer_z.empty() ? zmin : layer_z[li];
  }
  return tp;
}
