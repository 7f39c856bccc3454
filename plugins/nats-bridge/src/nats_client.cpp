// SPDX-License-Identifier: Apache-2.0
#include "nats_client.h"

#include <nats/nats.h>

#include <algorithm>
#include <chrono>
#include <utility>

namespace skr::nats_bridge {

// Reached by the client's callbacks (its delivery and connection threads): the inbox, the
// counters and the state. Lives until stop() has seen the last callback.
struct NatsClient::Shared {
  LogFn log;
  WakeFn wake;
  size_t cap = 0;
  int64_t reconnect_min_ms = 100;
  int64_t reconnect_max_ms = 5000;
  std::atomic<bool>* connected = nullptr;

  std::mutex mutex;  // everything below
  std::condition_variable cv;
  std::deque<Incoming> inbox;
  size_t inbox_bytes = 0;
  bool open = true;   // false after stop(): nothing more is queued or woken
  int live_subs = 0;  // subscriptions whose completion callback has not run
  int closed = 0;     // connections whose closed callback ran
  bool up[2] = {false, false};
  bool ever_up = false;
  std::string state = "connecting";
  std::string server;
  std::string last_error;
  uint64_t connects = 0, disconnects = 0;
  uint64_t in_msgs = 0, in_bytes = 0, in_dropped = 0;

  std::atomic<uint64_t> out_msgs{0}, out_bytes{0}, out_dropped{0};

