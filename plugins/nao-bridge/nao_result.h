// Errors as values for the nao-bridge core: Result<T> holds a T or an Error with a named kind.
#pragma once

#include <string>
#include <utility>
#include <variant>

namespace nao {

enum class Errc {
  protocol,     // the peer broke the qi protocol (bad magic, size, signature, payload)
  io,           // socket error
  timeout,      // no answer in time
  closed,       // the connection is gone
  remote,       // the robot answered with an error
  not_found,    // no such service or method
  unsupported,  // a type or feature this client does not implement
};

struct Error {
  Errc code = Errc::protocol;
  std::string message;
};

inline Error fail(Errc code, std::string message) {
  return Error{code, std::move(message)};
}

template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : v_(std::move(value)) {}  // NOLINT: implicit by design
  Result(Error e) : v_(std::move(e)) {}      // NOLINT
  explicit operator bool() const noexcept { return v_.index() == 0; }
  T& value() & { return std::get<0>(v_); }
  T&& value() && { return std::get<0>(std::move(v_)); }
  const T& value() const& { return std::get<0>(v_); }
  T* operator->() { return &std::get<0>(v_); }
  const T* operator->() const { return &std::get<0>(v_); }
  T& operator*() { return std::get<0>(v_); }
  [[nodiscard]] const Error& error() const { return std::get<1>(v_); }

 private:
  std::variant<T, Error> v_;
};

template <>
class [[nodiscard]] Result<void> {
 public:
  Result() = default;
  Result(Error e) : e_(std::move(e)), failed_(true) {}  // NOLINT
  explicit operator bool() const noexcept { return !failed_; }
  [[nodiscard]] const Error& error() const { return e_; }

 private:
  Error e_;
  bool failed_ = false;
};

}  // namespace nao
