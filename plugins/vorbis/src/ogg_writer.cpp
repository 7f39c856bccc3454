// SPDX-License-Identifier: Apache-2.0
#include "ogg_writer.h"

#include <vorbis/vorbisenc.h>

#include <cstdlib>
#include <ctime>

namespace skr::audio {

struct OggWriter::Codec {
  vorbis_info vi{};
  vorbis_comment vc{};
  vorbis_dsp_state vd{};
  vorbis_block vb{};
  ogg_stream_state os{};
  Codec() {
    vorbis_info_init(&vi);
    vorbis_comment_init(&vc);
  }
  ~Codec() {
    ogg_stream_clear(&os);
    vorbis_block_clear(&vb);
    vorbis_dsp_clear(&vd);
    vorbis_comment_clear(&vc);
    vorbis_info_clear(&vi);
  }
  Codec(const Codec&) = delete;
  Codec& operator=(const Codec&) = delete;
};

OggWriter::OggWriter() = default;
OggWriter::~OggWriter() {
  close();
}

std::string OggWriter::open(const std::filesystem::path& path, std::uint32_t sample_rate,
                            std::uint16_t channels, float quality) {
  close();
  auto codec = std::make_unique<Codec>();
  if (vorbis_encode_init_vbr(&codec->vi, channels, static_cast<long>(sample_rate), quality) != 0) {
    return "libvorbis refuses " + std::to_string(sample_rate) + " Hz, " + std::to_string(channels) +
           " channels at quality " + std::to_string(quality);
  }
  vorbis_comment_add_tag(&codec->vc, "ENCODER", "skrobot vorbis module");
  vorbis_analysis_init(&codec->vd, &codec->vi);
  vorbis_block_init(&codec->vd, &codec->vb);
  std::srand(static_cast<unsigned>(std::time(nullptr)));
  ogg_stream_init(&codec->os, std::rand());

  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) return "cannot create " + path.string();
  file_ = f;
  codec_ = std::move(codec);
  rate_ = sample_rate;
  channels_ = channels;
  bytes_ = 0;
  frames_ = 0;
  failed_ = false;

  ogg_packet header, comments, codebooks;
  vorbis_analysis_headerout(&codec_->vd, &codec_->vc, &header, &comments, &codebooks);
  ogg_stream_packetin(&codec_->os, &header);
  ogg_stream_packetin(&codec_->os, &comments);
  ogg_stream_packetin(&codec_->os, &codebooks);
  ogg_page page;
  while (ogg_stream_flush(&codec_->os, &page) != 0) {  // audio starts on a fresh page
    bytes_ += std::fwrite(page.header, 1, static_cast<size_t>(page.header_len), file_);
    bytes_ += std::fwrite(page.body, 1, static_cast<size_t>(page.body_len), file_);
  }
  return {};
}

bool OggWriter::write(const std::int16_t* samples, std::size_t frames) {
  if (file_ == nullptr || failed_) return false;
  constexpr std::size_t kBlock = 4096;
  for (std::size_t done = 0; done < frames;) {
    const std::size_t n = std::min(kBlock, frames - done);
    float** buf = vorbis_analysis_buffer(&codec_->vd, static_cast<int>(n));
    for (std::size_t i = 0; i < n; ++i) {
      for (std::size_t c = 0; c < channels_; ++c) {
        buf[c][i] = static_cast<float>(samples[(done + i) * channels_ + c]) / 32768.0f;
      }
    }
    vorbis_analysis_wrote(&codec_->vd, static_cast<int>(n));
    done += n;
    if (!drain(false)) return false;
  }
  frames_ += frames;
  return true;
}

bool OggWriter::drain(bool flush_all) {
  while (vorbis_analysis_blockout(&codec_->vd, &codec_->vb) == 1) {
    vorbis_analysis(&codec_->vb, nullptr);
    vorbis_bitrate_addblock(&codec_->vb);
    ogg_packet packet;
    while (vorbis_bitrate_flushpacket(&codec_->vd, &packet) != 0) {
      ogg_stream_packetin(&codec_->os, &packet);
      ogg_page page;
      while ((flush_all ? ogg_stream_flush(&codec_->os, &page)
                        : ogg_stream_pageout(&codec_->os, &page)) != 0) {
        const size_t want = static_cast<size_t>(page.header_len + page.body_len);
        const size_t put =
            std::fwrite(page.header, 1, static_cast<size_t>(page.header_len), file_) +
            std::fwrite(page.body, 1, static_cast<size_t>(page.body_len), file_);
        bytes_ += put;
        if (put != want) failed_ = true;
      }
    }
  }
  return !failed_;
}

void OggWriter::close() {
  if (file_ == nullptr) return;
  vorbis_analysis_wrote(&codec_->vd, 0);  // end of stream: the last page carries the length
  drain(true);
  ogg_page page;
  while (ogg_stream_flush(&codec_->os, &page) != 0) {
    bytes_ += std::fwrite(page.header, 1, static_cast<size_t>(page.header_len), file_);
    bytes_ += std::fwrite(page.body, 1, static_cast<size_t>(page.body_len), file_);
  }
  std::fclose(file_);
  file_ = nullptr;
  codec_.reset();
}

}  // namespace skr::audio
