// SPDX-License-Identifier: Apache-2.0
#include <skrobot/ros2/cdr.h>
#include <skrobot/ros2/images.h>

#include <skrobot/media_frame.hpp>

#include "cdr_stream.h"

#include <algorithm>
#include <cctype>
#include <cstring>

namespace skr::ros2 {
namespace {

namespace media = skr::media;

// The media encodings an Image carries (their names are sensor_msgs' too).
bool imageEncoding(media::Format f) {
  switch (f) {
    case media::Format::rgb8:
    case media::Format::bgr8:
    case media::Format::rgba8:
    case media::Format::bgra8:
    case media::Format::y8:
    case media::Format::mono16:
      return true;
    default:
      return false;
  }
}

// The fields of an image message written in order (CdrOut: aligned, CDR_LE).
class Writer {
 public:
  explicit Writer(std::size_t reserve) : out_(reserve) {}
  void u8(std::uint8_t v) { out_.put(v); }
  void u32(std::uint32_t v) { out_.put(v); }
  void string(std::string_view s) {
    u32(static_cast<std::uint32_t>(s.size() + 1));
    out_.append(s);
    out_.append(std::string_view("\0", 1));
  }
  void bytes(std::string_view b) {
    u32(static_cast<std::uint32_t>(b.size()));
    out_.append(b);
  }
  void stamp(std::int64_t ns) {
    const std::int64_t sec = ns / 1000000000;
    u32(static_cast<std::uint32_t>(static_cast<std::int32_t>(sec)));
    u32(static_cast<std::uint32_t>(ns - sec * 1000000000));
  }
  std::string take() { return out_.take(); }

 private:
  CdrOut out_;
};

// The fields of an image message read in order (CdrIn), every length checked against what is
// left; an error names the field.
class Reader {
 public:
  Reader(std::string_view type, std::string_view bytes)
      : type_(type), bytes_(bytes), in_(bytes, true) {}

  Result<void> start() {
    if (bytes_.size() < kEncapsulationBytes || bytes_[0] != 0 ||
        (bytes_[1] != 0 && bytes_[1] != 1)) {
      return makeError(Errc::parse_error,
                       std::string(type_) + ": not a CDR sample (its encapsulation header)");
    }
    in_ = CdrIn(bytes_, bytes_[1] == 1);
    return {};
  }
  Result<std::uint8_t> u8(const char* field) {
    std::uint8_t v = 0;
    if (!in_.read(v)) return short_(field, 1);
    return v;
  }
  Result<std::uint32_t> u32(const char* field) {
    std::uint32_t v = 0;
    if (!in_.read(v)) return short_(field, 4);
    return v;
  }
  // A string without its NUL.
  Result<std::string_view> string(const char* field) {
    auto n = u32(field);
    if (!n) return n.error();
    std::string_view s;
    if (*n == 0 || !in_.bytes(*n, s)) return short_(field, *n);
    if (s.back() != '\0') return error(field, "a string without its terminating NUL");
    s.remove_suffix(1);
    if (s.find('\0') != std::string_view::npos) return error(field, "a string with a NUL inside");
    return s;
  }
  Result<std::string_view> bytes(const char* field) {
    auto n = u32(field);
    if (!n) return n.error();
    std::string_view s;
    if (!in_.bytes(*n, s)) return short_(field, *n);
    return s;
  }
  Result<std::int64_t> stamp() {
    auto sec = u32("header.stamp.sec");
    if (!sec) return sec.error();
    auto nanosec = u32("header.stamp.nanosec");
    if (!nanosec) return nanosec.error();
    if (*nanosec >= 1000000000u) return error("header.stamp.nanosec", "is 1e9 or more");
    return static_cast<std::int64_t>(static_cast<std::int32_t>(*sec)) * 1000000000 + *nanosec;
  }
  // At most 3 bytes of padding after the last field, as cdrToJson allows.
  Result<void> end() {
    if (in_.left() > 3) {
      return error("", std::to_string(in_.left()) + " bytes left after the last field");
    }
    return {};
  }
  Error error(std::string_view field, const std::string& why) const {
    return makeError(Errc::parse_error, std::string(type_) + (field.empty() ? "" : ": ") +
                                            std::string(field) + ": " + why + " (offset " +
                                            std::to_string(in_.at()) + ")");
  }
  [[nodiscard]] bool little() const { return in_.little(); }