  void push(Incoming in) {
    std::lock_guard lock(mutex);
    if (!open) return;
    const size_t size = in.data.size() + in.subject.size() + in.reply.size();
    if (inbox_bytes + size > cap) {
      ++in_dropped;
      return;
    }
    ++in_msgs;
    in_bytes += in.data.size();
    const bool was_empty = inbox.empty();
    inbox_bytes += size;
    inbox.push_back(std::move(in));
    if (was_empty) wake();
  }
  // Connection `lane` went up or down; the client is connected when both are.
  void setState(natsConnection* nc, int lane, bool is_up) {
    char url[256] = "";
    if (nc != nullptr && is_up) natsConnection_GetConnectedUrl(nc, url, sizeof url);
    bool both = false;
    {
      std::lock_guard lock(mutex);
      if (lane == 0) {
        server = url;
        if (is_up) ++connects;
        if (!is_up) ++disconnects;
      }
      up[lane] = is_up;
      both = up[0] && up[1];
      ever_up = ever_up || both;
      state = both ? "connected" : ever_up ? "reconnecting" : "connecting";
    }
    connected->store(both);
  }
};

// One connection's callbacks' closure.
struct NatsClient::Link {
  NatsClient::Shared* shared;
  int lane;
  const char* role;
};

struct NatsClient::Route {
  NatsClient::Shared* shared;
  uint64_t route;
};

namespace {

using Route = NatsClient::Route;
using Shared = NatsClient::Shared;

void onMessage(natsConnection*, natsSubscription*, natsMsg* msg, void* closure) {
  const auto* r = static_cast<const Route*>(closure);
  Incoming in;
  in.route = r->route;
  in.subject = natsMsg_GetSubject(msg);
  if (const char* reply = natsMsg_GetReply(msg)) in.reply = reply;
  if (const char* data = natsMsg_GetData(msg)) {
    in.data.assign(data, static_cast<size_t>(natsMsg_GetDataLength(msg)));
  }
  const char* value = nullptr;
  if (natsMsgHeader_Get(msg, kCommandHeader, &value) == NATS_OK && value != nullptr) {
    in.command = value;
  }
  if (natsMsgHeader_Get(msg, kErrorHeader, &value) == NATS_OK && value != nullptr) {
    in.error = value;
  }
  in.no_responders = natsMsg_IsNoResponders(msg);
  natsMsg_Destroy(msg);
  r->shared->push(std::move(in));
}

void onSubscriptionDone(void* closure) {
  auto* s = static_cast<Shared*>(closure);
  std::lock_guard lock(s->mutex);
  --s->live_subs;
  s->cv.notify_all();
}

void onConnected(natsConnection* nc, void* closure) {
  const auto* l = static_cast<const NatsClient::Link*>(closure);
  l->shared->setState(nc, l->lane, true);
  char url[256] = "";
  natsConnection_GetConnectedUrl(nc, url, sizeof url);
  l->shared->log(NatsClient::Level::info, "NATS-CONNECTED",
                 std::string("connected to ") + url + " (" + l->role + ")");
}

void onReconnected(natsConnection* nc, void* closure) {
  const auto* l = static_cast<const NatsClient::Link*>(closure);
  l->shared->setState(nc, l->lane, true);
  char url[256] = "";
  natsConnection_GetConnectedUrl(nc, url, sizeof url);
  l->shared->log(
      NatsClient::Level::info, "NATS-RECONNECTED",
      std::string("reconnected to ") + url + " (" + l->role + "); subscriptions restored");
}

void onDisconnected(natsConnection* nc, void* closure) {
  const auto* l = static_cast<const NatsClient::Link*>(closure);
  l->shared->setState(nc, l->lane, false);
  l->shared->log(NatsClient::Level::warn, "NATS-DISCONNECTED",
                 std::string("lost the server (") + l->role +
                     "); retrying (messages published meanwhile wait in the client's buffer)");
}

void onClosed(natsConnection*, void* closure) {
  auto* s = static_cast<const NatsClient::Link*>(closure)->shared;
  std::lock_guard lock(s->mutex);
  s->state = "closed";
  ++s->closed;
  s->cv.notify_all();
}

void onError(natsConnection*, natsSubscription*, natsStatus err, void* closure) {
  auto* s = static_cast<const NatsClient::Link*>(closure)->shared;
  {
    std::lock_guard lock(s->mutex);
    s->last_error = natsStatus_GetText(err);
    if (err == NATS_SLOW_CONSUMER) ++s->in_dropped;
  }
  s->log(NatsClient::Level::warn, "NATS-ERROR", natsStatus_GetText(err));
}

int64_t reconnectDelay(natsConnection*, int attempts, void* closure) {
  const auto* s = static_cast<const NatsClient::Link*>(closure)->shared;
  const int shift = std::clamp(attempts - 1, 0, 20);
  return std::min(s->reconnect_max_ms, s->reconnect_min_ms << shift);
}

std::string statusText(natsStatus st) {
  std::string text = natsStatus_GetText(st);
  natsStatus last = NATS_OK;
  if (const char* detail = nats_GetLastError(&last); detail != nullptr && *detail != '\0') {
    text += std::string(": ") + detail;
  }
  return text;
}

}  // namespace

struct Options {
  natsOptions* opts = nullptr;
  ~Options() {
    if (opts != nullptr) natsOptions_Destroy(opts);
  }
};

NatsClient::NatsClient(ClientOptions options, WakeFn wake, LogFn log)
    : options_(std::move(options)), log_(std::move(log)), shared_(std::make_shared<Shared>()) {
  shared_->log = log_;
  shared_->wake = std::move(wake);
  shared_->cap = options_.queue_bytes;
  shared_->reconnect_min_ms = options_.reconnect_min_ms;
  shared_->reconnect_max_ms = options_.reconnect_max_ms;
  shared_->connected = &connected_;
  char* inbox = nullptr;
  if (natsInbox_Create(&inbox) == NATS_OK) {
    inbox_ = inbox;
    natsInbox_Destroy(inbox);
  }
}

NatsClient::~NatsClient() {
  stop();
}

namespace {
// The options of the connection; the reason in `error` when one cannot be applied.
natsOptions* makeOptions(const ClientOptions& o, NatsClient::Link* link, std::string& error) {
  natsOptions* opts = nullptr;
  if (natsOptions_Create(&opts) != NATS_OK) {
    error = "cannot create the client's options";
    return nullptr;
  }
  std::vector<const char*> urls;
  for (const auto& s : o.servers) urls.push_back(s.c_str());
  natsStatus st = natsOptions_SetServers(opts, urls.data(), static_cast<int>(urls.size()));
  auto step = [&](natsStatus s, const char* what) {
    if (st == NATS_OK && s != NATS_OK) {
      st = s;
      error = std::string(what) + ": " + statusText(s);
    }
  };
  if (st != NATS_OK) error = "servers: " + statusText(st);
  step(natsOptions_SetName(opts, (o.name + " " + link->role).c_str()), "name");
  if (link->lane == static_cast<int>(Lane::prompt)) {
    step(natsOptions_SetSendAsap(opts, true), "send asap");
  } else {
    // Many streams: the client's shared delivery threads, not one per subscription.
    step(natsOptions_UseGlobalMessageDelivery(opts, true), "global delivery");
  }
  if (!o.user.empty()) {
    step(natsOptions_SetUserInfo(opts, o.user.c_str(), o.password.c_str()), "user");
  }
  if (!o.token.empty()) step(natsOptions_SetToken(opts, o.token.c_str()), "token");
  if (!o.creds_file.empty()) {
    step(natsOptions_SetUserCredentialsFromFiles(opts, o.creds_file.c_str(), nullptr),
         "creds_file");
  }
  if (!o.nkey.empty()) {
    step(natsOptions_SetNKeyFromSeed(opts, o.nkey.c_str(), o.nkey_seed_file.c_str()), "nkey");
  }
  if (!o.tls_ca.empty() || !o.tls_cert.empty()) {
    step(natsOptions_SetSecure(opts, true), "tls");
    if (!o.tls_ca.empty()) {
      step(natsOptions_LoadCATrustedCertificates(opts, o.tls_ca.c_str()), "tls_ca");
    }
    if (!o.tls_cert.empty()) {
      step(natsOptions_LoadCertificatesChain(opts, o.tls_cert.c_str(), o.tls_key.c_str()),
           "tls_cert");
    }
  }
  step(natsOptions_SetTimeout(opts, o.connect_timeout_ms), "connect_timeout_ms");
  step(natsOptions_SetMaxReconnect(opts, -1), "reconnect");
  step(natsOptions_SetCustomReconnectDelay(opts, &reconnectDelay, link), "reconnect delay");
  step(natsOptions_SetRetryOnFailedConnect(opts, true, &onConnected, link), "retry");
  step(natsOptions_SetDisconnectedCB(opts, &onDisconnected, link), "callbacks");
  step(natsOptions_SetReconnectedCB(opts, &onReconnected, link), "callbacks");
  step(natsOptions_SetClosedCB(opts, &onClosed, link), "callbacks");
  step(natsOptions_SetErrorHandler(opts, &onError, link), "callbacks");
  if (st != NATS_OK) {
    natsOptions_Destroy(opts);
    return nullptr;
  }
  return opts;
}
}  // namespace

bool NatsClient::start(std::string& error) {
  std::vector<std::shared_ptr<Options>> opts;
  for (int lane : {0, 1}) {
    links_[lane] =
        std::make_unique<Link>(Link{shared_.get(), lane, lane == 0 ? "streams" : "services"});
    auto o = std::make_shared<Options>();
    o->opts = makeOptions(options_, links_[lane].get(), error);
    if (o->opts == nullptr) return false;
    opts.push_back(std::move(o));
  }
  thread_ = std::thread([this, opts] {
    for (int lane : {0, 1}) {
      natsConnection* nc = nullptr;
      const natsStatus st = natsConnection_Connect(&nc, opts[lane]->opts);
      if (st == NATS_OK) {
        onConnected(nc, links_[lane].get());
      } else if (st == NATS_NOT_YET_CONNECTED) {
        if (lane == 0) {
          log_(Level::warn, "NATS-CONNECT-RETRY",
               "no server answers yet; retrying in the background");
        }
      } else {
        log_(Level::error, "NATS-CONNECT-FAILED", statusText(st));
        std::lock_guard lock(shared_->mutex);
        shared_->state = "failed";
        shared_->last_error = statusText(st);
      }
      connections_[lane] = nc;
    }
    run();
  });
  return true;
}

void NatsClient::stop() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ && !thread_.joinable()) return;
    stopping_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
  std::lock_guard lock(shared_->mutex);
  shared_->open = false;
  shared_->inbox.clear();
}

