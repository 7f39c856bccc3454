// SPDX-License-Identifier: Apache-2.0
// Fuzz target: what a robot (or anything on port 9559) can send the qi client. The input is cut
// into messages by MessageFramer (with a small size limit); each payload is decoded as a dynamic
// value, as the MetaObject and the ServiceInfo (seven and six fields) structures, and as a
// signature taken from the input. Whatever decodes must re-encode and decode to the same value.
#include "qi_message.h"
#include "qi_meta.h"

#include <cstdint>
#include <cstdlib>
#include <string_view>

namespace {

using namespace skr::nao::qi;

void roundTrip(const Type& t, const Value& v) {
  std::string again;
  if (!encode(t, v, again)) return;  // e.g. NaN-free but unrepresentable: not an error
  auto back = decode(t, again);
  if (!back) std::abort();
}

void decodeAs(const Type& t, std::string_view payload) {
  std::size_t used = 0;
  auto v = decode(t, payload, &used);
  if (!v) return;
  if (used > payload.size()) std::abort();
  (void)v->text();
  roundTrip(t, v.value());
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view in(reinterpret_cast<const char*>(data), size);
  static const Type kDynamic = parseSignature("m").value();
  static const Type kMeta = parseSignature(kMetaObjectSignature).value();
  static const Type kInfo = parseSignature(kServiceInfoSignature).value();
  static const Type kInfo6 = parseSignature(kServiceInfoSignature6).value();

  // First byte: how long a signature to take from the input's tail.
  if (!in.empty()) {
    const std::size_t n = static_cast<unsigned char>(in[0]) % 32;
    if (n < in.size()) {
      if (auto t = parseSignature(in.substr(in.size() - n))) {
        if (toString(t.value()).size() > kMaxSignatureBytes * 2) std::abort();
        decodeAs(t.value(), in.substr(1, in.size() - 1 - n));
      }
    }
  }

  MessageFramer framer(4096);
  framer.append(in);
  for (int i = 0; i < 64; ++i) {
    auto m = framer.next();
    if (!m || !m.value()) break;
    const Message& msg = *m.value();
    if (msg.payload.size() != msg.header.size || msg.payload.size() > 4096) std::abort();
    decodeAs(kDynamic, msg.payload);
    auto meta = decode(kMeta, msg.payload);
    if (meta) (void)toMetaObject(meta.value());
    auto info = decode(kInfo, msg.payload);
    if (info) (void)toServiceInfo(info.value());
    auto info6 = decode(kInfo6, msg.payload);
    if (info6) (void)toServiceInfo(info6.value());
    if (info && info6) std::abort();  // one payload cannot fill both exactly
    const std::string again = encodeMessage(msg.header, msg.payload);
    if (!parseHeader(again, 4096)) std::abort();
  }
  return 0;
}
