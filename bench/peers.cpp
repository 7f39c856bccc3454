// SPDX-License-Identifier: Apache-2.0
// The hub beside its peers: Redis pub/sub, Mosquitto (MQTT QoS 0) and NATS core, each started
// here from Debian's binaries on a free loopback port, persisting nothing, and stopped at the
// end. The same sizes and patterns go through every server and through the hub (in-process,
// bench/relay_harness.h, as flow_relay runs it), in one run:
//   round trip   ping-pong A -> server -> B -> server -> A, one message in flight: p50/p99
//   1:1          delivered messages/s and MB/s from one publisher to one subscriber
//   fan-out 1:16 delivered messages/s in all
// Every server on TCP loopback, the hub on TCP and on its Unix socket; each figure is printed with
// its ratio to the hub on TCP. Nagle is off everywhere (the hub's clients, hiredis and libnats
// set TCP_NODELAY; libmosquitto and mosquitto are told to).
//
// Each client is written the efficient way its library allows: the hub's publisher sends 256 KB
// of frames per send(); Redis PUBLISH is pipelined (hiredis redisAppendCommand, the replies of a
// batch read while the next one is on its way); libnats buffers publishes and flushes them from
// its own thread (and, for round trips, sends at once: natsOptions_SetSendAsap); libmosquitto
// writes each packet as it is published and reads one packet per mosquitto_loop_read(), which is
// what that library offers. Subscribers run on their own threads. A publisher never runs more
// than a window (4 MB; a fan-out shares it and the batch among its subscribers) ahead of its
// slowest subscriber, so figures are delivered traffic; what a server still lost (QoS 0 and
// pub/sub drop silently) is counted from sequence gaps and reported.
//
//   peers [--quick] [--seconds S] [--only LIST] [--require-all]
//
// Exits 1 on a real error (lost connection, a server that does not start, no data at all); a
// slower figure is reported, not an error. A missing server binary skips its column, unless
// --require-all (the test suite) makes it an error.
#include <skrobot/runtime/log.h>

#include "hub_process.h"  // Child
#include "nats_server.h"  // NatsServer, freePort
#include "relay_harness.h"

#include <hiredis/hiredis.h>
#include <mosquitto.h>
#include <nats/nats.h>
#include <poll.h>
#include <sys/ioctl.h>

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

