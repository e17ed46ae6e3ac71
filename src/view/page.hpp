// The pieces a viewer page is made of: the bundled template (view.cpp), the data blocks of its
// scenes (encode.cpp, read by viewer/src/data.js) and the string escaping both need.
#pragma once
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "trellis/view/view.hpp"

namespace trellis::view_page {

// The page template of viewer/build.mjs; the data blocks go where kDataMarker stands.
std::string_view page_template();
inline constexpr std::string_view kDataMarker = "<!--TRELLIS_DATA-->";

// How a scene's layers are written:
//   Chunks: one base64 block per layer (float32 positions, layout in encode.cpp), read as it
//     stands; what `trellis view` writes.
//   Packed: every layer in one block, positions in steps of a quantum (1 µm unless the part is
//     too large for 32-bit steps) written as zigzag varint differences, then deflated (zlib) and
//     base64; the page inflates it with DecompressionStream. About a third of Chunks' size on
//     G-code; what a notebook view carries (notebook.cpp).
enum class LayerData { Chunks, Packed };

// The index block and every scene's blocks (meta, layers, design, extras).
std::string data_blocks(const std::vector<ViewScene>& scenes, const std::string& title,
                        LayerData layers);

// The Packed bytes of a scene's layers before deflating (for tests): see encode.cpp for the layout.
std::string pack_layers(const ViewScene& scene);

// JSON as text safe inside <script> (`<`, `>`, `&` as \u escapes; invalid UTF-8 as U+FFFD).
std::string script_json(const nlohmann::json& value);
std::string html_escape(const std::string& s);

}  // namespace trellis::view_page
