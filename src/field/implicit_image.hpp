// Internal (implicit3mf module): volumetric image stacks of the 3MF Volumetric Extension (Part I
// ch. 3: an <image3d> of PNG <imagesheet>s) and the sampler of a <functionfromimage3d> (Part I
// §2.2: filter, tile styles, value offset and scale), which implicit_graph.cpp runs as one
// instruction of a compiled graph.
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "implicit_xml.hpp"

namespace trellis::implicit {

// A voxel grid of 1 (Y), 2 (YA), 3 (RGB) or 4 (RGBA) channels, `columns` × `rows` × `sheets`,
// values pixel / (2^bits − 1) stored as the PNG's integers. Voxel (row i, column j, sheet k)
// is at data[((k·rows + i)·columns + j)·channels + c]; row 0 is the top of a sheet (v = 1).
struct Image3d {
  int columns = 0, rows = 0, sheets = 0, channels = 0;
  double max = 255;  // 2^bits − 1
  std::vector<std::uint16_t> data;
  // The R, G, B and A of a voxel per the pixel-layout table of Part I §3.2 (Y → R = G = B,
  // no alpha → 1).
  void rgba(int i, int j, int k, double out[4]) const;
};

// Reads the <image3d> element's <imagestack> (Part I §3.2) from the package: `part` returns a
// part's bytes by its name (nullopt when the package has none). Refuses (Ctx::fail, naming the
// sheet) a missing part, a sheet that is not a PNG, differs in size from rowcount × columncount
// or in pixel layout or bit depth from the first sheet, a sheet count that is not sheetcount, or
// more than kMaxImageSamples values, and a sheet whose part `related` says the model part has no
// 3D Texture relationship to (§3.2.2: each sheet's part MUST be associated with the model part
// through one).
using PartReader = std::function<std::optional<std::string>(const std::string& name)>;
using RelatedPart = std::function<bool(const std::string& name)>;
inline constexpr const char* kTextureRelationship =
    "http://schemas.microsoft.com/3dmanufacturing/2013/01/3dtexture";
std::shared_ptr<const Image3d> read_image3d(const Ctx& c, const El& image3d, const PartReader& part,
                                            const RelatedPart& related);
inline constexpr double kMaxImageSamples = 1 << 30;  // 2 GB of 16-bit values

enum class Tile : std::uint8_t { Wrap, Mirror, Clamp };
enum class Filter : std::uint8_t { Linear, Nearest };

// A <functionfromimage3d> (Part I §2.2): the image sampled at uvw, each value V'' = V' · scale
// + offset.
struct ImageFunction {
  std::shared_ptr<const Image3d> image;
  Filter filter = Filter::Linear;
  Tile tile[3] = {Tile::Wrap, Tile::Wrap, Tile::Wrap};
  double offset = 0, scale = 1;
  // out: red, green, blue, alpha at uvw.
  void sample(const double uvw[3], double out[4]) const;
};

// The function's attributes read (defaults per the XSD; the specification's example spells
// image3dID, offset and scale, read too); its image from `image` (the image3d's id → image).
ImageFunction image_function(const Ctx& c, const El& fn,
                             const std::function<std::shared_ptr<const Image3d>(long long)>& image);

}  // namespace trellis::implicit
