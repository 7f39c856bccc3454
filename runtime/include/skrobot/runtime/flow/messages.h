// SPDX-License-Identifier: Apache-2.0
// The body of every FlowProtocol frame as a struct. Each struct lists its fields once, in wire
// order, with SKR_FLOW_FIELDS; the same list drives encoding and decoding (codec.h) and the
// catalogue's description of the layout (catalogue.h, describe.h), so they cannot disagree.
// Field types and their wire form:
//   uint8_t/uint16_t/uint32_t/uint64_t  fixed-size little-endian
//   std::string                          str16: u16 length + bytes
//   Text32                               str32: u32 length + bytes
//   Variant                              value: u8 encoding (0 binary, 1 JSON) + binary Variant or
//                                        str32 JSON text
//   Rest                                 the remaining bytes of the frame (payloads), a view
#pragma once

#include <skrobot/runtime/flow/protocol.h>
#include <skrobot/runtime/flow/variant.h>

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

// The fields of a message struct, in wire order: defines io(f), which calls f(field) for each in
// turn (codec.h's readers and writers), and field_names, the same list as text (describe.h).
#define SKR_FLOW_FIELDS(...)                                            \
  static constexpr std::string_view field_names = #__VA_ARGS__;         \
  template <class IO>                                                   \
  bool io(IO& f) {                                                      \
    return ::skr::flow::msg::visitFields(f __VA_OPT__(, ) __VA_ARGS__); \
  }

