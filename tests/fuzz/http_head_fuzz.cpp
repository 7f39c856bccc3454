// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: arbitrary bytes as an HTTP head, through the runtime's parser
// (runtime/internal/http_head.h) that the hub's web port and the ws: client run: a request or a
// response is parsed or refused with a reason, a parsed one keeps its promises (a known method,
// an absolute target, lower-case header names), and the WebSocket checks never fail on it.
#include "http_head.h"

#include <cstdint>
#include <cstdlib>
#include <string_view>

using namespace skr::flow;

namespace {

void checkHeaders(const std::vector<std::pair<std::string, std::string>>& headers) {
  for (const auto& [name, value] : headers) {
    if (name.empty()) std::abort();
    for (const char c : name) {
      if (c >= 'A' && c <= 'Z') std::abort();
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view d(reinterpret_cast<const char*>(data), size);
  const size_t end = http::headEnd(d);
  if (end > size) std::abort();
  const std::string_view head = end > 0 ? d.substr(0, end) : d;
  if (auto r = http::parseRequest(head)) {
    if (r->method != "GET" && r->method != "HEAD" && r->method != "POST") std::abort();
    if (r->target.empty() || r->target[0] != '/' || r->path().size() > r->target.size())
      std::abort();
    if (head.size() > http::kMaxHeadBytes) std::abort();
    checkHeaders(r->headers);
    (void)r->list("sec-websocket-protocol");
    if (!http::checkWebSocket(*r)) {
      const auto key = r->header("sec-websocket-key");
      if (!key || http::websocketAccept(*key).size() != 28) std::abort();
      (void)http::switchingProtocols(*key, http::kFlowSubprotocol);
    }
  } else if (r.error().message.empty()) {
    std::abort();
  }
  if (auto r = http::parseResponse(head)) {
    if (r->status < 0 || r->status > 999) std::abort();
    checkHeaders(r->headers);
    (void)http::checkAccepted(*r, "dGhlIHNhbXBsZSBub25jZQ==", http::kFlowSubprotocol);
  }
  return 0;
}
