// Lattice file formats:
//  - JSON: {"nodes": [[x,y,z] | [x,y], ...], "edges": [[i,j] | {"ends":[i,j],"material":m,
//    "directed":true}, ...], "material": [m per edge] (optional), "directed": [bool per edge]}
//  - AERO pair: NAME_vertices.csv (x,y,z per line) + NAME_edges.csv (i,j per line, 0-based);
//    given either file, the other is found by name.
//  - CSV of segments: x1,y1,z1,x2,y2,z2 per line (x1,y1,x2,y2 for 2D), as Grasshopper exports;
//    an optional header line of names is skipped.
//  - OBJ: `v x y z` and `l i j ...` (1-based or negative); other records ignored.
//  - 3MF with the Beam Lattice extension: beams (radius: the mean of its two end radii), beam
//    sets as materials (identifier or name an integer, or "material N"; else the set's index).
// Material columns: JSON "material"; AERO edges `i,j,m`; segment CSV a 7th column (a 5th for 2D
// under a header `x1,y1,x2,y2,material`); OBJ `usemtl NAME` (an integer, else numbered in order).
// Parsers throw ParseError naming file and line (CSV, OBJ) or element (JSON).
#pragma once
#include <string>
#include <vector>

#include "trellis/lattice/graph.hpp"

namespace trellis {

// A lattice as read, before cleaning; edge_where[i] names the origin of edges[i].
struct LatticeInput {
  Graph graph;
  std::vector<std::string> edge_where;
};

LatticeInput parse_lattice_json(const std::string& text, const std::string& origin);
LatticeInput parse_segments_csv(const std::string& text, const std::string& origin);
LatticeInput parse_obj_lines(const std::string& text, const std::string& origin);
LatticeInput parse_aero_pair(const std::string& vertices_text, const std::string& vertices_origin,
                             const std::string& edges_text, const std::string& edges_origin);

// 3MF beam lattices through lib3mf (coordinates are stored as 32-bit floats).
LatticeInput read_beam_lattice_3mf(const std::string& path, Diagnostics& diag);
// One mesh object without triangles: a vertex per node, a beam per strut (its radius, else
// default_radius mm), a beam set per material named "material N" with identifier "N".
void write_beam_lattice_3mf(const std::string& path, const Graph& g, double default_radius);

// Reads any supported format (by extension and name), then cleans it (see clean_graph).
// Throws GeometryError if the result has no edges.
Graph read_lattice(const std::string& path, const CleanOptions& options, Diagnostics& diag);

std::string lattice_to_json(const Graph& g);
// JSON for a .json path, a 3MF beam lattice for a .3mf path (struts without a radius get
// `beam_radius` mm); any other name → SettingError, nothing written.
void write_lattice(const std::string& path, const Graph& g, double beam_radius = 0.25);

}  // namespace trellis
