// mesh("file.stl") as a field: OpenVDB turns the closed mesh into a narrow-band signed distance
// grid; values are sampled trilinearly. OpenVDB's heavy headers stay in this one file.
#include <openvdb/openvdb.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/MeshToVolume.h>

#include <mutex>

#include "node.hpp"
#include "trellis/core/error.hpp"
#include "trellis/geom/mesh_io.hpp"

namespace trellis {

namespace {

using Sampler =
    openvdb::tools::GridSampler<openvdb::FloatGrid::ConstAccessor, openvdb::tools::BoxSampler>;

// Accessors cache the tree path of the last lookup: one per thread (EvalState) and grid.
struct Samplers {
  openvdb::FloatGrid::ConstAccessor acc;
  Sampler sampler;
  explicit Samplers(const openvdb::FloatGrid& g) : acc(g.getConstAccessor()), sampler(acc, g.transform()) {}
};

struct MeshNode : FieldNode {
  openvdb::FloatGrid::ConstPtr grid;
  BBox3 box;
  double background = 0;
  std::string name;

  Sampler& sampler(EvalState& s) const {
    auto& slot = s.caches[this];
    if (!slot) slot = std::make_shared<Samplers>(*grid);
    return static_cast<Samplers*>(slot.get())->sampler;
  }
  void eval(const Vec3* p, double* out, std::size_t n, EvalState& s, std::size_t) const override {
    auto& sm = sampler(s);
    for (std::size_t i = 0; i < n; ++i) out[i] = sm.wsSample(openvdb::Vec3d(p[i].x, p[i].y, p[i].z));
  }
  Interval bound(const BBox3& b, EvalState& s, std::size_t depth) const override {
    // Lipschitz rule on the band-limited distance (|value| <= background).
    const Interval l = FieldNode::bound(b, s, depth);
    return {std::max(l.lo, -background), std::min(l.hi, background)};
  }
  BBox3 extent() const override { return box; }
};

}  // namespace

Field mesh_field(const TriangleMesh& input, const MeshSdfOptions& options, std::string name) {
  static std::once_flag init;
  std::call_once(init, [] { openvdb::initialize(); });
  if (!(options.voxel > 0)) throw GeometryError("mesh voxel size must be > 0", {name, 0, ""});
  const TriangleMesh mesh = weld(input);
  require_closed(mesh, name);
  const BBox3 box = bounds(mesh);
  const double span = std::max({box.max.x - box.min.x, box.max.y - box.min.y, box.max.z - box.min.z});
  if (span / options.voxel > 20000)
    throw GeometryError("mesh voxel size " + std::to_string(options.voxel) +
                            " mm is too fine for a " + std::to_string(span) + " mm mesh",
                        {name, 0, ""});
  auto transform = openvdb::math::Transform::createLinearTransform(options.voxel);
  std::vector<openvdb::Vec3s> points;
  points.reserve(mesh.vertices.size());
  for (const auto& v : mesh.vertices) {
    // World-space positions: the function maps them through `transform` itself.
    points.emplace_back(static_cast<float>(v.x), static_cast<float>(v.y), static_cast<float>(v.z));
  }
  std::vector<openvdb::Vec3I> tris;
  tris.reserve(mesh.triangles.size());
  for (const auto& t : mesh.triangles) tris.emplace_back(t[0], t[1], t[2]);
  std::vector<openvdb::Vec4I> quads;
  const float band = static_cast<float>(std::max(options.band_voxels, 1.5));
  openvdb::FloatGrid::Ptr grid = openvdb::tools::meshToSignedDistanceField<openvdb::FloatGrid>(
      *transform, points, tris, quads, band, band);
  auto node = std::make_shared<MeshNode>();
  node->grid = grid;

  node->box = box;
  node->background = grid->background();
  node->name = std::move(name);
  return Field(node);
}

}  // namespace trellis
