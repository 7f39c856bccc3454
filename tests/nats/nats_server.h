// SPDX-License-Identifier: Apache-2.0
// Real nats-server processes on loopback for the bridge's tests and benchmark, and a small raw
// NATS client (Debian's libnats) to look at what the bridge sends from the NATS side.
#pragma once

#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <nats/nats.h>

#include "hub_process.h"

#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

namespace skr::sat::test {

// A TCP port nobody listens on now, for a nats-server to take: picked at random below the
// kernel's ephemeral range (32768 and up), where the loopback connections of the tests running
// beside this one take their source ports, and checked by binding it (released at once). The
// kernel's own pick, from that range, was taken by such a connection before nats-server bound it
// (seen once in the release tests: "bind: address already in use").
inline int freePort() {
  static std::mt19937 pick(std::random_device{}());
  for (int attempt = 0; attempt < 200; ++attempt) {
    const int port = std::uniform_int_distribution<int>(20000, 32000)(pick);
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons(static_cast<uint16_t>(port));
    const bool free = ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
    ::close(fd);
    if (free) return port;
  }
  return 0;  // nats-server then fails to start, and the test says so
}

// One nats-server on 127.0.0.1, JetStream on (its store in `dir`), optionally one node of a
// cluster whose route ports are `routes`.
class NatsServer {
 public:
  NatsServer(fs::path dir, std::string name, bool jetstream = true)
      : dir_(std::move(dir)), name_(std::move(name)), port_(freePort()), jetstream_(jetstream) {}
  void cluster(int cluster_port, std::vector<int> routes) {
    cluster_port_ = cluster_port;
    routes_ = std::move(routes);
  }
  bool start() {
    std::vector<std::string> argv{NATS_SERVER_BIN,       "-a", "127.0.0.1", "-p",
                                  std::to_string(port_), "-n", name_};
    if (jetstream_) argv.insert(argv.end(), {"-js", "-sd", (dir_ / ("js-" + name_)).string()});
    if (cluster_port_ != 0) {
      std::string routes;
      for (int r : routes_) {
        routes +=
            (routes.empty() ? "" : ",") + std::string("nats://127.0.0.1:") + std::to_string(r);
      }
      argv.insert(argv.end(),
                  {"--cluster_name", "skr", "--cluster",
                   "nats://127.0.0.1:" + std::to_string(cluster_port_), "--routes", routes});
    }
    ++starts_;
    child_ = std::make_unique<Child>(argv, std::vector<std::string>{},
                                     dir_ / (name_ + "-" + std::to_string(starts_) + ".log"));
    return child_->waitOutput("Server is ready", 10000);
  }
  void kill() { child_.reset(); }  // SIGKILL
  [[nodiscard]] std::string url() const { return "nats://127.0.0.1:" + std::to_string(port_); }
  [[nodiscard]] int port() const noexcept { return port_; }
  [[nodiscard]] std::string log() const { return child_ ? child_->output() : std::string(); }

 private:
  fs::path dir_;
  std::string name_;
  int port_;
  bool jetstream_;
  int cluster_port_ = 0;
  std::vector<int> routes_;
  int starts_ = 0;
  std::unique_ptr<Child> child_;
};

// A plain NATS client, synchronous: what any program of a fleet would do.
class RawNats {
 public:
  explicit RawNats(const std::string& url) {
    natsOptions* o = nullptr;
    natsOptions_Create(&o);
    natsOptions_SetURL(o, url.c_str());
    natsOptions_SetMaxReconnect(o, -1);
    natsOptions_SetReconnectWait(o, 50);
    ok_ = natsConnection_Connect(&nc_, o) == NATS_OK;
    natsOptions_Destroy(o);
  }
  ~RawNats() {
    for (auto* s : subs_) natsSubscription_Destroy(s);
    if (kv_ != nullptr) kvStore_Destroy(kv_);
    if (js_ != nullptr) jsCtx_Destroy(js_);
    if (nc_ != nullptr) natsConnection_Destroy(nc_);
  }
  RawNats(const RawNats&) = delete;
  RawNats& operator=(const RawNats&) = delete;
  [[nodiscard]] bool ok() const noexcept { return ok_; }
  natsConnection* nc() { return nc_; }

