// SPDX-License-Identifier: Apache-2.0
#include <skrobot/web/ws_server.h>

#include <libwebsockets.h>

#include <atomic>
#include <cstring>
#include <deque>
#include <filesystem>
#include <map>
#include <mutex>
#include <thread>

namespace skr::wsui {
namespace {

using Payload = std::shared_ptr<const std::string>;

struct Outgoing {
  bool binary = false;
  bool droppable = true;
  Payload data;
};

struct Conn {
  lws* wsi = nullptr;
  std::deque<Outgoing> queue;
  std::size_t queued_bytes = 0;
  std::string rx;  // the message being reassembled
  bool rx_binary = false;
  std::optional<std::pair<int, std::string>> closing;  // close code and reason, once decided
  std::vector<unsigned char> scratch;                  // LWS_PRE + one message
};

struct Posted {  // from other threads to the service thread
  std::uint64_t conn = 0;
  bool is_close = false;
  Outgoing msg;
  int code = 0;
  std::string reason;
};

// libwebsockets logs through one process-wide function; route it to the server started first of
// those running (websocket-ui and foxglove-bridge may both run in one hub).
struct LogSink {
  const void* owner;
  std::string tag;
  std::function<void(int, const std::string&)> fn;
};
std::mutex g_log_mutex;
std::vector<LogSink> g_logs;

void lwsLog(int level, const char* line) {
  std::string text(line);
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.pop_back();
  std::lock_guard lock(g_log_mutex);
  if (g_logs.empty() || !g_logs.front().fn) return;
  g_logs.front().fn(level == LLL_ERR    ? 3
                    : level == LLL_WARN ? 2
                                        : 0,
                    g_logs.front().tag + "-LWS " + text);
}

std::string header(lws* wsi, lws_token_indexes token) {
  const int len = lws_hdr_total_length(wsi, token);
  if (len <= 0) return {};
  std::string out(static_cast<std::size_t>(len) + 1, '\0');
  if (lws_hdr_copy(wsi, out.data(), len + 1, token) < 0) return {};
  out.resize(static_cast<std::size_t>(len));
  return out;
}

// "http://host:port" -> "host:port".
std::string originHost(const std::string& origin) {
  const auto scheme = origin.find("://");
  std::string rest = scheme == std::string::npos ? origin : origin.substr(scheme + 3);
  if (const auto slash = rest.find('/'); slash != std::string::npos) rest.resize(slash);
  return rest;
}

}  // namespace

struct WsServer::Impl {
  WsServerOptions opts;
  WsServerEvents events;
  lws_context* context = nullptr;
  std::thread thread;
  std::atomic<bool> stopping{false};
  std::atomic<int> bound_port{0};

  // Service thread only.
  std::map<std::uint64_t, Conn> conns;
  std::uint64_t next_conn = 1;

  mutable std::mutex mutex;  // guards posted and stats
  std::vector<Posted> posted;
  WsServerStats stats;

  // lws option lists; they must outlive the context.
  std::vector<lws_protocol_vhost_options> mimes;
  std::vector<lws_protocol_vhost_options> headers;
  lws_http_mount mount{};
  lws_protocols protocols[3]{};

  void countHandshakeRefused() {
    std::lock_guard lock(mutex);
    ++stats.refused_handshakes;
  }

  void log(int level, const std::string& line) const {
    if (events.log) events.log(level, line);
  }

  void enqueue(Conn& c, Outgoing&& out) {
    const std::size_t size = out.data->size();
    auto drop_oldest = [&](bool only_droppable) {
      for (auto it = c.queue.begin(); it != c.queue.end(); ++it) {
        if (only_droppable && !it->droppable) continue;
        c.queued_bytes -= it->data->size();
        c.queue.erase(it);
        std::lock_guard lock(mutex);
        ++stats.dropped;
        return true;
      }
      return false;
    };
    while (c.queued_bytes + size > opts.max_queued_bytes && drop_oldest(true)) {
    }
    if (c.queued_bytes + size > opts.max_queued_bytes) {
      if (out.droppable) {
        std::lock_guard lock(mutex);
        ++stats.dropped;
        return;
      }
      while (c.queued_bytes + size > opts.max_queued_bytes && drop_oldest(false)) {
      }
    }
    c.queued_bytes += size;
    c.queue.push_back(std::move(out));
    lws_callback_on_writable(c.wsi);
  }

