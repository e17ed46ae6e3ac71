#include "trellis/toolpath/layer_spill.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "trellis/core/error.hpp"
#include "trellis/core/file.hpp"

namespace trellis {

namespace {

template <class T>
void put(std::string& out, const T& v) {
  out.append(reinterpret_cast<const char*>(&v), sizeof v);
}

// A path's fixed fields, written and read in one piece.
struct PathHead {
  std::int32_t role, tool, part, joined, inside, unused;
  double width, height, speed, power, filament, temperature, flow, fan;
  std::uint64_t mixture, via, points;
};

[[noreturn]] void fail(const char* what) {
  throw IoError(std::string(what) + " a temporary layer file: " + std::strerror(errno));
}

}  // namespace

LayerSpill::LayerSpill() {
  file_ =
      temporary_file();  // in $TMPDIR, unlinked already: gone with the process, whatever happens
  // Small buffers: a plate keeps one spill per part open at once.
  std::setvbuf(file_, nullptr, _IOFBF, 64u << 10);
}

LayerSpill::~LayerSpill() {
  if (file_) std::fclose(file_);
}

void LayerSpill::append(const Layer& layer) {
  if (!writing_) throw Error("LayerSpill: layer appended after reading started");
  // The layer's byte count first, so that reading takes it in one piece.
  const std::size_t start = buffer_.size();
  put(buffer_, std::uint64_t{0});
  put(buffer_, layer.z);
  put(buffer_, static_cast<std::uint64_t>(layer.paths.size()));
  for (const Path& p : layer.paths) {
    const PathHead h{static_cast<std::int32_t>(p.role),
                     p.tool,
                     p.part,
                     p.joined ? 1 : 0,
                     p.inside ? 1 : 0,
                     0,
                     p.width,
                     p.height,
                     p.speed,
                     p.power,
                     p.filament,
                     p.temperature,
                     p.flow,
                     p.fan,
                     p.mixture.size(),
                     p.via.size(),
                     p.points.size()};
    put(buffer_, h);
    buffer_.append(reinterpret_cast<const char*>(p.mixture.data()),
                   p.mixture.size() * sizeof(double));
    buffer_.append(reinterpret_cast<const char*>(p.via.data()), p.via.size() * sizeof(Vec3));
    buffer_.append(reinterpret_cast<const char*>(p.points.data()), p.points.size() * sizeof(Vec3));
  }
  const std::uint64_t size = buffer_.size() - start - sizeof(std::uint64_t);
  std::memcpy(buffer_.data() + start, &size, sizeof size);
  ++layers_;
  if (buffer_.size() > (256u << 10)) flush();
}

void LayerSpill::flush() {
  if (!buffer_.empty() && std::fwrite(buffer_.data(), 1, buffer_.size(), file_) != buffer_.size())
    fail("cannot write");
  bytes_ += buffer_.size();
  buffer_.clear();
}

void LayerSpill::rewind() {
  end_writing();
  std::rewind(file_);
  read_layers_ = 0;
}

void LayerSpill::read(void* data, std::size_t n) {
  if (n && std::fread(data, 1, n, file_) != n) fail("cannot read");
}

bool LayerSpill::next(Layer& layer) {
  if (writing_) throw Error("LayerSpill: next() before rewind()");
  if (read_layers_ == layers_) return false;
  std::uint64_t size = 0;
  read(&size, sizeof size);
  buffer_.resize(size);
  read(buffer_.data(), size);
  decode(buffer_, layer);
  ++read_layers_;
  return true;
}

void LayerSpill::decode(const std::string& record, Layer& layer) {
  const char* at = record.data();
  const char* const end = at + record.size();
  // An empty vector's data() may be null: memcpy must not see it even for zero bytes.
  auto take = [&](void* to, std::size_t n) {
    if (n == 0) return;
    if (n > static_cast<std::size_t>(end - at)) fail("layer record shorter than its contents");
    std::memcpy(to, at, n);
    at += n;
  };
  take(&layer.z, sizeof layer.z);
  std::uint64_t paths = 0;
  take(&paths, sizeof paths);
  layer.paths.resize(paths);
  for (Path& p : layer.paths) {
    PathHead h;
    take(&h, sizeof h);
    p.role = static_cast<PathRole>(h.role);
    p.tool = h.tool;
    p.part = h.part;
    p.width = h.width, p.height = h.height, p.speed = h.speed, p.power = h.power;
    p.filament = h.filament, p.temperature = h.temperature;
    p.flow = h.flow, p.fan = h.fan, p.joined = h.joined != 0;
    p.inside = h.inside != 0;
    p.mixture.resize(h.mixture);
    take(p.mixture.data(), h.mixture * sizeof(double));
    p.via.resize(h.via);
    take(p.via.data(), h.via * sizeof(Vec3));
    p.points.resize(h.points);
    take(p.points.data(), h.points * sizeof(Vec3));
  }
}

void LayerSpill::end_writing() {
  if (!writing_) return;
  flush();
  if (std::fflush(file_) != 0) fail("cannot write");
  writing_ = false;
  buffer_.shrink_to_fit();  // from now on it holds one layer (next())
}

void LayerSpill::visit(const LayerVisitor& visit) {
  end_writing();  // (not while another thread visits: source() ends it first)
  // Read with pread at offsets of its own, never through file_'s position: visits may run on
  // several threads at once (the G-code writer and its thumbnails).
  const int fd = fileno(file_);
  std::string record;
  Layer layer;
  std::uint64_t offset = 0;
  auto read_at = [&](void* data, std::size_t n) {
    for (std::size_t done = 0; done < n;) {
      const ssize_t got =
          ::pread(fd, static_cast<char*>(data) + done, n - done, static_cast<off_t>(offset + done));
      if (got < 0 && errno == EINTR) continue;
      if (got <= 0) fail("cannot read");
      done += static_cast<std::size_t>(got);
    }
    offset += n;
  };
  for (std::size_t i = 0; i < layers_; ++i) {
    std::uint64_t size = 0;
    read_at(&size, sizeof size);
    record.resize(size);
    read_at(record.data(), size);
    decode(record, layer);
    visit(i, layer);
  }
}

LayerSource LayerSpill::source() {
  end_writing();
  return [this](const LayerVisitor& v) { visit(v); };
}

}  // namespace trellis
