// SPDX-License-Identifier: Apache-2.0
// An Ogg Vorbis file being written from s16 PCM (libvorbisenc, VBR). One thread at a time.
#pragma once

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

namespace skr::audio {

class OggWriter {
 public:
  OggWriter();
  ~OggWriter();  // closes (finishes the stream)
  OggWriter(const OggWriter&) = delete;
  OggWriter& operator=(const OggWriter&) = delete;
  OggWriter(OggWriter&&) = delete;
  OggWriter& operator=(OggWriter&&) = delete;

  // Creates `path`; quality -0.1..1.0. An error text, empty on success.
  std::string open(const std::filesystem::path& path, std::uint32_t sample_rate,
                   std::uint16_t channels, float quality);
  // `frames` interleaved frames of channels() samples. False after a write error.
  bool write(const std::int16_t* samples, std::size_t frames);
  // Flushes the end of stream and closes the file. Idempotent.
  void close();

  [[nodiscard]] bool isOpen() const noexcept { return file_ != nullptr; }
  [[nodiscard]] std::uint64_t bytes() const noexcept { return bytes_; }
  [[nodiscard]] std::uint64_t frames() const noexcept { return frames_; }
  [[nodiscard]] std::uint32_t sampleRate() const noexcept { return rate_; }
  [[nodiscard]] std::uint16_t channels() const noexcept { return channels_; }

 private:
  struct Codec;
  bool drain(bool flush_all);
  std::unique_ptr<Codec> codec_;
  std::FILE* file_ = nullptr;
  std::uint64_t bytes_ = 0;
  std::uint64_t frames_ = 0;
  std::uint32_t rate_ = 0;
  std::uint16_t channels_ = 0;
  bool failed_ = false;
};

}  // namespace skr::audio
