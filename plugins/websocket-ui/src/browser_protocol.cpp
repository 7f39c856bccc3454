// SPDX-License-Identifier: Apache-2.0
#include "browser_protocol.h"

#include <skrobot/support/json.hpp>

namespace skr::wsui {
namespace {

Inbound parseBinary(std::string_view message, const InboundLimits& limits) {
  auto frame = skr::media::parseFrame(message);
  if (!frame) return Refusal{kCloseUnsupported, "binary message is not a media frame"};
  const auto& h = frame->header;
  switch (h.format) {
    case skr::media::Format::jpeg: {
      if (h.width == 0 || h.height == 0 || h.width > limits.max_width ||
          h.height > limits.max_height) {
        return Refusal{kCloseUnsupported, "camera frame of " + std::to_string(h.width) + "x" +
                                              std::to_string(h.height) + " pixels"};
      }
      const std::string_view p = frame->payload;
      if (p.size() < 4 || static_cast<unsigned char>(p[0]) != 0xFF ||
          static_cast<unsigned char>(p[1]) != 0xD8) {
        return Refusal{kCloseUnsupported, "camera frame is not a JPEG file"};
      }
      return CameraFrame{h, p};
    }
    case skr::media::Format::pcm_s16le:
      if (h.channels != 1 || h.sample_rate != limits.mic_sample_rate) {
        return Refusal{kCloseUnsupported, "microphone audio must be mono at " +
                                              std::to_string(limits.mic_sample_rate) + " Hz"};
      }
      if (frame->payload.empty()) return Refusal{kCloseUnsupported, "empty audio frame"};
      return MicFrame{h, frame->payload};
    default:
      break;
  }
  return Refusal{kCloseUnsupported, "browsers send JPEG or PCM frames only"};
}

Inbound parseText(std::string_view message, const InboundLimits& limits) {
  if (message.size() > limits.max_text_bytes) {
    return Refusal{kClosePolicy,
                   "text message over " + std::to_string(limits.max_text_bytes) + " bytes"};
  }
  // Browsers send flat objects: a shallow nesting limit keeps the parser cheap.
  auto parsed = skr::support::parseJson(message, {16, limits.max_text_bytes});
  if (!parsed) {
    return Refusal{kCloseBadPayload, "text message is not JSON: " + parsed.error().message};
  }
  const Json::Value& v = *parsed;
  if (!v.isObject() || !v["type"].isString()) {
    return Refusal{kCloseBadPayload, "text message is not an object with a \"type\""};
  }
  const std::string type = v["type"].asString();
  if (type == "hello") {
    if (!v["version"].isInt()) return Refusal{kCloseBadPayload, "hello without a version"};
    return Hello{v["version"].asInt(), v["page"].isString() ? v["page"].asString() : ""};
  }
  if (type == "say") {
    if (!v["text"].isString()) return Refusal{kCloseBadPayload, "say without a text"};
    Say s{v["text"].asString(), v["voice"].isString() ? v["voice"].asString() : ""};
    if (s.text.empty() || s.text.size() > limits.max_say_chars) {
      return Refusal{kCloseBadPayload,
                     "say text must have 1 to " + std::to_string(limits.max_say_chars) + " bytes"};
    }
    return s;
  }
  return Refusal{kCloseBadPayload, "unknown message type '" + type.substr(0, 40) + "'"};
}

}  // namespace

Inbound parseInbound(bool binary, std::string_view message, const InboundLimits& limits) {
  return binary ? parseBinary(message, limits) : parseText(message, limits);
}

}  // namespace skr::wsui
