// SPDX-License-Identifier: Apache-2.0
#include <skrobot/runtime/flow/codec.h>
#include <skrobot/runtime/flow/protocol.h>

#include <array>
#include <iterator>

namespace skr::flow {

namespace {

// A wire name ("LOGIN") from a C++ name ("login"), at compile time.
struct UpperName {
  char text[32] = {};
  size_t size = 0;
  constexpr explicit UpperName(std::string_view lower) {
    for (char c : lower) text[size++] = (c >= 'a' && c <= 'z') ? char(c - 'a' + 'A') : c;
  }
};

#define SKR_FLOW_NAME(code, name, ...) UpperName(#name),
constexpr UpperName kUpperNames[] = {SKR_FLOW_CATALOGUE(SKR_FLOW_NAME)};
#undef SKR_FLOW_NAME

constexpr size_t kRows = std::size(kUpperNames);

constexpr std::array<CodeInfo, kRows> makeRows() {
  std::array<CodeInfo, kRows> rows{};
  size_t i = 0;
#define SKR_FLOW_ROW(code, name, minor, dir, via, family, ...)                             \
  rows[i] = CodeInfo{code,     std::string_view(kUpperNames[i].text, kUpperNames[i].size), \
                     minor,    Direction::dir,                                             \
                     Via::via, Family::family};                                            \
  ++i;
  SKR_FLOW_CATALOGUE(SKR_FLOW_ROW)
#undef SKR_FLOW_ROW
  return rows;
}
constexpr std::array<CodeInfo, kRows> kRowsInOrder = makeRows();

// Row index by code (kRows: none).
constexpr std::array<uint16_t, 256> makeIndex() {
  std::array<uint16_t, 256> index{};
  index.fill(uint16_t(kRows));
  for (size_t i = 0; i < kRows; ++i) index[kRowsInOrder[i].code] = uint16_t(i);
  return index;
}
constexpr std::array<uint16_t, 256> kIndex = makeIndex();

constexpr bool inCodeOrder() {
  for (size_t i = 1; i < kRows; ++i) {
    if (kRowsInOrder[i - 1].code >= kRowsInOrder[i].code) return false;
  }
  return true;
}
static_assert(inCodeOrder(), "catalogue.h: rows in code order, each code once");

}  // namespace

const CodeInfo* codeInfo(uint8_t code) noexcept {
  const uint16_t i = kIndex[code];
  return i < kRows ? &kRowsInOrder[i] : nullptr;
}

std::span<const CodeInfo> catalogue() noexcept {
  return kRowsInOrder;
}

std::string_view codeName(uint8_t code) noexcept {
  const CodeInfo* info = codeInfo(code);
  return info != nullptr ? info->name : "UNKNOWN";
}

uint16_t minorOf(Code code) noexcept {
  const CodeInfo* info = codeInfo(static_cast<uint8_t>(code));
  return info != nullptr ? info->minor : 0;
}

std::string_view familyName(Family family) noexcept {
  switch (family) {
    case Family::session:
      return "session";
    case Family::channels:
      return "channels";
    case Family::databases:
      return "databases";
    case Family::services:
      return "services";
    case Family::blobs:
      return "blobs";
    case Family::sync:
      return "sync";
    case Family::links:
      return "links";
    case Family::physical:
      return "physical";
    case Family::admin:
      return "admin";
  }
  return "unknown";
}

std::string_view viaName(Via via) noexcept {
  switch (via) {
    case Via::sync:
      return "sync";
    case Via::flow:
      return "flow";
    case Via::link_sync:
      return "sync, hubs only";
    case Via::link_flow:
      return "flow, hubs only";
  }
  return "unknown";
}

std::string_view errorCodeName(ErrorCode code) noexcept {
  switch (code) {
#define SKR_FLOW_ERROR_NAME(value, name, minor) \
  case ErrorCode::name:                         \
    return #name;
    SKR_FLOW_ERRORS(SKR_FLOW_ERROR_NAME)
#undef SKR_FLOW_ERROR_NAME
  }
  return "unknown";
}

// Every wire error has the Errc of the same name.
Errc toErrc(ErrorCode code) noexcept {
  switch (code) {
#define SKR_FLOW_TO_ERRC(value, name, minor) \
  case ErrorCode::name:                      \
    return Errc::name;
    SKR_FLOW_ERRORS(SKR_FLOW_TO_ERRC)
#undef SKR_FLOW_TO_ERRC
  }
  return Errc::internal;  // a code this build does not know (a newer peer)
}

ErrorCode toErrorCode(Errc code) noexcept {
  switch (code) {
#define SKR_FLOW_FROM_ERRC(value, name, minor) \
  case Errc::name:                             \
    return ErrorCode::name;
    SKR_FLOW_ERRORS(SKR_FLOW_FROM_ERRC)
#undef SKR_FLOW_FROM_ERRC
    // The codes that never travel: the nearest wire error.
    case Errc::config_error:
    case Errc::parse_error:
      return ErrorCode::invalid_argument;
    case Errc::closed:
      return ErrorCode::io_error;
    case Errc::abi_mismatch:
    case Errc::module_failed:
    case Errc::exception:
    case Errc::remote:
      return ErrorCode::internal;
  }
  return ErrorCode::internal;
}

Error wireError(ErrorCode code, std::string message) {
  return Error{toErrc(code), std::move(message)};
}

std::string_view channelKindName(ChannelKind kind) noexcept {
  switch (kind) {
#define SKR_FLOW_KIND_NAME(value, name, minor) \
  case ChannelKind::name:                      \
    return #name;
    SKR_FLOW_CHANNEL_KINDS(SKR_FLOW_KIND_NAME)
#undef SKR_FLOW_KIND_NAME
  }
  return "unknown";
}

uint16_t minorOfKind(ChannelKind kind) noexcept {
  switch (kind) {
#define SKR_FLOW_KIND_MINOR(value, name, minor) \
  case ChannelKind::name:                       \
    return minor;
    SKR_FLOW_CHANNEL_KINDS(SKR_FLOW_KIND_MINOR)
#undef SKR_FLOW_KIND_MINOR
  }
  return 0;
}

FrameSplitter::Next FrameSplitter::next(const uint8_t* data, size_t size) const noexcept {
  Next n;
  ByteReader r(data, size);
  uint32_t length = 0;
  if (!r.u32(length)) {
    n.wanted = 4;
    return n;
  }
  n.announced = length;
  if (length == 0) {
    n.status = Status::empty_frame;
    return n;
  }
  if (length > max_) {
    n.status = Status::too_large;
    return n;
  }
  n.wanted = 4 + static_cast<size_t>(length);
  if (size < n.wanted) return n;
  n.status = Status::frame;
  n.code = data[4];
  n.body = std::string_view(reinterpret_cast<const char*>(data) + kFrameHeaderBytes, length - 1);
  n.consumed = n.wanted;
  return n;
}

void appendHeader(std::string& out, Code code, size_t body_bytes) {
  ByteWriter w(out);
  w.u32(static_cast<uint32_t>(body_bytes + 1));
  w.u8(static_cast<uint8_t>(code));
}

bool FieldReader::operator()(Variant& v) {
  uint8_t enc = 0;
  if (!r_.u8(enc)) return fail("value encoding");
  if (enc == static_cast<uint8_t>(ValueEncoding::binary)) {
    auto decoded = decodeVariant(r_, limits_);
    if (!decoded) return failWith(decoded.error().message);
    v = std::move(decoded).value();
    return true;
  }
  if (enc == static_cast<uint8_t>(ValueEncoding::json)) {
    std::string_view text;
    if (!r_.str32(text)) return fail("JSON value");
    auto parsed = variantFromJsonText(text);
    if (!parsed) return failWith("JSON value: " + parsed.error().message);
    v = std::move(parsed).value();
    return true;
  }
  return failWith("unknown value encoding " + std::to_string(enc));
}

}  // namespace skr::flow
