// SPDX-License-Identifier: Apache-2.0
#include <skrobot/foxglove/images.h>
#include <skrobot/base64.hpp>
#include <skrobot/media_frame.hpp>
#include <skrobot/support/json.hpp>

#include <algorithm>
#include <array>

namespace skr::foxglove {
namespace {

constexpr std::string_view kTimeSchema =
    R"({"type":"object","properties":{"sec":{"type":"integer","minimum":0},)"
    R"("nsec":{"type":"integer","minimum":0,"maximum":999999999}}})";

// `"timestamp":{...}}` of a capture time, closing the object written by hand.
void appendTimestampAndClose(std::string& out, std::int64_t ns) {
  out += R"(,"timestamp":{"nsec":)";
  out += std::to_string(ns % 1000000000);
  out += R"(,"sec":)";
  out += std::to_string(ns / 1000000000);
  out += "}}";
}

Error bad(std::string why) {
  return makeError(Errc::parse_error, "not an image message of a media frame: " + std::move(why));
}

// An unsigned integer member no larger than `max`.
std::optional<std::uint64_t> unsignedOf(const Json::Value& in, const char* key, std::uint64_t max) {
  const Json::Value& v = in[key];
  if (!v.isIntegral() || (v.isInt64() && v.asInt64() < 0) || v.asUInt64() > max) {
    return std::nullopt;
  }
  return v.asUInt64();
}

// Whether what follows `prefix` is a member of the top-level object (outside strings, one level
// of braces or brackets deep).
bool atTopLevel(std::string_view prefix) {
  int depth = 0;
  bool in_string = false;
  for (std::size_t i = 0; i < prefix.size(); ++i) {
    const char c = prefix[i];
    if (in_string) {
      if (c == '\\') {
        ++i;
      } else if (c == '"') {
        in_string = false;
      }
    } else if (c == '"') {
      in_string = true;
    } else if (c == '{' || c == '[') {
      ++depth;
    } else if (c == '}' || c == ']') {
      --depth;
    }
  }
  return depth == 1 && !in_string;
}

}  // namespace

std::string_view timeSchema() {
  return kTimeSchema;
}

std::string compressedImageSchema() {
  return std::string(R"({"title":"foxglove.CompressedImage","type":"object","properties":{)") +
         R"("timestamp":)" + std::string(kTimeSchema) + R"(,"frame_id":{"type":"string"},)" +
         R"("data":{"type":"string","contentEncoding":"base64"},"format":{"type":"string"}},)" +
         R"("required":["timestamp","frame_id","data","format"]})";
}

std::string rawImageSchema() {
  return std::string(R"({"title":"foxglove.RawImage","type":"object","properties":{)") +
         R"("timestamp":)" + std::string(kTimeSchema) + R"(,"frame_id":{"type":"string"},)" +
         R"("width":{"type":"integer","minimum":0},"height":{"type":"integer","minimum":0},)" +
         R"("encoding":{"type":"string"},"step":{"type":"integer","minimum":0},)" +
         R"("data":{"type":"string","contentEncoding":"base64"}},)" +
         R"("required":["timestamp","frame_id","width","height","encoding","step","data"]})";
}

std::optional<Converted> compressedImage(std::string_view message, const std::string& frame_id) {
  auto frame = skr::media::parseFrame(message);
  if (!frame || frame->header.format != skr::media::Format::jpeg) return std::nullopt;
  const auto& h = frame->header;
  // Written by hand: base64 needs no escaping, and writeJson checks every byte's UTF-8.
  const std::int64_t ns = std::max<std::int64_t>(h.capture_ns, 0);
  std::string out;
  out.reserve(frame->payload.size() / 3 * 4 + 160 + frame_id.size());
  out += R"({"data":")";
  base64::append(out, frame->payload);
  out += R"(","format":"jpeg","frame_id":)";
  out += skr::support::jsonQuote(frame_id);
  out += R"(,"height":)" + std::to_string(h.height) + R"(,"seq":)" + std::to_string(h.seq) +
         R"(,"width":)" + std::to_string(h.width);
  appendTimestampAndClose(out, ns);
  return Converted{std::move(out), static_cast<std::uint64_t>(ns)};
}

bool isRawImageEncoding(std::string_view encoding) {
  const auto* e = skr::media::encodingInfo(encoding);
  return e != nullptr && e->video && skr::media::isRaw(*e);
}

