// SPDX-License-Identifier: Apache-2.0
// An Ogg Vorbis file being read as s16 PCM (libvorbisfile). One thread at a time.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace skr::audio {

class OggReader {
 public:
  OggReader();
  ~OggReader();
  OggReader(const OggReader&) = delete;
  OggReader& operator=(const OggReader&) = delete;
  OggReader(OggReader&&) = delete;
  OggReader& operator=(OggReader&&) = delete;

  // Opens `path` and reads its headers. An error text, empty on success.
  std::string open(const std::filesystem::path& path);
  // Up to `frames` interleaved frames appended to `out`; 0 at the end of the file, -1 on error.
  long read(std::vector<std::int16_t>& out, std::size_t frames);
  // Back to the first sample. False when the file cannot seek.
  bool rewind();

  [[nodiscard]] std::uint32_t sampleRate() const noexcept { return rate_; }
  [[nodiscard]] std::uint16_t channels() const noexcept { return channels_; }

 private:
  struct File;
  std::unique_ptr<File> file_;
  std::uint32_t rate_ = 0;
  std::uint16_t channels_ = 0;
};

}  // namespace skr::audio
