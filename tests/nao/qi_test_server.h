// A qi endpoint for tests, written from the same protocol description as the client: it answers
// authenticate, ServiceDirectory.service and metaObject, and fakes ALTextToSpeech, ALMotion,
// ALRobotPosture, ALMemory and ALLeds. It records every call (service, method, arguments) so
// tests can assert on them. One thread, one client at a time, 127.0.0.1 on a free port.
#pragma once

#include "qi_message.h"
#include "qi_meta.h"

#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace nao::test {

struct RecordedCall {
  std::string service;
  std::string method;
  qi::Value args;  // the decoded argument tuple
};

class QiTestServer {
 public:
  QiTestServer() {
    listen_fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    const int one = 1;
    ::setsockopt(listen_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ::bind(listen_fd_, reinterpret_cast<sockaddr*>(&a), sizeof(a));
    ::listen(listen_fd_, 4);
    socklen_t len = sizeof(a);
    ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&a), &len);
    port_ = ntohs(a.sin_port);
    defineServices();
    thread_ = std::thread([this] { run(); });
  }
  ~QiTestServer() {
    stop_ = true;
    thread_.join();
    if (client_fd_ >= 0) ::close(client_fd_);
    ::close(listen_fd_);
  }
  QiTestServer(const QiTestServer&) = delete;
  QiTestServer& operator=(const QiTestServer&) = delete;

  [[nodiscard]] std::uint16_t port() const { return port_; }
  [[nodiscard]] std::vector<RecordedCall> calls() {
    std::lock_guard<std::mutex> l(mu_);
    return calls_;
  }
  [[nodiscard]] int authentications() const { return auths_; }
  // TCP connections accepted, including those closed at once while not accepting.
  [[nodiscard]] int connections() const { return connections_; }
  // Closes the current connection (the robot "goes away") and returns once it is closed.
  void dropConnection() {
    drop_ = true;
    while (drop_) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  // While off, new connections are accepted and closed at once.
  void setAccepting(bool on) { accepting_ = on; }
  // Replies carry the dynamic-payload flag and an 'm' payload (MessageFlags capability).
  void setDynamicReplies(bool on) { dynamic_ = on; }
  // The next message sent is this raw byte string instead of a reply.
  void sendRawNext(std::string bytes) {
    std::lock_guard<std::mutex> l(mu_);
    raw_next_ = std::move(bytes);
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

 private:
  struct Service {
    std::uint32_t id;
    qi::MetaObject meta;
  };

  void defineServices() {
    auto svc = [&](const char* name, std::uint32_t id, std::vector<qi::MetaMethod> methods) {
      qi::MetaObject m;
      // Every object has metaObject as action 2; methods of the service start at 100.
      m.methods.push_back({2, qi::kMetaObjectSignature, "metaObject", "(I)"});
      for (auto& x : methods) m.methods.push_back(x);
      m.description = name;
      services_[name] = Service{id, m};
    };
    svc("ALTextToSpeech", 10, {{100, "v", "say", "(s)"}, {101, "v", "say", "(ss)"}});
    svc("ALMotion", 11,
        {{100, "v", "setAngles", "(mmf)"},
         {101, "v", "moveToward", "(fff)"},
         {102, "v", "moveToward", "(fffm)"},
         {103, "v", "stopMove", "()"},
         {104, "v", "rest", "()"},
         {105, "v", "wakeUp", "()"},
         {106, "[f]", "getAngles", "(mb)"}});
    svc("ALRobotPosture", 12, {{100, "b", "goToPosture", "(sf)"}, {101, "s", "getPosture", "()"}});
    svc("ALMemory", 13, {{100, "m", "getData", "(s)"}, {101, "m", "getListData", "(m)"}});
    svc("ALLeds", 14, {{100, "v", "fadeRGB", "(sif)"}, {101, "v", "fadeRGB", "(sfff)"}});
  }

  void run() {
    while (!stop_) {
      if (client_fd_ < 0) {
        pollfd p{listen_fd_, POLLIN, 0};
        if (::poll(&p, 1, 20) > 0) {
          const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
          if (fd >= 0) ++connections_;
          if (fd >= 0 && !accepting_) {
            ::close(fd);
          } else if (fd >= 0) {
            client_fd_ = fd;
            framer_ = qi::MessageFramer();
          }
        }
        drop_ = false;
        continue;
      }
      if (drop_) {
        closeClient();
        drop_ = false;
        continue;
      }
      pollfd p{client_fd_, POLLIN, 0};
      if (::poll(&p, 1, 20) <= 0) continue;
      char buf[8192];
      const ssize_t n = ::recv(client_fd_, buf, sizeof(buf), 0);
      if (n <= 0) {
        closeClient();
        continue;
      }
      framer_.append(std::string_view(buf, static_cast<std::size_t>(n)));
      for (;;) {
        auto m = framer_.next();
        if (!m || !m.value()) break;
        handle(*m.value());
      }
    }
  }

  void closeClient() {
    ::close(client_fd_);
    client_fd_ = -1;
  }

  void send(const qi::Message& to, qi::MsgType type, const std::string& payload,
            std::uint8_t flags = 0) {
    std::string raw;
    {
      std::lock_guard<std::mutex> l(mu_);
      raw.swap(raw_next_);
    }
    qi::Header h = to.header;
    h.type = type;
    h.flags = flags;
    const std::string body = corrupt_.exchange(false) ? std::string("\xff\xff\xff\xff") : payload;
    const std::string bytes = raw.empty() ? qi::encodeMessage(h, body) : raw;
    (void)!::send(client_fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL);
  }
  void reply(const qi::Message& to, const std::string& sig, const qi::Value& v) {
    if (dynamic_) {
      send(to, qi::MsgType::reply, qi::encode("m", v).value(), qi::kFlagDynamicPayload);
    } else {
      send(to, qi::MsgType::reply, qi::encode(sig, v).value());
    }
  }
  void error(const qi::Message& to, const std::string& text) {
    send(to, qi::MsgType::error, qi::encode("m", qi::Value::string(text)).value());
  }

  void handle(const qi::Message& m) {
    const qi::Header& h = m.header;
    if (h.type != qi::MsgType::call) return;
    if (h.service == qi::kServiceServer && h.action == qi::kActionAuthenticate) {
      auto caps = qi::decode("{sm}", m.payload);
      if (!caps || caps->find("ClientServerSocket") == nullptr) {
        return error(m, "authenticate: no capability map");
      }
      ++auths_;
      return reply(m, "{sm}",
                   qi::Value::map({{qi::Value::string("__qi_auth_state"), qi::Value::integer(3)}}));
    }
    if (h.service == qi::kServiceDirectory && h.action == qi::kActionService) {
      auto name = qi::decode("s", m.payload);
      if (!name) return error(m, "service: bad argument");
      auto it = services_.find(name->asString());
      if (it == services_.end()) return error(m, "Cannot find service '" + name->asString() + "'");
      qi::ServiceInfo info{it->first,
                           it->second.id,
                           "test-machine",
                           42,
                           {"tcp://127.0.0.1:" + std::to_string(port_)},
                           "session"};
      return reply(m, qi::kServiceInfoSignature, qi::fromServiceInfo(info));
    }
    for (const auto& [name, svc] : services_) {
      if (svc.id != h.service) continue;
      for (const qi::MetaMethod& mm : svc.meta.methods) {
        if (mm.uid != h.action) continue;
        auto args = qi::decode(mm.parameters_signature, m.payload);
        if (!args) return error(m, "bad arguments: " + args.error().message);
        if (mm.name == "metaObject") {
          return reply(m, qi::kMetaObjectSignature, qi::fromMetaObject(svc.meta));
        }
        {
          std::lock_guard<std::mutex> l(mu_);
          calls_.push_back({name, mm.name, args.value()});
        }
        return answer(m, name, mm, args.value());
      }
      return error(m, "no action " + std::to_string(h.action));
    }
    error(m, "no service " + std::to_string(h.service));
  }

  void answer(const qi::Message& m, const std::string& service, const qi::MetaMethod& mm,
              const qi::Value& args) {
    const auto& a = args.items();
    if (mm.name == "say" && a[0].asString() == "fail") {
      return error(m, "ALTextToSpeech::say: speech engine failure");
    }
    if (mm.name == "goToPosture") {
      posture_ = a[0].asString();
      return reply(m, "b", qi::Value::boolean(posture_ != "Unreachable"));
    }
    if (mm.name == "getPosture") return reply(m, "s", qi::Value::string(posture_));
    if (mm.name == "getAngles") {
      std::vector<double> angles(a[0].items().size(), 0.25);
      return reply(m, "[f]", qi::Value::reals(angles));
    }
    if (mm.name == "getData") return reply(m, "m", qi::Value::real(0.5));
    if (mm.name == "getListData") {
      std::vector<qi::Value> v;
      for (std::size_t i = 0; i < a[0].items().size(); ++i) v.push_back(qi::Value::real(0.75));
      return reply(m, "m", qi::Value::list(std::move(v)));
    }
    (void)service;
    reply(m, mm.return_signature, qi::Value());
  }

  int listen_fd_ = -1;
  int client_fd_ = -1;
  std::uint16_t port_ = 0;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> drop_{false};
  std::atomic<bool> accepting_{true};
  std::atomic<bool> dynamic_{false};
  std::atomic<bool> corrupt_{false};
  std::atomic<int> auths_{0};
  std::atomic<int> connections_{0};
  qi::MessageFramer framer_;
  std::map<std::string, Service> services_;
  std::mutex mu_;
  std::vector<RecordedCall> calls_;
  std::string raw_next_;
  std::string posture_ = "Crouch";
};

}  // namespace nao::test
