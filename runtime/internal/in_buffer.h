// SPDX-License-Identifier: Apache-2.0
// Bytes read from a socket, received straight into place (no zero-filling, no copy from a bounce
// buffer): a large frame is read into memory that already has its size. Used by path sockets and
// the synchronous connection.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstring>
#include <memory>
#include <string_view>

namespace skr::flow {

class InBuffer {
 public:
  [[nodiscard]] std::string_view view() const { return {data_.get() + head_, len_}; }
  [[nodiscard]] bool empty() const { return len_ == 0; }
  void append(std::string_view b) {
    std::memcpy(tail(b.size()), b.data(), b.size()), len_ += b.size();
  }
  // Room for `n` more bytes at the end; commit(k) keeps the k read there.
  char* tail(size_t n) {
    if (head_ + len_ + n > cap_) {
      const size_t cap = std::max(cap_ * 2, len_ + n);
      if (len_ + n <= cap_ && head_ > 0) {
        std::memmove(data_.get(), data_.get() + head_, len_);
      } else {
        std::unique_ptr<char[]> d(new char[cap]);
        if (len_ > 0) std::memcpy(d.get(), data_.get() + head_, len_);
        data_ = std::move(d);
        cap_ = cap;
      }
      head_ = 0;
    }
    return data_.get() + head_ + len_;
  }
  void commit(size_t n) { len_ += n; }
  void consume(size_t n) {
    head_ += n;
    len_ -= n;
    if (len_ == 0) head_ = 0;
  }
  void clear() { head_ = len_ = 0; }

 private:
  std::unique_ptr<char[]> data_;
  size_t cap_ = 0, head_ = 0, len_ = 0;
};

}  // namespace skr::flow
