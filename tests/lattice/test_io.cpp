#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "support/temp_dir.hpp"
#include "trellis/core/error.hpp"
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
      R"({"nodes": [[0,0,0],[1,0,0],[1,1]], "edges": [[0,1], {"ends":[1,2],"material":2,"directed":true}]})",
      "t.json");
  ASSERT_EQ(in.graph.nodes.size(), 3u);
  ASSERT_EQ(in.graph.edges.size(), 2u);
  EXPECT_EQ(in.graph.nodes[2].z, 0.0);
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
  expect_parse_error([] { parse_aero_pair("0,0,0\n1,0\n1,1,1,1\n", "v.csv", "0,1\n", "e.csv"); }, 3,
                     "expected x,y,z");
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
