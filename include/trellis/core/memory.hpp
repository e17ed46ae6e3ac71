// Large buffers filled right after they are allocated (a file read whole, a mesh's arrays): the
// kernel is asked for 2 MB pages there (transparent huge pages, which this system's default
// "madvise" mode gives only on request), so filling 50 MB costs 25 page faults, not 12,800. A
// hint only: where it is not granted, the buffer is the same, filled a 4 KB page at a time.
#pragma once
#include <cstddef>

namespace trellis {

// For the whole 2 MB pages inside bytes [data, data + size) that nothing has touched yet.
void advise_huge_pages(const void* data, std::size_t size);

// `v` (a std::vector or std::string) resized to n elements, its new storage advised first.
template <class Buffer>
void resize_filled(Buffer& v, std::size_t n) {
  v.reserve(n);
  advise_huge_pages(v.data(), n * sizeof(*v.data()));
  v.resize(n);
}

}  // namespace trellis
