// SPDX-License-Identifier: Apache-2.0
// flowctl: argument helpers, errors and the synchronous connection shared by the commands.
#include <charconv>
#include <cmath>

#include "cli.h"

namespace flowctl {

std::optional<std::string> Args::option(std::string_view name) {
  for (size_t i = 0; i < args_.size(); ++i) {
    const std::string& a = args_[i];
    if (a == "--") break;
    if (a == name) {
      if (i + 1 >= args_.size()) {
        if (error_.empty()) error_ = std::string(name) + " needs a value";
        args_.erase(args_.begin() + static_cast<long>(i));
        return std::nullopt;
      }
      std::string value = args_[i + 1];
      args_.erase(args_.begin() + static_cast<long>(i), args_.begin() + static_cast<long>(i) + 2);
      return value;
    }
    if (a.size() > name.size() && a.compare(0, name.size(), name) == 0 && a[name.size()] == '=') {
      std::string value = a.substr(name.size() + 1);
      args_.erase(args_.begin() + static_cast<long>(i));
      return value;
    }
  }
  return std::nullopt;
}

bool Args::flag(std::string_view name) {
  for (size_t i = 0; i < args_.size(); ++i) {
    if (args_[i] == "--") break;
    if (args_[i] == name) {
      args_.erase(args_.begin() + static_cast<long>(i));
      return true;
    }
  }
  return false;
}

std::vector<std::string> Args::rest() {
  std::vector<std::string> out;
  bool positional_only = false;
  for (const auto& a : args_) {
    if (!positional_only && a == "--") {
      positional_only = true;
    } else if (!positional_only && a.size() > 1 && a[0] == '-' &&
               !(std::isdigit(static_cast<unsigned char>(a[1])) || a[1] == '.')) {
      if (error_.empty()) error_ = "unknown option '" + a + "'";
    } else {
      out.push_back(a);
    }
  }
  return out;
}

int fail(int code, const std::string& message) {
  std::fprintf(stderr, "flowctl: %s\n", message.c_str());
  return code;
}

int exitFor(const skr::Error& error) {
  switch (error.code) {
    case skr::Errc::not_found:
      return kNotFound;
    case skr::Errc::timeout:
      return kTimeout;
    case skr::Errc::permission_denied:
      return kDenied;
    case skr::Errc::closed:
      return kNoHub;
    default:
      return kFailed;
  }
}

std::optional<skr::sat::SyncClient> connectSync(const Cli& cli, int& code) {
  auto c = skr::sat::SyncClient::connect(cli.connect);
  if (c) return std::move(c).value();
  switch (c.error().code) {
    case skr::Errc::io_error:
    case skr::Errc::timeout:
      code = kNoHub;
      break;
    case skr::Errc::auth_failed:
    case skr::Errc::version_mismatch:
      code = kLoginRefused;
      break;
    default:
      code = kFailed;
  }
  fail(code, c.error().message);
  return std::nullopt;
}

bool flowOnly(const Cli& cli) {
  const auto kind = cli.connect.address.kind;
  return kind == skr::sat::Address::Kind::serial || kind == skr::sat::Address::Kind::udp ||
         kind == skr::sat::Address::Kind::ws || kind == skr::sat::Address::Kind::wss;
}

bool parseNumber(const std::string& text, const char* what, double& out) {
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), out);
  if (ec != std::errc() || end != text.data() + text.size() || !std::isfinite(out) || out < 0) {
    fail(kUsage, std::string(what) + " must be a non-negative number, got '" + text + "'");
    return false;
  }
  return true;
}

std::optional<skr::flow::Variant> jsonArg(const std::string& text, const char* what) {
  auto v = skr::flow::variantFromJsonText(text);
  if (v) return std::move(v).value();
  fail(kUsage,
       std::string(what) + " must be JSON (" + v.error().message + "); quote strings: '\"text\"'");
  return std::nullopt;
}

int runAdmin(const Cli& cli, const std::string& command, const skr::flow::Variant& args,
             const std::function<void(const skr::flow::Variant&)>& print) {
  int code = kOk;
  auto sync = connectSync(cli, code);
  if (!sync) return code;
  auto answer = sync->admin(command, args);
  if (!answer) return fail(exitFor(answer.error()), command + ": " + answer.error().message);
  if (cli.json) {
    std::printf("%s\n", skr::flow::variantToJsonText(*answer).c_str());
  } else {
    print(*answer);
  }
  return kOk;
}

std::string field(const skr::flow::Variant& map, const char* key) {
  const auto* m = map.asMap();
  if (m == nullptr) return {};
  auto it = m->find(key);
  if (it == m->end()) return {};
  if (const auto* s = it->second.asString()) return *s;
  return skr::flow::variantToJsonText(it->second);
}

}  // namespace flowctl
