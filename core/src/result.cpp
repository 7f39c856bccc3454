#include <skrobot/core/result.h>

namespace skr {

std::string_view errcName(Errc code) noexcept {
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
  }
  return "unknown";
}

}  // namespace skr
