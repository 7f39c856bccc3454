#include <skrobot/flow/codec.h>
#include <skrobot/flow/protocol.h>

namespace skr::flow {

std::string_view codeName(uint8_t code) noexcept {
  switch (static_cast<Code>(code)) {
    case Code::login:
      return "LOGIN";
    case Code::db_select:
      return "DB_SELECT";
    case Code::db_create:
      return "DB_CREATE";
    case Code::db_save:
      return "DB_SAVE";
    case Code::db_remove:
      return "DB_REMOVE";
    case Code::var_get:
      return "VAR_GET";
    case Code::var_set:
      return "VAR_SET";
    case Code::var_del:
      return "VAR_DEL";
    case Code::var_get_all:
      return "VAR_GET_ALL";
    case Code::var_keys:
      return "VAR_KEYS";
    case Code::chan_list:
      return "CHAN_LIST";
    case Code::poll_register:
      return "POLL_REGISTER";
    case Code::poll_fetch:
      return "POLL_FETCH";
    case Code::poll_deregister:
      return "POLL_DEREGISTER";
    case Code::service_call:
      return "SERVICE_CALL";
    case Code::go_async:
      return "GO_ASYNC";
    case Code::ping:
      return "PING";
    case Code::db_list:
      return "DB_LIST";
    case Code::chan_info:
      return "CHAN_INFO";
    case Code::admin:
      return "ADMIN";
    case Code::db_sync:
      return "DB_SYNC";
    case Code::db_sync_async:
      return "DB_SYNC_ASYNC";
    case Code::ev_db_synced:
      return "EV_DB_SYNCED";
    case Code::chan_add:
      return "CHAN_ADD";
    case Code::chan_remove:
      return "CHAN_REMOVE";
    case Code::subscribe:
      return "SUBSCRIBE";
    case Code::unsubscribe:
      return "UNSUBSCRIBE";
    case Code::publish:
      return "PUBLISH";
    case Code::service_request:
      return "SERVICE_REQUEST";
    case Code::service_request_timed:
      return "SERVICE_REQUEST_TIMED";
    case Code::service_response:
      return "SERVICE_RESPONSE";
    case Code::db_set_current:
      return "DB_SET_CURRENT";
    case Code::db_create_async:
      return "DB_CREATE_ASYNC";
    case Code::db_remove_async:
      return "DB_REMOVE_ASYNC";
    case Code::db_save_async:
      return "DB_SAVE_ASYNC";
    case Code::var_set_async:
      return "VAR_SET_ASYNC";
    case Code::var_del_async:
      return "VAR_DEL_ASYNC";
    case Code::chan_set_props:
      return "CHAN_SET_PROPS";
    case Code::reply_ok:
      return "REPLY_OK";
    case Code::reply_error:
      return "REPLY_ERROR";
    case Code::ev_db_changed:
      return "EV_DB_CHANGED";
    case Code::ev_chan_added:
      return "EV_CHAN_ADDED";
    case Code::ev_chan_removed:
      return "EV_CHAN_REMOVED";
    case Code::ev_chan_header:
      return "EV_CHAN_HEADER";
    case Code::ev_service_request:
      return "EV_SERVICE_REQUEST";
    case Code::ev_start_publish:
      return "EV_START_PUBLISH";
    case Code::ev_stop_publish:
      return "EV_STOP_PUBLISH";
    case Code::ev_data:
      return "EV_DATA";
    case Code::ev_service_response:
      return "EV_SERVICE_RESPONSE";
    case Code::ev_error:
      return "EV_ERROR";
    case Code::ev_dropped:
      return "EV_DROPPED";
    case Code::blob_list:
      return "BLOB_LIST";
    case Code::blob_get:
      return "BLOB_GET";
    case Code::blob_put:
      return "BLOB_PUT";
    case Code::blob_mkdir:
      return "BLOB_MKDIR";
    case Code::blob_rmdir:
      return "BLOB_RMDIR";
    case Code::blob_remove:
      return "BLOB_REMOVE";
    case Code::blob_chunk:
      return "BLOB_CHUNK";
    case Code::blob_modify:
      return "BLOB_MODIFY";
    case Code::blob_abort:
      return "BLOB_ABORT";
    case Code::blob_create:
      return "BLOB_CREATE";
    case Code::ev_blob_changed:
      return "EV_BLOB_CHANGED";
    case Code::sync_pulse:
      return "SYNC_PULSE";
    case Code::sync_follow:
      return "SYNC_FOLLOW";
    case Code::sync_unfollow:
      return "SYNC_UNFOLLOW";
    case Code::sync_done:
      return "SYNC_DONE";
    case Code::ev_sync_pulse:
      return "EV_SYNC_PULSE";
    case Code::replicate_channel:
      return "REPLICATE_CHANNEL";
    case Code::replicate_stop:
      return "REPLICATE_STOP";
    case Code::hub_link_hello:
      return "HUB_LINK_HELLO";
    case Code::time_probe:
      return "TIME_PROBE";
    case Code::ev_time_probe:
      return "EV_TIME_PROBE";
    case Code::db_read:
      return "DB_READ";
    case Code::link_offer:
      return "LINK_OFFER";
    case Code::ev_link_wanted:
      return "EV_LINK_WANTED";
    case Code::ev_db_value:
      return "EV_DB_VALUE";
    case Code::phys_offer:
      return "PHYS_OFFER";
    case Code::phys_request:
      return "PHYS_REQUEST";
    case Code::phys_state:
      return "PHYS_STATE";
    case Code::phys_count:
      return "PHYS_COUNT";
    case Code::ev_phys_grant:
      return "EV_PHYS_GRANT";
    case Code::ev_phys_path:
      return "EV_PHYS_PATH";
    case Code::ev_phys_revoke:
      return "EV_PHYS_REVOKE";
    case Code::ev_phys_relay:
      return "EV_PHYS_RELAY";
    case Code::phys_switched:
      return "PHYS_SWITCHED";
    case Code::ev_phys_switch:
      return "EV_PHYS_SWITCH";
    case Code::ev_phys_marker:
      return "EV_PHYS_MARKER";
    case Code::phys_received:
      return "PHYS_RECEIVED";
    case Code::phys_fallback:
      return "PHYS_FALLBACK";
    case Code::phys_replay:
      return "PHYS_REPLAY";
    case Code::ev_phys_resume:
      return "EV_PHYS_RESUME";
  }
  return "UNKNOWN";
}

uint16_t minorOf(Code code) noexcept {
  switch (code) {
    case Code::admin:
      return 1;
    case Code::db_sync:
    case Code::db_sync_async:
    case Code::ev_db_synced:
      return 2;
    case Code::blob_list:
    case Code::blob_get:
    case Code::blob_put:
    case Code::blob_mkdir:
    case Code::blob_rmdir:
    case Code::blob_remove:
    case Code::blob_chunk:
    case Code::blob_modify:
    case Code::blob_abort:
    case Code::blob_create:
    case Code::ev_blob_changed:
      return 3;
    case Code::service_request_timed:
    case Code::poll_deregister:
    case Code::sync_pulse:
    case Code::sync_follow:
    case Code::sync_unfollow:
    case Code::sync_done:
    case Code::ev_sync_pulse:
      return 4;
    case Code::hub_link_hello:
    case Code::replicate_channel:
    case Code::replicate_stop:
    case Code::time_probe:
    case Code::ev_time_probe:
      return 5;
    case Code::db_read:
    case Code::ev_db_value:
    case Code::link_offer:
    case Code::ev_link_wanted:
      return 6;
    case Code::phys_offer:
    case Code::phys_request:
    case Code::phys_state:
    case Code::phys_count:
    case Code::ev_phys_grant:
    case Code::ev_phys_path:
    case Code::ev_phys_revoke:
    case Code::ev_phys_relay:
      return 7;
    case Code::phys_switched:
    case Code::ev_phys_switch:
    case Code::ev_phys_marker:
      return 9;
    case Code::phys_received:
      return 10;
    case Code::phys_fallback:
    case Code::phys_replay:
    case Code::ev_phys_resume:
      return 11;
    default:
      return 0;
  }
}

std::string_view errorCodeName(ErrorCode code) noexcept {
  switch (code) {
    case ErrorCode::ok:
      return "ok";
    case ErrorCode::protocol_error:
      return "protocol_error";
    case ErrorCode::version_mismatch:
      return "version_mismatch";
    case ErrorCode::auth_failed:
      return "auth_failed";
    case ErrorCode::not_logged_in:
      return "not_logged_in";
    case ErrorCode::not_found:
      return "not_found";
    case ErrorCode::already_exists:
      return "already_exists";
    case ErrorCode::permission_denied:
      return "permission_denied";
    case ErrorCode::invalid_argument:
      return "invalid_argument";
    case ErrorCode::timeout:
      return "timeout";
    case ErrorCode::owner_gone:
      return "owner_gone";
    case ErrorCode::overflow:
      return "overflow";
    case ErrorCode::unsupported:
      return "unsupported";
    case ErrorCode::limit_exceeded:
      return "limit_exceeded";
    case ErrorCode::io_error:
      return "io_error";
    case ErrorCode::internal:
      return "internal";
  }
  return "unknown";
}

Errc toErrc(ErrorCode code) noexcept {
  switch (code) {
    case ErrorCode::ok:
      return Errc::ok;
    case ErrorCode::protocol_error:
      return Errc::protocol_error;
    case ErrorCode::version_mismatch:
      return Errc::version_mismatch;
    case ErrorCode::auth_failed:
      return Errc::auth_failed;
    case ErrorCode::not_logged_in:
      return Errc::not_logged_in;
    case ErrorCode::not_found:
      return Errc::not_found;
    case ErrorCode::already_exists:
      return Errc::already_exists;
    case ErrorCode::permission_denied:
      return Errc::permission_denied;
    case ErrorCode::invalid_argument:
      return Errc::invalid_argument;
    case ErrorCode::timeout:
      return Errc::timeout;
    case ErrorCode::owner_gone:
      return Errc::owner_gone;
    case ErrorCode::overflow:
      return Errc::overflow;
    case ErrorCode::unsupported:
      return Errc::unsupported;
    case ErrorCode::limit_exceeded:
      return Errc::limit_exceeded;
    case ErrorCode::io_error:
      return Errc::io_error;
    case ErrorCode::internal:
      return Errc::internal;
  }
  return Errc::internal;  // a code this build does not know (a newer peer)
}

ErrorCode toErrorCode(Errc code) noexcept {
  switch (code) {
    case Errc::ok:
      return ErrorCode::ok;
    case Errc::protocol_error:
      return ErrorCode::protocol_error;
    case Errc::version_mismatch:
      return ErrorCode::version_mismatch;
    case Errc::auth_failed:
      return ErrorCode::auth_failed;
    case Errc::not_logged_in:
      return ErrorCode::not_logged_in;
    case Errc::not_found:
      return ErrorCode::not_found;
    case Errc::already_exists:
      return ErrorCode::already_exists;
    case Errc::permission_denied:
      return ErrorCode::permission_denied;
    case Errc::invalid_argument:
    case Errc::config_error:
    case Errc::parse_error:
      return ErrorCode::invalid_argument;
    case Errc::timeout:
      return ErrorCode::timeout;
    case Errc::owner_gone:
      return ErrorCode::owner_gone;
    case Errc::overflow:
      return ErrorCode::overflow;
    case Errc::unsupported:
      return ErrorCode::unsupported;
    case Errc::limit_exceeded:
      return ErrorCode::limit_exceeded;
    case Errc::io_error:
    case Errc::closed:
      return ErrorCode::io_error;
    case Errc::internal:
    case Errc::abi_mismatch:
    case Errc::module_failed:
    case Errc::exception:
    case Errc::remote:
      return ErrorCode::internal;
  }
  return ErrorCode::internal;
}

Error wireError(ErrorCode code, std::string message) {
  return Error{toErrc(code), std::move(message)};
}

std::string_view channelKindName(ChannelKind kind) noexcept {
  switch (kind) {
    case ChannelKind::streaming:
      return "streaming";
    case ChannelKind::service:
      return "service";
    case ChannelKind::blob:
      return "blob";
    case ChannelKind::sync:
      return "sync";
  }
  return "unknown";
}

uint16_t minorOfKind(ChannelKind kind) noexcept {
  switch (kind) {
    case ChannelKind::blob:
      return minorOf(Code::blob_list);
    case ChannelKind::sync:
      return minorOf(Code::sync_pulse);
    default:
      return 0;
  }
}

FrameSplitter::Next FrameSplitter::next(const uint8_t* data, size_t size) const noexcept {
  Next n;
  ByteReader r(data, size);
  uint32_t length = 0;
  if (!r.u32(length)) {
    n.wanted = 4;
    return n;
  }
  n.announced = length;
  if (length == 0) {
    n.status = Status::empty_frame;
    return n;
  }
  if (length > max_) {
    n.status = Status::too_large;
    return n;
  }
  n.wanted = 4 + static_cast<size_t>(length);
  if (size < n.wanted) return n;
  n.status = Status::frame;
  n.code = data[4];
  n.body = std::string_view(reinterpret_cast<const char*>(data) + kFrameHeaderBytes, length - 1);
  n.consumed = n.wanted;
  return n;
}

void appendHeader(std::string& out, Code code, size_t body_bytes) {
  ByteWriter w(out);
  w.u32(static_cast<uint32_t>(body_bytes + 1));
  w.u8(static_cast<uint8_t>(code));
}

bool FieldReader::operator()(Variant& v) {
  uint8_t enc = 0;
  if (!r_.u8(enc)) return fail("value encoding");
  if (enc == static_cast<uint8_t>(ValueEncoding::binary)) {
    auto decoded = decodeVariant(r_, limits_);
    if (!decoded) return failWith(decoded.error().message);
    v = std::move(decoded).value();
    return true;
  }
  if (enc == static_cast<uint8_t>(ValueEncoding::json)) {
    std::string_view text;
    if (!r_.str32(text)) return fail("JSON value");
    auto parsed = variantFromJsonText(text);
    if (!parsed) return failWith("JSON value: " + parsed.error().message);
    v = std::move(parsed).value();
    return true;
  }
  return failWith("unknown value encoding " + std::to_string(enc));
}

}  // namespace skr::flow
