// SPDX-License-Identifier: Apache-2.0
// A qi endpoint for tests, written from the same protocol description as the client and from
// what a server built on libqi 4.0.5 did (NAOqi 2.5 and later; libqi's src/messaging/server.cpp
// and tcpmessagesocket.hpp at that release):
// - on every connection of every endpoint, each call before the capability/authenticate
//   exchange is refused with "The call request could not be handled." (libqi binds a socket to
//   its server's objects only once it is authenticated);
// - ServiceDirectory.service answers with seven fields (libqi 4 adds the object uid), or six
//   (setSixFieldLookups, as older NAOqi);
// - ALTextToSpeech and ALLeds live in a second session: on a second listening socket, which
//   their look-up names as their only endpoint, and which alone answers their calls (a call to
//   a service that a socket's server does not host gets the same refusal). That session is
//   another process by default, or a second session of the directory's own process
//   (setSideProcessId(kDirectoryProcess)): then the look-ups name the same process for all
//   services, only the endpoints tell them apart.
// It fakes ALTextToSpeech, ALMotion, ALRobotPosture, ALMemory and ALLeds and records every call
// (service, method, arguments, endpoint) so tests can assert on them. One thread, any number of
// clients, 127.0.0.1 on free ports.
#pragma once

#include "qi_message.h"
#include "qi_meta.h"

#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <chrono>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

namespace skr::nao::test {

struct RecordedCall {
  std::string service;
  std::string method;
  qi::Value args;    // the decoded argument tuple
  int endpoint = 0;  // 0: the main endpoint (port()), 1: the other one (sidePort())
};

constexpr int kAllEndpoints = -1;
constexpr std::uint32_t kDirectoryProcess = 42;  // the process id of the directory's session

class QiTestServer {
 public:
  QiTestServer() {
    for (auto& l : listeners_) l = listenLoopback();
    defineServices();
    thread_ = std::thread([this] { run(); });
  }
  ~QiTestServer() {
    stop_ = true;
    thread_.join();
    for (auto& c : clients_) ::close(c.fd);
    for (auto& l : listeners_) ::close(l.fd);
  }
  QiTestServer(const QiTestServer&) = delete;
  QiTestServer& operator=(const QiTestServer&) = delete;

