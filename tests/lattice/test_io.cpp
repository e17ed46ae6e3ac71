#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "support/temp_dir.hpp"
#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"
#include "trellis/lattice/io.hpp"

using namespace trellis;
namespace fs = std::filesystem;

namespace {

// Expects a ParseError whose location has the given line (0 = any) and whose text contains `what`.
template <class Fn>
void expect_parse_error(Fn fn, long line, const std::string& what) {
  try {
    fn();
    ADD_FAILURE() << "no error for: " << what;
  } catch (const ParseError& e) {
    if (line) {
      EXPECT_EQ(e.where().line, line) << e.what();
    }
    EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
  }
}

std::string temp_file(const std::string& name, const std::string& text) {
  static const trellis::test::TempDir dir("trellis_test_io");
  const fs::path p = dir / name;
  std::ofstream(p) << text;
  return p.string();
}

}  // namespace

TEST(LatticeJson, ReadsNodesEdgesMaterialAndDirected) {
  const auto in = parse_lattice_json(
      R"({"nodes": [[0,0],[1,0],[1,1]], "edges": [[0,1], {"ends":[1,2],"material":2,"directed":true}]})",
      "t.json");
  ASSERT_EQ(in.graph.nodes.size(), 3u);
  ASSERT_EQ(in.graph.edges.size(), 2u);
  EXPECT_EQ(in.graph.nodes[2].z, 0.0);
  // 2D and 3D nodes mixed: an error naming the node, not z = 0 (issue 24).
  EXPECT_THROW(
      parse_lattice_json(R"({"nodes": [[0,0,0],[1,0,0],[1,1]], "edges": [[0,1]]})", "t.json"),
      ParseError);
  EXPECT_EQ(in.graph.edges[1].material, 2);
  EXPECT_TRUE(in.graph.edges[1].directed);
  const auto arr = parse_lattice_json(
      R"({"nodes": [[0,0,0],[1,0,0]], "edges": [[0,1]], "material": [3], "directed": [false]})",
      "t.json");
  EXPECT_EQ(arr.graph.edges[0].material, 3);
}

TEST(LatticeJson, BadInputIsAClearError) {
  expect_parse_error([] { parse_lattice_json("", "e.json"); }, 1, "invalid JSON");
  expect_parse_error(
      [] { parse_lattice_json("{\"nodes\": [[0,0,0]],\n \"edges\": [[0,1]]}", "e.json"); }, 0,
      "edges[0]: node index 1 out of range");
  expect_parse_error([] { parse_lattice_json(R"({"nodes": [[0,"x",0]], "edges": []})", "e.json"); },
                     0, "nodes[0]: expected a number");
  expect_parse_error(
      [] {
        parse_lattice_json(R"({"nodes": [[0,0,0],[1,1,1]], "edges": [[0,1]], "colour": 1})",
                           "e.json");
      },
      0, "unknown key 'colour'");
  expect_parse_error([] { parse_lattice_json(R"({"nodes": [[0,0,0]], "edges": []})", "e.json"); },
                     0, "no edges");
  expect_parse_error(
      [] { parse_lattice_json(R"({"nodes": [[0,0]], "edges": [[0,-1]]})", "e.json"); }, 0,
      "out of range");
  expect_parse_error(
      [] {
        parse_lattice_json(R"({"nodes": [[0,0],[1,1]], "edges": [[0,1]], "material": [1,2]})",
                           "e.json");
      },
      0, "one value per edge");
}

TEST(SegmentsCsv, ReadsWithHeaderCommentsAnd2D) {
  const auto in =
      parse_segments_csv("x1,y1,z1,x2,y2,z2\n0,0,0,1,0,0\n# note\n\n1,0,0, 1,1,0\n", "s.csv");
  EXPECT_EQ(in.graph.edges.size(), 2u);
  EXPECT_EQ(in.edge_where[1], "s.csv:5");
  EXPECT_EQ(parse_segments_csv("0,0,1,1\n", "s.csv").graph.nodes[1].x, 1.0);
}

TEST(SegmentsCsv, BadLinesNameTheLine) {
  expect_parse_error([] { parse_segments_csv("0,0,0,1,0,0\n0,0,0,1,0\n", "s.csv"); }, 2,
                     "got 5 field");
  expect_parse_error([] { parse_segments_csv("0,0,0,1,0,0\n0,0,1,0\n", "s.csv"); }, 2,
                     "expected 6 fields like the first row");
  expect_parse_error([] { parse_segments_csv("0,0,0,1,0,0\n0,0,0,1,abc,0\n", "s.csv"); }, 2,
                     "column 5");
  expect_parse_error([] { parse_segments_csv("0,0,0,nan,0,0\n", "s.csv"); }, 1,
                     "not a finite number");
  expect_parse_error([] { parse_segments_csv("0,0,0,1e999,0,0\n", "s.csv"); }, 1,
                     "not a finite number");
  expect_parse_error([] { parse_segments_csv("", "s.csv"); }, 0, "no edges");
  expect_parse_error([] { parse_segments_csv("\n\n# only comments\n", "s.csv"); }, 0, "no edges");
}

