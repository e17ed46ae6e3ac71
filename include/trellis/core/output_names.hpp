// An output is named for the format written in it. The routes' outputs follow this rule
// (RouteSpec::formats, job/run.cpp check_output_names); a front end's own writers call
// require_output_format (Python: Mesh.write_stl, Field.mesh(stl=), Toolpath.save_view).
#pragma once
#include <string>
#include <vector>

namespace trellis {

// An extension an output may have and the format written under it (".stl", "binary STL").
struct OutputFormat {
  std::string extension;  // lower case, with its dot
  std::string format;     // what is written ("" when the extension says it)
};

// Unless `path`'s extension (in any case) is one of `formats`, or `path` is a stream
// (is_stream_output: its name says no format), a SettingError at `element` naming the file and
// the names it may have ("'m.obj' is named .obj, but Mesh.write_stl writes the mesh as .stl
// (binary STL): name it so"), before anything is written.
void require_output_format(const std::string& path, const std::vector<OutputFormat>& formats,
                           const std::string& writer, const std::string& what,
                           const std::string& element);

}  // namespace trellis
