#include "trellis/toolpath/layer_spill.hpp"

#include <cerrno>
#include <cstring>

#include "trellis/core/error.hpp"

namespace trellis {

namespace {

template <class T>
void put(std::string& out, const T& v) {
  out.append(reinterpret_cast<const char*>(&v), sizeof v);
}

template <class T>
void put_vector(std::string& out, const std::vector<T>& v) {
  put(out, static_cast<std::uint64_t>(v.size()));
  out.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
}

[[noreturn]] void fail(const char* what) {
  throw IoError(std::string(what) + " a temporary layer file: " + std::strerror(errno));
}

}  // namespace

LayerSpill::LayerSpill() {
  file_ = std::tmpfile();  // unlinked already: gone with the process, whatever happens
  if (!file_) fail("cannot create");
  std::setvbuf(file_, nullptr, _IOFBF, 1u << 20);
}

LayerSpill::~LayerSpill() {
  if (file_) std::fclose(file_);
}

void LayerSpill::append(const Layer& layer) {
  if (!writing_) throw Error("LayerSpill: layer appended after reading started");
  put(buffer_, layer.z);
  put(buffer_, static_cast<std::uint64_t>(layer.paths.size()));
  for (const Path& p : layer.paths) {
    put(buffer_, static_cast<std::int32_t>(p.role));
    put(buffer_, static_cast<std::int32_t>(p.tool));
    put(buffer_, static_cast<std::int32_t>(p.part));
    for (double v : {p.width, p.height, p.speed, p.power, p.filament, p.temperature}) put(buffer_, v);
    put_vector(buffer_, p.mixture);
    put_vector(buffer_, p.points);
  }
  ++layers_;
  if (buffer_.size() > (1u << 20)) flush();
}

void LayerSpill::flush() {
  if (!buffer_.empty() && std::fwrite(buffer_.data(), 1, buffer_.size(), file_) != buffer_.size())
    fail("cannot write");
  bytes_ += buffer_.size();
  buffer_.clear();
}

void LayerSpill::rewind() {
  if (writing_) {
    flush();
    if (std::fflush(file_) != 0) fail("cannot write");
    writing_ = false;
    buffer_.shrink_to_fit();
  }
  std::rewind(file_);
  read_layers_ = 0;
}

void LayerSpill::read(void* data, std::size_t n) {
  if (n && std::fread(data, 1, n, file_) != n) fail("cannot read");
}

bool LayerSpill::next(Layer& layer) {
  if (writing_) throw Error("LayerSpill: next() before rewind()");
  if (read_layers_ == layers_) return false;
  auto get = [&](auto& v) { read(&v, sizeof v); };
  auto get_vector = [&](auto& v) {
    std::uint64_t n = 0;
    get(n);
    v.resize(n);
    read(v.data(), n * sizeof(v[0]));
  };
  get(layer.z);
  std::uint64_t paths = 0;
  get(paths);
  layer.paths.resize(paths);
  for (Path& p : layer.paths) {
    std::int32_t role = 0, tool = 0, part = 0;
    get(role), get(tool), get(part);
    p.role = static_cast<PathRole>(role);
    p.tool = tool;
    p.part = part;
    for (double* v : {&p.width, &p.height, &p.speed, &p.power, &p.filament, &p.temperature}) get(*v);
    get_vector(p.mixture);
    get_vector(p.points);
  }
  ++read_layers_;
  return true;
}

void LayerSpill::visit(const LayerVisitor& visit) {
  rewind();
  Layer layer;
  for (std::size_t i = 0; next(layer); ++i) visit(i, layer);
}

LayerSource LayerSpill::source() {
  return [this](const LayerVisitor& v) { visit(v); };
}

}  // namespace trellis