  // The endpoint of the ServiceDirectory and of ALMotion, ALRobotPosture, ALMemory.
  [[nodiscard]] std::uint16_t port() const { return listeners_[0].port; }
  // The endpoint of ALTextToSpeech and ALLeds ("another process").
  [[nodiscard]] std::uint16_t sidePort() const { return listeners_[1].port; }
  [[nodiscard]] std::vector<RecordedCall> calls() {
    std::lock_guard<std::mutex> l(mu_);
    return calls_;
  }
  // Successful capability exchanges, on either endpoint.
  [[nodiscard]] int authentications() const { return auths_; }
  // Calls refused because they came before the capability exchange.
  [[nodiscard]] int refusedUnauthenticated() const { return refused_; }
  // TCP connections accepted on the main endpoint, including those closed at once while not
  // accepting.
  [[nodiscard]] int connections() const { return connections_; }
  // Connections accepted on the side endpoint.
  [[nodiscard]] int sideConnections() const { return side_connections_; }
  // Closes every connection (the robot "goes away"), or those of one endpoint (0 or 1), and
  // returns once they are closed.
  void dropConnection(int endpoint = kAllEndpoints) {
    drop_ = endpoint;
    while (drop_ != kNoDrop) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  // While off, new connections (to every endpoint, or to one) are accepted and closed at once.
  void setAccepting(bool on, int endpoint = kAllEndpoints) {
    for (std::size_t i = 0; i < accepting_.size(); ++i) {
      if (endpoint == kAllEndpoints || endpoint == static_cast<int>(i)) accepting_[i] = on;
    }
  }
  // The process id that look-ups give the second session's services (43 unless set).
  void setSideProcessId(std::uint32_t pid) { side_pid_ = pid; }
  // Replies carry the dynamic-payload flag and an 'm' payload (MessageFlags capability).
  void setDynamicReplies(bool on) { dynamic_ = on; }
  // Look-ups answer with the six fields of libqi before the object uid.
  void setSixFieldLookups(bool on) { six_fields_ = on; }
  // The directory no longer knows `name` (its process went away), or knows it again. Calls
  // over connections already open still reach it.
  void removeService(const std::string& name) {
    std::lock_guard<std::mutex> l(mu_);
    removed_.insert(name);
  }
  void restoreService(const std::string& name) {
    std::lock_guard<std::mutex> l(mu_);
    removed_.erase(name);
  }
  // The next message sent is this raw byte string instead of a reply.
  void sendRawNext(std::string bytes) {
    std::lock_guard<std::mutex> l(mu_);
    raw_next_ = std::move(bytes);
  }
  // The next reply carries these bytes after its value (a reply not read to its end).
  void appendToNextReply(std::string bytes) {
    std::lock_guard<std::mutex> l(mu_);
    trailing_next_ = std::move(bytes);
  }
  // The next reply keeps its header but carries a payload that cannot be a string.
  void corruptNextReply() { corrupt_ = true; }
  // Waits until `n` calls were recorded.
  bool waitCalls(std::size_t n, int timeout_ms = 3000) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
    while (std::chrono::steady_clock::now() < end) {
      if (calls().size() >= n) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return false;
  }

  static constexpr char kObjectUid[] = "0123456789abcdefghij";  // 20 bytes, as libqi's PtrUid
  static constexpr char kUnhandled[] = "The call request could not be handled.";

 private:
  struct Listener {
    int fd = -1;
    std::uint16_t port = 0;
  };
  struct Client {
    int fd;
    int endpoint;
    bool authenticated = false;
    qi::MessageFramer framer;
  };
  struct Service {
    std::uint32_t id;
    int endpoint;
    qi::MetaObject meta;
  };

  static Listener listenLoopback() {
    Listener l;
    l.fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    const int one = 1;
    ::setsockopt(l.fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ::bind(l.fd, reinterpret_cast<sockaddr*>(&a), sizeof(a));
    ::listen(l.fd, 8);
    socklen_t len = sizeof(a);
    ::getsockname(l.fd, reinterpret_cast<sockaddr*>(&a), &len);
    l.port = ntohs(a.sin_port);
    return l;
  }

  void defineServices() {
    auto svc = [&](const char* name, std::uint32_t id, int endpoint,
                   std::vector<qi::MetaMethod> methods) {
      qi::MetaObject m;
      // Every object has metaObject as action 2; methods of the service start at 100.
      m.methods.push_back({2, qi::kMetaObjectSignature, "metaObject", "(I)"});
      for (auto& x : methods) m.methods.push_back(x);
      m.description = name;
      services_[name] = Service{id, endpoint, m};
    };
    svc("ALTextToSpeech", 10, 1, {{100, "v", "say", "(s)"}, {101, "v", "say", "(ss)"}});
    svc("ALMotion", 11, 0,
        {{100, "v", "setAngles", "(mmf)"},
         {101, "v", "moveToward", "(fff)"},
         {102, "v", "moveToward", "(fffm)"},
         {103, "v", "stopMove", "()"},
         {104, "v", "rest", "()"},
         {105, "v", "wakeUp", "()"},
         {106, "[f]", "getAngles", "(mb)"}});
    svc("ALRobotPosture", 12, 0,
        {{100, "b", "goToPosture", "(sf)"}, {101, "s", "getPosture", "()"}});
    svc("ALMemory", 13, 0, {{100, "m", "getData", "(s)"}, {101, "m", "getListData", "(m)"}});
    svc("ALLeds", 14, 1, {{100, "v", "fadeRGB", "(sif)"}, {101, "v", "fadeRGB", "(sfff)"}});
  }

  void run() {
    while (!stop_) {
      if (const int drop = drop_; drop != kNoDrop) {
        for (auto& c : clients_) {
          if (drop == kAllEndpoints || c.endpoint == drop) ::close(c.fd);
        }
        std::erase_if(clients_, [drop](const Client& c) {
          return drop == kAllEndpoints || c.endpoint == drop;
        });
        drop_ = kNoDrop;
      }
      std::vector<pollfd> p;
      for (const auto& l : listeners_) p.push_back({l.fd, POLLIN, 0});
      for (const auto& c : clients_) p.push_back({c.fd, POLLIN, 0});
      if (::poll(p.data(), p.size(), 20) <= 0) continue;
      for (std::size_t i = 0; i < listeners_.size(); ++i) {
        if ((p[i].revents & POLLIN) != 0) accept(static_cast<int>(i));
      }
      // Clients accepted above are polled next time; those polled now keep their index.
      std::vector<int> gone;
      for (std::size_t i = listeners_.size(); i < p.size(); ++i) {
        if (p[i].revents == 0) continue;
        Client& c = clients_[i - listeners_.size()];
        char buf[8192];
        const ssize_t n = ::recv(c.fd, buf, sizeof(buf), 0);
        if (n <= 0) {
          gone.push_back(c.fd);
          continue;
        }
        c.framer.append(std::string_view(buf, static_cast<std::size_t>(n)));
        for (;;) {
          auto m = c.framer.next();
          if (!m || !m.value()) break;
          handle(c, *m.value());
        }
      }
      for (int fd : gone) {
        ::close(fd);
        std::erase_if(clients_, [fd](const Client& c) { return c.fd == fd; });
      }
    }
  }

  void accept(int endpoint) {
    const int fd = ::accept4(listeners_[endpoint].fd, nullptr, nullptr, SOCK_CLOEXEC);
    if (fd < 0) return;
    ++(endpoint == 0 ? connections_ : side_connections_);
    if (!accepting_[static_cast<std::size_t>(endpoint)]) {
      ::close(fd);
      return;
    }
    clients_.push_back(Client{fd, endpoint, false, qi::MessageFramer()});
  }

  void send(const Client& c, const qi::Message& to, qi::MsgType type, const std::string& payload,
            std::uint8_t flags = 0) {
    std::string raw;
    std::string trailing;
    {
      std::lock_guard<std::mutex> l(mu_);
      raw.swap(raw_next_);
      if (type == qi::MsgType::reply) trailing.swap(trailing_next_);
    }
    qi::Header h = to.header;
    h.type = type;
    h.flags = flags;
    const std::string body =
        corrupt_.exchange(false) ? std::string("\xff\xff\xff\xff") : payload + trailing;
    const std::string bytes = raw.empty() ? qi::encodeMessage(h, body) : raw;
    (void)!::send(c.fd, bytes.data(), bytes.size(), MSG_NOSIGNAL);
  }
  void reply(const Client& c, const qi::Message& to, const std::string& sig, const qi::Value& v) {
    if (dynamic_) {
      send(c, to, qi::MsgType::reply, qi::encode("m", v).value(), qi::kFlagDynamicPayload);
    } else {
      send(c, to, qi::MsgType::reply, qi::encode(sig, v).value());
    }
  }
  void error(const Client& c, const qi::Message& to, const std::string& text) {
    send(c, to, qi::MsgType::error, qi::encode("m", qi::Value::string(text)).value());
  }

  void handle(Client& c, const qi::Message& m) {
    const qi::Header& h = m.header;
    if (h.type != qi::MsgType::call) return;
    if (h.service == qi::kServiceServer && h.action == qi::kActionAuthenticate) {
      auto caps = qi::decode("{sm}", m.payload);
      if (!caps || caps->find("ClientServerSocket") == nullptr) {
        return error(c, m, "authenticate: no capability map");
      }
      ++auths_;
      c.authenticated = true;
      return reply(c, m, "{sm}",
                   qi::Value::map({{qi::Value::string("__qi_auth_state"), qi::Value::integer(3)}}));
    }
    if (!c.authenticated) {  // libqi >= 2.5, even without a password
      ++refused_;
      return error(c, m, kUnhandled);
    }
    if (h.service == qi::kServiceDirectory && h.action == qi::kActionService && c.endpoint == 0) {
      return lookup(c, m);
    }
    for (const auto& [name, svc] : services_) {
      if (svc.id != h.service || svc.endpoint != c.endpoint) continue;
      for (const qi::MetaMethod& mm : svc.meta.methods) {
        if (mm.uid != h.action) continue;
        auto args = qi::decode(mm.parameters_signature, m.payload);
        if (!args) return error(c, m, "bad arguments: " + args.error().message);
        if (mm.name == "metaObject") {
          return reply(c, m, qi::kMetaObjectSignature, qi::fromMetaObject(svc.meta));
        }
        {
          std::lock_guard<std::mutex> l(mu_);
          calls_.push_back({name, mm.name, args.value(), c.endpoint});
        }
        return answer(c, m, mm, args.value());
      }
      return error(c, m, "no action " + std::to_string(h.action));
    }
    // What libqi 4's socket answers for a call that no object bound to it handles.
    error(c, m, kUnhandled);
  }

  void lookup(const Client& c, const qi::Message& m) {
    auto name = qi::decode("s", m.payload);
    if (!name) return error(c, m, "service: bad argument");
    qi::ServiceInfo info;
    info.name = name->asString();
    info.machine_id = "test-machine";
    info.session_id = "session";
    info.object_uid = six_fields_ ? "" : kObjectUid;
    std::uint16_t port = listeners_[0].port;
    if (info.name == "ServiceDirectory") {
      info.service_id = qi::kServiceDirectory;
      info.process_id = kDirectoryProcess;
    } else {
      auto it = services_.find(info.name);
      bool removed = false;
      {
        std::lock_guard<std::mutex> l(mu_);
        removed = removed_.count(info.name) != 0;
      }
      if (it == services_.end() || removed) {
        return error(c, m, "Cannot find service '" + info.name + "'");
      }
      info.service_id = it->second.id;
      info.process_id = it->second.endpoint == 0 ? kDirectoryProcess : side_pid_.load();
      port = listeners_[it->second.endpoint].port;
    }
    info.endpoints = {"tcp://127.0.0.1:" + std::to_string(port)};
    if (six_fields_) {
      return reply(c, m, qi::kServiceInfoSignature6, qi::fromServiceInfo(info, false));
    }
    reply(c, m, qi::kServiceInfoSignature, qi::fromServiceInfo(info, true));
  }

  void answer(const Client& c, const qi::Message& m, const qi::MetaMethod& mm,
              const qi::Value& args) {
    const auto& a = args.items();
    if (mm.name == "say" && a[0].asString() == "fail") {
      return error(c, m, "ALTextToSpeech::say: speech engine failure");
    }
    if (mm.name == "goToPosture") {
      posture_ = a[0].asString();
      return reply(c, m, "b", qi::Value::boolean(posture_ != "Unreachable"));
    }
    if (mm.name == "getPosture") return reply(c, m, "s", qi::Value::string(posture_));
    if (mm.name == "getAngles") {
      std::vector<double> angles(a[0].items().size(), 0.25);
      return reply(c, m, "[f]", qi::Value::reals(angles));
    }
    if (mm.name == "getData") return reply(c, m, "m", qi::Value::real(0.5));
    if (mm.name == "getListData") {
      std::vector<qi::Value> v;
      for (std::size_t i = 0; i < a[0].items().size(); ++i) v.push_back(qi::Value::real(0.75));
      return reply(c, m, "m", qi::Value::list(std::move(v)));
    }
    reply(c, m, mm.return_signature, qi::Value());
  }

  std::array<Listener, 2> listeners_;
  std::vector<Client> clients_;  // the server thread's own
  std::thread thread_;
  std::atomic<bool> stop_{false};
  static constexpr int kNoDrop = -2;
  std::atomic<int> drop_{kNoDrop};
  std::array<std::atomic<bool>, 2> accepting_{true, true};
  std::atomic<std::uint32_t> side_pid_{43};
  std::atomic<bool> dynamic_{false};
  std::atomic<bool> six_fields_{false};
  std::atomic<bool> corrupt_{false};
  std::atomic<int> auths_{0};
  std::atomic<int> refused_{0};
  std::atomic<int> connections_{0};
  std::atomic<int> side_connections_{0};
  std::map<std::string, Service> services_;
  std::mutex mu_;
  std::vector<RecordedCall> calls_;
  std::set<std::string> removed_;
  std::string raw_next_;
  std::string trailing_next_;
  std::string posture_ = "Crouch";
};

}  // namespace skr::nao::test
