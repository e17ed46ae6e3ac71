#include "trellis/core/memory.hpp"

#include <sys/mman.h>

#include <cstdint>

namespace trellis {

void advise_huge_pages(const void* data, std::size_t size) {
  constexpr std::uintptr_t kHuge = std::uintptr_t{2} << 20;
  const auto begin = reinterpret_cast<std::uintptr_t>(data);
  const std::uintptr_t first = (begin + kHuge - 1) & ~(kHuge - 1),
                       last = (begin + size) & ~(kHuge - 1);
  if (last > first)
    ::madvise(reinterpret_cast<void*>(first), last - first, MADV_HUGEPAGE);  // a hint: no error
}

}  // namespace trellis