 private:
  Error short_(const char* field, std::size_t need) const {
    return error(
        field, "needs " + std::to_string(need) + " bytes, " + std::to_string(in_.left()) + " left");
  }
  std::string_view type_;
  std::string_view bytes_;
  CdrIn in_;
};

Result<std::string> imageToRaw(Reader& r, std::int64_t stamp, std::uint64_t seq) {
  auto height = r.u32("height");
  if (!height) return height.error();
  auto width = r.u32("width");
  if (!width) return width.error();
  auto encoding = r.string("encoding");
  if (!encoding) return encoding.error();
  auto bigendian = r.u8("is_bigendian");
  if (!bigendian) return bigendian.error();
  auto step = r.u32("step");
  if (!step) return step.error();
  auto data = r.bytes("data");
  if (!data) return data.error();
  if (auto e = r.end(); !e) return e.error();
  const media::EncodingInfo* info = media::encodingInfo(*encoding);
  if (info == nullptr || !imageEncoding(info->format)) {
    return makeError(Errc::unsupported, std::string(kImageType) + ": encoding \"" +
                                            std::string(*encoding) +
                                            "\" has no media frame (rgb8, bgr8, rgba8, bgra8, "
                                            "mono8, mono16 do): import it as cdr");
  }
  if (*width == 0 || *height == 0 || *width > 0xFFFF || *height > 0xFFFF) {
    return r.error("width", std::to_string(*width) + "x" + std::to_string(*height) +
                                " is not a frame's size (1 to 65535 each)");
  }
  const std::size_t row = static_cast<std::size_t>(*width) * info->bits_per_pixel / 8;
  if (*step < row) {
    return r.error("step", std::to_string(*step) + " is less than a row of " +
                               std::to_string(*width) + " " + std::string(info->encoding) +
                               " pixels (" + std::to_string(row) + " bytes)");
  }
  // The last row may come without its padding.
  const std::size_t need = static_cast<std::size_t>(*step) * (*height - 1) + row;
  if (data->size() < need || data->size() > static_cast<std::size_t>(*step) * *height) {
    return r.error("data", std::to_string(data->size()) + " bytes for " + std::to_string(*height) +
                               " rows of step " + std::to_string(*step));
  }
  media::FrameHeader h;
  h.format = info->format;
  h.seq = seq;
  h.capture_ns = stamp;
  h.width = static_cast<std::uint16_t>(*width);
  h.height = static_cast<std::uint16_t>(*height);
  std::string out(media::kHeaderBytes + row * *height, '\0');
  media::writeHeader(h, out.data());
  char* pixels = out.data() + media::kHeaderBytes;
  if (*step == row) {
    std::memcpy(pixels, data->data(), row * *height);
  } else {
    for (std::uint32_t y = 0; y < *height; ++y) {
      std::memcpy(pixels + y * row, data->data() + static_cast<std::size_t>(y) * *step, row);
    }
  }
  if (info->format == media::Format::mono16 && *bigendian != 0) {
    for (std::size_t i = 0; i + 1 < row * *height; i += 2) std::swap(pixels[i], pixels[i + 1]);
  }
  return out;
}

Result<std::string> compressedToJpeg(Reader& r, std::int64_t stamp, std::uint64_t seq) {
  auto format = r.string("format");
  if (!format) return format.error();
  auto data = r.bytes("data");
  if (!data) return data.error();
  if (auto e = r.end(); !e) return e.error();
  std::string lower(*format);
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (lower.find("jpeg") == std::string::npos && lower.find("jpg") == std::string::npos) {
    return makeError(Errc::unsupported, std::string(kCompressedImageType) + ": format \"" +
                                            std::string(*format) +
                                            "\" is not JPEG, the one compressed media "
                                            "frame: import it as cdr");
  }
  const auto size = media::jpegSize(*data);
  if (!size) return r.error("data", "not a JPEG file with a frame header");
  media::FrameHeader h;
  h.format = media::Format::jpeg;
  h.seq = seq;
  h.capture_ns = stamp;
  h.width = size->first;
  h.height = size->second;
  return media::makeFrame(h, *data);
}

}  // namespace

bool isImageType(std::string_view type) {
  return type == kImageType || type == kCompressedImageType;
}

Result<std::string> frameToImage(std::string_view type, std::string_view frame,
                                 std::string_view frame_id, std::int64_t now_ns) {
  if (!isImageType(type)) {
    return makeError(Errc::invalid_argument,
                     std::string(type) + " is not sensor_msgs/msg/Image or CompressedImage");
  }
  const auto f = media::parseFrame(frame);
  if (!f) return makeError(Errc::invalid_argument, "not a media frame (docs/channels.md)");
  const media::EncodingInfo& info = *media::encodingInfo(f->header.format);
  const std::int64_t stamp = f->header.capture_ns > 0 ? f->header.capture_ns : now_ns;
  Writer w(64 + frame_id.size() + f->payload.size());
  if (type == kCompressedImageType) {
    if (info.format != media::Format::jpeg) {
      return makeError(Errc::invalid_argument,
                       "a " + std::string(info.encoding) +
                           " frame is not compressed: export it as sensor_msgs/msg/Image");
    }
    w.stamp(stamp);
    w.string(frame_id);
    w.string("jpeg");
    w.bytes(f->payload);
    return w.take();
  }
  if (!imageEncoding(info.format)) {
    return makeError(Errc::invalid_argument,
                     "a " + std::string(info.encoding) +
                         " frame has no sensor_msgs/msg/Image encoding" +
                         (info.format == media::Format::jpeg
                              ? ": export it as sensor_msgs/msg/CompressedImage"
                              : " (rgb8, bgr8, rgba8, bgra8, mono8, mono16 have)"));
  }
  const std::uint32_t step = static_cast<std::uint32_t>(f->header.width) * info.bits_per_pixel / 8;
  w.stamp(stamp);
  w.string(frame_id);
  w.u32(f->header.height);
  w.u32(f->header.width);
  w.string(info.encoding);
  w.u8(0);  // is_bigendian: frames are little-endian
  w.u32(step);
  w.bytes(f->payload);
  return w.take();
}

Result<std::string> imageToFrame(std::string_view type, std::string_view cdr, std::uint64_t seq,
                                 std::int64_t now_ns) {
  if (!isImageType(type)) {
    return makeError(Errc::invalid_argument,
                     std::string(type) + " is not sensor_msgs/msg/Image or CompressedImage");
  }
  Reader r(type, cdr);
  if (auto s = r.start(); !s) return s.error();
  auto stamp = r.stamp();
  if (!stamp) return stamp.error();
  if (auto id = r.string("header.frame_id"); !id) return id.error();
  const std::int64_t capture = *stamp > 0 ? *stamp : now_ns;
  return type == kImageType ? imageToRaw(r, capture, seq) : compressedToJpeg(r, capture, seq);
}

}  // namespace skr::ros2