std::optional<Converted> rawImage(std::string_view message, const std::string& frame_id) {
  auto frame = skr::media::parseFrame(message);
  if (!frame) return std::nullopt;
  const auto& h = frame->header;
  const auto* e = skr::media::encodingInfo(h.format);
  if (!e->video || !skr::media::isRaw(*e)) return std::nullopt;
  // parseFrame checked the payload's size; rows are packed, so step is width * bytes per pixel
  // (the luma row for nv12).
  std::string_view pixels = frame->payload;
  std::string nv12;
  std::string_view encoding = e->encoding;
  const bool i420 = h.format == skr::media::Format::i420;
  if (i420) {  // Foxglove has nv12, not i420
    const std::size_t luma = static_cast<std::size_t>(h.width) * h.height, quarter = luma / 4;
    nv12.assign(pixels.substr(0, luma));
    nv12.resize(luma + 2 * quarter);
    for (std::size_t i = 0; i < quarter; ++i) {
      nv12[luma + 2 * i] = pixels[luma + i];
      nv12[luma + 2 * i + 1] = pixels[luma + quarter + i];
    }
    pixels = nv12;
    encoding = "nv12";
  }
  const std::size_t step = e->even_size ? h.width : h.width * (e->bits_per_pixel / 8u);
  const std::int64_t ns = std::max<std::int64_t>(h.capture_ns, 0);
  std::string out;
  out.reserve(pixels.size() / 3 * 4 + 200 + frame_id.size());
  out += R"({"data":")";
  base64::append(out, pixels);
  out += R"(","encoding":")";
  out += encoding;
  if (i420) out += R"(","frame_encoding":"i420)";
  out += R"(","frame_id":)";
  out += skr::support::jsonQuote(frame_id);
  out += R"(,"height":)" + std::to_string(h.height) + R"(,"seq":)" + std::to_string(h.seq) +
         R"(,"step":)" + std::to_string(step) + R"(,"width":)" + std::to_string(h.width);
  appendTimestampAndClose(out, ns);
  return Converted{std::move(out), static_cast<std::uint64_t>(ns)};
}

Result<std::string> mediaFrameOf(std::string_view json) {
  // jsoncpp copies a string a byte at a time (50 ms for a 1080p frame's 8 MB): the base64 text
  // (no quote or backslash in it) of the top-level "data" is cut out and the rest parsed; when it
  // cannot be (escapes in it, or no such key), the whole text is parsed.
  std::string_view data_text;
  std::string rest;
  constexpr std::string_view kKey = R"("data":")";
  if (const auto at = json.find(kKey); at != std::string_view::npos) {
    const auto from = at + kKey.size();
    const auto to = json.find('"', from);  // memchr: find_first_of tests a byte at a time
    if (to != std::string_view::npos &&
        json.substr(from, to - from).find('\\') == std::string_view::npos &&
        atTopLevel(json.substr(0, at))) {
      data_text = json.substr(from, to - from);
      rest.reserve(json.size() - data_text.size());
      rest.append(json.substr(0, from)).append(json.substr(to));
    }
  }
  auto parsed = rest.empty() ? Result<Json::Value>(Json::Value())
                             : skr::support::parseJsonObject(rest, {8, rest.size() + 1});
  if (!parsed || !(*parsed)["data"].isString() || !(*parsed)["data"].asString().empty()) {
    data_text = {};
    parsed = skr::support::parseJsonObject(json, {8, json.size() + 1});
  }
  if (!parsed) return bad(parsed.error().message);
  const Json::Value& in = *parsed;
  if (!in["data"].isString()) return bad("no \"data\" string");
  if (data_text.empty()) {
    const char* text = nullptr;
    const char* end = nullptr;
    in["data"].getString(&text, &end);
    data_text = std::string_view(text, static_cast<std::size_t>(end - text));
  }
  const auto seq = unsignedOf(in, "seq", UINT64_MAX);
  const auto width = unsignedOf(in, "width", UINT16_MAX);
  const auto height = unsignedOf(in, "height", UINT16_MAX);
  const Json::Value& t = in["timestamp"];
  const auto sec = t.isObject() ? unsignedOf(t, "sec", INT64_MAX / 1000000000) : std::nullopt;
  const auto nsec = t.isObject() ? unsignedOf(t, "nsec", 999999999) : std::nullopt;
  if (!seq || !width || !height || !sec || !nsec) {
    return bad("\"seq\", \"width\", \"height\" and \"timestamp\" {sec, nsec} are needed");
  }
  auto data = base64::decode(data_text);
  if (!data) return bad("\"data\" is not base64");
  skr::media::FrameHeader h;
  h.seq = *seq;
  h.capture_ns = static_cast<std::int64_t>(*sec * 1000000000 + *nsec);
  h.width = static_cast<std::uint16_t>(*width);
  h.height = static_cast<std::uint16_t>(*height);
  if (in["format"].isString()) {  // CompressedImage
    if (in["format"].asString() != "jpeg") return bad("a format other than jpeg");
    h.format = skr::media::Format::jpeg;
    return skr::media::makeFrame(h, *data);
  }
  const std::string encoding =
      in["frame_encoding"].isString() ? in["frame_encoding"].asString() : in["encoding"].asString();
  const auto* e = skr::media::encodingInfo(encoding);
  if (e == nullptr || !e->video || !skr::media::isRaw(*e)) {
    return bad("encoding '" + encoding + "' is not a raw one");
  }
  if (skr::media::rawPayloadBytes(*e, h.width, h.height) != data->size()) {
    return bad("\"data\" does not hold " + std::to_string(h.width) + "x" +
               std::to_string(h.height) + " " + encoding + " pixels");
  }
  if (e->format == skr::media::Format::i420) {  // sent as nv12: the chroma planes interleaved
    if (in["encoding"].asString() != "nv12") return bad("i420 sent as other than nv12");
    const std::size_t luma = static_cast<std::size_t>(h.width) * h.height, quarter = luma / 4;
    std::string planar(data->size(), '\0');
    std::copy_n(data->data(), luma, planar.data());
    for (std::size_t i = 0; i < quarter; ++i) {
      planar[luma + i] = (*data)[luma + 2 * i];
      planar[luma + quarter + i] = (*data)[luma + 2 * i + 1];
    }
    data = std::move(planar);
  }
  h.format = e->format;
  return skr::media::makeFrame(h, *data);
}

}  // namespace skr::foxglove
