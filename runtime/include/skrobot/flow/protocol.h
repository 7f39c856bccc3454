// FlowProtocol: frame layout, command codes, error codes and limits. docs/flow-protocol.md is the
// byte-by-byte specification; this header is its code. Used by the hub, the satellite libraries,
// the tests and the fuzz targets.
//
// A frame: u32 length (bytes after this field, >= 1), u8 code, body. Little-endian throughout.
#pragma once

#include <skrobot/result.hpp>

#include <cstdint>
#include <string>
#include <string_view>

namespace skr::flow {

constexpr uint16_t kProtocolMajor = 1;
constexpr uint16_t kProtocolMinor = 11;  // history: docs/flow-protocol.md, "Minor versions"

constexpr size_t kFrameHeaderBytes = 5;                       // u32 length + u8 code
constexpr uint32_t kDefaultMaxFrameBytes = 16 * 1024 * 1024;  // the length field's limit
constexpr uint32_t kMaxChannels = 32768;
// The largest frame a hub reads before LOGIN succeeded: a LOGIN with the longest user name and
// password and a long client name fits.
constexpr uint32_t kPreLoginMaxFrameBytes = 4096;

enum class Code : uint8_t {
  // Synchronous requests, client -> hub; each gets exactly one REPLY_OK or REPLY_ERROR, in order.
  login = 0x01,
  db_select = 0x02,
  db_create = 0x03,
  db_save = 0x04,
  db_remove = 0x05,
  var_get = 0x06,
  var_set = 0x07,
  var_del = 0x08,
  var_get_all = 0x09,
  var_keys = 0x0A,
  chan_list = 0x0B,
  poll_register = 0x0C,
  poll_fetch = 0x0D,
  service_call = 0x0E,
  go_async = 0x0F,
  ping = 0x10,
  db_list = 0x11,
  chan_info = 0x12,
  db_sync = 0x13,  // 1.2: answered once every database change made before it is on disk
  // 1.1
  admin = 0x14,            // administration: an administrator's command, a value in, a value out
  poll_deregister = 0x15,  // 1.4: the hub stops keeping a channel's latest payload for this client

  // Asynchronous commands, client -> hub, on a flow. No reply on success; failures come back as
  // EV_ERROR carrying the command's tag.
  chan_add = 0x40,
  chan_remove = 0x41,
  subscribe = 0x42,
  unsubscribe = 0x43,
  publish = 0x44,
  service_request = 0x45,
  service_response = 0x46,
  db_set_current = 0x47,
  db_create_async = 0x48,
  db_remove_async = 0x49,
  db_save_async = 0x4A,
  var_set_async = 0x4B,
  var_del_async = 0x4C,
  chan_set_props = 0x4D,
  db_sync_async = 0x4E,  // 1.2: EV_DB_SYNCED with its tag once the changes before it are on disk
  service_request_timed = 0x4F,  // 1.4: SERVICE_REQUEST with the caller's timeout
  db_read = 0x50,  // 1.6: a database read on a flow (a linked hub's too); EV_DB_VALUE answers

  // Hub -> client.
  reply_ok = 0x80,
  reply_error = 0x81,
  ev_db_changed = 0x90,
  ev_chan_added = 0x91,
  ev_chan_removed = 0x92,
  ev_chan_header = 0x93,
  ev_service_request = 0x94,
  ev_start_publish = 0x95,
  ev_stop_publish = 0x96,
  ev_data = 0x97,
  ev_service_response = 0x98,
  ev_error = 0x99,
  ev_dropped = 0x9A,
  ev_db_synced = 0x9B,  // 1.2
  ev_db_value = 0x9C,   // 1.6: the answer to DB_READ

  // 1.3: blob channels. Synchronous requests (REPLY_OK or REPLY_ERROR, on a synchronous
  // connection), and one event to the subscribers of a blob channel.
  blob_list = 0xC0,
  blob_get = 0xC1,
  blob_put = 0xC2,
  blob_mkdir = 0xC3,
  blob_rmdir = 0xC4,
  blob_remove = 0xC5,
  blob_chunk = 0xC6,
  blob_modify = 0xC7,
  blob_abort = 0xC8,
  blob_create = 0xC9,
  ev_blob_changed = 0xCF,

