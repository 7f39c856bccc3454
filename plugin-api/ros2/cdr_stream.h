// SPDX-License-Identifier: Apache-2.0
// CDR's layout, shared by cdr.cpp (any type, from its parsed definition) and images.cpp (the
// fixed layouts of the image messages): positions aligned from the end of the 4-byte
// encapsulation header; values read in the sample's byte order, written little-endian (ROS 2's
// CDR_LE). Every read is checked against what is left. Internal to skrobot_ros2_types.
#pragma once

#include <skrobot/ros2/cdr.h>  // kEncapsulationBytes

#include <bit>
#include <cstddef>
#include <cstring>
#include <string>
#include <string_view>
#include <utility>

namespace skr::ros2 {

static_assert(std::endian::native == std::endian::little, "CdrOut writes host order as CDR_LE");

class CdrIn {
 public:
  CdrIn(std::string_view bytes, bool little) : bytes_(bytes), little_(little) {}

  [[nodiscard]] std::size_t at() const noexcept { return pos_; }
  [[nodiscard]] std::size_t left() const noexcept {
    return pos_ < bytes_.size() ? bytes_.size() - pos_ : 0;
  }
  [[nodiscard]] bool little() const noexcept { return little_; }

  bool align(std::size_t n) {
    const std::size_t off = (pos_ - kEncapsulationBytes) % n;
    return off == 0 || skip(n - off);
  }
  bool skip(std::size_t n) {
    if (left() < n) return false;
    pos_ += n;
    return true;
  }
  // A value of T, aligned to its size.
  template <typename T>
  bool read(T& out) {
    if (!align(sizeof(T)) || left() < sizeof(T)) return false;
    std::memcpy(&out, bytes_.data() + pos_, sizeof(T));
    if (!little_ && sizeof(T) > 1) out = byteswap(out);
    pos_ += sizeof(T);
    return true;
  }
  // `n` bytes as they are.
  bool bytes(std::size_t n, std::string_view& out) {
    if (left() < n) return false;
    out = bytes_.substr(pos_, n);
    pos_ += n;
    return true;
  }

 private:
  template <typename T>
  static T byteswap(T v) {
    unsigned char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
    std::memcpy(&v, b, sizeof(T));
    return v;
  }

  std::string_view bytes_;
  bool little_;
  std::size_t pos_ = kEncapsulationBytes;
};

class CdrOut {
 public:
  // The encapsulation header (CDR_LE) first.
  explicit CdrOut(std::size_t reserve = 0) {
    out_.reserve(reserve);
    out_.append("\x00\x01\x00\x00", kEncapsulationBytes);
  }

  void align(std::size_t n) {
    const std::size_t off = (out_.size() - kEncapsulationBytes) % n;
    if (off != 0) out_.append(n - off, '\0');
  }
  // A value of T, aligned to its size.
  template <typename T>
  void put(T v) {
    align(sizeof(T));
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    out_.append(b, sizeof(T));
  }
  // Bytes as they are (after a length put by the caller).
  void append(std::string_view b) { out_.append(b); }
  [[nodiscard]] std::size_t size() const noexcept { return out_.size(); }
  std::string take() { return std::move(out_); }

 private:
  std::string out_;
};

}  // namespace skr::ros2
