#include "src/core/limits.hpp"

#include <cstdio>
#include <stdexcept>

#include <unistd.h>

namespace atacom::limits {

uint64_t physical_memory_bytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), size = ::sysconf(_SC_PAGE_SIZE);
  if (pages <= 0 || size <= 0) return 0;
  return uint64_t(pages) * uint64_t(size);
}

void require_memory(double bytes, const std::string& what) {
  const uint64_t have = physical_memory_bytes();
  if (have == 0 || bytes <= double(have)) return;
  char b[160];
  std::snprintf(b, sizeof(b), " needs %.1f GB, more than this machine's %.1f GB of memory", bytes / 1e9,
                double(have) / 1e9);
  throw std::invalid_argument(what + b);
}

}  // namespace atacom::limits
