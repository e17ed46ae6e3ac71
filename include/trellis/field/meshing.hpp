// Meshing a field for interactive callers (the Python package's Field.mesh): field_to_mesh with
// progress and cancel, and the estimate of its memory to refuse before starting.
#pragma once
#include "trellis/core/budget.hpp"
#include "trellis/core/run_context.hpp"
#include "trellis/field/field.hpp"
#include "trellis/geom/mesh.hpp"

namespace trellis {

// field_to_mesh (field.hpp) with a run context (core/run_context.hpp): reporting "meshing" per
// slab of 8 voxel rows, stopping with Cancelled when cancelled, on the context's threads.
TriangleMesh field_to_mesh(const Field& field, const BBox3& box, double voxel, MeshingStats* stats,
                           const RunContext& context);

// Memory of field_to_mesh over `box` at `voxel`: its grid with every voxel of the box active
// (the most it can hold) and a mesh as large as the box's faces.
Estimate field_mesh_estimate(const BBox3& box, double voxel);

}  // namespace trellis
