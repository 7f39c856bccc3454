// SPDX-License-Identifier: Apache-2.0
#include "ogg_reader.h"

#include <vorbis/vorbisfile.h>

namespace skr::audio {

struct OggReader::File {
  OggVorbis_File vf{};
  bool open = false;
  ~File() {
    if (open) ov_clear(&vf);
  }
};

OggReader::OggReader() = default;
OggReader::~OggReader() = default;

std::string OggReader::open(const std::filesystem::path& path) {
  auto f = std::make_unique<File>();
  const int st = ov_fopen(path.c_str(), &f->vf);
  if (st != 0) {
    return path.string() + " is not a readable Ogg Vorbis file (libvorbisfile error " +
           std::to_string(st) + ")";
  }
  f->open = true;
  const vorbis_info* vi = ov_info(&f->vf, -1);
  if (vi == nullptr || vi->channels < 1 || vi->channels > 8 || vi->rate < 1) {
    return path.string() + ": unsupported stream";
  }
  rate_ = static_cast<std::uint32_t>(vi->rate);
  channels_ = static_cast<std::uint16_t>(vi->channels);
  file_ = std::move(f);
  return {};
}

long OggReader::read(std::vector<std::int16_t>& out, std::size_t frames) {
  if (!file_) return -1;
  const std::size_t start = out.size();
  out.resize(start + frames * channels_);
  auto* at = reinterpret_cast<char*>(out.data() + start);
  const long want = static_cast<long>(frames * channels_ * 2);
  long got = 0;
  while (got < want) {
    int section = 0;
    // Little-endian (0), 16-bit, signed: straight into int16_t samples on this (LE) host.
    const long n = ov_read(&file_->vf, at + got, static_cast<int>(want - got), 0, 2, 1, &section);
    if (n == OV_HOLE) continue;  // a gap in the data: skip it
    if (n < 0) {
      out.resize(start);
      return -1;
    }
    if (n == 0) break;
    got += n;
  }
  const long frames_read = got / (2 * channels_);
  out.resize(start + static_cast<std::size_t>(frames_read) * channels_);
  return frames_read;
}

bool OggReader::rewind() {
  return file_ && ov_pcm_seek(&file_->vf, 0) == 0;
}

}  // namespace skr::audio
