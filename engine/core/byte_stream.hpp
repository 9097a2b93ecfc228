// Minimal binary serialisation for save_state()/restore_state(): raw bytes of trivially copyable data.
#pragma once
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace grains {

// A 64-bit check sum of a saved state's bytes (FNV-1a over 8-byte words, then the tail bytes): a state
// corrupted on its way back (a flipped bit, a truncated or spliced copy) is refused before it is read.
// Not a defence against a state crafted to pass it; the loaders check their indices as well.
inline std::uint64_t check_sum(std::span<const std::byte> bytes) {
  constexpr std::uint64_t prime = 1099511628211ull;
  std::uint64_t h = 1469598103934665603ull ^ bytes.size();
  std::size_t k = 0;
  for (; k + 8 <= bytes.size(); k += 8) {
    std::uint64_t word;
    std::memcpy(&word, bytes.data() + k, 8);
    h = (h ^ word) * prime;
    h ^= h >> 29;   // fold the high bits back: a word's high bits would otherwise only reach the hash's high bits
  }
  for (; k < bytes.size(); ++k) h = (h ^ std::uint64_t(bytes[k])) * prime;
  return h;
}

class ByteWriter {
 public:
  template <class T> void put(const T& x) {
    static_assert(std::is_standard_layout_v<T>);   // plain data: PODs and Eigen fixed-size types
    auto p = reinterpret_cast<const std::byte*>(&x);
    bytes_.insert(bytes_.end(), p, p + sizeof(T));
  }
  template <class T> void put_vector(const std::vector<T>& v) {
    static_assert(std::is_standard_layout_v<T>);   // plain data: PODs and Eigen fixed-size types
    put<std::uint64_t>(v.size());
    auto p = reinterpret_cast<const std::byte*>(v.data());
    bytes_.insert(bytes_.end(), p, p + v.size() * sizeof(T));
  }
  std::vector<std::byte> take() { return std::move(bytes_); }
  // The bytes written so far.
  std::span<const std::byte> written() const { return bytes_; }

 private:
  std::vector<std::byte> bytes_;
};

class ByteReader {
 public:
  explicit ByteReader(std::span<const std::byte> b) : bytes_(b) {}
  template <class T> T get() {
    if constexpr (std::is_same_v<T, bool>) {   // a byte other than 0 or 1 is no bool: reading it as one is undefined
      const auto b = get<std::uint8_t>();
      if (b > 1) throw std::runtime_error("saved state holds a flag that is neither 0 nor 1 (corrupted, or from another scene)");
      return b == 1;
    }
    T x;
    need(sizeof(T));
    // Eigen fixed-size types are plain scalars whose copy assignment is user-provided, so not "trivially
    // copyable" by the letter: copy through void* (their standard layout is asserted when writing).
    std::memcpy(static_cast<void*>(&x), bytes_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return x;
  }
  template <class T> void get_vector(std::vector<T>& v) {
    const auto n = get<std::uint64_t>();
    // Compared as a count, not as bytes: a corrupted count times sizeof(T) could wrap past the check.
    if (n > (bytes_.size() - pos_) / sizeof(T)) throw std::runtime_error(truncated);
    v.resize(n);
    if (n > 0) std::memcpy(static_cast<void*>(v.data()), bytes_.data() + pos_, n * sizeof(T));   // an empty v has no data()
    pos_ += n * sizeof(T);
  }
  bool done() const { return pos_ == bytes_.size(); }

 private:
  static constexpr const char* truncated = "saved state is truncated or from another scene";
  void need(std::size_t n) const {
    if (pos_ + n > bytes_.size()) throw std::runtime_error(truncated);
  }
  std::span<const std::byte> bytes_;
  std::size_t pos_ = 0;
};

}  // namespace grains