  // 1.4: the sync pulse. A source is a channel of kind sync; commands on a flow, and one event.
  sync_pulse = 0xD0,     // the source's pulse
  sync_follow = 0xD1,    // become a target of a source (every Nth pulse)
  sync_unfollow = 0xD2,  // stop following it
  sync_done = 0xD3,      // a target's tick for a pulse is done: it may have the next one
  ev_sync_pulse = 0xD8,  // a pulse, to each target

  // 1.5: hub links. A hub that links to another logs in as a satellite and says who it is.
  hub_link_hello = 0xE8,  // synchronous, after LOGIN: the linking hub's name
  time_probe = 0xE9,      // on a flow: the sender's wall clock, answered at once
  ev_time_probe = 0xEA,   // the answer: the hub's wall clock when it got and answered the probe

  // 1.5: replicas: a channel mirrored as a local one of the caller's name, while its flow lasts.
  replicate_channel = 0xE0,  // on a flow
  replicate_stop = 0xE1,     // on a flow

  // 1.6: a shared link (two hubs that list each other keep one connection): the far hub asks the
  // linking hub to offer its channels over the connection the linking hub opened.
  link_offer = 0xE2,      // on a flow: one of the linking hub's channels, owned here by its link
  ev_link_wanted = 0xEB,  // hub -> linking hub: offer your channels on this connection