  void takePosted() {
    std::vector<Posted> batch;
    {
      std::lock_guard lock(mutex);
      batch.swap(posted);
    }
    for (Posted& p : batch) {
      if (p.is_close) {
        auto it = conns.find(p.conn);
        if (it == conns.end() || it->second.closing) continue;
        it->second.closing = std::make_pair(p.code, p.reason);
        lws_callback_on_writable(it->second.wsi);
        continue;
      }
      if (p.conn == 0) {
        for (auto& [id, c] : conns) {
          if (!c.closing) enqueue(c, Outgoing(p.msg));
        }
      } else if (auto it = conns.find(p.conn); it != conns.end() && !it->second.closing) {
        enqueue(it->second, std::move(p.msg));
      }
    }
  }

  // Refuses the connection's current message: close with `code` and `reason`.
  void refuse(Conn& c, int code, const std::string& reason) {
    {
      std::lock_guard lock(mutex);
      ++stats.refused;
    }
    c.closing = std::make_pair(code, reason);
    c.rx.clear();
    c.rx.shrink_to_fit();
    lws_callback_on_writable(c.wsi);
  }

  int onReceive(lws* wsi, std::uint64_t id, const char* in, std::size_t len) {
    auto it = conns.find(id);
    if (it == conns.end()) return -1;
    Conn& c = it->second;
    if (c.closing) return 0;  // ignore what follows a refused message
    if (c.rx.empty()) c.rx_binary = lws_frame_is_binary(wsi) != 0;
    // Refuse before buffering: what has come, this fragment and what the frame announces.
    const std::size_t announced = lws_remaining_packet_payload(wsi);
    if (c.rx.size() + len + announced > opts.max_message_bytes) {
      refuse(c, LWS_CLOSE_STATUS_MESSAGE_TOO_LARGE,
             "message over " + std::to_string(opts.max_message_bytes) + " bytes");
      log(2, opts.log_tag + "-REFUSED " + opts.peer_noun + " " + std::to_string(id) +
                 ": message over " + std::to_string(opts.max_message_bytes) + " bytes");
      return 0;
    }
    c.rx.append(in, len);
    if (lws_is_final_fragment(wsi) == 0 || lws_remaining_packet_payload(wsi) != 0) return 0;
    std::string message;
    message.swap(c.rx);
    int code = LWS_CLOSE_STATUS_POLICY_VIOLATION;
    std::optional<std::string> error;
    if (events.message) error = events.message(id, c.rx_binary, std::move(message), code);
    if (error) {
      log(2,
          opts.log_tag + "-REFUSED " + opts.peer_noun + " " + std::to_string(id) + ": " + *error);
      refuse(c, code, *error);
    }
    return 0;
  }

  int onWritable(lws* wsi, std::uint64_t id) {
    auto it = conns.find(id);
    if (it == conns.end()) return -1;
    Conn& c = it->second;
    if (c.closing) {
      std::string reason = c.closing->second.substr(0, 120);
      lws_close_reason(wsi, static_cast<lws_close_status>(c.closing->first),
                       reinterpret_cast<unsigned char*>(reason.data()), reason.size());
      return -1;
    }
    if (c.queue.empty()) return 0;
    Outgoing out = std::move(c.queue.front());
    c.queue.pop_front();
    c.queued_bytes -= out.data->size();
    c.scratch.resize(LWS_PRE + out.data->size());
    std::memcpy(c.scratch.data() + LWS_PRE, out.data->data(), out.data->size());
    const int n = lws_write(wsi, c.scratch.data() + LWS_PRE, out.data->size(),
                            out.binary ? LWS_WRITE_BINARY : LWS_WRITE_TEXT);
    if (n < static_cast<int>(out.data->size())) return -1;
    if (!c.queue.empty()) lws_callback_on_writable(wsi);
    return 0;
  }

