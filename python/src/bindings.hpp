// What the extension's source files share: the interruptible runner of long calls, the numpy
// conversions of the IR (arrays.cpp) and the field bindings (fields.cpp).
#pragma once
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <functional>

#include "trellis/core/run_context.hpp"
#include "trellis/lattice/graph.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace py = pybind11;

// Runs `fn` on a worker thread with the GIL released, with the module's one run context
// (core/run_context.hpp): `base` (its diagnostics, budget, threads) with a progress that goes to
// `callback` (a Python callable or None) from the calling thread; Ctrl-C sets the cancel flag and
// the call raises KeyboardInterrupt; an error of `fn` is rethrown here.
void run_interruptible(const std::function<void(const trellis::RunContext&)>& fn,
                       const py::object& callback, trellis::RunContext base = {});

// numpy views of the IR: whole arrays, one copy, no per-point Python objects.
py::dict toolpath_arrays(const trellis::Toolpath& tp);
py::dict lattice_arrays(const trellis::Graph& g);
// The inverses, checked: shapes, dtypes, offsets and ranges here; each path by the IR's own check
// (toolpath/check.hpp). Errors name the argument and its index.
trellis::Graph lattice_from_arrays(const py::object& nodes, const py::object& edges,
                                   const py::object& material);
trellis::Toolpath toolpath_from_arrays(const py::object& points, const py::object& path_offsets,
                                       const py::object& layer_offsets, const py::object& layer_z,
                                       const py::dict& attributes);

// Field.evaluate / sample / bounds / mesh over the compiled .vcad design (fields.cpp).
void bind_fields(py::module_& m);