bool NatsClient::publish(Lane lane, std::string subject, std::string data, std::string reply,
                         std::string command, std::string error) {
  const size_t size = subject.size() + data.size() + reply.size();
  {
    std::lock_guard lock(mutex_);
    if (stopping_ || ops_bytes_ + size > options_.queue_bytes) {
      ++shared_->out_dropped;
      return false;
    }
    ops_bytes_ += size;
    ops_.push_back(Op{Op::Kind::publish, lane, 0, std::move(subject), std::move(reply),
                      std::move(data), std::move(command), std::move(error)});
  }
  cv_.notify_one();
  return true;
}

void NatsClient::subscribe(Lane lane, uint64_t route, std::string subject, std::string queue) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return;
    // The queue group travels in `reply`: an Op has no other use for it here.
    ops_.push_back(
        Op{Op::Kind::subscribe, lane, route, std::move(subject), std::move(queue), {}, {}, {}});
  }
  cv_.notify_one();
}

void NatsClient::unsubscribe(uint64_t route) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return;
    ops_.push_back(Op{Op::Kind::unsubscribe, Lane::bulk, route, {}, {}, {}, {}, {}});
  }
  cv_.notify_one();
}

std::deque<Incoming> NatsClient::take() {
  std::lock_guard lock(shared_->mutex);
  shared_->inbox_bytes = 0;
  return std::exchange(shared_->inbox, {});
}

ClientStats NatsClient::stats() const {
  ClientStats s;
  {
    std::lock_guard lock(shared_->mutex);
    s.state = shared_->state;
    s.server = shared_->server;
    s.connects = shared_->connects;
    s.disconnects = shared_->disconnects;
    s.in_msgs = shared_->in_msgs;
    s.in_bytes = shared_->in_bytes;
    s.in_dropped = shared_->in_dropped;
    s.in_queued_bytes = shared_->inbox_bytes;
    s.last_error = shared_->last_error;
  }
  s.out_msgs = shared_->out_msgs;
  s.out_bytes = shared_->out_bytes;
  s.out_dropped = shared_->out_dropped;
  std::lock_guard lock(mutex_);
  s.out_queued_bytes = ops_bytes_;
  return s;
}

