// SPDX-License-Identifier: Apache-2.0
// libFuzzer target: the MCAP reader (tools/mcap) on any bytes, indexed and streaming. A
// malformed file must give an error, never a crash, a leak or an allocation past the limits.
#include <skrobot/mcap/reader.h>

#include <cstddef>
#include <cstdint>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace skr::mcap;
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  // Both with and without CRC checks (the first byte decides), so that damaged chunks are parsed.
  const bool crcs = size > 0 && (data[size - 1] & 1) != 0;
  auto reader = Reader::fromBytes(bytes, {.max_chunk_bytes = 4u << 20, .check_crcs = crcs});
  if (!reader) return 0;
  size_t messages = 0;
  (void)reader->scan({.message = [&](const Message& m) { messages += m.data.size() > 0; }});
  auto summary = reader->readSummary();
  if (!summary) return 0;
  std::string buffer;
  for (const auto& c : summary->chunks) (void)reader->readChunk(c, buffer);
  for (const auto& m : summary->metadata) (void)reader->readMetadata(m);
  return 0;
}