TEST(AeroPair, ReadsTheSharedOctetAndFindsTheOtherFile) {
  Diagnostics diag;
  const std::string dir = TRELLIS_TEST_DATA;
  const Graph a = read_lattice(dir + "/cubic_vertices.csv", {}, diag);
  const Graph b = read_lattice(dir + "/cubic_edges.csv", {}, diag);
  EXPECT_EQ(a.nodes.size(), 64u);
  EXPECT_EQ(a.edges.size(), 144u);
  EXPECT_EQ(b.edges.size(), a.edges.size());
}

TEST(AeroPair, BadIndicesAndMissingPartner) {
  expect_parse_error([] { parse_aero_pair("0,0,0\n1,0,0\n", "v.csv", "0,1\n1,2\n", "e.csv"); }, 2,
                     "node index 2 out of range");
  expect_parse_error([] { parse_aero_pair("0,0,0\n1,0,0\n1,1,1,1\n", "v.csv", "0,1\n", "e.csv"); },
                     3, "expected x,y,z");
  // A short row is not a 2D point among 3D ones (issue 24: it planned without a word).
  expect_parse_error([] { parse_aero_pair("0,0,0\n1,0,0\n1,1\n", "v.csv", "0,1\n", "e.csv"); }, 3,
                     "expected 3 fields like the first row");
  expect_parse_error([] { parse_aero_pair("0,0,0\n1,0,0\n", "v.csv", "0,1.5\n", "e.csv"); }, 1,
                     "not an integer");
  const auto lonely = temp_file("lonely_vertices.csv", "0,0,0\n");
  Diagnostics diag;
  EXPECT_THROW(read_lattice(lonely, {}, diag), IoError);
}

TEST(ObjLines, ReadsPolylinesAndNegativeIndices) {
  const auto in =
      parse_obj_lines("# obj\nv 0 0 0\nv 1 0 0\nv 1 1 0\nl 1 2 3\nl -1 -3\nf 1 2 3\n", "l.obj");
  EXPECT_EQ(in.graph.edges.size(), 3u);
  EXPECT_EQ(in.graph.edges[2].a, 2u);
  EXPECT_EQ(in.graph.edges[2].b, 0u);
  expect_parse_error([] { parse_obj_lines("v 0 0 0\nv 1 0 0\nl 1 5\n", "l.obj"); }, 3,
                     "out of range");
  expect_parse_error([] { parse_obj_lines("v 0 0\n", "l.obj"); }, 1, "needs x y z");
  expect_parse_error([] { parse_obj_lines("v 0 0 0\nl 1 x\n", "l.obj"); }, 2, "not a vertex index");
}

TEST(ReadLattice, UnknownExtensionAndEmptyResult) {
  Diagnostics diag;
  EXPECT_THROW(read_lattice(temp_file("x.stl", "solid"), {}, diag), ParseError);
  // Only a self-loop: nothing left after cleaning.
  EXPECT_THROW(read_lattice(temp_file("loop.csv", "0,0,0,0,0,0\n"), {}, diag), GeometryError);
}

TEST(LatticeJson, WriteReadRoundTripIsExact) {
  Graph g;
  g.nodes = {{0.1, 0.2, 0.3}, {1.0 / 3, 2.0 / 3, 0}, {5, 5, 5}};
  g.edges = {{0, 1}, {1, 2, 4, true}};
  const auto back = parse_lattice_json(lattice_to_json(g), "mem");
  EXPECT_EQ(back.graph.nodes, g.nodes);
  EXPECT_EQ(back.graph.edges[1].material, 4);
  EXPECT_TRUE(back.graph.edges[1].directed);
}

TEST(ReadLattice, KeepGraphLeavesTheBunnyAsGiven) {
  // The bunny has two nodes lying on struts: split by default (1,093 struts), kept as given
  // (1,091, the file's own nodes and struts in order) with keep_graph_options().
  const std::string path = std::string(TRELLIS_TEST_DATA) + "/aero/stanford_bunny_edges.csv";
  Diagnostics d1, d2;
  const Graph split = read_lattice(path, {}, d1);
  const Graph kept = read_lattice(path, keep_graph_options(), d2);
  EXPECT_EQ(split.edges.size(), 1093u);
  EXPECT_GT(d1.count("t_junction_split"), 0u);
  ASSERT_EQ(kept.edges.size(), 1091u);
  EXPECT_EQ(d2.count("t_junction_split"), 0u);
  const std::string vpath = std::string(TRELLIS_TEST_DATA) + "/aero/stanford_bunny_vertices.csv";
  const LatticeInput raw = parse_aero_pair(read_file(vpath), vpath, read_file(path), path);
  ASSERT_EQ(kept.nodes.size(), raw.graph.nodes.size());
  for (std::size_t i = 0; i < kept.nodes.size(); ++i) EXPECT_EQ(kept.nodes[i], raw.graph.nodes[i]);
  for (std::size_t i = 0; i < kept.edges.size(); ++i) {
    EXPECT_EQ(kept.edges[i].a, raw.graph.edges[i].a);
    EXPECT_EQ(kept.edges[i].b, raw.graph.edges[i].b);
  }
}

