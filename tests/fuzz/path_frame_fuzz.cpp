// SPDX-License-Identifier: Apache-2.0
// Fuzz target: physical mode's path framing (skrobot/runtime/flow/path_framing.h), as a subscriber
// or an owner reads it from the other end: frames split from any bytes, each decoded by its type,
// and what decodes is encoded again to the same bytes.
#include <skrobot/runtime/flow/path_framing.h>

#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

using namespace skr::flow::path;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string_view in(reinterpret_cast<const char*>(data), size);
  const uint32_t max = size > 0 && (data[0] & 1) ? kMaxControlBytes : kMaxDataBytes;
  for (;;) {
    const Next f = next(in, max);
    if (f.status != Next::Status::frame) break;
    if (f.size > in.size() || f.body.size() + 5 != f.size) std::abort();
    const std::string_view whole = in.substr(0, f.size);
    switch (static_cast<Type>(f.type)) {
      case Type::hello:
        if (auto h = decodeHello(f.body); h && encode(*h) != whole) std::abort();
        break;
      case Type::welcome:
        if (auto w = decodeWelcome(f.body); w && w->message.size() <= 1000 && encode(*w) != whole) {
          std::abort();
        }
        break;
      case Type::data:
        if (auto d = decodeData(f.body)) {
          if (dataHead(d->seq, d->capture_ns, d->payload.size()) + std::string(d->payload) !=
              whole) {
            std::abort();
          }
        }
        break;
      case Type::bye:
        if (auto b = decodeBye(f.body); b && b->size() <= 1000 && encodeBye(*b) != whole) {
          std::abort();
        }
        break;
    }
    in.remove_prefix(f.size);
  }
  return 0;
}
