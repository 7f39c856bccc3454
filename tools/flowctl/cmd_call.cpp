// SPDX-License-Identifier: Apache-2.0
// flowctl call: a request to a service channel, and its answer.
#include "cli.h"

namespace flowctl {

using skr::flow::Variant;

namespace {

// What an answer says went wrong, if it says so: services answer an object, by convention
// {"ok": true, ...} or {"ok": false, "error": "..."}, or {"error": "..."} (plugin_channels.hpp).
std::optional<std::string> failureIn(const Variant& answer) {
  const auto* map = answer.asMap();
  if (map == nullptr) return std::nullopt;
  std::optional<bool> ok;
  if (auto it = map->find("ok"); it != map->end()) ok = it->second.asBool();
  const std::string* error = nullptr;
  if (auto it = map->find("error"); it != map->end()) error = it->second.asString();
  const bool has_error = map->count("error") > 0;
  if (ok.value_or(!has_error)) return std::nullopt;
  if (error != nullptr) return *error;
  return std::string("the service answered that it failed");
}

}  // namespace

int cmdCall(const Cli& cli) {
  Args args(cli.args);
  const auto timeout = args.option("--timeout-ms");
  const auto rest = args.rest();
  if (!args.error().empty()) return fail(kUsage, args.error());
  if (rest.size() < 2 || rest.size() > 3) return usageError(cli);
  double timeout_ms = 5000;
  if (timeout && !parseNumber(*timeout, "--timeout-ms", timeout_ms)) return kUsage;
  Variant value;
  if (rest.size() == 3) {
    auto v = jsonArg(rest[2], "VALUE");
    if (!v) return kUsage;
    value = std::move(*v);
  }
  int code = kOk;
  auto sync = connectSync(cli, code);
  if (!sync) return code;
  auto info = sync->channel(rest[0]);
  if (!info) return fail(exitFor(info.error()), "no such channel " + rest[0]);
  if (info->kind != static_cast<uint8_t>(skr::flow::ChannelKind::service)) {
    return fail(kFailed, rest[0] + " is not a service channel");
  }
  auto answer = sync->call(info->id, rest[1], value, static_cast<uint32_t>(timeout_ms));
  if (!answer) {
    const auto e = sync->lastError();
    if (e == skr::flow::ErrorCode::timeout || answer.error().code == skr::Errc::timeout) {
      return fail(kTimeout,
                  rest[0] + " did not answer within " + std::to_string(int(timeout_ms)) + " ms");
    }
    return fail(e == skr::flow::ErrorCode::owner_gone ? kFailed : exitFor(answer.error()),
                rest[0] + ": " + answer.error().message);
  }
  std::printf("%s\n", skr::flow::variantToJsonText(*answer).c_str());
  // The answer is printed either way; a script tells a refusal by the exit code.
  if (const auto why = failureIn(*answer)) return fail(kAnsweredFailure, rest[0] + ": " + *why);
  return kOk;
}

}  // namespace flowctl
