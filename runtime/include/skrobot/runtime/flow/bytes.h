// SPDX-License-Identifier: Apache-2.0
// Little-endian byte reading and writing for the FlowProtocol. A ByteReader never reads past its
// end: every read checks the remaining length first and fails (returns false) instead.
#pragma once

#include <bit>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <string_view>

namespace skr::flow {

class ByteReader {
 public:
  ByteReader() = default;
  ByteReader(const void* data, size_t size)
      : p_(static_cast<const uint8_t*>(data)), end_(p_ + size) {}
  explicit ByteReader(std::string_view s) : ByteReader(s.data(), s.size()) {}

  [[nodiscard]] size_t remaining() const noexcept { return static_cast<size_t>(end_ - p_); }
  [[nodiscard]] bool empty() const noexcept { return p_ == end_; }
  [[nodiscard]] const uint8_t* position() const noexcept { return p_; }

  bool u8(uint8_t& v) noexcept { return fixed(v); }
  bool u16(uint16_t& v) noexcept { return fixed(v); }
  bool u32(uint32_t& v) noexcept { return fixed(v); }
  bool u64(uint64_t& v) noexcept { return fixed(v); }
  bool i64(int64_t& v) noexcept { return fixed(v); }
  bool f64(double& v) noexcept { return fixed(v); }

  // A view of the next n bytes; the data stays where it is.
  bool view(size_t n, std::string_view& out) noexcept {
    if (remaining() < n) return false;
    out = std::string_view(reinterpret_cast<const char*>(p_), n);
    p_ += n;
    return true;
  }
  // u16 length + bytes (names, keys, short text).
  bool str16(std::string_view& out) noexcept {
    uint16_t n = 0;
    return u16(n) && view(n, out);
  }
  // u32 length + bytes (payloads, long text).
  bool str32(std::string_view& out) noexcept {
    uint32_t n = 0;
    return u32(n) && view(n, out);
  }
  // The rest of the input.
  std::string_view rest() noexcept {
    std::string_view out(reinterpret_cast<const char*>(p_), remaining());
    p_ = end_;
    return out;
  }

 private:
  template <typename T>
  bool fixed(T& v) noexcept {
    static_assert(std::endian::native == std::endian::little, "big-endian hosts need byte swaps");
    if (remaining() < sizeof(T)) return false;
    std::memcpy(&v, p_, sizeof(T));
    p_ += sizeof(T);
    return true;
  }

  const uint8_t* p_ = nullptr;
  const uint8_t* end_ = nullptr;
};

// Appends little-endian values to a std::string used as a byte buffer.
class ByteWriter {
 public:
  explicit ByteWriter(std::string& out) : out_(&out) {}

  void u8(uint8_t v) { fixed(v); }
  void u16(uint16_t v) { fixed(v); }
  void u32(uint32_t v) { fixed(v); }
  void u64(uint64_t v) { fixed(v); }
  void i64(int64_t v) { fixed(v); }
  void f64(double v) { fixed(v); }
  void raw(std::string_view bytes) { out_->append(bytes); }
  // Callers check lengths against the protocol limits before writing.
  void str16(std::string_view s) {
    u16(static_cast<uint16_t>(s.size()));
    raw(s);
  }
  void str32(std::string_view s) {
    u32(static_cast<uint32_t>(s.size()));
    raw(s);
  }
  [[nodiscard]] size_t size() const noexcept { return out_->size(); }
  // Overwrites a u32 written earlier at `offset` (frame lengths known only at the end).
  void patchU32(size_t offset, uint32_t v) { std::memcpy(out_->data() + offset, &v, sizeof v); }

 private:
  template <typename T>
  void fixed(T v) {
    out_->append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  std::string* out_;
};

// Bytes handed to another thread and what keeps them alive: a connection's read buffer given away
// without a copy (the hub's Connection::takeBody, for the blob store), or a string of their own.
class SharedBytes {
 public:
  SharedBytes(std::string s)  // NOLINT(google-explicit-constructor): a string is bytes
      : owner_(std::make_shared<const std::string>(std::move(s))),
        view_(*static_cast<const std::string*>(owner_.get())) {}
  SharedBytes(const char* s) : SharedBytes(std::string(s)) {}  // NOLINT: the tests' literals
  SharedBytes(std::shared_ptr<const void> owner, std::string_view view)
      : owner_(std::move(owner)), view_(view) {}
  operator std::string_view() const noexcept { return view_; }  // NOLINT: a view of them
  [[nodiscard]] size_t size() const noexcept { return view_.size(); }

 private:
  std::shared_ptr<const void> owner_;
  std::string_view view_;
};

}  // namespace skr::flow