  // Only the configured path, the configured subprotocol, and (when the browser sends an Origin)
  // pages served by this server itself may open a WebSocket.
  std::optional<std::string> filter(lws* wsi) const {
    const std::string uri = header(wsi, WSI_TOKEN_GET_URI);
    if (uri != opts.ws_path) return "WebSocket on path '" + uri + "' (only " + opts.ws_path + ")";
    const std::string origin = header(wsi, WSI_TOKEN_ORIGIN);
    const std::string host = header(wsi, WSI_TOKEN_HOST);
    if (opts.same_origin_only && !origin.empty() && originHost(origin) != host) {
      return "WebSocket from origin '" + origin + "', not a page of this server (" + host + ")";
    }
    return std::nullopt;
  }
};

namespace {

int wsCallback(lws* wsi, lws_callback_reasons reason, void* user, void* in, std::size_t len) {
  lws_context* ctx = lws_get_context(wsi);
  auto* impl = static_cast<WsServer::Impl*>(lws_context_user(ctx));
  auto* id = static_cast<std::uint64_t*>(user);
  switch (reason) {
    case LWS_CALLBACK_FILTER_PROTOCOL_CONNECTION:
      if (auto why = impl->filter(wsi)) {
        impl->countHandshakeRefused();
        impl->log(2, impl->opts.log_tag + "-REFUSED connection: " + *why);
        return 1;
      }
      return 0;
    case LWS_CALLBACK_ESTABLISHED: {
      *id = impl->next_conn++;
      impl->conns[*id].wsi = wsi;
      {
        std::lock_guard lock(impl->mutex);
        ++impl->stats.connections;
        ++impl->stats.accepted;
      }
      char peer[64] = "?";
      lws_get_peer_simple(wsi, peer, sizeof peer);
      if (impl->events.opened) impl->events.opened(*id, peer);
      return 0;
    }
    case LWS_CALLBACK_RECEIVE:
      return impl->onReceive(wsi, *id, static_cast<const char*>(in), len);
    case LWS_CALLBACK_SERVER_WRITEABLE:
      return impl->onWritable(wsi, *id);
    case LWS_CALLBACK_WS_PEER_INITIATED_CLOSE:
      return 0;
    case LWS_CALLBACK_CLOSED: {
      auto it = impl->conns.find(*id);
      if (it == impl->conns.end()) return 0;
      const std::string why = it->second.closing ? it->second.closing->second : "closed by peer";
      impl->conns.erase(it);
      {
        std::lock_guard lock(impl->mutex);
        --impl->stats.connections;
      }
      if (impl->events.closed) impl->events.closed(*id, why);
      return 0;
    }
    case LWS_CALLBACK_EVENT_WAIT_CANCELLED:
      impl->takePosted();
      return 0;
    default:
      return 0;
  }
}

// HTTP (files from the mount); refuses WebSocket upgrades that name no subprotocol.
int httpCallback(lws* wsi, lws_callback_reasons reason, void* user, void* in, std::size_t len) {
  if (reason == LWS_CALLBACK_FILTER_PROTOCOL_CONNECTION) {
    auto* impl = static_cast<WsServer::Impl*>(lws_context_user(lws_get_context(wsi)));
    impl->countHandshakeRefused();
    impl->log(2, impl->opts.log_tag + "-REFUSED connection: WebSocket without the subprotocol " +
                     impl->opts.subprotocol);
    return 1;
  }
  return lws_callback_http_dummy(wsi, reason, user, in, len);
}

void dropLogSink(const void* owner) {
  std::lock_guard lock(g_log_mutex);
  std::erase_if(g_logs, [owner](const LogSink& s) { return s.owner == owner; });
}

}  // namespace

WsServer::WsServer() : impl_(std::make_unique<Impl>()) {}
WsServer::~WsServer() {
  stop();
}

std::optional<std::string> WsServer::start(WsServerOptions options, WsServerEvents events) {
  Impl& m = *impl_;
  m.opts = std::move(options);
  m.events = std::move(events);
  std::error_code ec;
  if (m.opts.serve_files && !std::filesystem::is_regular_file(
                                std::filesystem::path(m.opts.web_root) / "index.html", ec)) {
    return "web_root '" + m.opts.web_root + "' has no index.html";
  }
  const bool tls = !m.opts.tls_cert.empty() || !m.opts.tls_key.empty();
  if (tls && (m.opts.tls_cert.empty() || m.opts.tls_key.empty())) {
    return "TLS needs both tls_cert and tls_key";
  }
  {
    std::lock_guard lock(g_log_mutex);
    g_logs.push_back(LogSink{&m, m.opts.log_tag, m.events.log});
  }
  lws_set_log_level(LLL_ERR | LLL_WARN, lwsLog);

  static const std::pair<const char*, const char*> kMimes[] = {
      {".html", "text/html; charset=utf-8"},
      {".js", "text/javascript"},
      {".mjs", "text/javascript"},
      {".css", "text/css"},
      {".json", "application/json"},
      {".glb", "model/gltf-binary"},
      {".wasm", "application/wasm"},
      {".svg", "image/svg+xml"},
      {".png", "image/png"},
      {".jpg", "image/jpeg"},
      {".ico", "image/x-icon"}};
  m.mimes.clear();
  for (const auto& [ext, type] : kMimes) m.mimes.push_back({nullptr, nullptr, ext, type});
  for (std::size_t i = 0; i + 1 < m.mimes.size(); ++i) m.mimes[i].next = &m.mimes[i + 1];

  m.headers = {
      {nullptr, nullptr, "content-security-policy:", m.opts.content_security_policy.c_str()},
      {nullptr, nullptr, "x-content-type-options:", "nosniff"},
      {nullptr, nullptr, "referrer-policy:", "no-referrer"}};
  for (std::size_t i = 0; i + 1 < m.headers.size(); ++i) m.headers[i].next = &m.headers[i + 1];

  m.mount = lws_http_mount{};
  m.mount.mountpoint = "/";
  m.mount.mountpoint_len = 1;
  m.mount.origin = m.opts.web_root.c_str();
  m.mount.def = "index.html";
  m.mount.origin_protocol = LWSMPRO_FILE;
  m.mount.extra_mimetypes = m.mimes.data();

  m.protocols[0] = lws_protocols{"http", httpCallback, 0, 0, 0, nullptr, 0};
  m.protocols[1] = lws_protocols{
      m.opts.subprotocol.c_str(), wsCallback, sizeof(std::uint64_t), 64 * 1024, 0, nullptr, 0};
  m.protocols[2] = lws_protocols{nullptr, nullptr, 0, 0, 0, nullptr, 0};

  lws_context_creation_info info{};
  info.port = m.opts.port;
  info.iface = m.opts.address.c_str();
  info.protocols = m.protocols;
  info.mounts = m.opts.serve_files ? &m.mount : nullptr;
  info.headers = m.headers.data();
  info.user = &m;
  info.gid = static_cast<gid_t>(-1);
  info.uid = static_cast<uid_t>(-1);
  info.options = LWS_SERVER_OPTION_VALIDATE_UTF8 | LWS_SERVER_OPTION_DISABLE_IPV6;
  if (tls) {
    info.options |= LWS_SERVER_OPTION_DO_SSL_GLOBAL_INIT;
    info.ssl_cert_filepath = m.opts.tls_cert.c_str();
    info.ssl_private_key_filepath = m.opts.tls_key.c_str();
  }
  m.context = lws_create_context(&info);
  if (m.context == nullptr) {
    dropLogSink(&m);
    return "cannot listen on " + m.opts.address + ":" + std::to_string(m.opts.port) +
           (tls ? " with TLS (check the certificate and key)" : " (address in use?)");
  }
  lws_vhost* vh = lws_get_vhost_by_name(m.context, "default");
  m.bound_port = vh != nullptr ? lws_get_vhost_listen_port(vh) : m.opts.port;
  m.stopping = false;
  m.thread = std::thread([&m] {
    while (!m.stopping.load()) {
      if (lws_service(m.context, 0) < 0) break;
    }
  });
  return std::nullopt;
}

void WsServer::stop() noexcept {
  Impl& m = *impl_;
  if (m.context == nullptr) return;
  m.stopping = true;
  lws_cancel_service(m.context);
  if (m.thread.joinable()) m.thread.join();
  lws_context_destroy(m.context);  // closes the browsers' connections (CLOSED callbacks)
  m.context = nullptr;
  m.conns.clear();
  dropLogSink(&m);
}

void WsServer::send(std::uint64_t conn, bool binary, std::string data, bool droppable) {
  Impl& m = *impl_;
  if (m.context == nullptr) return;
  Posted p;
  p.conn = conn;
  p.msg = Outgoing{binary, droppable, std::make_shared<const std::string>(std::move(data))};
  {
    std::lock_guard lock(m.mutex);
    m.posted.push_back(std::move(p));
  }
  lws_cancel_service(m.context);
}

void WsServer::close(std::uint64_t conn, int code, const std::string& reason) {
  Impl& m = *impl_;
  if (m.context == nullptr) return;
  Posted p;
  p.conn = conn;
  p.is_close = true;
  p.code = code;
  p.reason = reason;
  {
    std::lock_guard lock(m.mutex);
    m.posted.push_back(std::move(p));
  }
  lws_cancel_service(m.context);
}

WsServerStats WsServer::stats() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->stats;
}

int WsServer::port() const noexcept {
  return impl_->bound_port.load();
}

}  // namespace skr::wsui
