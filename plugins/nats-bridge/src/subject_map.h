// SPDX-License-Identifier: Apache-2.0
// Names between the hub and NATS (docs/fleet.md, "Subjects"): a channel name becomes a subject
// under the bridge's prefix, a database key a JetStream key-value key, both reversibly and
// without collisions.
//
// Channel names: each '.'-separated part is one NATS token. Within a token A-Z a-z 0-9 '-' '_'
// stay; every other byte ('/', a linked hub's separator, among them) is written %XX (hex, upper
// case); an empty part is the token "%"; a '_' starting the first part is written %5F, so that
// tokens starting with '_' right after the prefix are the bridge's own (_props, _status).
//   guest.camera        -> <prefix>.guest.camera
//   arm/guest.cam.left  -> <prefix>.arm%2Fguest.cam.left
// Keys: A-Z a-z 0-9 '-' '_' '/' '.' stay (a '.' neither first nor last); every other byte,
// '=' included, is =XX.
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace skr::nats_bridge {

// One token for a part of a name (see above); `first`: the first part after the prefix.
[[nodiscard]] std::string encodeToken(std::string_view part, bool first);
// The subject of channel `name` under `prefix` (a subject without wildcards).
[[nodiscard]] std::string channelSubject(std::string_view prefix, std::string_view name);
// The channel name of a subject under `prefix`; nullopt when it is not one (another prefix, a
// reserved token, a bad escape).
[[nodiscard]] std::optional<std::string> subjectChannel(std::string_view prefix,
                                                        std::string_view subject);

[[nodiscard]] std::string encodeKey(std::string_view key);
[[nodiscard]] std::optional<std::string> decodeKey(std::string_view encoded);

// A subject as NATS takes it: tokens of printable ASCII other than space, none empty; with
// `wildcards`, a token may be "*" and the last one ">". The reason when not.
[[nodiscard]] std::optional<std::string> badSubject(std::string_view subject, bool wildcards);

}  // namespace skr::nats_bridge