namespace {

using namespace skr::bench;  // NOLINT(google-build-using-namespace): the harness's vocabulary
using skr::sat::test::Child;
using skr::sat::test::freePort;
using skr::sat::test::NatsServer;
namespace fs = std::filesystem;

constexpr size_t kFanOut = 16;
constexpr int kSilenceMs = 10000;  // a subscriber with nothing for this long: an error
constexpr int kTailIdleMs = 1500;  // after the last publish: what has not come by then is lost
constexpr int kServerStartMs = 10000;
constexpr int kSlowWriteMs = 30000;  // a broker that takes no bytes this long: an error

// --- options -------------------------------------------------------------------------------

struct Options {
  bool quick = false;
  double seconds = 1.5;           // per throughput figure
  std::vector<std::string> only;  // tests and systems; empty: all
  bool require_all = false;
};

void usage() {
  std::printf(
      "usage: peers [--quick] [--seconds S] [--only LIST] [--require-all]\n"
      "  --quick        a short run (seconds), used by the test suite\n"
      "  --seconds S    seconds per throughput figure (default 1.5)\n"
      "  --only LIST    comma-separated tests (round-trip, 1:1, fan-out) and systems (hub-unix,\n"
      "                 redis, mosquitto, nats); the hub on TCP always runs: it is the reference\n"
      "  --require-all  a missing server binary is an error, not a skipped column\n");
}

std::vector<std::string> splitList(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

Options parseOptions(int argc, char** argv) {
  Options o;
  bool seconds_given = false;
  for (int i = 1; i < argc; ++i) {
    const std::string_view a = argv[i];
    const bool has_value = i + 1 < argc;
    if (a == "--quick") {
      o.quick = true;
    } else if (a == "--seconds" && has_value) {
      o.seconds = std::atof(argv[++i]);
      seconds_given = true;
    } else if (a == "--only" && has_value) {
      o.only = splitList(argv[++i]);
    } else if (a == "--require-all") {
      o.require_all = true;
    } else {
      usage();
      std::exit(a == "--help" || a == "-h" ? 0 : 2);
    }
  }
  if (o.quick && !seconds_given) o.seconds = 0.1;
  const std::vector<std::string> known{"round-trip", "1:1",       "fan-out", "hub-unix",
                                       "redis",      "mosquitto", "nats",    "hub-tcp"};
  for (const auto& w : o.only) {
    if (std::find(known.begin(), known.end(), w) == known.end()) {
      usage();
      std::exit(2);
    }
  }
  if (o.seconds <= 0) {
    usage();
    std::exit(2);
  }
  return o;
}

// True when `--only` names this test (or names no test at all).
bool wantTest(const Options& o, const std::string& test) {
  const bool any_test = std::any_of(o.only.begin(), o.only.end(), [](const std::string& w) {
    return w == "round-trip" || w == "1:1" || w == "fan-out";
  });
  return !any_test || std::find(o.only.begin(), o.only.end(), test) != o.only.end();
}

bool wantSystem(const Options& o, const std::string& system) {
  if (system == "hub-tcp") return true;
  const bool any_system = std::any_of(o.only.begin(), o.only.end(), [](const std::string& w) {
    return w != "round-trip" && w != "1:1" && w != "fan-out" && w != "hub-tcp";
  });
  return !any_system || std::find(o.only.begin(), o.only.end(), system) != o.only.end();
}

// --- a client of a peer server ---------------------------------------------------------------

// Called with each message's payload, valid during the call only.
using Handler = std::function<void(std::string_view)>;

// One client connection (or two, for Redis) of a server: publishes and receives on topics.
// Used by one thread at a time.
class PubSub {
 public:
  PubSub() = default;
  virtual ~PubSub() = default;
  PubSub(const PubSub&) = delete;
  PubSub& operator=(const PubSub&) = delete;
  PubSub(PubSub&&) = delete;
  PubSub& operator=(PubSub&&) = delete;
  // Returns once the server has the subscription.
  virtual void subscribe(const std::string& topic) = 0;
  // May buffer; flush() sends what is buffered.
  virtual void publish(const std::string& topic, std::string_view data) = 0;
  virtual void flush() = 0;
  // Hands the messages that arrive within timeout_ms to `h`; how many (0: none came).
  virtual size_t poll(int timeout_ms, const Handler& h) = 0;
  // Messages the client library itself dropped (NATS slow consumer), if it counts them.
  virtual uint64_t libraryDrops() { return 0; }
};
using PubSubPtr = std::unique_ptr<PubSub>;

// For round trips, a client sends each message at once; for throughput, as its library batches.
enum class Mode { latency, throughput };

bool waitReadable(int fd, int timeout_ms) {
  pollfd p{fd, POLLIN, 0};
  const int n = ::poll(&p, 1, timeout_ms);
  if (n < 0 && errno != EINTR) fail(errnoText("poll"));
  return n > 0;
}

// --- Redis (hiredis) -------------------------------------------------------------------------

struct RedisDeleter {
  void operator()(redisContext* c) const { redisFree(c); }
};
using RedisPtr = std::unique_ptr<redisContext, RedisDeleter>;
struct ReplyDeleter {
  void operator()(redisReply* r) const { freeReplyObject(r); }
};
using ReplyPtr = std::unique_ptr<redisReply, ReplyDeleter>;

RedisPtr redisDial(int port) {
  RedisPtr c(redisConnectWithTimeout("127.0.0.1", port, timeval{5, 0}));
  if (!c || c->err != 0) fail("redis connect: " + std::string(c ? c->errstr : "out of memory"));
  redisSetTimeout(c.get(), timeval{kIoTimeoutMs / 1000, 0});  // hiredis sets TCP_NODELAY itself
  return c;
}

// A subscribed connection cannot PUBLISH (RESP2), so a client has one of each. PUBLISH is
// pipelined: the replies (receiver counts) are read one batch late, while the next batch is on
// its way, or at once in latency mode when many are outstanding.
class RedisClient final : public PubSub {
 public:
  RedisClient(int port, Mode mode) : port_(port), mode_(mode) {}
  ~RedisClient() override {
    try {
      if (pub_) drain(0);
    } catch (const std::exception&) {  // nothing to do about it at the end
    }
  }
  RedisClient(const RedisClient&) = delete;
  RedisClient& operator=(const RedisClient&) = delete;
  RedisClient(RedisClient&&) = delete;
  RedisClient& operator=(RedisClient&&) = delete;

  void subscribe(const std::string& topic) override {
    sub_ = redisDial(port_);
    ReplyPtr r(static_cast<redisReply*>(redisCommand(sub_.get(), "SUBSCRIBE %s", topic.c_str())));
    if (!r || r->type != REDIS_REPLY_ARRAY) fail("redis SUBSCRIBE: " + error(sub_.get()));
  }
  void publish(const std::string& topic, std::string_view data) override {
    if (!pub_) pub_ = redisDial(port_);
    if (redisAppendCommand(pub_.get(), "PUBLISH %s %b", topic.c_str(), data.data(), data.size()) !=
        REDIS_OK) {
      fail("redis PUBLISH: " + error(pub_.get()));
    }
    ++unflushed_;
  }
  void flush() override {
    if (!pub_) return;
    for (int done = 0; done == 0;) {
      if (redisBufferWrite(pub_.get(), &done) != REDIS_OK)
        fail("redis write: " + error(pub_.get()));
    }
    const uint64_t batch = unflushed_;
    outstanding_ += unflushed_;
    unflushed_ = 0;
    drain(mode_ == Mode::latency ? 256 : batch);
  }
  size_t poll(int timeout_ms, const Handler& h) override {
    size_t n = 0;
    for (;;) {
      void* raw = nullptr;
      if (redisGetReplyFromReader(sub_.get(), &raw) != REDIS_OK) {
        fail("redis read: " + error(sub_.get()));
      }
      if (raw != nullptr) {
        ReplyPtr r(static_cast<redisReply*>(raw));
        if (r->type != REDIS_REPLY_ARRAY || r->elements != 3 ||
            r->element[2]->type != REDIS_REPLY_STRING) {
          fail("redis: unexpected push on a subscribed connection");
        }
        h(std::string_view(r->element[2]->str, r->element[2]->len));
        ++n;
        continue;
      }
      if (n > 0 || !waitReadable(sub_->fd, timeout_ms)) return n;
      if (redisBufferRead(sub_.get()) != REDIS_OK) fail("redis read: " + error(sub_.get()));
    }
  }

 private:
  static std::string error(redisContext* c) { return c->err != 0 ? c->errstr : "bad reply"; }
  // Reads PUBLISH replies until at most `keep` are outstanding.
  void drain(uint64_t keep) {
    while (outstanding_ > keep) {
      void* raw = nullptr;
      if (redisGetReply(pub_.get(), &raw) != REDIS_OK || raw == nullptr) {
        fail("redis PUBLISH reply: " + error(pub_.get()));
      }
      freeReplyObject(raw);
      --outstanding_;
    }
  }

  int port_;
  Mode mode_;
  RedisPtr sub_, pub_;
  uint64_t unflushed_ = 0, outstanding_ = 0;
};

// --- Mosquitto (libmosquitto, MQTT QoS 0) ------------------------------------------------------

// Driven on the caller's thread (no mosquitto_loop_start): a publish outside a callback is
// written at once; reading polls the socket, then calls mosquitto_loop_read while bytes are
// waiting (it reads one packet per call).
class MqttClient final : public PubSub {
 public:
  explicit MqttClient(int port) {
    static std::atomic<int> n{0};
    const std::string id = "peers-" + std::to_string(::getpid()) + "-" + std::to_string(++n);
    mosq_ = mosquitto_new(id.c_str(), true, this);
    if (mosq_ == nullptr) fail("mosquitto_new failed");
    mosquitto_int_option(mosq_, MOSQ_OPT_PROTOCOL_VERSION, MQTT_PROTOCOL_V311);
    mosquitto_int_option(mosq_, MOSQ_OPT_TCP_NODELAY, 1);
    mosquitto_connect_callback_set(mosq_, [](mosquitto*, void* self, int rc) {
      static_cast<MqttClient*>(self)->connack_ = rc == 0 ? 1 : -1;
    });
    mosquitto_subscribe_callback_set(mosq_, [](mosquitto*, void* self, int, int, const int*) {
      static_cast<MqttClient*>(self)->suback_ = true;
    });
    mosquitto_message_callback_set(mosq_, [](mosquitto*, void* self, const mosquitto_message* m) {
      auto* c = static_cast<MqttClient*>(self);
      (*c->handler_)(std::string_view(static_cast<const char*>(m->payload),
                                      static_cast<size_t>(m->payloadlen)));
      ++c->received_;
    });
    check(mosquitto_connect(mosq_, "127.0.0.1", port, 600), "connect");
    waitFor([&] { return connack_ != 0; }, "CONNACK");
    if (connack_ < 0) fail("mosquitto: connection refused");
  }
  ~MqttClient() override {
    mosquitto_disconnect(mosq_);
    mosquitto_destroy(mosq_);
  }
  MqttClient(const MqttClient&) = delete;
  MqttClient& operator=(const MqttClient&) = delete;
  MqttClient(MqttClient&&) = delete;
  MqttClient& operator=(MqttClient&&) = delete;

  void subscribe(const std::string& topic) override {
    check(mosquitto_subscribe(mosq_, nullptr, topic.c_str(), 0), "subscribe");
    waitFor([&] { return suback_; }, "SUBACK");
  }
  void publish(const std::string& topic, std::string_view data) override {
    check(mosquitto_publish(mosq_, nullptr, topic.c_str(), static_cast<int>(data.size()),
                            data.data(), 0, false),
          "publish");
  }
  void flush() override {
    while (mosquitto_want_write(mosq_)) {
      pollfd p{mosquitto_socket(mosq_), POLLOUT, 0};
      if (::poll(&p, 1, kSlowWriteMs) == 0) fail("mosquitto: socket not writable for 30 s");
      check(mosquitto_loop_write(mosq_, 1), "write");
    }
  }
  size_t poll(int timeout_ms, const Handler& h) override {
    handler_ = &h;
    received_ = 0;
    const int fd = mosquitto_socket(mosq_);
    // A packet may come in pieces: wait until a whole message arrived or timeout_ms passed.
    const skr::Nanos end = skr::monotonicNs() + skr::Nanos{timeout_ms} * 1000000;
    while (received_ == 0) {
      const skr::Nanos left = end - skr::monotonicNs();
      if (pending(fd) == 0 && (left <= 0 || !waitReadable(fd, static_cast<int>(left / 1000000)))) {
        return 0;
      }
      do {
        check(mosquitto_loop_read(mosq_, 1), "read");
      } while (pending(fd) > 0 && received_ < 4096);
    }
    flush();  // what a callback published (an echo) is only queued
    return received_;
  }

 private:
  static int pending(int fd) {
    int n = 0;
    ::ioctl(fd, FIONREAD, &n);
    return n;
  }
  static void check(int rc, const char* what) {
    if (rc != MOSQ_ERR_SUCCESS) {
      fail(std::string("mosquitto ") + what + ": " + mosquitto_strerror(rc));
    }
  }
  template <class F>
  void waitFor(F done, const char* what) {
    const Handler ignore = [](std::string_view) {};
    handler_ = &ignore;
    const skr::Nanos end = skr::monotonicNs() + skr::Nanos{kServerStartMs} * 1000000;
    while (!done()) {
      if (skr::monotonicNs() > end) fail(std::string("mosquitto: no ") + what);
      check(mosquitto_loop(mosq_, 100, 1), what);
    }
  }

  mosquitto* mosq_ = nullptr;
  const Handler* handler_ = nullptr;
  size_t received_ = 0;
  int connack_ = 0;
  bool suback_ = false;
};

// --- NATS (libnats) --------------------------------------------------------------------------

// Publishes are buffered and flushed by libnats' own thread (throughput) or sent at once
// (latency: natsOptions_SetSendAsap); subscriptions are synchronous, read with NextMsg.
class NatsClient final : public PubSub {
 public:
  NatsClient(const std::string& url, Mode mode) {
    natsOptions* o = nullptr;
    natsOptions_Create(&o);
    natsOptions_SetURL(o, url.c_str());
    natsOptions_SetSendAsap(o, mode == Mode::latency);
    const natsStatus st = natsConnection_Connect(&nc_, o);
    natsOptions_Destroy(o);
    if (st != NATS_OK) fail(std::string("nats connect: ") + natsStatus_GetText(st));
  }
  ~NatsClient() override {
    if (sub_ != nullptr) natsSubscription_Destroy(sub_);
    natsConnection_Destroy(nc_);
  }
  NatsClient(const NatsClient&) = delete;
  NatsClient& operator=(const NatsClient&) = delete;
  NatsClient(NatsClient&&) = delete;
  NatsClient& operator=(NatsClient&&) = delete;

  void subscribe(const std::string& topic) override {
    check(natsConnection_SubscribeSync(&sub_, nc_, topic.c_str()), "subscribe");
    // The window keeps far fewer in flight; the default (65536 messages) is below it at 16 B.
    check(natsSubscription_SetPendingLimits(sub_, 1 << 24, 1 << 30), "pending limits");
    check(natsConnection_Flush(nc_), "flush");  // the server has the subscription
  }
  void publish(const std::string& topic, std::string_view data) override {
    check(natsConnection_Publish(nc_, topic.c_str(), data.data(), static_cast<int>(data.size())),
          "publish");
  }
  void flush() override {}  // libnats' flusher thread (throughput) or SendAsap (latency)
  size_t poll(int timeout_ms, const Handler& h) override {
    natsMsg* m = nullptr;
    const natsStatus st = natsSubscription_NextMsg(&m, sub_, timeout_ms);
    if (st == NATS_TIMEOUT) return 0;
    if (st == NATS_SLOW_CONSUMER) return 0;  // counted in libraryDrops
    check(st, "next message");
    h(std::string_view(natsMsg_GetData(m), static_cast<size_t>(natsMsg_GetDataLength(m))));
    natsMsg_Destroy(m);
    return 1;
  }
  uint64_t libraryDrops() override {
    int64_t d = 0;
    natsSubscription_GetDropped(sub_, &d);
    return static_cast<uint64_t>(d);
  }

 private:
  static void check(natsStatus st, const char* what) {
    if (st != NATS_OK) fail(std::string("nats ") + what + ": " + natsStatus_GetText(st));
  }
  natsConnection* nc_ = nullptr;
  natsSubscription* sub_ = nullptr;
};

// --- servers -----------------------------------------------------------------------------------

bool executable(const std::string& path) {
  return !path.empty() && ::access(path.c_str(), X_OK) == 0;
}

bool waitPort(int port, Child& child, int timeout_ms) {
  return skr::test::eventually(
             [&] {
               if (!child.running()) return true;
               try {
                 connectTcp(static_cast<uint16_t>(port));
                 return true;
               } catch (const Fail&) {
                 return false;
               }
             },
             timeout_ms) &&
         child.running();
}

// A server process of ours on 127.0.0.1:port, killed at the end.
class Server {
 public:
  Server() = default;
  virtual ~Server() = default;
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;
  Server(Server&&) = delete;
  Server& operator=(Server&&) = delete;
  [[nodiscard]] virtual PubSubPtr connect(Mode mode) const = 0;
};

class RedisServer final : public Server {
 public:
  explicit RedisServer(const fs::path& dir) : port_(freePort()) {
    // Nothing persisted; the pub/sub output limit as Debian ships it (the window stays below).
    child_ = std::make_unique<Child>(
        std::vector<std::string>{REDIS_SERVER_BIN, "--port", std::to_string(port_), "--bind",
                                 "127.0.0.1", "--save", "", "--appendonly", "no", "--dir",
                                 dir.string(), "--protected-mode", "no", "--daemonize", "no"},
        std::vector<std::string>{}, dir / "redis.log");
    if (!waitPort(port_, *child_, kServerStartMs)) {
      fail("redis-server did not start: " + child_->output());
    }
  }
  [[nodiscard]] PubSubPtr connect(Mode mode) const override {
    return std::make_unique<RedisClient>(port_, mode);
  }

 private:
  int port_;
  std::unique_ptr<Child> child_;
};

class MosquittoServer final : public Server {
 public:
  explicit MosquittoServer(const fs::path& dir) : port_(freePort()) {
    // No persistence; QoS 0 queues without a count limit (the window bounds them), like the hub's
    // byte-bounded queue; Nagle off on the broker's sockets.
    const fs::path conf = dir / "mosquitto.conf";
    std::ofstream(conf) << "listener " << port_ << " 127.0.0.1\n"
                        << "allow_anonymous true\npersistence false\nset_tcp_nodelay true\n"
                        << "max_queued_messages 0\nmax_queued_bytes 0\n"
                        << "log_dest stderr\nlog_type error\nlog_type warning\n";
    child_ = std::make_unique<Child>(std::vector<std::string>{MOSQUITTO_BIN, "-c", conf.string()},
                                     std::vector<std::string>{}, dir / "mosquitto.log");
    if (!waitPort(port_, *child_, kServerStartMs)) {
      fail("mosquitto did not start: " + child_->output());
    }
  }
  [[nodiscard]] PubSubPtr connect(Mode) const override {
    return std::make_unique<MqttClient>(port_);
  }

 private:
  int port_;
  std::unique_ptr<Child> child_;
};

class NatsCoreServer final : public Server {
 public:
  explicit NatsCoreServer(const fs::path& dir) : server_(dir, "peers", false) {
    if (!server_.start()) fail("nats-server did not start: " + server_.log());
  }
  [[nodiscard]] PubSubPtr connect(Mode mode) const override {
    return std::make_unique<NatsClient>(server_.url(), mode);
  }

 private:
  NatsServer server_;
};

// --- systems: the hub and its peers ------------------------------------------------------------

struct System {
  std::string id;       // as --only names it
  std::string title;    // column title
  std::string library;  // the client, for the preamble
  Transport hub_transport = Transport::tcp;
  std::unique_ptr<Server> server;  // null for the hub
};

// --- measurements ------------------------------------------------------------------------------

void stamp(std::string& data, uint64_t seq) {
  std::memcpy(data.data(), &seq, 8);
}
uint64_t seqOf(std::string_view data, size_t payload) {
  if (data.size() != payload) {
    fail("message of " + std::to_string(data.size()) + " bytes, expected " +
         std::to_string(payload));
  }
  uint64_t seq = 0;
  std::memcpy(&seq, data.data(), 8);
  return seq;
}

// A ping-pong pair through a peer server: A publishes on "ping", B answers on "pong".
struct PeerPingPair {
  PubSubPtr a, b;
};

PeerPingPair peerPingPair(const Server& s) {
  PeerPingPair p{s.connect(Mode::latency), s.connect(Mode::latency)};
  p.b->subscribe("ping");
  p.a->subscribe("pong");
  return p;
}

void peerPingPong(PeerPingPair& p, size_t payload, int rounds, int warmup,
                  std::vector<skr::Nanos>& samples) {
  const int total = warmup + rounds;
  std::atomic<bool> stop{false};
  Worker responder([&] {
    std::string reply(payload, 'x');
    for (int i = 0; i < total && !stop.load();) {
      bool got = false;
      const Handler h = [&](std::string_view m) {
        if (seqOf(m, payload) != static_cast<uint64_t>(i)) fail("echo: out of order message");
        std::memcpy(reply.data(), m.data(), payload);
        got = true;
      };
      if (p.b->poll(200, h) == 0) continue;
      if (got) {
        p.b->publish("pong", reply);
        p.b->flush();
        ++i;
      }
    }
  });
  std::string ping(payload, 'x');
  try {
    for (int i = 0; i < total; ++i) {
      stamp(ping, static_cast<uint64_t>(i));
      const skr::Nanos t0 = skr::monotonicNs();
      p.a->publish("ping", ping);
      p.a->flush();
      bool got = false;
      const Handler h = [&](std::string_view m) {
        if (seqOf(m, payload) != static_cast<uint64_t>(i)) fail("ping: wrong answer");
        got = true;
      };
      while (!got) {
        if (p.a->poll(kSilenceMs, h) == 0) fail("round trip: no answer for 10 s");
      }
      if (i >= warmup) samples.push_back(skr::monotonicNs() - t0);
    }
  } catch (...) {
    stop.store(true);
    throw;
  }
  responder.join("round trip responder");
}

// What one subscriber saw; `seen` (the next sequence number expected) paces the publisher.
struct alignas(64) PeerSub {
  std::atomic<uint64_t> seen{0};
  uint64_t received = 0;
  uint64_t lost = 0;
  skr::Nanos last_ns = 0;
};

void peerSubscriberLoop(PubSub& c, size_t payload, const std::atomic<uint64_t>& total,
                        PeerSub& st) {
  uint64_t expect = 0;
  skr::Nanos idle_since = skr::monotonicNs();
  const Handler h = [&](std::string_view m) {
    const uint64_t seq = seqOf(m, payload);
    if (seq < expect) fail("sequence went back from " + std::to_string(expect));
    expect = seq + 1;
    ++st.received;
  };
  for (;;) {
    const uint64_t want = total.load(std::memory_order_acquire);
    if (expect >= want) break;
    if (c.poll(100, h) > 0) {
      st.last_ns = idle_since = skr::monotonicNs();
      st.seen.store(expect, std::memory_order_release);
      continue;
    }
    const double idle_ms = static_cast<double>(skr::monotonicNs() - idle_since) / 1e6;
    if (want != std::numeric_limits<uint64_t>::max() && idle_ms > kTailIdleMs) break;
    if (idle_ms > kSilenceMs) fail("no data for 10 s");
  }
  st.lost = total.load() - st.received;
}

Throughput peerStream(const Server& server, size_t subscribers, size_t payload, double seconds,
                      size_t batch_bytes, size_t window_bytes) {
  PubSubPtr pub = server.connect(Mode::throughput);
  std::vector<PubSubPtr> readers;
  for (size_t i = 0; i < subscribers; ++i) {
    readers.push_back(server.connect(Mode::throughput));
    readers.back()->subscribe("stream");
  }
  std::vector<PeerSub> subs(subscribers);
  std::atomic<uint64_t> total{std::numeric_limits<uint64_t>::max()};
  std::vector<std::unique_ptr<Worker>> workers;
  for (size_t i = 0; i < subscribers; ++i) {
    workers.push_back(std::make_unique<Worker>(
        [&, i] { peerSubscriberLoop(*readers[i], payload, total, subs[i]); }));
  }
  // The same batches and window as the hub's publisher (relay_harness.cpp).
  const uint64_t k = std::max<size_t>(1, batch_bytes / (kDataOverhead + payload));
  const uint64_t window = std::max<uint64_t>(2 * k, window_bytes / (kDataOverhead + payload));
  const auto slowest = [&] {
    uint64_t m = std::numeric_limits<uint64_t>::max();
    for (const auto& s : subs) m = std::min(m, s.seen.load(std::memory_order_acquire));
    return m;
  };
  const auto anyFailed = [&] {
    return std::any_of(workers.begin(), workers.end(), [](const auto& w) { return w->failed(); });
  };
  std::string data(payload, 'x');
  const skr::Nanos start = skr::monotonicNs();
  const skr::Nanos deadline = start + static_cast<skr::Nanos>(seconds * 1e9);
  // A lossy server never lets `seen` reach the window's edge: the wait gives up after a while.
  try {
    for (uint64_t seq = 0;;) {
      const bool last = skr::monotonicNs() >= deadline;
      const skr::Nanos wait_start = skr::monotonicNs();
      while (seq + k > slowest() + window && !anyFailed() &&
             skr::monotonicNs() - wait_start < skr::Nanos{kTailIdleMs} * 1000000) {
        std::this_thread::sleep_for(std::chrono::microseconds(50));
      }
      if (anyFailed()) break;
      for (uint64_t i = 0; i < k; ++i) {
        stamp(data, seq + i);
        pub->publish("stream", data);
      }
      pub->flush();
      seq += k;
      if (last) {
        total.store(seq, std::memory_order_release);
        break;
      }
    }
  } catch (...) {
    total.store(0);  // the subscribers stop at once
    throw;
  }
  if (total.load() == std::numeric_limits<uint64_t>::max()) total.store(0);  // a reader failed
  for (auto& w : workers) w->join("subscriber");
  Throughput t;
  skr::Nanos end = start + 1;
  for (size_t i = 0; i < subscribers; ++i) {
    t.delivered += subs[i].received;
    t.dropped += subs[i].lost;
    end = std::max(end, subs[i].last_ns);
  }
  if (t.delivered == 0) fail("nothing delivered");
  const double secs = static_cast<double>(end - start) / 1e9;
  t.total_rate = static_cast<double>(t.delivered) / secs;
  t.per_sub_rate = t.total_rate / static_cast<double>(subscribers);
  t.mb_s = t.total_rate * static_cast<double>(payload) / static_cast<double>(kMiB);
  return t;
}

// --- the tables ----------------------------------------------------------------------------------

struct Cell {
  bool measured = false;
  Latency rtt;
  Throughput tp;
};

// cells[size][system index]
using Table = std::map<size_t, std::vector<Cell>>;

std::string cellText(const Cell& c, const Cell& ref, bool latency, bool mb) {
  if (!c.measured) return "-";
  if (latency) {
    return fmt("%.1f/%.0f us", c.rtt.p50_us, c.rtt.p99_us) +
           fmt(" %.2fx", c.rtt.p50_us / ref.rtt.p50_us);
  }
  std::string s = rateText(c.tp.total_rate);
  if (mb) s += fmt(" %.0fMB/s", c.tp.mb_s);
  const double ratio = c.tp.total_rate / ref.tp.total_rate;
  s += fmt(ratio < 0.1 ? " %.3fx" : " %.2fx", ratio);
  if (c.tp.dropped > 0) s += " lost " + std::to_string(c.tp.dropped);
  return s;
}

void printTable(const char* title, const char* how, const Table& t,
                const std::vector<System>& systems, const std::vector<bool>& on, bool latency,
                bool mb) {
  std::printf("\n%s (%s)\n%-6s", title, how, "size");
  for (size_t i = 0; i < systems.size(); ++i) {
    if (on[i]) std::printf(" %-30s", systems[i].title.c_str());
  }
  std::printf("\n");
  for (const auto& [size, cells] : t) {
    std::printf("%-6s", sizeText(size).c_str());
    for (size_t i = 0; i < systems.size(); ++i) {
      if (on[i]) std::printf(" %-30s", cellText(cells[i], cells[0], latency, mb).c_str());
    }
    std::printf("\n");
  }
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parseOptions(argc, argv);
  std::signal(SIGPIPE, SIG_IGN);  // a server that goes away is an error, not a signal
  skr::log::setLevel(skr::log::Level::error);
  mosquitto_lib_init();
  int status = 0;
  try {
    skr::test::TempDir dir("skrobot-peers");
    Hub hub(HubOptions{8 * kMiB, 50, true, false});
    std::vector<System> systems;
    systems.push_back({"hub-tcp",
                       "hub tcp",
                       "FlowProtocol on blocking sockets, 256 KB of frames per send()",
                       Transport::tcp,
                       {}});
    systems.push_back(
        {"hub-unix", "hub unix", "the same, on the hub's Unix socket", Transport::unix_socket, {}});
    const auto addServer = [&](const char* id, const char* title, const char* library,
                               const char* binary, auto make) {
      if (!wantSystem(o, id)) return;
      if (!executable(binary)) {
        const std::string why = std::string(id) + ": " +
                                (binary[0] ? std::string(binary) : std::string("the server")) +
                                " not found (tools/bootstrap.sh installs it)";
        if (o.require_all) fail(why);
        std::printf("skipped %s\n", why.c_str());
        return;
      }
      systems.push_back({id, title, library, Transport::tcp, make()});
    };
    int mq_major = 0, mq_minor = 0, mq_rev = 0;
    mosquitto_lib_version(&mq_major, &mq_minor, &mq_rev);
    const std::string hiredis = "hiredis " + std::to_string(HIREDIS_MAJOR) + "." +
                                std::to_string(HIREDIS_MINOR) + "." + std::to_string(HIREDIS_PATCH);
    const std::string libmosquitto = "libmosquitto " + std::to_string(mq_major) + "." +
                                     std::to_string(mq_minor) + "." + std::to_string(mq_rev);
    addServer("redis", "redis",
              (hiredis + ": PUBLISH pipelined, replies read a batch late").c_str(),
              REDIS_SERVER_BIN, [&] { return std::make_unique<RedisServer>(dir.path()); });
    addServer("mosquitto", "mosquitto (QoS 0)",
              (libmosquitto + ": a write per message, a packet per mosquitto_loop_read").c_str(),
              MOSQUITTO_BIN, [&] { return std::make_unique<MosquittoServer>(dir.path()); });
    addServer("nats", "nats",
              (std::string("libnats ") + nats_GetVersion() +
               ": publishes buffered by its flusher (sent at once for round trips), NextMsg")
                  .c_str(),
              NATS_SERVER_BIN, [&] { return std::make_unique<NatsCoreServer>(dir.path()); });
    std::vector<bool> on;
    on.reserve(systems.size());
    for (const auto& s : systems) on.push_back(wantSystem(o, s.id));

    double load[3] = {0, 0, 0};
    if (::getloadavg(load, 3) < 0) load[0] = -1;
    std::printf(
        "peers: every server on 127.0.0.1 (TCP, Nagle off), the hub in-process on its loop "
        "thread; %u cpus, load %.2f\n",
        std::thread::hardware_concurrency(), load[0]);
    for (size_t i = 0; i < systems.size(); ++i) {
      if (on[i]) std::printf("  %-18s %s\n", systems[i].title.c_str(), systems[i].library.c_str());
    }
    std::printf(
        "  publishers at most %zu MB ahead of the slowest subscriber (fan-out: shared), %.2f s per "
        "figure; "
        "MB = 2^20 bytes of payload;\n  ratios are to the hub on TCP; lost = messages a server "
        "dropped (sequence gaps)\n",
        kWindowBytes / kMiB, o.seconds);

    const std::vector<size_t> sizes =
        o.quick ? std::vector<size_t>{16, 64 * kKiB} : std::vector<size_t>{16, kKiB, 64 * kKiB};

    if (wantTest(o, "round-trip")) {
      Table t;
      const int blocks = o.quick ? 2 : 5;
      for (size_t size : sizes) {
        const int rounds = roundsFor(size, o.quick) / blocks;
        const int warmup = std::max(20, rounds / 10);
        std::vector<PingPair> hub_pairs(systems.size());
        std::vector<PeerPingPair> peer_pairs(systems.size());
        std::vector<std::vector<skr::Nanos>> samples(systems.size());
        for (size_t i = 0; i < systems.size(); ++i) {
          if (!on[i]) continue;
          if (systems[i].server) {
            peer_pairs[i] = peerPingPair(*systems[i].server);
          } else {
            hub_pairs[i] = hubPingPair(hub, systems[i].hub_transport);
          }
        }
        // Systems alternate in blocks, so that a change in the machine's load touches all alike.
        for (int b = 0; b < blocks; ++b) {
          for (size_t i = 0; i < systems.size(); ++i) {
            if (!on[i]) continue;
            if (systems[i].server) {
              peerPingPong(peer_pairs[i], size, rounds, warmup, samples[i]);
            } else {
              pingPong(hub_pairs[i], size, rounds, warmup, samples[i]);
            }
          }
        }
        auto& cells = t[size];
        cells.resize(systems.size());
        for (size_t i = 0; i < systems.size(); ++i) {
          if (!on[i]) continue;
          cells[i].measured = true;
          cells[i].rtt = percentiles(samples[i]);
        }
      }
      printTable("round trip", "p50/p99, p50 ratio: above 1 is slower than the hub", t, systems, on,
                 true, false);
    }
    const auto streams = [&](const char* test, const char* title, size_t subscribers, bool mb) {
      if (!wantTest(o, test)) return;
      // The same bytes in flight in all: a fan-out's batch and window are shared among its
      // subscribers (a slow server would otherwise hold a minute of backlog at 16 B).
      const size_t batch = kBatchBytes / subscribers;
      const size_t window = kWindowBytes / subscribers;
      Table t;
      for (size_t size : sizes) {
        auto& cells = t[size];
        cells.resize(systems.size());
        for (size_t i = 0; i < systems.size(); ++i) {
          if (!on[i]) continue;
          cells[i].measured = true;
          cells[i].tp = systems[i].server ? peerStream(*systems[i].server, subscribers, size,
                                                       o.seconds, batch, window)
                                          : hubStream(hub, systems[i].hub_transport, subscribers,
                                                      size, o.seconds, batch, window);
        }
      }
      printTable(title, "delivered messages/s, ratio: below 1 is slower than the hub", t, systems,
                 on, false, mb);
    };
    streams("1:1", "1:1", 1, true);
    streams("fan-out", "fan-out 1:16", kFanOut, false);
    const flow::ServerStats st = hub.stats();
    std::printf("\nhub: %llu data frames out, %llu dropped, %llu protocol errors\n",
                static_cast<unsigned long long>(st.data_frames_out),
                static_cast<unsigned long long>(st.data_frames_dropped),
                static_cast<unsigned long long>(st.protocol_errors));
    if (st.protocol_errors != 0) fail("the hub saw protocol errors");
  } catch (const std::exception& e) {
    std::fflush(stdout);
    std::fprintf(stderr, "peers: error: %s\n", e.what());
    status = 1;
  }
  mosquitto_lib_cleanup();
  return status;
}
