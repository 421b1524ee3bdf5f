// Plain byte buffers for moving per-frame results between ranks (dist::Comm::Gather): append
// trivially copyable values and arrays, read them back in the same order.
#ifndef FACECAP_UTIL_BYTES_H_
#define FACECAP_UTIL_BYTES_H_

#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <type_traits>
#include <vector>

namespace facecap {

class ByteWriter {
 public:
  template <typename T>
  void Put(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    PutBytes(&value, sizeof(T));
  }
  template <typename T>
  void PutArray(const T* values, size_t count) {
    static_assert(std::is_trivially_copyable_v<T>);
    Put<uint64_t>(count);
    PutBytes(values, count * sizeof(T));
  }
  template <typename T>
  void PutVector(const std::vector<T>& values) { PutArray(values.data(), values.size()); }
  std::vector<uint8_t>& bytes() { return bytes_; }

 private:
  void PutBytes(const void* p, size_t n) {
    const size_t old = bytes_.size();
    bytes_.resize(old + n);
    if (n) std::memcpy(bytes_.data() + old, p, n);
  }
  std::vector<uint8_t> bytes_;
};

class ByteReader {
 public:
  ByteReader(const uint8_t* data, size_t size) : data_(data), size_(size) {}
  explicit ByteReader(const std::vector<uint8_t>& bytes) : ByteReader(bytes.data(), bytes.size()) {}
  template <typename T>
  T Get() {
    T value;
    GetBytes(&value, sizeof(T));
    return value;
  }
  template <typename T>
  std::vector<T> GetVector() {
    const uint64_t n = Get<uint64_t>();
    if (n > (size_ - offset_) / sizeof(T) + 1) throw std::runtime_error("ByteReader: corrupt buffer");
    std::vector<T> values(n);
    GetBytes(values.data(), n * sizeof(T));
    return values;
  }
  bool AtEnd() const { return offset_ == size_; }

 private:
  void GetBytes(void* p, size_t n) {
    if (offset_ + n > size_) throw std::runtime_error("ByteReader: read past the end");
    if (n) std::memcpy(p, data_ + offset_, n);
    offset_ += n;
  }
  const uint8_t* data_;
  size_t size_;
  size_t offset_ = 0;
};

}  // namespace facecap

#endif  // FACECAP_UTIL_BYTES_H_
