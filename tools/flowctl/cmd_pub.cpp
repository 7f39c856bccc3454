// SPDX-License-Identifier: Apache-2.0
// flowctl pub: publish on one of the caller's channels, creating it for the time flowctl runs.
#include <skrobot/channel_type.hpp>

#include <algorithm>
#include <fstream>
#include <iostream>
#include <iterator>

#include "ros2_messages.h"
#include "session.h"

namespace flowctl {

int cmdPub(const Cli& cli) {
  Args args(cli.args);
  const auto file = args.option("--file");
  const auto repeat_text = args.option("--repeat");
  const auto rate_text = args.option("--rate");
  const std::string mime = args.option("--mime").value_or("text/plain");
  const auto wait_text = args.option("--wait-ms");
  const auto props_text = args.option("--props");
  const auto message_encoding = args.option("--encoding");
  const auto schema_name = args.option("--schema-name");
  const auto schema_encoding = args.option("--schema-encoding");
  const auto schema_file = args.option("--schema-file");
  const bool variant = args.flag("--variant");
  const auto ros2_type = args.option("--ros2-type");
  const auto definitions = args.option("--definitions");
  const auto rest = args.rest();
  if (!args.error().empty()) return fail(kUsage, args.error());
  if (rest.empty() || rest.size() > 2 || (rest.size() == 2 && file)) return usageError(cli);
  if (ros2_type && (message_encoding || schema_name || schema_encoding || schema_file || variant)) {
    return fail(kUsage,
                "--ros2-type gives the channel its type: not with --encoding, --schema-* "
                "or --variant");
  }
  if (definitions && !ros2_type) return fail(kUsage, "--definitions goes with --ros2-type");
  double repeat = 1, rate = 0, wait_ms = 1000;
  if (repeat_text && !parseNumber(*repeat_text, "--repeat", repeat)) return kUsage;
  if (rate_text && !parseNumber(*rate_text, "--rate", rate)) return kUsage;
  if (wait_text && !parseNumber(*wait_text, "--wait-ms", wait_ms)) return kUsage;
  const bool forever = rate > 0 && !repeat_text;
  skr::flow::Variant props = skr::flow::Variant::Map{};
  if (props_text) {
    auto v = skr::flow::variantFromJsonText(*props_text);
    if (!v || !v->isMap())
      return fail(kUsage, "--props: a JSON object, e.g. '{\"encoding\":\"bgr8\"}'");
    props = std::move(*v);
  }
  namespace ct = skr::channel_type;
  auto setType = [&](const ct::ChannelType& type) {
    auto& map = *props.asMap();
    map[std::string(ct::kMessageEncodingKey)] = type.message_encoding;
    if (!type.schema_name.empty()) {
      map[std::string(ct::kSchemaNameKey)] = type.schema_name;
      map[std::string(ct::kSchemaEncodingKey)] = type.schema_encoding;
      map[std::string(ct::kSchemaKey)] = type.schema;
    }
  };
  // The channel's type (docs/channels.md, "Typed channels"), checked before anything is sent.
  if (message_encoding || schema_name || schema_encoding || schema_file) {
    ct::ChannelType type{message_encoding.value_or(""), schema_name.value_or(""),
                         schema_encoding.value_or(""), ""};
    if (schema_file) {
      std::ifstream in(*schema_file, std::ios::binary);
      if (!in) return fail(kFailed, "cannot read " + *schema_file);
      type.schema.assign(std::istreambuf_iterator<char>(in), {});
    }
    if (auto bad = ct::check(type)) return fail(kUsage, "the channel's type: " + *bad);
    setType(type);
  }

  std::string payload;
  if (rest.size() == 2) {
    payload = rest[1];
  } else if (file) {
    std::ifstream in(*file, std::ios::binary);
    if (!in) return fail(kFailed, "cannot read " + *file);
    payload.assign(std::istreambuf_iterator<char>(in), {});
  } else {
    payload.assign(std::istreambuf_iterator<char>(std::cin), {});
  }
  if (variant) {
    auto v = skr::flow::variantFromJsonText(payload);
    if (!v) return fail(kUsage, "--variant: the payload must be JSON: " + v.error().message);
    payload.clear();
    skr::flow::ByteWriter w(payload);
    skr::flow::encodeVariant(*v, w);
  }
  if (ros2_type) {  // JSON as the CDR of a ROS 2 type (docs/ros2.md)
    std::vector<std::string> folders;
    if (definitions) folders.push_back(*definitions);
    auto registry = ros2msg::shippedRegistry(folders);
    if (!registry) return fail(kFailed, registry.error().message);
    auto encoded = ros2msg::encode(*registry, *ros2_type, payload);
    if (!encoded) return fail(kUsage, "--ros2-type: " + encoded.error().message);
    payload = std::move(encoded->sample);
    setType(encoded->type);
  }

  std::string full = rest[0], short_name;
  if (flowOnly(cli)) {  // no synchronous check: the hub refuses a channel that is not ours
    const std::string prefix = cli.connect.user + ".";
    if (full.find('.') == std::string::npos) full = prefix + full;
    if (!full.starts_with(prefix)) {
      return fail(kDenied, full + " is not yours: you publish on " + prefix + "<name> channels");
    }
    short_name = full.substr(prefix.size());
  } else {
    int code = kOk;
    auto sync = connectSync(cli, code);
    if (!sync) return code;
    const std::string prefix = sync->login().user + ".";
    if (full.find('.') == std::string::npos) full = prefix + full;
    if (!full.starts_with(prefix)) {
      return fail(kDenied, full + " is not yours: you publish on " + prefix +
                               "<name> channels (logged in as " + sync->login().user + ")");
    }
    short_name = full.substr(prefix.size());
    if (auto info = sync->channel(full)) {
      return fail(kDenied, full + " exists and belongs to connection " +
                               std::to_string(info->owner_connection) +
                               ": only its owner publishes on it");
    }
  }
  const skr::Nanos tick =
      rate > 0 ? static_cast<skr::Nanos>(1e9 / rate) : skr::Nanos{skr::kNsPerMs};
  Session s(cli, std::max<skr::Nanos>(tick, 1000));
  if (auto added =
          s.satellite.addChannel({.name = short_name, .mime = mime, .props = std::move(props)});
      !added) {
    return fail(kUsage, added.error().message);
  }
  skr::Nanos ready_ns = 0;
  bool publishing = false;
  uint64_t sent = 0, bytes = 0;
  const auto total = static_cast<uint64_t>(repeat);
  s.satellite.channelReady.connect(&s.satellite,
                                   [&](const sat::ChannelInfo&) { ready_ns = skr::monotonicNs(); });
  s.loop.addTickHandler(skr::Tick::fast, [&] {
    if (ready_ns == 0 || !s.satellite.isConnected()) return;
    if (!publishing) {
      const bool waited = skr::monotonicNs() - ready_ns >= static_cast<skr::Nanos>(wait_ms * 1e6);
      publishing = s.satellite.hasSubscribers(short_name) || waited;
      if (!publishing) return;
    }
    // With a rate, one message per tick; without, as many as the queue takes.
    while ((forever || sent < total) && s.satellite.queuedBytes() < (1u << 20)) {
      if (auto r = s.satellite.publish(short_name, payload); !r) {
        return s.end(kFailed, r.error().message);
      }
      ++sent;
      bytes += payload.size();
      if (rate > 0) break;
    }
    if (!forever && sent >= total && s.satellite.queuedBytes() == 0) s.loop.stop();
  });
  const int code = s.run();
  if (code != kOk) return code;
  if (cli.json) {
    std::printf("{\"channel\":\"%s\",\"messages\":%llu,\"bytes\":%llu}\n", full.c_str(),
                (unsigned long long)sent, (unsigned long long)bytes);
  } else {
    std::printf("published %llu message%s (%llu bytes) on %s\n", (unsigned long long)sent,
                sent == 1 ? "" : "s", (unsigned long long)bytes, full.c_str());
  }
  return kOk;
}

}  // namespace flowctl
