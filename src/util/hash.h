// FNV-1a, 64 bits, over bytes: stable across platforms and builds (configuration hashes,
// comparing parameters across ranks).
#ifndef FACECAP_UTIL_HASH_H_
#define FACECAP_UTIL_HASH_H_

#include <cstddef>
#include <cstdint>

namespace facecap {

inline uint64_t Fnv1a(const void* data, size_t bytes) {
  const auto* b = static_cast<const unsigned char*>(data);
  uint64_t h = 1469598103934665603ull;
  for (size_t i = 0; i < bytes; ++i) {
    h ^= b[i];
    h *= 1099511628211ull;
  }
  return h;
}

}  // namespace facecap

#endif  // FACECAP_UTIL_HASH_H_
