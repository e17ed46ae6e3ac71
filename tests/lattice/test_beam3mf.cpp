#include <Model/COM/NMR_DLLInterfaces.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <tuple>

#include "support/random_graphs.hpp"
#include "support/temp_dir.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/core/rng.hpp"
#include "trellis/lattice/io.hpp"

using namespace trellis;
namespace fs = std::filesystem;

namespace {

std::string temp_path(const std::string& name) {
  static const test::TempDir dir("trellis_test_beam3mf");
  const fs::path p = dir / name;
  return p.string();
}

// A strut as its two end points (ordered, rounded to 10 µm), with material and radius.
using Key = std::tuple<long long, long long, long long, long long, long long, long long>;
Key key(Vec3 a, Vec3 b) {
  auto r = [](double v) { return std::llround(v * 1e5); };
  auto p = std::make_tuple(r(a.x), r(a.y), r(a.z)), q = std::make_tuple(r(b.x), r(b.y), r(b.z));
  if (q < p) std::swap(p, q);
  return std::tuple_cat(p, q);
}

std::map<Key, Edge> struts(const Graph& g) {
  std::map<Key, Edge> out;
  for (const auto& e : g.edges) out[key(g.nodes[e.a], g.nodes[e.b])] = e;
  return out;
}

struct Handle {
  NMR::PLib3MFBase* p = nullptr;
  ~Handle() {
    if (p) NMR::lib3mf_release(p);
  }
};

}  // namespace

TEST(BeamLattice3mf, WrittenThenReadGivesTheSameGraphRadiiAndMaterials) {
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    Graph g = test::random_lattice3d(seed, 3 + static_cast<int>(seed % 3), 0.6, 0.4);
    Rng rng(seed);
    for (auto& e : g.edges) {
      e.material = static_cast<int>(rng.uniform_index(seed % 2 ? 3 : 1)) * (seed % 4 == 3 ? 7 : 1);
      if (rng.uniform01() < 0.7) e.radius = 0.1 + 0.4 * rng.uniform01();
    }
    const std::string path = temp_path("rt" + std::to_string(seed) + ".3mf");
    write_lattice(path, g, 0.3);
    Diagnostics d;
    const Graph back = read_lattice(path, keep_graph_options(), d);
    EXPECT_EQ(d.total(), 0u) << seed;
    ASSERT_EQ(back.edges.size(), g.edges.size()) << seed;
    std::vector<char> has_strut(g.nodes.size(), 0);
    for (const auto& e : g.edges) has_strut[e.a] = has_strut[e.b] = 1;
    ASSERT_EQ(back.nodes.size(),  // nodes without struts are not beams' vertices
              static_cast<std::size_t>(std::count(has_strut.begin(), has_strut.end(), 1)));
    // Each strut once, at the same place (3MF stores 32-bit floats: within 10 µm).
    std::vector<char> used(back.edges.size(), 0);
    for (const auto& e : g.edges) {
      const Vec3 a = g.nodes[e.a], b = g.nodes[e.b];
      std::size_t found = back.edges.size();
      for (std::size_t j = 0; j < back.edges.size(); ++j) {
        const Vec3 p = back.nodes[back.edges[j].a], q = back.nodes[back.edges[j].b];
        if ((distance(a, p) < 1e-5 && distance(b, q) < 1e-5) ||
            (distance(a, q) < 1e-5 && distance(b, p) < 1e-5)) {
          found = j;
          break;
        }
      }
      ASSERT_LT(found, back.edges.size()) << seed;
      EXPECT_FALSE(used[found]) << seed;
      used[found] = 1;
      EXPECT_EQ(back.edges[found].material, e.material) << seed;
      // lib3mf writes radii with 6 decimals.
      EXPECT_NEAR(back.edges[found].radius, e.radius > 0 ? e.radius : 0.3, 2e-6) << seed;
    }
  }
}