  // 1.7: physical mode (docs/physical-mode.md): the hub grants direct and shared-memory paths
  // between a channel's owner and its subscribers. Commands on a flow, events to the two ends.
  phys_offer = 0xF0,      // owner: the paths it serves for a channel, and where
  phys_request = 0xF1,    // subscriber: a path to a channel it follows
  phys_state = 0xF2,      // subscriber: its path works (stop relaying to it) or broke
  phys_count = 0xF3,      // owner: messages it delivered over paths only, for the statistics
  ev_phys_grant = 0xF8,   // to the owner: accept this subscriber with this token, once
  ev_phys_path = 0xF9,    // to the subscriber: where to connect, with which token
  ev_phys_revoke = 0xFA,  // to the owner: close that subscriber's path
  ev_phys_relay = 0xFB,   // to the owner: whether any subscriber still needs the relay
  // 1.8: PHYS_OFFER's endpoint may name a unix: and a tcp: endpoint, separated by a space.
  // 1.9: a subscriber moves to its path at a point of the owner's choosing, so that nothing
  // published meanwhile is lost: the hub asks the owner, which answers with its message number.
  phys_switched = 0xF4,   // owner: the subscriber may leave the relay after message `seq`
  ev_phys_switch = 0xFC,  // to the owner: a subscriber's path works; answer with PHYS_SWITCHED
  ev_phys_marker = 0xFD,  // to the subscriber: relayed up to `seq`; the rest comes on the path
  // 1.10: each subscriber reports what came on its path, for the statistics of its flow.
  phys_received = 0xF5,  // subscriber: messages, bytes and skipped ones on its path since the last
  // 1.11: a direct path falls back to the relay without losing what the owner sent meanwhile.
  phys_fallback = 0xF6,   // subscriber: its direct path broke after message `last`
  phys_replay = 0xF7,     // owner: a kept message for one subscriber, or the end of them
  ev_phys_resume = 0xFE,  // to the owner: replay what came after `after` to that subscriber
};

[[nodiscard]] std::string_view codeName(uint8_t code) noexcept;

// A blob channel request (1.3): sent by satellites on a synchronous connection, like 0x01-0x3F.
[[nodiscard]] constexpr bool isBlobRequest(uint8_t code) noexcept {
  return code >= 0xC0 && code <= 0xC9;
}
// A synchronous request of a family block: blob channels (1.3), HUB_LINK_HELLO (1.5).
[[nodiscard]] constexpr bool isSyncFamilyRequest(uint8_t code) noexcept {
  return isBlobRequest(code) || code == 0xE8;
}
// A command of a family block sent on a flow: the sync pulse (1.4), replicas and TIME_PROBE (1.5),
// LINK_OFFER (1.6), physical mode (1.7, 1.9, 1.10).
[[nodiscard]] constexpr bool isFlowFamilyCommand(uint8_t code) noexcept {
  return (code >= 0xD0 && code <= 0xD3) || (code >= 0xE0 && code <= 0xE2) || code == 0xE9 ||
         (code >= 0xF0 && code <= 0xF7);
}
// A sync pulse command (1.4): sent by satellites on a flow, like 0x40-0x7F.
[[nodiscard]] constexpr bool isSyncCommand(uint8_t code) noexcept {
  return code >= 0xD0 && code <= 0xD3;
}

enum class ErrorCode : uint16_t {
  ok = 0,
  protocol_error = 1,
  version_mismatch = 2,
  auth_failed = 3,
  not_logged_in = 4,
  not_found = 5,
  already_exists = 6,
  permission_denied = 7,
  invalid_argument = 8,
  timeout = 9,
  owner_gone = 10,
  overflow = 11,
  unsupported = 12,
  limit_exceeded = 13,
  io_error = 14,
  internal = 15,
};

[[nodiscard]] std::string_view errorCodeName(ErrorCode code) noexcept;

// The protocol minor that introduced `code` (0 for everything of 1.0). A request newer than the
// connection's minor (the lower of the client's and the hub's) is answered `unsupported`.
[[nodiscard]] uint16_t minorOf(Code code) noexcept;

// The one mapping between wire errors and skr::Errc, used by the hub, its modules (LocalClient)
// and the satellite libraries, so that a failure reaches every client as the same code.
// Every ErrorCode has the Errc of the same name, and toErrorCode(toErrc(e)) == e. Codes that never
// travel map onto the nearest wire error: config_error and parse_error -> invalid_argument,
// closed -> io_error, abi_mismatch, module_failed, exception and remote -> internal.
[[nodiscard]] Errc toErrc(ErrorCode code) noexcept;
[[nodiscard]] ErrorCode toErrorCode(Errc code) noexcept;
// A wire error as an Error (toErrc(code) and the peer's message).
[[nodiscard]] Error wireError(ErrorCode code, std::string message);

// sync (1.4): a sync pulse source; it carries pulses, not data.
enum class ChannelKind : uint8_t { streaming = 1, service = 2, blob = 3, sync = 4 };
[[nodiscard]] std::string_view channelKindName(ChannelKind kind) noexcept;
// The protocol minor that introduced a channel kind (0 for those of 1.0).
[[nodiscard]] uint16_t minorOfKind(ChannelKind kind) noexcept;

// How a frame carries a typed value: u8 encoding, then a binary Variant or u32 length + JSON text.
enum class ValueEncoding : uint8_t { binary = 0, json = 1 };

// Splits a byte stream into frames. Feed it what the socket gave; it never allocates more than
// the announced length of a frame, and only after checking that length against the limit.
class FrameSplitter {
 public:
  explicit FrameSplitter(uint32_t max_frame_bytes = kDefaultMaxFrameBytes)
      : max_(max_frame_bytes) {}

  enum class Status { frame, need_more, too_large, empty_frame };

  // Looks at the buffered bytes [data, data+size) and reports the next frame: on `frame`,
  // `code`, `body` (a view into data) and `consumed` (header + body) are set. On `need_more`,
  // `wanted` is the total number of bytes the next frame needs (header included) when known.
  struct Next {
    Status status = Status::need_more;
    uint8_t code = 0;
    std::string_view body;
    size_t consumed = 0;
    size_t wanted = 0;
    uint32_t announced = 0;  // the length field, for error messages
  };
  [[nodiscard]] Next next(const uint8_t* data, size_t size) const noexcept;
  [[nodiscard]] uint32_t maxFrameBytes() const noexcept { return max_; }
  void setMaxFrameBytes(uint32_t max_frame_bytes) noexcept { max_ = max_frame_bytes; }

 private:
  uint32_t max_;
};

// Appends a frame header for a body of `body_bytes` bytes; the caller appends the body.
void appendHeader(std::string& out, Code code, size_t body_bytes);

}  // namespace skr::flow
