// SPDX-License-Identifier: Apache-2.0
// Fuzz target: what reaches the bridge from NATS and from its config. Subjects (of requests for
// an exported channel's properties) and key-value keys must decode to the one name that encodes
// back to them, and any name must survive the round trip; the config reader takes any JSON.
#include "bridge_config.h"
#include "subject_map.h"

#include <skrobot/support/json.hpp>

#include <cstdint>
#include <cstdlib>
#include <string>

using namespace skr::nats_bridge;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::string prefix = "skrobot.hub";
  if (auto name = subjectChannel(prefix, text)) {
    if (channelSubject(prefix, *name) != text) std::abort();
  }
  if (subjectChannel(prefix, channelSubject(prefix, text)) != text) std::abort();
  if (auto key = decodeKey(text)) {
    if (encodeKey(*key) != text) std::abort();
  }
  if (decodeKey(encodeKey(text)) != text) std::abort();
  if (!badSubject(channelSubject(prefix, text), false)) {
    // A subject the bridge makes is one NATS takes.
  } else {
    std::abort();
  }
  (void)badSubject(text, true);
  if (auto json = skr::support::parseJson(text)) {
    BridgeConfig config;
    (void)readConfig(*json, config);
  }
  return 0;
}
