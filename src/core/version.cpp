#include "trellis/version.hpp"

namespace trellis {

const char* version() {
  return TRELLIS_VERSION;
}

}  // namespace trellis
