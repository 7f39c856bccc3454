// SPDX-License-Identifier: Apache-2.0
// flowctl echo and poll: print what a streaming channel carries, as it comes or its latest.
#include <chrono>
#include <csignal>
#include <optional>
#include <thread>

#include <skrobot/support/json.hpp>

#include "mcap_mapping.h"
#include "ros2_messages.h"
#include "session.h"

namespace flowctl {

using skr::flow::Variant;

namespace {

bool printable(std::string_view s) {
  if (!skr::flow::isValidUtf8(s)) return false;
  for (unsigned char c : s) {
    if (c < 0x20 && c != '\n' && c != '\t' && c != '\r') return false;
  }
  return true;
}

std::string hex(std::string_view s) {
  static const char* digits = "0123456789abcdef";
  std::string out;
  out.reserve(s.size() * 2);
  for (unsigned char c : s) out += {digits[c >> 4], digits[c & 15]};
  return out;
}

// A payload as a value: a binary Variant, else JSON text, else bytes.
Variant asValue(std::string_view payload) {
  skr::flow::ByteReader r(payload);
  if (auto v = skr::flow::decodeVariant(r); v && r.empty()) return std::move(v).value();
  if (auto v = skr::flow::variantFromJsonText(payload)) return std::move(v).value();
  return Variant::Bytes(std::string(payload));
}

std::string render(const std::string& format, bool json, const std::string& channel,
                   std::string_view payload) {
  const bool text = format == "text" || (format == "auto" && printable(payload));
  if (!json) {
    if (format == "json") return skr::flow::variantToJsonText(asValue(payload));
    return text ? std::string(payload) : hex(payload);
  }
  Variant data;
  if (format == "json") {
    data = asValue(payload);
  } else if (format == "hex" || !text || !skr::flow::isValidUtf8(payload)) {
    data = format == "hex" ? Variant(hex(payload)) : Variant(Variant::Bytes(std::string(payload)));
  } else {
    data = std::string(payload);
  }
  return skr::flow::variantToJsonText(
      Variant::Map{{"channel", channel}, {"bytes", payload.size()}, {"data", std::move(data)}});
}

}  // namespace

int cmdEcho(const Cli& cli) {
  Args args(cli.args);
  const std::string format = args.option("--format").value_or("auto");
  const auto count_text = args.option("--count");
  const bool rate = args.flag("--rate");
  const bool wait = args.flag("--wait");
  const auto queue_text = args.option("--queue");
  const auto max_hz_text = args.option("--max-hz");
  const auto rest = args.rest();
  if (!args.error().empty()) return fail(kUsage, args.error());
  if (rest.size() != 1) return usageError(cli);
  if (format != "auto" && format != "text" && format != "hex" && format != "json") {
    return fail(kUsage, "--format is auto, text, hex or json, not '" + format + "'");
  }
  double count = 0;
  if (count_text && !parseNumber(*count_text, "--count", count)) return kUsage;
  double queue = 0;
  if (queue_text && !parseNumber(*queue_text, "--queue", queue)) return kUsage;
  if (queue > 4294967295.0) return fail(kUsage, "--queue is at most 4294967295 bytes");
  double max_hz = 0;
  if (max_hz_text && !parseNumber(*max_hz_text, "--max-hz", max_hz)) return kUsage;
  if (max_hz > 65535 || max_hz != static_cast<double>(static_cast<uint32_t>(max_hz))) {
    return fail(kUsage, "--max-hz is a whole number of messages a second, at most 65535");
  }
  const std::string& name = rest[0];
  if (!flowOnly(cli)) {  // serial:, udp: no synchronous check: waits for the channel (--wait)
    int code = kOk;
    auto sync = connectSync(cli, code);
    if (!sync) return code;
    auto info = sync->channel(name);
    if (!info && sync->lastError() == skr::flow::ErrorCode::not_found) {
      if (!wait) return fail(kNotFound, "no such channel " + name + " (--wait waits for it)");
    } else if (!info) {
      return fail(exitFor(info.error()), info.error().message);
    } else if (info->kind != uint8_t(skr::flow::ChannelKind::streaming)) {
      return fail(kFailed, name + " is not a streaming channel (a service? use flowctl call)");
    }
  }
  Session s(cli, 100 * skr::kNsPerMs);
  uint64_t received = 0, window_msgs = 0, window_bytes = 0;
  // A ROS 2 channel's reader, for the channel instance (hash) it was made for.
  std::optional<ros2msg::CdrReader> ros2_reader;
  uint64_t typed_hash = 0;
  s.satellite.data.connect(&s.satellite, [&](uint16_t id, const std::string& payload) {
    const auto* info = s.satellite.channel(id);
    if (info == nullptr || info->name != name) return;
    ++window_msgs;
    window_bytes += payload.size();
    if (!rate && (format == "auto" || format == "json") && typed_hash != info->hash) {
      typed_hash = info->hash;
      std::string why;
      ros2_reader = ros2msg::CdrReader::of(mcapmap::typeOf(info->props), why);
      if (!why.empty())
        std::fprintf(stderr, "flowctl: %s: shown as bytes: %s\n", name.c_str(), why.c_str());
    }
    if (!rate && ros2_reader) {
      if (auto value = ros2_reader->read(payload)) {
        const std::string text = skr::support::writeJson(*value);
        const std::string line = cli.json ? skr::flow::variantToJsonText(Variant::Map{
                                                {"channel", name},
                                                {"bytes", payload.size()},
                                                {"data", *skr::flow::variantFromJsonText(text)}}) +
                                                "\n"
                                          : text + "\n";
        std::fwrite(line.data(), 1, line.size(), stdout);
        std::fflush(stdout);
        if (count > 0 && ++received >= static_cast<uint64_t>(count)) s.loop.stop();
        return;
      } else {
        std::fprintf(stderr, "flowctl: %s: %s\n", name.c_str(), value.error().message.c_str());
      }
    }
    if (!rate) {
      const std::string line = render(format, cli.json, name, payload) + "\n";
      std::fwrite(line.data(), 1, line.size(), stdout);
      std::fflush(stdout);
    }
    if (count > 0 && ++received >= static_cast<uint64_t>(count)) s.loop.stop();
  });
  if (rate) {
    s.loop.addTickHandler(skr::Tick::one_sec, [&] {
      if (cli.json) {
        std::printf("{\"channel\":\"%s\",\"messages_per_s\":%llu,\"bytes_per_s\":%llu}\n",
                    name.c_str(), (unsigned long long)window_msgs,
                    (unsigned long long)window_bytes);
      } else {
        std::printf("%s: %llu msg/s, %llu B/s\n", name.c_str(), (unsigned long long)window_msgs,
                    (unsigned long long)window_bytes);
      }
      std::fflush(stdout);
      window_msgs = window_bytes = 0;
    });
  }
  if (queue_text || max_hz_text) {
    // A request above the hub's cap: subscribed with the cap, and said so (the library's own
    // log line is below flowctl's level).
    s.satellite.error.connect(&s.satellite, [](const skr::sat::FlowError& e) {
      if (e.command == uint8_t(skr::flow::Code::subscribe_queue) ||
          e.command == uint8_t(skr::flow::Code::subscribe_rate)) {
        std::fprintf(stderr, "flowctl: %s\n", e.message.c_str());
      }
    });
    s.satellite.subscribe(name, static_cast<size_t>(queue), static_cast<uint16_t>(max_hz));
  } else {
    s.satellite.subscribe(name);
  }
  return s.run();
}

int cmdPoll(const Cli& cli) {
  Args args(cli.args);
  const std::string format = args.option("--format").value_or("auto");
  const auto count_text = args.option("--count");
  const auto interval_text = args.option("--interval");
  const auto rest = args.rest();
  if (!args.error().empty()) return fail(kUsage, args.error());
  if (rest.size() != 1) return usageError(cli);
  if (format != "auto" && format != "text" && format != "hex" && format != "json") {
    return fail(kUsage, "--format is auto, text, hex or json, not '" + format + "'");
  }
  double count = 0, interval_ms = 500;
  if (count_text && !parseNumber(*count_text, "--count", count)) return kUsage;
  if (interval_text && !parseNumber(*interval_text, "--interval", interval_ms)) return kUsage;
  const std::string& name = rest[0];
  int code = kOk;
  auto sync = connectSync(cli, code);
  if (!sync) return code;
  auto info = sync->channel(name);
  if (!info) return fail(exitFor(info.error()), info.error().message);
  if (info->kind != uint8_t(skr::flow::ChannelKind::streaming)) {
    return fail(kFailed, name + " is not a streaming channel");
  }
  if (auto r = sync->pollRegister(info->id); !r) return fail(exitFor(r.error()), r.error().message);
  // Until --count payloads were printed, or SIGINT/SIGTERM (checked between fetches).
  static volatile std::sig_atomic_t stop = 0;
  std::signal(SIGINT, [](int) { stop = 1; });
  std::signal(SIGTERM, [](int) { stop = 1; });
  uint64_t last = 0, printed = 0;
  while (stop == 0 && (count <= 0 || printed < static_cast<uint64_t>(count))) {
    auto p = sync->pollFetch(info->id);
    if (!p) return fail(exitFor(p.error()), p.error().message);
    if (p->seq != 0 && p->seq != last) {
      last = p->seq;
      ++printed;
      std::string line = render(format, cli.json, name, p->payload);
      if (cli.json) line.insert(1, "\"seq\":" + std::to_string(p->seq) + ",");
      line += "\n";
      std::fwrite(line.data(), 1, line.size(), stdout);
      std::fflush(stdout);
    }
    std::this_thread::sleep_for(std::chrono::microseconds(static_cast<int64_t>(interval_ms * 1e3)));
  }
  // Lets the hub stop keeping the payload (an older hub keeps it: it has no deregister).
  if (auto r = sync->pollDeregister(info->id); !r && r.error().code != skr::Errc::unsupported) {
    return fail(exitFor(r.error()), r.error().message);
  }
  return kOk;
}

}  // namespace flowctl