namespace skr::flow::msg {

template <class IO, class... T>
bool visitFields(IO& f, T&... fields) {
  return (f(fields) && ...);
}

struct Text32 {
  std::string text;
};
struct Rest {
  std::string_view bytes;  // points into the decoded frame, or at the data to encode
};

// --- synchronous requests ------------------------------------------------------------------
struct Login {
  static constexpr Code code = Code::login;
  uint16_t major = kProtocolMajor;
  uint16_t minor = kProtocolMinor;
  uint8_t value_encoding = 0;  // ValueEncoding the hub uses for values it sends
  std::string user, password, client_name;
  SKR_FLOW_FIELDS(major, minor, value_encoding, user, password, client_name)
};
struct LoginOk {
  static constexpr Code code = Code::reply_ok;
  uint16_t major = kProtocolMajor;
  uint16_t minor = kProtocolMinor;
  uint32_t connection_id = 0;
  std::string app_name, user, current_db;
  SKR_FLOW_FIELDS(major, minor, connection_id, app_name, user, current_db)
};
// db_select, db_create, db_save, db_remove (empty name = the current database for save).
template <Code C>
struct DbName {
  static constexpr Code code = C;
  std::string name;
  SKR_FLOW_FIELDS(name)
};
using DbSelect = DbName<Code::db_select>;
using DbCreate = DbName<Code::db_create>;
using DbSave = DbName<Code::db_save>;
using DbRemove = DbName<Code::db_remove>;
struct VarGet {
  static constexpr Code code = Code::var_get;
  std::string key;
  SKR_FLOW_FIELDS(key)
};
struct VarSet {
  static constexpr Code code = Code::var_set;
  std::string key;
  Variant value;
  SKR_FLOW_FIELDS(key, value)
};
struct VarDel {
  static constexpr Code code = Code::var_del;
  std::string key;
  SKR_FLOW_FIELDS(key)
};
// var_get_all, var_keys, chan_list, go_async, db_list: no body.
template <Code C>
struct Empty {
  static constexpr Code code = C;
  SKR_FLOW_FIELDS()
};
using VarGetAll = Empty<Code::var_get_all>;
using VarKeys = Empty<Code::var_keys>;
using ChanList = Empty<Code::chan_list>;
using GoAsync = Empty<Code::go_async>;
using DbList = Empty<Code::db_list>;
using DbSync = Empty<Code::db_sync>;
// REPLY_OK with no body: the answer of requests that return nothing.
using Ack = Empty<Code::reply_ok>;
struct PollRegister {
  static constexpr Code code = Code::poll_register;
  uint16_t chan_id = 0;
  SKR_FLOW_FIELDS(chan_id)
};
struct PollFetch {
  static constexpr Code code = Code::poll_fetch;
  uint16_t chan_id = 0;
  SKR_FLOW_FIELDS(chan_id)
};
// 1.4: this client no longer polls the channel; the hub keeps its payload while anyone does.
struct PollDeregister {
  static constexpr Code code = Code::poll_deregister;
  uint16_t chan_id = 0;
  SKR_FLOW_FIELDS(chan_id)
};
struct ServiceCall {
  static constexpr Code code = Code::service_call;
  uint16_t chan_id = 0;
  uint32_t timeout_ms = 0;
  std::string command;
  Variant value;
  SKR_FLOW_FIELDS(chan_id, timeout_ms, command, value)
};
struct Ping {
  static constexpr Code code = Code::ping;
  Rest echo;
  SKR_FLOW_FIELDS(echo)
};
// SESSION_LIMITS (1.12): a small session (a board on a serial line or UDP) states, after LOGIN
// and before GO_ASYNC, the largest frame it takes and which broadcast events it wants.
struct SessionLimits {
  static constexpr Code code = Code::session_limits;
  uint32_t max_frame = 0;  // the largest frame the hub sends it, length field included; 0: none
  uint32_t events = 0;     // SessionEvents bits
  std::string watch;       // a channel-name filter, patterns separated by spaces
  SKR_FLOW_FIELDS(max_frame, events, watch)
};
enum SessionEvents : uint32_t {
  session_events_channels = 1,  // every channel's EV_CHAN_ADDED, _REMOVED and _HEADER
  session_events_all = session_events_channels,
};
// PING's answer: the same bytes.
struct Pong {
  static constexpr Code code = Code::reply_ok;
  Rest echo;
  SKR_FLOW_FIELDS(echo)
};
struct ChanInfoByName {
  static constexpr Code code = Code::chan_info;
  std::string name;
  SKR_FLOW_FIELDS(name)
};

// ADMIN (1.1): an administrator's command ("flows", "kick", "chan_rm", "db_rm") with its
// arguments; REPLY_OK carries a value (docs/security.md).
struct Admin {
  static constexpr Code code = Code::admin;
  std::string command;
  Variant args;
  SKR_FLOW_FIELDS(command, args)
};

// --- replies -------------------------------------------------------------------------------
struct ReplyError {
  static constexpr Code code = Code::reply_error;
  uint16_t error = 0;  // ErrorCode
  std::string message;
  SKR_FLOW_FIELDS(error, message)
};
// REPLY_OK bodies: nothing, a value, or the structs below.
struct ReplyValue {
  static constexpr Code code = Code::reply_ok;
  Variant value;
  SKR_FLOW_FIELDS(value)
};
struct PollData {
  static constexpr Code code = Code::reply_ok;
  uint64_t seq = 0;  // the channel's sequence of `payload`; 0: nothing kept yet
  Rest payload;
  SKR_FLOW_FIELDS(seq, payload)
};

// Everything a satellite learns about a channel.
struct ChannelInfo {
  static constexpr std::string_view wire_name = "ChannelInfo";  // a part of several frames
  uint16_t id = 0;
  uint64_t hash = 0;  // unique per channel instance: a re-created channel gets a new one
  uint8_t kind = 0;   // ChannelKind
  std::string name;   // <user>.<short name>
  std::string owner;  // user name of the owner
  uint32_t owner_connection = 0;
  std::string mime;
  uint32_t subscribers = 0;
  Variant props;  // the channel's database, a map
  SKR_FLOW_FIELDS(id, hash, kind, name, owner, owner_connection, mime, subscribers, props)
};
struct ChannelList {
  static constexpr Code code = Code::reply_ok;
  std::vector<ChannelInfo> channels;
  SKR_FLOW_FIELDS(channels)
};
struct ChannelInfoReply {
  static constexpr Code code = Code::reply_ok;
  ChannelInfo info;
  SKR_FLOW_FIELDS(info)
};

// --- asynchronous commands -----------------------------------------------------------------
struct ChanAdd {
  static constexpr Code code = Code::chan_add;
  uint32_t tag = 0;
  uint8_t kind = 0;        // ChannelKind
  std::string short_name;  // the hub prefixes "<user>."
  std::string mime;
  Variant props;  // a map (or null): the channel's database
  SKR_FLOW_FIELDS(tag, kind, short_name, mime, props)
};
template <Code C>
struct TagChan {
  static constexpr Code code = C;
  uint32_t tag = 0;
  uint16_t chan_id = 0;
  SKR_FLOW_FIELDS(tag, chan_id)
};
using ChanRemove = TagChan<Code::chan_remove>;
using Subscribe = TagChan<Code::subscribe>;
using Unsubscribe = TagChan<Code::unsubscribe>;
// 1.13: SUBSCRIBE with the queue this subscription asks for (the hub clamps it to its cap).
struct SubscribeQueue {
  static constexpr Code code = Code::subscribe_queue;
  uint32_t tag = 0;
  uint16_t chan_id = 0;
  uint32_t queue_bytes = 0;  // 0: the hub's default (server.subscriber_queue_bytes)
  SKR_FLOW_FIELDS(tag, chan_id, queue_bytes)
};
struct Publish {
  static constexpr Code code = Code::publish;
  uint16_t chan_id = 0;
  Rest payload;
  SKR_FLOW_FIELDS(chan_id, payload)
};
struct ServiceRequest {
  static constexpr Code code = Code::service_request;
  uint32_t tag = 0;  // echoed in the EV_SERVICE_RESPONSE
  uint16_t chan_id = 0;
  std::string command;
  Variant value;
  SKR_FLOW_FIELDS(tag, chan_id, command, value)
};
// 1.4: the same with the caller's timeout; past it the caller gets `timeout` and the request's
// slot is freed (0: the hub's server.request_timeout_ms, which SERVICE_REQUEST gets too).
struct ServiceRequestTimed {
  static constexpr Code code = Code::service_request_timed;
  uint32_t tag = 0;
  uint16_t chan_id = 0;
  uint32_t timeout_ms = 0;
  std::string command;
  Variant value;
  SKR_FLOW_FIELDS(tag, chan_id, timeout_ms, command, value)
};
struct ServiceResponse {
  static constexpr Code code = Code::service_response;
  uint16_t chan_id = 0;
  uint64_t request = 0;  // the request hash from EV_SERVICE_REQUEST
  Variant value;
  SKR_FLOW_FIELDS(chan_id, request, value)
};
template <Code C>
struct TagName {
  static constexpr Code code = C;
  uint32_t tag = 0;
  std::string name;
  SKR_FLOW_FIELDS(tag, name)
};
using DbSetCurrent = TagName<Code::db_set_current>;
using DbCreateAsync = TagName<Code::db_create_async>;
using DbRemoveAsync = TagName<Code::db_remove_async>;
using DbSaveAsync = TagName<Code::db_save_async>;
// DB_SYNC_ASYNC (1.2): a barrier; EV_DB_SYNCED carries the same tag.
struct DbSyncAsync {
  static constexpr Code code = Code::db_sync_async;
  uint32_t tag = 0;
  SKR_FLOW_FIELDS(tag)
};
// DB_READ (1.6), on a flow: a read of database `db` (any the user may read; "<hub>/<name>" is
// read on that linked hub). EV_DB_VALUE answers with the tag; a failure is EV_ERROR with it.
enum class DbReadWhat : uint8_t { get = 0, all = 1, keys = 2 };
struct DbRead {
  static constexpr Code code = Code::db_read;
  uint32_t tag = 0;
  std::string db;
  uint8_t what = 0;  // DbReadWhat
  std::string key;   // for get
  SKR_FLOW_FIELDS(tag, db, what, key)
};
struct EvDbValue {
  static constexpr Code code = Code::ev_db_value;
  uint32_t tag = 0;
  Variant value;  // get: the value; all: a map of every pair; keys: a sorted list of strings
  SKR_FLOW_FIELDS(tag, value)
};
struct VarSetAsync {
  static constexpr Code code = Code::var_set_async;
  uint32_t tag = 0;
  std::string key;
  Variant value;
  SKR_FLOW_FIELDS(tag, key, value)
};
struct VarDelAsync {
  static constexpr Code code = Code::var_del_async;
  uint32_t tag = 0;
  std::string key;
  SKR_FLOW_FIELDS(tag, key)
};
struct ChanSetProps {
  static constexpr Code code = Code::chan_set_props;
  uint32_t tag = 0;
  uint16_t chan_id = 0;
  Variant props;  // a map: keys set (null values remove a key)
  SKR_FLOW_FIELDS(tag, chan_id, props)
};

// --- events --------------------------------------------------------------------------------
struct EvDbChanged {
  static constexpr Code code = Code::ev_db_changed;
  std::string name;
  SKR_FLOW_FIELDS(name)
};
// EV_DB_SYNCED (1.2): every database change made before DB_SYNC_ASYNC `tag` is on disk.
struct EvDbSynced {
  static constexpr Code code = Code::ev_db_synced;
  uint32_t tag = 0;
  SKR_FLOW_FIELDS(tag)
};
struct EvChanAdded {
  static constexpr Code code = Code::ev_chan_added;
  uint32_t tag = 0;  // the creator's CHAN_ADD tag in the creator's copy, else 0
  ChannelInfo info;
  SKR_FLOW_FIELDS(tag, info)
};
struct EvChanRemoved {
  static constexpr Code code = Code::ev_chan_removed;
  uint16_t chan_id = 0;
  uint64_t hash = 0;
  std::string name;
  SKR_FLOW_FIELDS(chan_id, hash, name)
};
struct EvChanHeader {
  static constexpr Code code = Code::ev_chan_header;
  ChannelInfo info;
  SKR_FLOW_FIELDS(info)
};
struct EvServiceRequest {
  static constexpr Code code = Code::ev_service_request;
  uint16_t chan_id = 0;
  uint64_t request = 0;  // answer with SERVICE_RESPONSE carrying this
  std::string command;
  std::string requester;  // user name of the caller
  Variant value;
  SKR_FLOW_FIELDS(chan_id, request, command, requester, value)
};
template <Code C>
struct ChanOnly {
  static constexpr Code code = C;
  uint16_t chan_id = 0;
  SKR_FLOW_FIELDS(chan_id)
};
using EvStartPublish = ChanOnly<Code::ev_start_publish>;
using EvStopPublish = ChanOnly<Code::ev_stop_publish>;
struct EvData {
  static constexpr Code code = Code::ev_data;
  uint16_t chan_id = 0;
  Rest payload;
  SKR_FLOW_FIELDS(chan_id, payload)
};
struct EvServiceResponse {
  static constexpr Code code = Code::ev_service_response;
  uint16_t chan_id = 0;
  uint32_t tag = 0;    // the SERVICE_REQUEST's tag
  uint16_t error = 0;  // ErrorCode; ok: value is the owner's answer, else a message string
  Variant value;
  SKR_FLOW_FIELDS(chan_id, tag, error, value)
};
struct EvError {
  static constexpr Code code = Code::ev_error;
  uint8_t command = 0;   // the code of the command that failed
  uint32_t tag = 0;      // its tag (0 for PUBLISH)
  uint16_t chan_id = 0;  // the channel concerned, or 0
  uint16_t error = 0;    // ErrorCode
  std::string message;
  SKR_FLOW_FIELDS(command, tag, chan_id, error, message)
};
struct EvDropped {
  static constexpr Code code = Code::ev_dropped;
  uint16_t chan_id = 0;
  uint32_t count = 0;  // data frames of this channel dropped for this subscriber since the last
  SKR_FLOW_FIELDS(chan_id, count)
};

// --- blob channels (1.3): synchronous requests and their answers, and the change event --------
// Paths are relative and '/'-separated (docs/blob-channels.md gives the rules).
struct BlobList {
  static constexpr Code code = Code::blob_list;
  uint16_t chan_id = 0;
  std::string dir;  // empty: the channel's root
  SKR_FLOW_FIELDS(chan_id, dir)
};
// BLOB_GET: up to max_bytes from offset of one version of a file. version 0: the current one,
// whose number the answer gives; later reads pass it so that every chunk comes from it.
struct BlobGet {
  static constexpr Code code = Code::blob_get;
  uint16_t chan_id = 0;
  std::string path;
  uint64_t version = 0;
  uint64_t offset = 0;
  uint32_t max_bytes = 0;
  SKR_FLOW_FIELDS(chan_id, path, version, offset, max_bytes)
};
struct BlobData {
  static constexpr Code code = Code::reply_ok;
  uint64_t version = 0;
  uint64_t total_size = 0;
  Rest data;
  SKR_FLOW_FIELDS(version, total_size, data)
};
// BLOB_PUT: starts an upload (upload_id 0) or resumes one; the answer says where to go on.
struct BlobPut {
  static constexpr Code code = Code::blob_put;
  uint16_t chan_id = 0;
  std::string path;
  uint64_t total_size = 0;
  uint64_t upload_id = 0;
  SKR_FLOW_FIELDS(chan_id, path, total_size, upload_id)
};
struct BlobPutOk {
  static constexpr Code code = Code::reply_ok;
  uint64_t upload_id = 0;
  uint64_t offset = 0;  // bytes the hub holds: the next chunk starts here
  SKR_FLOW_FIELDS(upload_id, offset)
};
// BLOB_MKDIR, BLOB_RMDIR, BLOB_REMOVE.
template <Code C>
struct BlobPath {
  static constexpr Code code = C;
  uint16_t chan_id = 0;
  std::string path;
  SKR_FLOW_FIELDS(chan_id, path)
};
using BlobMkdir = BlobPath<Code::blob_mkdir>;
using BlobRmdir = BlobPath<Code::blob_rmdir>;
using BlobRemove = BlobPath<Code::blob_remove>;
struct BlobChunk {
  static constexpr Code code = Code::blob_chunk;
  uint16_t chan_id = 0;
  uint64_t upload_id = 0;
  uint64_t offset = 0;  // must be the bytes received so far
  Rest data;
  SKR_FLOW_FIELDS(chan_id, upload_id, offset, data)
};
// The answer to BLOB_CHUNK and BLOB_MODIFY: version is that of the file now in place, 0 while an
// upload is not complete.
struct BlobWritten {
  static constexpr Code code = Code::reply_ok;
  uint64_t received = 0;
  uint64_t version = 0;
  SKR_FLOW_FIELDS(received, version)
};
// BLOB_MODIFY: writes data at offset of an existing file, as a new whole version.
struct BlobModify {
  static constexpr Code code = Code::blob_modify;
  uint16_t chan_id = 0;
  std::string path;
  uint64_t offset = 0;
  Rest data;
  SKR_FLOW_FIELDS(chan_id, path, offset, data)
};
struct BlobAbort {
  static constexpr Code code = Code::blob_abort;
  uint16_t chan_id = 0;
  uint64_t upload_id = 0;
  SKR_FLOW_FIELDS(chan_id, upload_id)
};
// BLOB_CREATE: the caller's blob channel <user>.<short_name>, created unless it exists; the
// answer is a ChannelInfoReply.
struct BlobCreate {
  static constexpr Code code = Code::blob_create;
  std::string short_name;
  SKR_FLOW_FIELDS(short_name)
};
enum class BlobChange : uint8_t { written = 1, removed = 2, dir_added = 3, dir_removed = 4 };
struct EvBlobChanged {
  static constexpr Code code = Code::ev_blob_changed;
  uint16_t chan_id = 0;
  uint8_t change = 0;  // BlobChange
  std::string path;
  uint64_t size = 0;
  uint64_t version = 0;
  SKR_FLOW_FIELDS(chan_id, change, path, size, version)
};

// --- the sync pulse (1.4) ---------------------------------------------------------------------

// Source -> hub: a pulse of the source channel `chan_id` (owner only). `source_time_ns` is the
// source's CLOCK_MONOTONIC when it sent the pulse (comparable on one machine).
struct SyncPulse {
  static constexpr Code code = Code::sync_pulse;
  uint16_t chan_id = 0;
  uint64_t source_time_ns = 0;
  SKR_FLOW_FIELDS(chan_id, source_time_ns)
};
// Target -> hub: follow source `chan_id`, every `every`th pulse (0 and 1: each).
struct SyncFollow {
  static constexpr Code code = Code::sync_follow;
  uint32_t tag = 0;
  uint16_t chan_id = 0;
  uint32_t every = 1;
  SKR_FLOW_FIELDS(tag, chan_id, every)
};
struct SyncUnfollow {
  static constexpr Code code = Code::sync_unfollow;
  uint32_t tag = 0;
  uint16_t chan_id = 0;
  SKR_FLOW_FIELDS(tag, chan_id)
};
// Target -> hub: its tick for pulse `seq` of `chan_id` is done. Until then the hub drops that
// source's pulses for it and counts them.
struct SyncDone {
  static constexpr Code code = Code::sync_done;
  uint16_t chan_id = 0;
  uint64_t seq = 0;
  SKR_FLOW_FIELDS(chan_id, seq)
};
// Hub -> target: pulse `seq` of source `chan_id` (1, 2, ... as the source sent them);
// `dropped`: pulses of that source dropped for this target since its previous one, because its
// tick was not done (the ones `every` skips are not counted).
struct EvSyncPulse {
  static constexpr Code code = Code::ev_sync_pulse;
  uint16_t chan_id = 0;
  uint64_t seq = 0;
  uint64_t source_time_ns = 0;
  uint32_t dropped = 0;
  SKR_FLOW_FIELDS(chan_id, seq, source_time_ns, dropped)
};

// 1.5, hub links (docs/hub-links.md). Hub -> hub, on a synchronous connection after LOGIN and
// before GO_ASYNC: the linking hub's name. Answered with HubLinkHelloOk (the far hub's name), or
// already_exists (a hub of that name is linked already), invalid_argument (a bad name, or the far
// hub's own).
struct HubLinkHello {
  static constexpr Code code = Code::hub_link_hello;
  std::string hub_name;
  SKR_FLOW_FIELDS(hub_name)
};
struct HubLinkHelloOk {
  static constexpr Code code = Code::reply_ok;
  std::string hub_name;
  SKR_FLOW_FIELDS(hub_name)
};

// 1.5, on a flow: mirror the channel `source` (any streaming channel, a linked hub's included)
// as "<user>.<short_name>", kept while this flow lasts; a failure comes as EV_ERROR with `tag`.
struct ReplicateChannel {
  static constexpr Code code = Code::replicate_channel;
  uint32_t tag = 0;
  std::string source, short_name;
  SKR_FLOW_FIELDS(tag, source, short_name)
};
struct ReplicateStop {
  static constexpr Code code = Code::replicate_stop;
  uint32_t tag = 0;
  std::string short_name;
  SKR_FLOW_FIELDS(tag, short_name)
};
// 1.6, on a shared link's flow: the linking hub offers one of its channels (its name there: its
// own as "<user>.<name>", a third hub's as "<hub>/<user>.<name>"; props without this hub in
// hub_route). The far hub creates it, owned by this flow: EV_CHAN_ADDED with `tag`, or EV_ERROR.
struct LinkOffer {
  static constexpr Code code = Code::link_offer;
  uint32_t tag = 0;
  uint8_t kind = 0;
  std::string name, mime;
  Variant props;
  SKR_FLOW_FIELDS(tag, kind, name, mime, props)
};
// 1.6, to a linking hub's flow: the far hub lists it too, so this connection is their one link;
// offer your channels here (again: some may have been refused while another route had them).
struct EvLinkWanted {
  static constexpr Code code = Code::ev_link_wanted;
  std::string hub_name;  // the far hub's
  SKR_FLOW_FIELDS(hub_name)
};
// 1.5, on a flow: a clock probe (four timestamps, as NTP takes them). t1 is the sender's wall
// clock (CLOCK_REALTIME, ns) when it sent the probe; the hub answers at once with t2 (when it read
// the probe) and t3 (when it answered), on its own wall clock. With t4, the sender's clock when
// the answer arrived: round trip = (t4 - t1) - (t3 - t2), the hub's clock minus the sender's =
// ((t2 - t1) + (t3 - t4)) / 2.
struct TimeProbe {
  static constexpr Code code = Code::time_probe;
  uint32_t tag = 0;
  uint64_t t1 = 0;
  SKR_FLOW_FIELDS(tag, t1)
};
struct EvTimeProbe {
  static constexpr Code code = Code::ev_time_probe;
  uint32_t tag = 0;
  uint64_t t1 = 0, t2 = 0, t3 = 0;
  SKR_FLOW_FIELDS(tag, t1, t2, t3)
};

// --- physical mode (1.7, docs/physical-mode.md) -----------------------------------------------

// Path kinds, and their bits in `paths`.
enum class PhysPath : uint8_t { direct = 1, shm = 2 };
inline constexpr uint8_t kPhysDirect = 1, kPhysShm = 2;

// Owner -> hub: the paths (bits) it serves for channel `chan_id` and where its direct endpoint
// listens ("unix:<path>" for both kinds, "tcp:<host>:<port>" for direct only). paths 0 withdraws
// the offer: every path of the channel is revoked. A failure comes as EV_ERROR with `tag`.
struct PhysOffer {
  static constexpr Code code = Code::phys_offer;
  uint32_t tag = 0;
  uint16_t chan_id = 0;
  uint8_t paths = 0;
  std::string endpoint;
  SKR_FLOW_FIELDS(tag, chan_id, paths, endpoint)
};
// Subscriber -> hub: a path to channel `chan_id`, which it follows, of one of these kinds (bits).
// Answered with EV_PHYS_PATH, or EV_ERROR with `tag`.
struct PhysRequest {
  static constexpr Code code = Code::phys_request;
  uint32_t tag = 0;
  uint16_t chan_id = 0;
  uint8_t paths = 0;
  SKR_FLOW_FIELDS(tag, chan_id, paths)
};
// Subscriber -> hub: its granted path to `chan_id` works (1: the hub stops relaying that channel
// to it, at the point the owner picks (EV_PHYS_SWITCH, 1.9) and says so with EV_PHYS_MARKER, or
// at once with EV_PHYS_RELAY 0 for an owner older than 1.9) or broke (0: relayed again).
// Falling back may lose the messages published meanwhile; neither way duplicates one.
struct PhysState {
  static constexpr Code code = Code::phys_state;
  uint16_t chan_id = 0;
  uint8_t active = 0;
  SKR_FLOW_FIELDS(chan_id, active)
};
// Owner -> hub: messages (and their bytes) of `chan_id` it delivered over paths without
// publishing them through the hub, since its last count: the hub's statistics include them.
struct PhysCount {
  static constexpr Code code = Code::phys_count;
  uint16_t chan_id = 0;
  uint64_t messages = 0;
  uint64_t bytes = 0;
  SKR_FLOW_FIELDS(chan_id, messages, bytes)
};
// Hub -> owner: accept one connection from `subscriber` (a flow id; `name` "<user>/<client>")
// presenting `token`, for a path of kind `path`, within the grant's lifetime (docs).
struct EvPhysGrant {
  static constexpr Code code = Code::ev_phys_grant;
  uint16_t chan_id = 0;
  uint32_t subscriber = 0;
  std::string name;
  uint8_t path = 0;
  std::string token;
  SKR_FLOW_FIELDS(chan_id, subscriber, name, path, token)
};
// Hub -> subscriber: the answer to PHYS_REQUEST `tag`: connect to `endpoint` and present `token`.
struct EvPhysPath {
  static constexpr Code code = Code::ev_phys_path;
  uint32_t tag = 0;
  uint16_t chan_id = 0;
  uint8_t path = 0;
  std::string endpoint;
  std::string token;
  SKR_FLOW_FIELDS(tag, chan_id, path, endpoint, token)
};
// Hub -> owner: close the path of `subscriber` to `chan_id` (it unsubscribed, left, was kicked).
struct EvPhysRevoke {
  static constexpr Code code = Code::ev_phys_revoke;
  uint16_t chan_id = 0;
  uint32_t subscriber = 0;
  SKR_FLOW_FIELDS(chan_id, subscriber)
};
// Hub -> owner: whether some subscriber of `chan_id` still gets it through the hub (1), or every
// one has a path (0: the owner may stop publishing it to the hub and count instead).
// Hub -> subscriber, needed 0, after its PHYS_STATE 1: the hub relays that channel to it no more;
// data on the path from here on is not a duplicate of relayed data.
struct EvPhysRelay {
  static constexpr Code code = Code::ev_phys_relay;
  uint16_t chan_id = 0;
  uint8_t needed = 1;
  SKR_FLOW_FIELDS(chan_id, needed)
};
// Hub -> owner (1.9), after a subscriber's PHYS_STATE 1: answer with PHYS_SWITCHED and the same
// `switch_id` before publishing anything else, so that the hub moves the subscriber out of the
// relay at that point of the owner's messages.
struct EvPhysSwitch {
  static constexpr Code code = Code::ev_phys_switch;
  uint16_t chan_id = 0;
  uint32_t subscriber = 0;
  uint32_t switch_id = 0;
  SKR_FLOW_FIELDS(chan_id, subscriber, switch_id)
};
// Owner -> hub (1.9): the answer to EV_PHYS_SWITCH. `seq` is the number of the last message
// the owner published before it (the numbering of that subscriber's path: the direct frames'
// `seq`, or the ring's): what it published to the hub until then is relayed to the subscriber,
// what follows comes on the path only.
struct PhysSwitched {
  static constexpr Code code = Code::phys_switched;
  uint16_t chan_id = 0;
  uint32_t subscriber = 0;
  uint32_t switch_id = 0;
  uint64_t seq = 0;
  SKR_FLOW_FIELDS(chan_id, subscriber, switch_id, seq)
};
// Subscriber -> hub (1.10): what came on its path of `chan_id` since its last report: messages
// delivered, their bytes, and those it skipped (shared memory, newest wins). Added to its flow's
// statistics, as if the hub had sent them.
struct PhysReceived {
  static constexpr Code code = Code::phys_received;
  uint16_t chan_id = 0;
  uint64_t messages = 0;
  uint64_t bytes = 0;
  uint64_t missed = 0;
  SKR_FLOW_FIELDS(chan_id, messages, bytes, missed)
};
// Subscriber -> hub (1.11), instead of PHYS_STATE 0 for a direct path that broke after its
// marker: `last` is the number (the direct frames' `seq`) of the last message it has, relayed or
// on the path. The hub relays to it again once its owner has replayed what came after `last`.
struct PhysFallback {
  static constexpr Code code = Code::phys_fallback;
  uint16_t chan_id = 0;
  uint64_t last = 0;
  SKR_FLOW_FIELDS(chan_id, last)
};
// Hub -> owner (1.11), after a subscriber's PHYS_FALLBACK: send it, with PHYS_REPLAY and the same
// `resume_id`, the messages kept after `after`, then the end, before publishing anything else.
struct EvPhysResume {
  static constexpr Code code = Code::ev_phys_resume;
  uint16_t chan_id = 0;
  uint32_t subscriber = 0;
  uint32_t resume_id = 0;
  uint64_t after = 0;
  SKR_FLOW_FIELDS(chan_id, subscriber, resume_id, after)
};
// Owner -> hub (1.11), answering EV_PHYS_RESUME: `done` 0, one kept message for that subscriber
// alone (relayed to it as if published); `done` 1, the end (no payload): `lost` messages after
// `after` were no longer kept. From the end on, the owner publishes to the hub again and the
// subscriber is relayed.
struct PhysReplay {
  static constexpr Code code = Code::phys_replay;
  uint16_t chan_id = 0;
  uint32_t subscriber = 0;
  uint32_t resume_id = 0;
  uint8_t done = 0;
  uint64_t lost = 0;
  Rest payload;
  SKR_FLOW_FIELDS(chan_id, subscriber, resume_id, done, lost, payload)
};
// Hub -> subscriber (1.9), the marker that replaces EV_PHYS_RELAY 0 when the owner answered
// EV_PHYS_SWITCH: nothing of `chan_id` is relayed after it; path messages up to `seq` were
// relayed (duplicates), those after it come on the path only.
struct EvPhysMarker {
  static constexpr Code code = Code::ev_phys_marker;
  uint16_t chan_id = 0;
  uint64_t seq = 0;
  SKR_FLOW_FIELDS(chan_id, seq)
};

}  // namespace skr::flow::msg
