// A client of a qi (NAOqi 2.x) endpoint over TCP: authenticate, find services through the
// ServiceDirectory, learn their methods from metaObject, call them and read the replies.
//
// Not thread-safe: one thread (the bridge's robot worker) owns a QiClient and calls everything,
// including pump(). Calls are asynchronous (replies are matched by message id when pump() reads
// them) except the look-ups, which wait for their answer with a deadline. Nothing blocks without
// a deadline.
#pragma once

#include "qi_message.h"
#include "qi_meta.h"

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

namespace nao::qi {

struct ClientOptions {
  std::string host = "127.0.0.1";
  std::uint16_t port = 9559;
  int connect_timeout_ms = 2000;
  int lookup_timeout_ms = 3000;  // authenticate, service, metaObject
  std::uint32_t max_payload = kDefaultMaxPayload;
  bool authenticate = true;
  std::string user;  // only sent when not empty (NAOqi 2.9 robots with a password)
  std::string token;
};

class QiClient {
 public:
  using ReplyFn = std::function<void(Result<Value>)>;

  QiClient() = default;
  ~QiClient();
  QiClient(const QiClient&) = delete;
  QiClient& operator=(const QiClient&) = delete;

  // TCP connect, then the capability/authentication exchange. Blocks up to the timeouts.
  [[nodiscard]] Result<void> connect(const ClientOptions& options);
  [[nodiscard]] bool connected() const noexcept { return fd_ >= 0; }
  // Closes the socket; every pending call gets Errc::closed with `why`.
  void close(const std::string& why);

  // Sends a call of `service`.`method` (the main object); `fn` runs from a later pump() with the
  // reply decoded by the method's return signature, the robot's error text, a timeout or the
  // close. Looks the service and its metaObject up first if it is not cached (blocking).
  [[nodiscard]] Result<void> call(const std::string& service, const std::string& method,
                                  std::vector<Value> args, int timeout_ms, ReplyFn fn);
  // call() and wait for its answer.
  [[nodiscard]] Result<Value> callSync(const std::string& service, const std::string& method,
                                       std::vector<Value> args, int timeout_ms);

  // Waits up to timeout_ms for bytes (or for `wake_fd` to become readable, when >= 0), reads
  // them, dispatches replies and expires late calls. An error means the connection is gone
  // (oversized or malformed message, EOF, socket error): it is closed already.
  [[nodiscard]] Result<void> pump(int timeout_ms, int wake_fd = -1);

  // Looks `service` up (ServiceDirectory, then its metaObject) unless it is cached. Blocking.
  [[nodiscard]] Result<void> resolve(const std::string& service);
  [[nodiscard]] Result<ServiceInfo> serviceInfo(const std::string& name);
  [[nodiscard]] Result<MetaObject> metaObject(std::uint32_t service, std::uint32_t object);
  [[nodiscard]] std::size_t pending() const noexcept { return pending_.size(); }

  // Low level: one call message with an encoded payload; the reply is decoded as `return_sig`.
  [[nodiscard]] Result<void> send(std::uint32_t service, std::uint32_t object, std::uint32_t action,
                                  const std::string& payload, std::string return_sig,
                                  int timeout_ms, ReplyFn fn);

 private:
  struct Pending {
    std::string return_sig;
    std::int64_t deadline_ns;
    ReplyFn fn;
  };
  struct Service {
    ServiceInfo info;
    MetaObject meta;
  };
  Result<Value> wait(std::uint32_t service, std::uint32_t object, std::uint32_t action,
                     const std::string& payload, const std::string& return_sig, int timeout_ms);
  Result<void> authenticate();
  Result<const Service*> lookup(const std::string& name);
  Result<void> writeAll(const std::string& bytes);
  void dispatch(Message&& m);
  void expire();

  ClientOptions options_;
  int fd_ = -1;
  std::uint32_t next_id_ = 1;
  MessageFramer framer_;
  std::map<std::uint32_t, Pending> pending_;
  std::map<std::string, Service> services_;
};

[[nodiscard]] std::int64_t monotonicNs();

}  // namespace nao::qi