  // A synchronous subscription; next() reads it.
  natsSubscription* subscribe(const std::string& subject) {
    natsSubscription* s = nullptr;
    if (natsConnection_SubscribeSync(&s, nc_, subject.c_str()) != NATS_OK) return nullptr;
    natsConnection_Flush(nc_);
    subs_.push_back(s);
    return s;
  }
  static std::optional<std::string> next(natsSubscription* s, int timeout_ms = 5000) {
    natsMsg* m = nullptr;
    if (natsSubscription_NextMsg(&m, s, timeout_ms) != NATS_OK) return std::nullopt;
    std::string data(natsMsg_GetData(m), static_cast<size_t>(natsMsg_GetDataLength(m)));
    natsMsg_Destroy(m);
    return data;
  }
  bool publish(const std::string& subject, const std::string& data) {
    return natsConnection_Publish(nc_, subject.c_str(), data.data(),
                                  static_cast<int>(data.size())) == NATS_OK &&
           natsConnection_Flush(nc_) == NATS_OK;
  }
  struct Reply {
    std::string data;
    std::string error;  // the Skr-Error header
    bool no_responders = false;
  };
  // A request with an optional Skr-Command header.
  std::optional<Reply> request(const std::string& subject, const std::string& data,
                               const std::string& command = {}, int timeout_ms = 5000) {
    natsMsg* req = nullptr;
    natsMsg_Create(&req, subject.c_str(), nullptr, data.data(), static_cast<int>(data.size()));
    if (!command.empty()) natsMsgHeader_Set(req, "Skr-Command", command.c_str());
    natsMsg* rep = nullptr;
    const natsStatus st = natsConnection_RequestMsg(&rep, nc_, req, timeout_ms);
    natsMsg_Destroy(req);
    if (st == NATS_NO_RESPONDERS) return Reply{{}, {}, true};
    if (st != NATS_OK) return std::nullopt;
    Reply r;
    r.data.assign(natsMsg_GetData(rep), static_cast<size_t>(natsMsg_GetDataLength(rep)));
    const char* e = nullptr;
    if (natsMsgHeader_Get(rep, "Skr-Error", &e) == NATS_OK && e != nullptr) r.error = e;
    natsMsg_Destroy(rep);
    return r;
  }
  // Serves `subject`: each request is answered by `answer(data, command)`.
  bool serve(const std::string& subject, std::function<std::string(const std::string&)> answer) {
    answer_ = std::move(answer);
    natsSubscription* s = nullptr;
    const natsStatus st = natsConnection_Subscribe(
        &s, nc_, subject.c_str(),
        [](natsConnection* nc, natsSubscription*, natsMsg* m, void* self) {
          auto* raw = static_cast<RawNats*>(self);
          const std::string in(natsMsg_GetData(m), static_cast<size_t>(natsMsg_GetDataLength(m)));
          const std::string out = raw->answer_(in);
          if (natsMsg_GetReply(m) != nullptr) {
            natsConnection_Publish(nc, natsMsg_GetReply(m), out.data(),
                                   static_cast<int>(out.size()));
          }
          natsMsg_Destroy(m);
        },
        this);
    if (st != NATS_OK) return false;
    subs_.push_back(s);
    return natsConnection_Flush(nc_) == NATS_OK;
  }
  // The key-value bucket (created if missing).
  kvStore* kv(const std::string& bucket) {
    if (kv_ != nullptr) return kv_;
    natsConnection_JetStream(&js_, nc_, nullptr);
    if (js_KeyValue(&kv_, js_, bucket.c_str()) != NATS_OK) {
      kvConfig c;
      kvConfig_Init(&c);
      c.Bucket = bucket.c_str();
      js_CreateKeyValue(&kv_, js_, &c);
    }
    return kv_;
  }
  std::optional<std::string> kvGet(const std::string& bucket, const std::string& key) {
    kvEntry* e = nullptr;
    if (kvStore_Get(&e, kv(bucket), key.c_str()) != NATS_OK) return std::nullopt;
    std::string v(static_cast<const char*>(kvEntry_Value(e)),
                  static_cast<size_t>(kvEntry_ValueLen(e)));
    kvEntry_Destroy(e);
    return v;
  }

 private:
  natsConnection* nc_ = nullptr;
  bool ok_ = false;
  std::vector<natsSubscription*> subs_;
  std::function<std::string(const std::string&)> answer_;
  jsCtx* js_ = nullptr;
  kvStore* kv_ = nullptr;
};

}  // namespace skr::sat::test
