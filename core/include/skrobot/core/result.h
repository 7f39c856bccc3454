// Error values with names: Result<T> holds either a T or an Error (code + message).
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <variant>

namespace skr {

enum class Errc {
  ok = 0,
  invalid_argument,
  not_found,
  io_error,
  parse_error,
  config_error,
  abi_mismatch,
  module_failed,
  exception,
  timeout,
  closed,
  permission_denied,
  limit_exceeded,
  protocol_error,
  already_exists,
};

// Stable name of an error code, suitable for log lines.
[[nodiscard]] std::string_view errcName(Errc code) noexcept;

struct Error {
  Errc code = Errc::ok;
  std::string message;

  [[nodiscard]] std::string describe() const {
    return std::string(errcName(code)) + ": " + message;
  }
};

template <typename T>
class [[nodiscard]] Result {
 public:
  Result(T value) : v_(std::move(value)) {}      // NOLINT(google-explicit-constructor)
  Result(Error error) : v_(std::move(error)) {}  // NOLINT(google-explicit-constructor)

  [[nodiscard]] bool ok() const noexcept { return v_.index() == 0; }
  explicit operator bool() const noexcept { return ok(); }

  T& value() & { return std::get<0>(v_); }
  const T& value() const& { return std::get<0>(v_); }
  T&& value() && { return std::get<0>(std::move(v_)); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() & { return value(); }

  [[nodiscard]] const Error& error() const { return std::get<1>(v_); }

 private:
  std::variant<T, Error> v_;
};

template <>
class [[nodiscard]] Result<void> {
 public:
  Result() = default;
  Result(Error error) : error_(std::move(error)) {}  // NOLINT(google-explicit-constructor)

  [[nodiscard]] bool ok() const noexcept { return error_.code == Errc::ok; }
  explicit operator bool() const noexcept { return ok(); }
  [[nodiscard]] const Error& error() const { return error_; }

 private:
  Error error_;
};

inline Error makeError(Errc code, std::string message) {
  return Error{code, std::move(message)};
}

}  // namespace skr