TEST(ReadLattice, NodeMergingOffKeepsCoincidentNodesAndSaysSo) {
  // Two struts whose ends coincide at node 1 and node 2: merged by default (a path of two
  // struts), kept apart (two separate struts, a warning) with merging off.
  const std::string json = temp_file("coincide.json",
                                     "{\"nodes\": [[0,0,0],[1,0,0],[1,0,0],[2,0,0]], "
                                     "\"edges\": [[0,1],[2,3]]}");
  Diagnostics d1, d2;
  EXPECT_EQ(read_lattice(json, {}, d1).nodes.size(), 3u);
  CleanOptions off;
  off.merge_nodes = false;
  EXPECT_EQ(read_lattice(json, off, d2).nodes.size(), 4u);
  EXPECT_EQ(d2.count("coincident_nodes_kept"), 1u);
  // A segment list has no node ids: ends at the same point still join.
  const std::string csv = temp_file("segs.csv", "0,0,0,1,0,0\n1,0,0,2,0,0\n");
  Diagnostics d3;
  EXPECT_EQ(read_lattice(csv, keep_graph_options(), d3).nodes.size(), 3u);
}

TEST(ReadLattice, EveryFormatCarriesAMaterialColumn) {
  // The same two-material lattice in each format reads to the same struts and materials.
  const std::vector<std::pair<std::string, std::string>> files = {
      {"m.json",
       "{\"nodes\": [[0,0,0],[1,0,0],[1,1,0]], \"edges\": [[0,1],[1,2]], \"material\": [0, 3]}"},
      {"m.csv", "x1,y1,z1,x2,y2,z2,material\n0,0,0,1,0,0,0\n1,0,0,1,1,0,3\n"},
      {"m_nohead.csv", "0,0,0,1,0,0,0\n1,0,0,1,1,0,3\n"},
      {"m.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nusemtl 0\nl 1 2\nusemtl 3\nl 2 3\n"},
  };
  temp_file("m_vertices.csv", "0,0,0\n1,0,0\n1,1,0\n");
  std::vector<std::pair<std::string, std::string>> all = files;
  all.push_back({"m_edges.csv", "0,1,0\n1,2,3\n"});  // the AERO pair with a third column
  for (const auto& [name, text] : all) {
    const std::string path = temp_file(name, text);
    Diagnostics d;
    const Graph g = read_lattice(path, {}, d);
    ASSERT_EQ(g.edges.size(), 2u) << name;
    for (const auto& e : g.edges) {
      const Vec3 mid = (g.nodes[e.a] + g.nodes[e.b]) * 0.5;
      EXPECT_EQ(e.material, mid.y > 0.25 ? 3 : 0) << name;
    }
  }
  // 2D with a material column needs the header naming it.
  const LatticeInput two_d = parse_segments_csv("x1,y1,x2,y2,material\n0,0,1,0,2\n", "t.csv");
  EXPECT_EQ(two_d.graph.edges.at(0).material, 2);
  // OBJ material names other than numbers: numbered in order of appearance.
  const LatticeInput named = parse_obj_lines(
      "v 0 0 0\nv 1 0 0\nv 2 0 0\nusemtl soft\nl 1 2\nusemtl hard\nl 2 3\n", "n.obj");
  EXPECT_EQ(named.graph.edges.at(0).material, 0);
  EXPECT_EQ(named.graph.edges.at(1).material, 1);
}

TEST(ReadLattice, BadMaterialsNameTheLine) {
  expect_parse_error([] { parse_segments_csv("0,0,0,1,0,0,0\n0,0,0,1,0,0,x\n", "s.csv"); }, 2,
                     "column 7: material 'x'");
  expect_parse_error([] { parse_segments_csv("0,0,0,1,0,0,256\n", "s.csv"); }, 1,
                     "not an integer 0..255");
  expect_parse_error([] { parse_aero_pair("0,0,0\n1,0,0\n", "v.csv", "0,1,-1\n", "e.csv"); }, 1,
                     "column 3: material '-1'");
  expect_parse_error([] { parse_obj_lines("v 0 0 0\nv 1 0 0\nusemtl 300\nl 1 2\n", "o.obj"); }, 3,
                     "material '300'");
  expect_parse_error([] { parse_obj_lines("v 0 0 0\nusemtl\n", "o.obj"); }, 2, "usemtl");
}
