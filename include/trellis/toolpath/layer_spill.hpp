// Layers kept on disk instead of in memory: a streamed route appends each layer as it is done and
// reads them back one at a time (as a LayerSource, toolpath/toolpath.hpp) for the passes that need
// the whole print (bed check, placement, thumbnails, the writer), so memory holds one layer at a
// time whatever the layer count. The file is an anonymous temporary in $TMPDIR (temporary_file,
// core/file.hpp), gone with the object or the process; the bytes are the IR's fields as they are in
// memory (this machine only).
#pragma once
#include <cstdio>
#include <string>

#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

class LayerSpill {
 public:
  LayerSpill();
  ~LayerSpill();
  LayerSpill(const LayerSpill&) = delete;
  LayerSpill& operator=(const LayerSpill&) = delete;

  void append(const Layer& layer);
  std::size_t layers() const { return layers_; }
  std::size_t bytes() const { return bytes_; }

  // Reading, after the last append: rewind() then next() until it returns false (one reader).
  void rewind();
  bool next(Layer& layer);
  // Every layer in order (the first read ends the writing). Visits read at offsets of their own,
  // so once the writing has ended several threads may visit at once. source(): a LayerSource over
  // this spill (keep it alive) that ends the writing first.
  void visit(const LayerVisitor& visit);
  LayerSource source();

 private:
  void end_writing();
  static void decode(const std::string& record, Layer& layer);
  void flush();
  void read(void* data, std::size_t n);
  std::FILE* file_ = nullptr;
  std::string buffer_;  // writing: bytes not yet in the file; reading: the current layer
  std::size_t layers_ = 0, bytes_ = 0, read_layers_ = 0;
  bool writing_ = true;
};

}  // namespace trellis