void NatsClient::run() {
  for (;;) {
    std::deque<Op> batch;
    {
      std::unique_lock lock(mutex_);
      cv_.wait(lock, [&] { return stopping_ || !ops_.empty(); });
      if (stopping_) break;
      batch.swap(ops_);
      ops_bytes_ = 0;
    }
    for (Op& op : batch) apply(op);
  }
  // Closing: unsubscribe everything, close, and wait for the client's last callbacks.
  for (auto& [route, sub] : subs_) {
    natsSubscription_Unsubscribe(static_cast<natsSubscription*>(sub.first));
  }
  int open_connections = 0;
  for (auto& c : connections_) {
    if (auto* nc = static_cast<natsConnection*>(c.load())) {
      natsConnection_Close(nc);
      ++open_connections;
    }
  }
  {
    std::unique_lock lock(shared_->mutex);
    shared_->cv.wait_for(lock, std::chrono::seconds(5), [&] {
      return shared_->live_subs == 0 && shared_->closed >= open_connections;
    });
  }
  for (auto& [route, sub] : subs_) {
    natsSubscription_Destroy(static_cast<natsSubscription*>(sub.first));
  }
  subs_.clear();
  for (auto& c : connections_) {
    if (auto* nc = static_cast<natsConnection*>(c.exchange(nullptr))) natsConnection_Destroy(nc);
  }
  connected_ = false;
}

void NatsClient::apply(Op& op) {
  auto* nc = static_cast<natsConnection*>(connections_[static_cast<int>(op.lane)].load());
  if (nc == nullptr) {  // the connect failed for good (logged)
    if (op.kind == Op::Kind::publish) ++shared_->out_dropped;
    return;
  }
  switch (op.kind) {
    case Op::Kind::publish: {
      natsStatus st = NATS_OK;
      const char* reply = op.reply.empty() ? nullptr : op.reply.c_str();
      const int len = static_cast<int>(op.data.size());
      if (op.command.empty() && op.error.empty()) {
        st = reply == nullptr ? natsConnection_Publish(nc, op.subject.c_str(), op.data.data(), len)
                              : natsConnection_PublishRequest(nc, op.subject.c_str(), reply,
                                                              op.data.data(), len);
      } else {
        natsMsg* msg = nullptr;
        st = natsMsg_Create(&msg, op.subject.c_str(), reply, op.data.data(), len);
        if (st == NATS_OK && !op.command.empty()) {
          st = natsMsgHeader_Set(msg, kCommandHeader, op.command.c_str());
        }
        if (st == NATS_OK && !op.error.empty()) {
          st = natsMsgHeader_Set(msg, kErrorHeader, op.error.c_str());
        }
        if (st == NATS_OK) st = natsConnection_PublishMsg(nc, msg);
        natsMsg_Destroy(msg);
      }
      if (st == NATS_OK) {
        ++shared_->out_msgs;
        shared_->out_bytes += op.data.size();
      } else {
        ++shared_->out_dropped;
        std::lock_guard lock(shared_->mutex);
        shared_->last_error = statusText(st);
      }
      return;
    }
    case Op::Kind::subscribe: {
      if (subs_.count(op.route) != 0) return;
      auto route = std::make_unique<Route>(Route{shared_.get(), op.route});
      natsSubscription* sub = nullptr;
      const natsStatus st =
          op.reply.empty()
              ? natsConnection_Subscribe(&sub, nc, op.subject.c_str(), &onMessage, route.get())
              : natsConnection_QueueSubscribe(&sub, nc, op.subject.c_str(), op.reply.c_str(),
                                              &onMessage, route.get());
      if (st != NATS_OK) {
        log_(Level::error, "NATS-SUBSCRIBE", op.subject + ": " + statusText(st));
        return;
      }
      {
        std::lock_guard lock(shared_->mutex);
        ++shared_->live_subs;
      }
      natsSubscription_SetOnCompleteCB(sub, &onSubscriptionDone, shared_.get());
      // Large enough for camera frames: the client's default (64 MB, 65536 messages).
      subs_.emplace(op.route, std::make_pair(static_cast<void*>(sub), std::move(route)));
      return;
    }
    case Op::Kind::unsubscribe: {
      auto it = subs_.find(op.route);
      if (it == subs_.end()) return;
      auto* sub = static_cast<natsSubscription*>(it->second.first);
      natsSubscription_Unsubscribe(sub);
      natsSubscription_Destroy(sub);
      // Its Route may still be read by a callback in flight: kept until stop().
      retired_.push_back(std::move(it->second.second));
      subs_.erase(it);
      return;
    }
  }
}

}  // namespace skr::nats_bridge
