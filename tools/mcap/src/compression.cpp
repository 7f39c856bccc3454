// SPDX-License-Identifier: Apache-2.0
// zstd (one frame per chunk) and lz4 (one LZ4 frame per chunk) through Debian's libzstd and liblz4.
#include <lz4frame.h>
#include <skrobot/mcap/compression.h>
#include <zstd.h>

#include <memory>

namespace skr::mcap {

namespace {
constexpr int kZstdLevel = 1;  // fast enough to keep up with camera and microphone on one core
}

std::string_view compressionName(Compression c) noexcept {
  switch (c) {
    case Compression::zstd:
      return "zstd";
    case Compression::lz4:
      return "lz4";
    case Compression::none:
      break;
  }
  return "";
}

Result<Compression> compressionFromName(std::string_view name) {
  if (name.empty()) return Compression::none;
  if (name == "zstd") return Compression::zstd;
  if (name == "lz4") return Compression::lz4;
  return makeError(Errc::unsupported, "unknown compression '" + std::string(name) + "'");
}

Result<void> compress(Compression c, std::string_view data, std::string& out) {
  switch (c) {
    case Compression::none:
      out.assign(data);
      return {};
    case Compression::zstd: {
      out.resize(ZSTD_compressBound(data.size()));
      const size_t n = ZSTD_compress(out.data(), out.size(), data.data(), data.size(), kZstdLevel);
      if (ZSTD_isError(n) != 0) {
        return makeError(Errc::internal, std::string("zstd: ") + ZSTD_getErrorName(n));
      }
      out.resize(n);
      return {};
    }
    case Compression::lz4: {
      LZ4F_preferences_t prefs{};
      prefs.frameInfo.contentSize = data.size();
      out.resize(LZ4F_compressFrameBound(data.size(), &prefs));
      const size_t n = LZ4F_compressFrame(out.data(), out.size(), data.data(), data.size(), &prefs);
      if (LZ4F_isError(n) != 0) {
        return makeError(Errc::internal, std::string("lz4: ") + LZ4F_getErrorName(n));
      }
      out.resize(n);
      return {};
    }
  }
  return makeError(Errc::internal, "unknown compression");
}

Result<void> decompress(Compression c, std::string_view data, uint64_t uncompressed_size,
                        std::string& out) {
  out.resize(static_cast<size_t>(uncompressed_size));
  switch (c) {
    case Compression::none:
      if (data.size() != uncompressed_size) {
        return makeError(Errc::parse_error, "uncompressed chunk size differs from its records");
      }
      out.assign(data);
      return {};
    case Compression::zstd: {
      const size_t n = ZSTD_decompress(out.data(), out.size(), data.data(), data.size());
      if (ZSTD_isError(n) != 0) {
        return makeError(Errc::parse_error, std::string("zstd: ") + ZSTD_getErrorName(n));
      }
      if (n != uncompressed_size) {
        return makeError(Errc::parse_error,
                         "zstd chunk decompresses to another size than declared");
      }
      return {};
    }
    case Compression::lz4: {
      LZ4F_dctx* raw = nullptr;
      if (LZ4F_isError(LZ4F_createDecompressionContext(&raw, LZ4F_VERSION)) != 0) {
        return makeError(Errc::internal, "lz4: no decompression context");
      }
      std::unique_ptr<LZ4F_dctx, decltype(&LZ4F_freeDecompressionContext)> ctx(
          raw, &LZ4F_freeDecompressionContext);
      size_t in_at = 0, out_at = 0;
      size_t hint = 1;
      while (hint != 0) {
        size_t out_n = out.size() - out_at, in_n = data.size() - in_at;
        hint = LZ4F_decompress(ctx.get(), out.data() + out_at, &out_n, data.data() + in_at, &in_n,
                               nullptr);
        if (LZ4F_isError(hint) != 0) {
          return makeError(Errc::parse_error, std::string("lz4: ") + LZ4F_getErrorName(hint));
        }
        in_at += in_n;
        out_at += out_n;
        // No progress: the input ended before the frame did, or the output is full.
        if (hint != 0 && in_n == 0 && out_n == 0) break;
      }
      if (hint != 0 || out_at != uncompressed_size || in_at != data.size()) {
        return makeError(Errc::parse_error, "lz4 chunk is damaged or another size than declared");
      }
      return {};
    }
  }
  return makeError(Errc::internal, "unknown compression");
}

}  // namespace skr::mcap
