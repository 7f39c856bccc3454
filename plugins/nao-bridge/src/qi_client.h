// SPDX-License-Identifier: Apache-2.0
// A client of a qi (NAOqi 2.x) endpoint over TCP: authenticate, find services through the
// ServiceDirectory, learn their methods from metaObject, call them and read the replies.
//
// A service is called, as libqi does, over a connection to an endpoint that its look-up lists:
// the ServiceDirectory's own connection when it lists the endpoint that connection reached (or
// one the directory's look-up lists), else a connection of its own, shared by every service at
// that endpoint. Which process a service is in does not matter: one process may run several
// sessions, each with its own endpoint and objects. Every connection makes the capability
// exchange before anything else (libqi 2.5 and later refuse every other call on a connection
// that has not). Losing the directory's connection closes them all; losing another one closes
// only it, and the services it carried are reported by takeLost().
//
// Not thread-safe: one thread (the bridge's robot worker) owns a QiClient and calls everything,
// including pump(). Calls are asynchronous (replies are matched by message id when pump() reads
// them) except the look-ups, which wait for their answer with a deadline. Nothing blocks without
// a deadline.
#pragma once

#include "qi_connection.h"
#include "qi_message.h"
#include "qi_meta.h"

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace skr::nao::qi {

struct ClientOptions {
  std::string host = "127.0.0.1";
  std::uint16_t port = 9559;
  int connect_timeout_ms = 2000;
  int lookup_timeout_ms = 3000;  // authenticate, service, metaObject
  std::uint32_t max_payload = kDefaultMaxPayload;
  // The capability map first (NAOqi >= 2.5 refuses every other call before it, even without a
  // password). Off only for robots older than that.
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

  // TCP connect, then the capability/authentication exchange, then the ServiceDirectory's own
  // look-up (to know which services share its process). Blocks up to the timeouts.
  [[nodiscard]] Result<void> connect(const ClientOptions& options);
  [[nodiscard]] bool connected() const noexcept {
    return !links_.empty() && links_[0] && links_[0]->open();
  }
  // Closes every connection; every pending call gets Errc::closed with `why`.
  void close(const std::string& why);

  // Sends a call of `service`.`method` (the main object); `fn` runs from a later pump() with the
  // reply decoded by the method's return signature, the robot's error text, a timeout or the
  // close. Looks the service and its metaObject up first if it is not cached (blocking).
  [[nodiscard]] Result<void> call(const std::string& service, const std::string& method,
                                  std::vector<Value> args, int timeout_ms, ReplyFn fn);
  // call() and wait for its answer.
  [[nodiscard]] Result<Value> callSync(const std::string& service, const std::string& method,
                                       std::vector<Value> args, int timeout_ms);

  // Waits up to timeout_ms for bytes on any connection (or for `wake_fd` to become readable,
  // when >= 0), reads them, dispatches replies and expires late calls. A connection that breaks
  // (oversized or malformed message, EOF, socket error) is closed and its pending calls fail
  // with Errc::closed; an error means it was the directory's, and all are closed.
  [[nodiscard]] Result<void> pump(int timeout_ms, int wake_fd = -1);
  // The services whose connection (not the directory's) was lost since the last call, each with
  // why; they are looked up again by the next resolve() or call().
  [[nodiscard]] std::map<std::string, std::string> takeLost();

  // Looks `service` up (ServiceDirectory, a connection to its endpoint if it is not the
  // directory's, then its metaObject) unless it is cached. Blocking. A look-up step that gets
  // no answer in time closes the connection it was sent on.
  [[nodiscard]] Result<void> resolve(const std::string& service);
  // ServiceDirectory.service(name), over the main connection.
  [[nodiscard]] Result<ServiceInfo> serviceInfo(const std::string& name);
  // metaObject(object) of `service`, over connection `link` (0: the main one).
  [[nodiscard]] Result<MetaObject> metaObject(std::uint32_t service, std::uint32_t object,
                                              std::size_t link = 0);
  [[nodiscard]] std::size_t pending() const noexcept { return pending_.size(); }
  // Open connections: 1 (the ServiceDirectory's) plus one per other endpoint in use.
  [[nodiscard]] std::size_t connections() const noexcept;
  // The endpoint calls of a resolved `service` go to ("host:port"), or "" when not resolved.
  [[nodiscard]] std::string endpointOf(const std::string& service) const;

  // Low level: one call message with an encoded payload over connection `link` (0: the main
  // one); the reply is decoded as the first of `return_sigs` that it fills exactly.
  [[nodiscard]] Result<void> send(std::size_t link, std::uint32_t service, std::uint32_t object,
                                  std::uint32_t action, const std::string& payload,
                                  std::vector<std::string> return_sigs, int timeout_ms, ReplyFn fn);

 private:
  struct Pending {
    std::size_t link;
    std::vector<std::string> return_sigs;
    std::int64_t deadline_ns;
    ReplyFn fn;
  };
  struct Service {
    ServiceInfo info;
    MetaObject meta;
    std::size_t link = 0;
  };
  Result<Value> wait(std::size_t link, std::uint32_t service, std::uint32_t object,
                     std::uint32_t action, const std::string& payload,
                     std::vector<std::string> return_sigs, int timeout_ms);
  // Dials `to` and makes the capability exchange on it: the only way a connection is opened.
  Result<std::size_t> openLink(const Endpoint& to);
  Result<void> authenticate(std::size_t link);
  // Closes connection `link` (all of them for 0), failing its pending calls.
  void dropLink(std::size_t link, const std::string& why);
  Result<const Service*> lookup(const std::string& name);
  Result<std::size_t> linkFor(const ServiceInfo& info);
  [[nodiscard]] bool isDirectoryEndpoint(const Endpoint& e) const;
  void dispatch(std::size_t link, Message&& m);
  void expire();

  ClientOptions options_;
  // [0]: the ServiceDirectory's; a lost one leaves an empty slot, so that indices stay valid.
  std::vector<std::unique_ptr<QiConnection>> links_;
  std::optional<ServiceInfo> directory_;  // its own look-up, when it answered one
  std::uint32_t next_id_ = 1;
  std::map<std::uint32_t, Pending> pending_;
  std::map<std::string, Service> services_;
  std::map<std::string, std::string> lost_;  // see takeLost()
};

}  // namespace skr::nao::qi
