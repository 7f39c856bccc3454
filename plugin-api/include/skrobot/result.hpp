// SPDX-License-Identifier: Apache-2.0
// Errors as values, shared by the hub, the satellite libraries, the tools and every module
// (header-only: nothing here crosses the C seam of plugin.h).
//
// Result<T> holds either a T or an Error (a named code and a message). The codes cover the
// FlowProtocol's wire errors one for one (skrobot/runtime/flow/protocol.h maps them both ways),
// plus the local failures that never travel (config, ABI, module steps).
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
  owner_gone,        // the owner of a channel or request went away
  overflow,          // a queue or table is full
  unsupported,       // the peer (or this build) does not implement it
  auth_failed,       // wrong user or password
  version_mismatch,  // the peer speaks another major version
  not_logged_in,     // a command that needs a login came before it
  internal,          // a bug on the far side
  remote,            // a remote system (e.g. a robot) answered with its own error
};

// Stable name of an error code, suitable for log lines and JSON.
[[nodiscard]] constexpr std::string_view errcName(Errc code) noexcept {
  switch (code) {
    case Errc::ok:
      return "ok";
    case Errc::invalid_argument:
      return "invalid_argument";
    case Errc::not_found:
      return "not_found";
    case Errc::io_error:
      return "io_error";
    case Errc::parse_error:
      return "parse_error";
    case Errc::config_error:
      return "config_error";
    case Errc::abi_mismatch:
      return "abi_mismatch";
    case Errc::module_failed:
      return "module_failed";
    case Errc::exception:
      return "exception";
    case Errc::timeout:
      return "timeout";
    case Errc::closed:
      return "closed";
    case Errc::permission_denied:
      return "permission_denied";
    case Errc::limit_exceeded:
      return "limit_exceeded";
    case Errc::protocol_error:
      return "protocol_error";
    case Errc::already_exists:
      return "already_exists";
    case Errc::owner_gone:
      return "owner_gone";
    case Errc::overflow:
      return "overflow";
    case Errc::unsupported:
      return "unsupported";
    case Errc::auth_failed:
      return "auth_failed";
    case Errc::version_mismatch:
      return "version_mismatch";
    case Errc::not_logged_in:
      return "not_logged_in";
    case Errc::internal:
      return "internal";
    case Errc::remote:
      return "remote";
  }
  return "unknown";
}

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
  const T& operator*() const& { return value(); }

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
