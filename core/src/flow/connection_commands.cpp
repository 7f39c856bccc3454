// What a connection does with each command it receives.
#include "connection.h"

#include <skrobot/core/log.h>

#include <algorithm>

namespace skr::flow {

namespace {

// One typed value in a command: a decoded Variant takes up to ~40 bytes of memory per input byte
// (a list of nulls), so values are bounded well below the frame limit. Payloads (PUBLISH) are
// never decoded and take the whole frame limit.
constexpr size_t kMaxValueBytes = 4u << 20;

DecodeLimits valueLimits(const ServerOptions& opt) {
  return DecodeLimits{32, std::min<size_t>(opt.max_frame_bytes, kMaxValueBytes)};
}

// Decodes `body` as M, or closes the connection as a protocol breaker.
#define SKR_DECODE(M, var)                  \
  auto var##_r = decode<M>(body, limits);   \
  if (!var##_r) {                           \
    protocolError(var##_r.error().message); \
    return;                                 \
  }                                         \
  auto& var = var##_r.value();

}  // namespace

void Connection::handleLogin(std::string_view body) {
  const DecodeLimits limits = valueLimits(server_.opt);
  SKR_DECODE(msg::Login, m);
  if (over_limit) {
    replyError(ErrorCode::limit_exceeded,
               "this hub serves " + std::to_string(server_.opt.max_connections) +
                   " connections at most (server.max_connections); try again later");
    closeAfterFlush("too many connections");
    return;
  }
  if (m.major != kProtocolMajor) {
    const std::string why = "this hub speaks FlowProtocol " + std::to_string(kProtocolMajor) + "." +
                            std::to_string(kProtocolMinor) + ", the client " +
                            std::to_string(m.major) + "." + std::to_string(m.minor);
    log::warn(kLogSource, "FLOW-VERSION", describe() + ": " + why);
    replyError(ErrorCode::version_mismatch, why);
    closeAfterFlush("protocol version mismatch");
    return;
  }
  if (m.value_encoding > static_cast<uint8_t>(ValueEncoding::json)) {
    protocolError("LOGIN: unknown value encoding " + std::to_string(m.value_encoding));
    return;
  }
  enc_ = static_cast<ValueEncoding>(m.value_encoding);
  client_name = m.client_name;
  state_ = State::authenticating;
  block();
  const Nanos now = monotonicNs();
  if (const Nanos wait = server_.throttle.wait(m.user, source, now); wait > 0) {
    log::warn(kLogSource, "FLOW-LOGIN-THROTTLED",
              describe() + ": login as \"" + m.user + "\" held back " +
                  std::to_string(wait / kNsPerMs) + " ms after failed logins");
    server_.delayed_logins.push_back({id, now + wait, std::move(m)});
    return;
  }
  verifyLogin(std::move(m));
}

void Connection::verifyLogin(msg::Login m) {
  const uint32_t my_id = id;
  FlowServer::Impl& server = server_;
  server_.auth->verify(
      m.user, std::move(m.password), transport_,
      [&server, my_id, user = m.user,
       minor = std::min(m.minor, kProtocolMinor)](const LoginResult& r) {
        auto it = server.connections.find(my_id);
        if (it == server.connections.end()) return;  // gone meanwhile
        Connection& c = *it->second;
        if (!r.ok) {
          ++server.stats.logins_failed;
          server.throttle.failed(user, c.source, monotonicNs());
          log::warn(kLogSource, "FLOW-AUTH-FAILED",
                    c.describe() + ": login as \"" + user + "\" refused (" + r.reason + ")");
          c.replyError(ErrorCode::auth_failed, "wrong user name or password");
          c.closeAfterFlush("login refused");
          return;
        }
        c.user = user;
        c.minor_ = minor;
        c.access = server.auth->accessOf(user);
        server.throttle.succeeded(user, c.source);
        const uint32_t limit = c.access->limits().orElse(server.opt.user_limits).connections;
        if (server.endpoints.holdingsOf(user).endpoints > limit) {   // this one included
          const Error e = limitReached(user, "connections", limit);  // logged (FLOW-LIMIT)
          c.replyError(ErrorCode::limit_exceeded, e.message);
          c.closeAfterFlush("connection limit");
          return;
        }
        c.splitter_.setMaxFrameBytes(server.opt.max_frame_bytes);
        server.loggedIn(c);
        c.state_ = State::sync;
        c.send(msg::LoginOk{kProtocolMajor, kProtocolMinor, c.id, server.opt.app_name, c.user,
                            c.current_db});
        log::info(kLogSource, "FLOW-LOGIN", c.describe() + " logged in");
        c.unblock();
      });
}

template <class R>
std::function<void(R)> Connection::whenAlive(std::function<void(Connection&, R)> then) {
  return [&server = server_, my_id = id, then = std::move(then)](R r) {
    auto it = server.connections.find(my_id);
    if (it != server.connections.end()) then(*it->second, std::move(r));  // else gone meanwhile
  };
}

std::function<void(Result<void>)> Connection::whenDone(
    std::function<void(Connection&, Result<void>)> then) {
  return whenAlive<Result<void>>(std::move(then));
}

std::function<void(Result<Variant>)> Connection::whenRead(
    std::function<void(Connection&, Result<Variant>)> then) {
  return whenAlive<Result<Variant>>(std::move(then));
}

void Connection::wantLinkOffers() {
  if (state_ == State::flow) send(msg::EvLinkWanted{server_.hub_name});
}

void Connection::answerDone(const Result<void>& r) {
  if (r) {
    replyOk();
  } else {
    replyError(toErrorCode(r.error().code), r.error().message);
  }
  unblock();
}

void Connection::answerDurably(const Result<void>& r, bool persistent) {
  if (!r) {
    replyError(toErrorCode(r.error().code), r.error().message);
  } else if (!persistent || !server_.databases.store().writesWaitForDisk()) {
    replyOk();
  } else {
    block();
    server_.databases.store().barrier(
        whenDone([](Connection& c, const Result<void>& done) { c.answerDone(done); }));
  }
}

void Connection::readCurrentDb(Code code, std::string_view body) {
  const DecodeLimits limits = valueLimits(server_.opt);
  std::string key;
  if (code == Code::var_get) {
    SKR_DECODE(msg::VarGet, m);
    key = std::move(m.key);
  } else if (!body.empty()) {
    return protocolError(std::string(codeName(uint8_t(code))) + " has a body");
  }
  const auto what = code == Code::var_get       ? msg::DbReadWhat::get
                    : code == Code::var_get_all ? msg::DbReadWhat::all
                                                : msg::DbReadWhat::keys;
  DatabaseAccess& dbs = server_.databases;
  if (!dbs.remote(current_db)) {
    // Selected (and checked) by DB_SELECT; the flow's own database if it was removed since.
    return replyRead(DatabaseAccess::readFrom(*dbs.current(*this), what, key, current_db));
  }
  block();  // answered when the link brings the value
  server_.readDatabase(*this, current_db, what, key, whenRead([](Connection& c, Result<Variant> r) {
    c.replyRead(std::move(r));
    c.unblock();
  }));
}

void Connection::replyRead(Result<Variant> r) {
  if (r) {
    send(msg::ReplyValue{std::move(*r)});
  } else {
    replyError(toErrorCode(r.error().code), r.error().message);
  }
}

void Connection::handleSync(Code code, std::string_view body) {
  const DecodeLimits limits = valueLimits(server_.opt);
  const auto answer = [&](const Result<void>& r) {
    if (r) {
      replyOk();
    } else {
      replyError(toErrorCode(r.error().code), r.error().message);
    }
  };
  DatabaseAccess& dbs = server_.databases;
  if (code == Code::var_get || code == Code::var_get_all || code == Code::var_keys) {
    return readCurrentDb(code, body);
  }
  switch (code) {
    case Code::db_select: {
      SKR_DECODE(msg::DbSelect, m);
      answer(dbs.select(*this, m.name));
      return;
    }
    case Code::db_create: {
      SKR_DECODE(msg::DbCreate, m);
      answerDurably(dbs.create(*this, m.name), true);
      return;
    }
    case Code::db_save: {
      SKR_DECODE(msg::DbSave, m);
      // Answered once the snapshot is written (by the journal's thread).
      block();
      auto r = dbs.save(*this, m.name,
                        whenDone([](Connection& c, const Result<void>& r) { c.answerDone(r); }));
      if (!r) {
        replyError(toErrorCode(r.error().code), r.error().message);
        unblock();
      }
      return;
    }
    case Code::db_remove: {
      SKR_DECODE(msg::DbRemove, m);
      answerDurably(dbs.remove(*this, m.name), true);
      return;
    }
    case Code::db_sync: {
      if (!body.empty()) return protocolError("DB_SYNC has a body");
      block();
      dbs.store().barrier(whenDone([](Connection& c, const Result<void>& r) { c.answerDone(r); }));
      return;
    }
    case Code::var_set: {
      SKR_DECODE(msg::VarSet, m);
      answerDurably(dbs.setVar(*this, {}, m.key, m.value), dbs.persistent(current_db));
      return;
    }
    case Code::var_del: {
      SKR_DECODE(msg::VarDel, m);
      answerDurably(dbs.delVar(*this, {}, m.key), dbs.persistent(current_db));
      return;
    }
    case Code::db_list: {
      if (!body.empty()) return protocolError("DB_LIST has a body");
      Variant::List names;
      for (auto& n : dbs.store().names()) {
        if (dbs.canRead(*this, n)) names.emplace_back(n);
      }
      send(msg::ReplyValue{Variant(std::move(names))});
      return;
    }
    case Code::chan_list: {
      if (!body.empty()) return protocolError("CHAN_LIST has a body");
      msg::ChannelList list;
      server_.channels.forEach([&](const Channel& ch) {
        if (sees(ch)) list.channels.push_back(server_.info(ch));
      });
      send(list);
      return;
    }
    case Code::chan_info: {
      SKR_DECODE(msg::ChanInfoByName, m);
      const Channel* ch = server_.channels.findByName(m.name);
      if (ch == nullptr || !sees(*ch)) {
        replyError(ErrorCode::not_found, "no channel \"" + m.name + "\"");
      } else {
        send(msg::ChannelInfoReply{server_.info(*ch)});
      }
      return;
    }
    case Code::poll_register:
    case Code::poll_fetch:
    case Code::poll_deregister: {
      SKR_DECODE(msg::PollFetch, m);  // the three are a u16 channel id
      Result<void> r;
      if (code == Code::poll_fetch) {
        auto kept = server_.channels.pollFetch(m.chan_id);
        if (kept) {
          send(msg::PollData{kept->first, msg::Rest{kept->second}});
          return;
        }
        r = kept.error();
      } else if (code == Code::poll_register) {
        r = server_.channels.pollRegister(id, m.chan_id);
      } else {
        r = server_.channels.pollDeregister(id, m.chan_id);
      }
      if (r) {
        replyOk();
      } else {
        replyError(toErrorCode(r.error().code), r.error().message);
      }
      return;
    }
    case Code::service_call: {
      SKR_DECODE(msg::ServiceCall, m);
      // Block first: the reply is the owner's response (an in-hub module may answer inside
      // request()), or a timeout.
      block();
      auto r =
          server_.requests.request(*this, m.chan_id, 0, true, m.timeout_ms, m.command, m.value);
      if (!r) {
        replyError(toErrorCode(r.error().code), r.error().message);
        unblock();
      }
      return;
    }
    case Code::admin: {
      SKR_DECODE(msg::Admin, m);
      if (isUsersCommand(m.command)) {
        adminUsers(m.command, m.args);
        return;
      }
      auto r = server_.admin(*this, m.command, m.args);
      if (r) {
        send(msg::ReplyValue{std::move(r).value()});
      } else {
        replyError(toErrorCode(r.error().code), r.error().message);
      }
      return;
    }
    case Code::hub_link_hello: {
      SKR_DECODE(msg::HubLinkHello, m);
      if (auto r = server_.acceptHubLink(*this, m.hub_name); !r) {
        replyError(toErrorCode(r.error().code), r.error().message);
      } else {
        send(msg::HubLinkHelloOk{server_.hub_name});
      }
      return;
    }
    case Code::go_async: {
      if (!body.empty()) return protocolError("GO_ASYNC has a body");
      replyOk();
      state_ = State::flow;
      log::debug(kLogSource, "FLOW-ASYNC", describe() + " is now a flow");
      if (server_.sharedLink(*this) != nullptr) wantLinkOffers();
      return;
    }
    case Code::ping: {
      appendHeader(out_, Code::reply_ok, body.size());
      out_.append(body);
      queued();
      return;
    }
    default:
      if (codeInfo(static_cast<uint8_t>(code))->family == Family::blobs) {
        handleBlob(code, body);
        return;
      }
      replyError(ErrorCode::unsupported,
                 std::string(codeName(static_cast<uint8_t>(code))) + " is not implemented");
      return;
  }
}

void Connection::handleAsync(Code code, std::string_view body) {
  const DecodeLimits limits = valueLimits(server_.opt);
  // A failed command comes back as EV_ERROR with its tag.
  const auto check = [&](const Result<void>& r, uint32_t tag, uint16_t chan) {
    if (!r) onError(code, tag, chan, toErrorCode(r.error().code), r.error().message);
  };
  DatabaseAccess& dbs = server_.databases;
  switch (code) {
    case Code::publish: {
      // The hot path: no decoding beyond the channel id, the payload stays in the read buffer.
      ByteReader r(body);
      uint16_t chan = 0;
      if (!r.u16(chan)) return protocolError("PUBLISH: truncated channel id");
      check(server_.channels.publish(*this, chan, r.rest()), 0, chan);
      return;
    }
    case Code::chan_add: {
      SKR_DECODE(msg::ChanAdd, m);
      const auto kind = static_cast<ChannelKind>(m.kind);
      if (minor_ < minorOfKind(kind)) {
        onError(code, m.tag, 0, ErrorCode::invalid_argument,
                std::string(channelKindName(kind)) + " channels need protocol 1." +
                    std::to_string(minorOfKind(kind)));
        return;
      }
      auto r = server_.createChannel(*this, m.short_name, static_cast<ChannelKind>(m.kind), m.mime,
                                     m.props, m.tag);
      if (!r) onError(code, m.tag, 0, toErrorCode(r.error().code), r.error().message);
      return;
    }
    case Code::chan_remove: {
      SKR_DECODE(msg::ChanRemove, m);
      check(server_.removeChannel(*this, m.chan_id), m.tag, m.chan_id);
      return;
    }
    case Code::subscribe: {
      SKR_DECODE(msg::Subscribe, m);
      auto r = server_.channels.subscribe(*this, m.chan_id);
      if (r) server_.physical.subscribersChanged(m.chan_id);
      check(r, m.tag, m.chan_id);
      return;
    }
    case Code::unsubscribe: {
      SKR_DECODE(msg::Unsubscribe, m);
      server_.physical.unsubscribed(*this, m.chan_id);
      auto r = server_.channels.unsubscribe(*this, m.chan_id);
      if (r) server_.physical.subscribersChanged(m.chan_id);
      check(r, m.tag, m.chan_id);
      return;
    }
    case Code::service_request:
    case Code::service_request_timed: {
      msg::ServiceRequestTimed m;
      if (code == Code::service_request) {
        SKR_DECODE(msg::ServiceRequest, old);
        m = {old.tag, old.chan_id, 0, std::move(old.command), std::move(old.value)};
      } else {
        SKR_DECODE(msg::ServiceRequestTimed, timed);
        m = std::move(timed);
      }
      auto r = server_.requests.request(*this, m.chan_id, m.tag, false, m.timeout_ms, m.command,
                                        m.value);
      // Failures of a request come back as its response, where the caller waits for them.
      if (!r) {
        send(msg::EvServiceResponse{m.chan_id, m.tag, uint16_t(toErrorCode(r.error().code)),
                                    Variant(r.error().message)});
      }
      return;
    }
    case Code::service_response: {
      SKR_DECODE(msg::ServiceResponse, m);
      check(server_.requests.respond(*this, m.chan_id, m.request, m.value), 0, m.chan_id);
      return;
    }
    case Code::db_set_current: {
      SKR_DECODE(msg::DbSetCurrent, m);
      auto r = dbs.select(*this, m.name);
      check(r, m.tag, 0);
      if (r) onDbChanged(m.name);
      return;
    }
    case Code::db_create_async: {
      SKR_DECODE(msg::DbCreateAsync, m);
      check(dbs.create(*this, m.name), m.tag, 0);
      return;
    }
    case Code::db_remove_async: {
      SKR_DECODE(msg::DbRemoveAsync, m);
      check(dbs.remove(*this, m.name), m.tag, 0);
      return;
    }
    case Code::db_save_async: {
      SKR_DECODE(msg::DbSaveAsync, m);
      const uint32_t tag = m.tag;
      check(dbs.save(*this, m.name, whenDone([tag](Connection& c, const Result<void>& r) {
        if (!r) {
          c.onError(Code::db_save_async, tag, 0, toErrorCode(r.error().code), r.error().message);
        }
      })),
            m.tag, 0);
      return;
    }
    case Code::db_sync_async: {
      SKR_DECODE(msg::DbSyncAsync, m);
      const uint32_t tag = m.tag;
      dbs.store().barrier(whenDone([tag](Connection& c, const Result<void>& r) {
        if (r) {
          c.send(msg::EvDbSynced{tag});
        } else {
          c.onError(Code::db_sync_async, tag, 0, toErrorCode(r.error().code), r.error().message);
        }
      }));
      return;
    }
    case Code::var_set_async: {
      SKR_DECODE(msg::VarSetAsync, m);
      check(dbs.setVar(*this, {}, m.key, m.value), m.tag, 0);
      return;
    }
    case Code::var_del_async: {
      SKR_DECODE(msg::VarDelAsync, m);
      check(dbs.delVar(*this, {}, m.key), m.tag, 0);
      return;
    }
    case Code::link_offer: {
      SKR_DECODE(msg::LinkOffer, m);
      auto made = server_.linkOffer(*this, m);
      if (!made) check(made.error(), m.tag, 0);
      return;
    }
    case Code::db_read: {
      SKR_DECODE(msg::DbRead, m);
      if (m.what > uint8_t(msg::DbReadWhat::keys)) {
        return onError(
            code, m.tag, 0, ErrorCode::invalid_argument,
            "DB_READ: what is 0 (get), 1 (all) or 2 (keys), not " + std::to_string(m.what));
      }
      server_.readDatabase(*this, m.db, static_cast<msg::DbReadWhat>(m.what), m.key,
                           whenRead([tag = m.tag](Connection& c, Result<Variant> r) {
                             if (r) {
                               c.send(msg::EvDbValue{tag, std::move(*r)});
                             } else {
                               c.onError(Code::db_read, tag, 0, toErrorCode(r.error().code),
                                         r.error().message);
                             }
                           }));
      return;
    }
    case Code::replicate_channel: {
      SKR_DECODE(msg::ReplicateChannel, m);
      check(server_.replicate(user, m.source, m.short_name, this), m.tag, 0);
      return;
    }
    case Code::replicate_stop: {
      SKR_DECODE(msg::ReplicateStop, m);
      check(server_.stopReplica(user, m.short_name, id), m.tag, 0);
      return;
    }
    case Code::time_probe: {
      SKR_DECODE(msg::TimeProbe, m);
      const auto now = static_cast<uint64_t>(realtimeNs());
      send(msg::EvTimeProbe{m.tag, m.t1, now, static_cast<uint64_t>(realtimeNs())});
      return;
    }
    case Code::sync_pulse: {
      SKR_DECODE(msg::SyncPulse, m);
      check(server_.syncs.pulse(*this, m.chan_id, m.source_time_ns), 0, m.chan_id);
      return;
    }
    case Code::sync_follow: {
      SKR_DECODE(msg::SyncFollow, m);
      auto r = server_.syncs.follow(*this, m.chan_id, m.every);
      if (r) server_.noteFollowed(*this);
      check(r, m.tag, m.chan_id);
      return;
    }
    case Code::sync_unfollow: {
      SKR_DECODE(msg::SyncUnfollow, m);
      auto r = server_.syncs.unfollow(*this, m.chan_id);
      if (r) server_.noteFollowed(*this);
      check(r, m.tag, m.chan_id);
      return;
    }
    case Code::sync_done: {
      SKR_DECODE(msg::SyncDone, m);
      server_.syncs.done(*this, m.chan_id, m.seq);
      return;
    }
    case Code::phys_offer: {
      SKR_DECODE(msg::PhysOffer, m);
      check(server_.physical.offer(*this, m), m.tag, m.chan_id);
      return;
    }
    case Code::phys_request: {
      SKR_DECODE(msg::PhysRequest, m);
      check(server_.physical.request(*this, m, transport() == Transport::unix_socket), m.tag,
            m.chan_id);
      return;
    }
    case Code::phys_state: {
      SKR_DECODE(msg::PhysState, m);
      check(server_.physical.state(*this, m), 0, m.chan_id);
      return;
    }
    case Code::phys_switched: {
      SKR_DECODE(msg::PhysSwitched, m);
      check(server_.physical.switched(*this, m), 0, m.chan_id);
      return;
    }
    case Code::phys_count: {
      SKR_DECODE(msg::PhysCount, m);
      check(server_.physical.count(*this, m), 0, m.chan_id);
      return;
    }
    case Code::phys_received: {
      SKR_DECODE(msg::PhysReceived, m);
      check(server_.physical.received(*this, m), 0, m.chan_id);
      return;
    }
    case Code::phys_fallback: {
      SKR_DECODE(msg::PhysFallback, m);
      check(server_.physical.fallback(*this, m), 0, m.chan_id);
      return;
    }
    case Code::phys_replay: {
      SKR_DECODE(msg::PhysReplay, m);
      check(server_.physical.replay(*this, m), 0, m.chan_id);
      return;
    }
    case Code::chan_set_props: {
      SKR_DECODE(msg::ChanSetProps, m);
      check(server_.setProps(*this, m.chan_id, m.props), m.tag, m.chan_id);
      return;
    }
    default:
      onError(code, 0, 0, ErrorCode::unsupported,
              std::string(codeName(static_cast<uint8_t>(code))) + " is not implemented");
      return;
  }
}

#undef SKR_DECODE

}  // namespace skr::flow
