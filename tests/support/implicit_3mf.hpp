// Test support: 3MF packages of the Volumetric & Implicit Extension written by hand (a stored,
// uncompressed ZIP of our own) and the pieces of their model parts: box meshes, function-graph
// nodes, the specification's sphere function.
#pragma once
#include <array>
#include <cctype>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

namespace trellis::test {

inline std::uint32_t crc32(const std::string& s) {
  std::uint32_t c = 0xFFFFFFFFu;
  for (unsigned char b : s) {
    c ^= b;
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
  }
  return ~c;
}

inline void put16(std::string& o, unsigned v) {
  o += static_cast<char>(v & 0xFF);
  o += static_cast<char>((v >> 8) & 0xFF);
}
inline void put32(std::string& o, std::uint32_t v) {
  put16(o, v & 0xFFFF);
  put16(o, v >> 16);
}

inline std::string stored_zip(const std::vector<std::pair<std::string, std::string>>& files) {
  std::string out, central;
  for (const auto& [name, data] : files) {
    const std::uint32_t offset = static_cast<std::uint32_t>(out.size()), crc = crc32(data);
    const auto size = static_cast<std::uint32_t>(data.size());
    put32(out, 0x04034b50);
    put16(out, 20), put16(out, 0), put16(out, 0), put16(out, 0), put16(out, 0x21);
    put32(out, crc), put32(out, size), put32(out, size);
    put16(out, static_cast<unsigned>(name.size())), put16(out, 0);
    out += name + data;
    put32(central, 0x02014b50);
    put16(central, 20), put16(central, 20), put16(central, 0), put16(central, 0);
    put16(central, 0), put16(central, 0x21);
    put32(central, crc), put32(central, size), put32(central, size);
    put16(central, static_cast<unsigned>(name.size()));
    for (int i = 0; i < 4; ++i) put16(central, 0);
    put32(central, 0), put32(central, offset);
    central += name;
  }
  const auto cd = static_cast<std::uint32_t>(out.size());
  out += central;
  put32(out, 0x06054b50);
  put16(out, 0), put16(out, 0);
  put16(out, static_cast<unsigned>(files.size())), put16(out, static_cast<unsigned>(files.size()));
  put32(out, static_cast<std::uint32_t>(central.size())), put32(out, cd);
  put16(out, 0);
  return out;
}

// How write_3mf relates the model part to its PNG parts (image sheets) by the 3D Texture
// relationship (Volumetric Part I §3.2.2): absolute targets, targets relative to /3D/ in upper
// case (part names compare without case), or none (a package the reader refuses).
enum class TextureRels { Absolute, RelativeUpperCase, None };

// A 3MF package: content types, relationships, the model part /3D/3dmodel.model and `parts`
// (name without the leading slash, bytes), e.g. an image stack's PNG sheets.
inline void write_3mf(const std::string& path, const std::string& model,
                      const std::vector<std::pair<std::string, std::string>>& parts = {},
                      TextureRels texture_rels = TextureRels::Absolute) {
  const std::string types =
      R"(<?xml version="1.0" encoding="UTF-8"?>
<Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types"><Default Extension="rels" ContentType="application/vnd.openxmlformats-package.relationships+xml"/><Default Extension="model" ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/><Default Extension="png" ContentType="image/png"/></Types>)";
  const std::string rels =
      R"(<?xml version="1.0" encoding="UTF-8"?>
<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships"><Relationship Target="/3D/3dmodel.model" Id="rel0" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/></Relationships>)";
  std::vector<std::pair<std::string, std::string>> files = {
      {"[Content_Types].xml", types}, {"_rels/.rels", rels}, {"3D/3dmodel.model", model}};
  std::string textures;
  int id = 0;
  for (const auto& [name, bytes] : parts) {
    if (!name.ends_with(".png") || texture_rels == TextureRels::None) continue;
    std::string target = "/" + name;
    if (texture_rels == TextureRels::RelativeUpperCase && target.starts_with("/3D/")) {
      target = target.substr(4);
      for (auto& ch : target) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
    }
    textures += "<Relationship Target=\"" + target + "\" Id=\"tex" + std::to_string(id++) +
                "\" Type=\"http://schemas.microsoft.com/3dmanufacturing/2013/01/3dtexture\"/>";
  }
  if (!textures.empty())
    files.push_back({"3D/_rels/3dmodel.model.rels",
                     "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<Relationships "
                     "xmlns=\"http://schemas.openxmlformats.org/package/2006/relationships\">" +
                         textures + "</Relationships>"});
  files.insert(files.end(), parts.begin(), parts.end());
  std::ofstream(path, std::ios::binary) << stored_zip(files);
}

inline std::string num(double v) {
  char b[40];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}

// A box mesh [lo, hi]^3 (outward triangles).
inline std::string box_mesh(std::array<double, 3> lo, std::array<double, 3> hi) {
  std::string s = "<mesh><vertices>\n";
  for (int i = 0; i < 8; ++i)
    s += "<vertex x=\"" + num(i & 1 ? hi[0] : lo[0]) + "\" y=\"" + num(i & 2 ? hi[1] : lo[1]) +
         "\" z=\"" + num(i & 4 ? hi[2] : lo[2]) + "\"/>\n";
  s += "</vertices><triangles>\n";
  const int t[12][3] = {{0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6}, {0, 1, 5}, {0, 5, 4},
                        {2, 6, 7}, {2, 7, 3}, {0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}};
  for (const auto& v : t)
    s += "<triangle v1=\"" + std::to_string(v[0]) + "\" v2=\"" + std::to_string(v[1]) + "\" v3=\"" +
         std::to_string(v[2]) + "\"/>\n";
  return s + "</triangles></mesh>";
}

// One node: <i:kind identifier=id attrs> with inputs (element, identifier, ref) and one output.
inline std::string node(const std::string& kind, const std::string& id,
                        const std::vector<std::array<std::string, 3>>& ins,
                        const std::string& out_type, const std::string& out = "result",
                        const std::string& attrs = "") {
  std::string s = "<i:" + kind + " identifier=\"" + id + "\"" + attrs + ">\n";
  if (!ins.empty()) {
    s += "<i:in>\n";
    for (const auto& in : ins)
      s += "<i:" + in[0] + " identifier=\"" + in[1] + "\" ref=\"" + in[2] + "\"/>\n";
    s += "</i:in>\n";
  }
  s += "<i:out><i:" + out_type + " identifier=\"" + out + "\"/></i:out>\n";
  return s + "</i:" + kind + ">\n";
}

// f(pos) = |pos| − r (Part II ch. 3's sphere, the radius a constant node).
inline std::string sphere_function(double r, int id = 2) {
  return "<i:implicitfunction id=\"" + std::to_string(id) +
         "\" displayname=\"sphere\">\n"
         "<i:in><i:vector identifier=\"pos\"/></i:in>\n" +
         node("constant", "radius", {}, "scalar", "value", " value=\"" + num(r) + "\"") +
         node("length", "len", {{"vectorref", "A", "inputs.pos"}}, "scalar") +
         node("subtraction", "sub",
              {{"scalarref", "A", "len.result"}, {"scalarref", "B", "radius.value"}}, "scalar") +
         "<i:out><i:scalarref identifier=\"shape\" ref=\"sub.result\"/></i:out>\n"
         "</i:implicitfunction>\n";
}

}  // namespace trellis::test