TEST(BeamLattice3mf, ReadsAFileBuiltWithLib3mfsOwnApi) {
  // A square of four beams and a diagonal: two beam sets named (not numbered) "rigid" and
  // "soft", one tapered beam, one beam in no set, the object placed by a build-item translation.
  using namespace NMR;
  const std::string path = temp_path("api.3mf");
  {
    Handle model, object, item, writer, rigid, soft;
    ASSERT_EQ(lib3mf_createmodel(&model.p), LIB3MF_OK);
    ASSERT_EQ(lib3mf_model_addmeshobject(model.p, &object.p), LIB3MF_OK);
    const float pts[4][2] = {{0, 0}, {10, 0}, {10, 10}, {0, 10}};
    for (const auto& p : pts) {
      MODELMESHVERTEX v;
      v.m_fPosition[0] = p[0];
      v.m_fPosition[1] = p[1];
      v.m_fPosition[2] = 2;
      ASSERT_EQ(lib3mf_meshobject_addvertex(object.p, &v, nullptr), LIB3MF_OK);
    }
    const DWORD ends[5][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {0, 2}};
    for (int i = 0; i < 5; ++i) {
      MODELMESHBEAM b;
      b.m_nIndices[0] = ends[i][0];
      b.m_nIndices[1] = ends[i][1];
      b.m_dRadius[0] = 0.2 + 0.1 * i;
      b.m_dRadius[1] = i == 4 ? 0.8 : 0.2 + 0.1 * i;  // the diagonal is tapered 0.6 -> 0.8
      ASSERT_EQ(lib3mf_meshobject_addbeam(object.p, &b, nullptr), LIB3MF_OK);
    }
    ASSERT_EQ(lib3mf_meshobject_setbeamlattice_radius(object.p, 0.5), LIB3MF_OK);
    ASSERT_EQ(lib3mf_meshobject_setbeamlattice_minlength(object.p, 0.01), LIB3MF_OK);
    ASSERT_EQ(lib3mf_meshobject_addbeamset(object.p, &rigid.p), LIB3MF_OK);
    ASSERT_EQ(lib3mf_beamset_setnameutf8(rigid.p, "rigid"), LIB3MF_OK);
    DWORD rigid_refs[] = {0, 2};
    ASSERT_EQ(lib3mf_beamset_setrefs(rigid.p, rigid_refs, 2), LIB3MF_OK);
    ASSERT_EQ(lib3mf_meshobject_addbeamset(object.p, &soft.p), LIB3MF_OK);
    ASSERT_EQ(lib3mf_beamset_setnameutf8(soft.p, "soft"), LIB3MF_OK);
    DWORD soft_refs[] = {1, 3};
    ASSERT_EQ(lib3mf_beamset_setrefs(soft.p, soft_refs, 2), LIB3MF_OK);
    MODELTRANSFORM tf{};
    tf.m_fFields[0][0] = tf.m_fFields[1][1] = tf.m_fFields[2][2] = 1;
    tf.m_fFields[0][3] = 100;  // x + 100
    ASSERT_EQ(lib3mf_model_addbuilditem(model.p, object.p, &tf, &item.p), LIB3MF_OK);
    ASSERT_EQ(lib3mf_model_querywriter(model.p, "3mf", &writer.p), LIB3MF_OK);
    ASSERT_EQ(lib3mf_writer_writetofileutf8(writer.p, path.c_str()), LIB3MF_OK);
  }
  Diagnostics d;
  const Graph g = read_lattice(path, {}, d);
  ASSERT_EQ(g.edges.size(), 5u);
  ASSERT_EQ(g.nodes.size(), 4u);
  EXPECT_EQ(d.count("tapered_beams_averaged"), 1u);
  const auto s = struts(g);
  auto at = [&](double ax, double ay, double bx, double by) {
    return s.at(key({100 + ax, ay, 2}, {100 + bx, by, 2}));
  };
  EXPECT_EQ(at(0, 0, 10, 0).material, 0);  // "rigid": the first set
  EXPECT_EQ(at(10, 10, 0, 10).material, 0);
  EXPECT_EQ(at(10, 0, 10, 10).material, 1);  // "soft": the second
  EXPECT_EQ(at(0, 10, 0, 0).material, 1);
  EXPECT_EQ(at(0, 0, 10, 10).material, 0);  // in no set
  EXPECT_NEAR(at(0, 0, 10, 0).radius, 0.2, 1e-6);
  EXPECT_NEAR(at(0, 10, 0, 0).radius, 0.5, 1e-6);
  EXPECT_NEAR(at(0, 0, 10, 10).radius, 0.7, 1e-6);  // mean of 0.6 and 0.8
}

TEST(BeamLattice3mf, BadFilesAreClearErrors) {
  Diagnostics d;
  EXPECT_THROW(read_lattice(temp_path("missing.3mf"), {}, d), IoError);
  const std::string junk = temp_path("junk.3mf");
  write_file_atomic(junk, "not a zip");
  EXPECT_THROW(read_lattice(junk, {}, d), ParseError);
  // A triangle mesh without beams: not a lattice.
  using namespace NMR;
  const std::string mesh = temp_path("mesh.3mf");
  {
    Handle model, object, item, writer;
    ASSERT_EQ(lib3mf_createmodel(&model.p), LIB3MF_OK);
    ASSERT_EQ(lib3mf_model_addmeshobject(model.p, &object.p), LIB3MF_OK);
    MODELMESHVERTEX v[3] = {};
    v[1].m_fPosition[0] = 1;
    v[2].m_fPosition[1] = 1;
    MODELMESHTRIANGLE t;
    t.m_nIndices[0] = 0;
    t.m_nIndices[1] = 1;
    t.m_nIndices[2] = 2;
    ASSERT_EQ(lib3mf_meshobject_setgeometry(object.p, v, 3, &t, 1), LIB3MF_OK);
    ASSERT_EQ(lib3mf_model_addbuilditem(model.p, object.p, nullptr, &item.p), LIB3MF_OK);
    ASSERT_EQ(lib3mf_model_querywriter(model.p, "3mf", &writer.p), LIB3MF_OK);
    ASSERT_EQ(lib3mf_writer_writetofileutf8(writer.p, mesh.c_str()), LIB3MF_OK);
  }
  try {
    read_lattice(mesh, {}, d);
    ADD_FAILURE() << "a mesh without beams was read as a lattice";
  } catch (const ParseError& e) {
    EXPECT_NE(std::string(e.what()).find("no beams"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("mesh.3mf"), std::string::npos) << e.what();
  }
  EXPECT_THROW(write_lattice(temp_path("bad.3mf"), Graph{}, 0.3), GeometryError);
  Graph one;
  one.nodes = {{0, 0, 0}, {1, 0, 0}};
  one.edges = {{0, 1}};
  EXPECT_THROW(write_lattice(temp_path("bad.3mf"), one, 0), SettingError);
}
