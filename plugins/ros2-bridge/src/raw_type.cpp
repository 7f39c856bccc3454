// SPDX-License-Identifier: Apache-2.0
#include "raw_type.h"

#include <fastdds/rtps/common/SerializedPayload.h>

#include <cstring>
#include <limits>

namespace skr::ros2_bridge {

namespace rtps = eprosima::fastrtps::rtps;

namespace {
// The history's first reservation per sample; larger samples grow their payload
// (PREALLOCATED_WITH_REALLOC_MEMORY_MODE on every endpoint).
constexpr std::uint32_t kInitialPayloadBytes = 256;
constexpr std::size_t kEncapsulationBytes = 4;
}  // namespace

RawCdrType::RawCdrType(const std::string& dds_type_name) {
  setName(dds_type_name.c_str());
  m_typeSize = kInitialPayloadBytes;
  m_isGetKeyDefined = false;
  auto_fill_type_object(false);
  auto_fill_type_information(false);
}

// RTPS carries a payload in whole 4-byte words: Fast DDS pads a shorter one with zeros, which
// its reader cannot tell from data. As DDS-XTypes says (and Cyclone DDS does), the padding is
// added here and counted in the two low bits of the header's options, which deserialize reads
// back: a sample crosses exactly as written. A sample of a writer that leaves those bits at 0
// (Fast DDS's generated types) arrives with its padding zeros, which a CDR decoder ignores.
namespace {
std::size_t paddingOf(std::size_t size) {
  return (4 - size % 4) % 4;
}
}  // namespace

bool RawCdrType::serialize(void* data, rtps::SerializedPayload_t* payload) {
  const auto* sample = static_cast<const RawCdrSample*>(data);
  const std::size_t size = sample->size();
  const std::size_t padding = paddingOf(size);
  if (size < kEncapsulationBytes || size + padding > payload->max_size) return false;
  std::memcpy(payload->data, sample->data(), size);
  if (padding > 0) {
    std::memset(payload->data + size, 0, padding);
    payload->data[3] = static_cast<rtps::octet>((payload->data[3] & ~3u) | padding);
  }
  payload->length = static_cast<std::uint32_t>(size + padding);
  // The header's second byte: 1 little-endian, 0 big-endian (CDR_LE / CDR_BE, XCDR1).
  payload->encapsulation = (sample->data()[1] & 1) != 0 ? CDR_LE : CDR_BE;
  return true;
}

bool RawCdrType::deserialize(rtps::SerializedPayload_t* payload, void* data) {
  auto* sample = static_cast<RawCdrSample*>(data);
  sample->view = nullptr;
  sample->view_size = 0;
  if (payload->length < kEncapsulationBytes) return false;
  std::size_t size = payload->length;
  const std::size_t padding = payload->data[3] & 3u;
  if (padding > 0 && size >= kEncapsulationBytes + padding) size -= padding;
  sample->owned.assign(reinterpret_cast<const char*>(payload->data), size);
  sample->owned[3] = static_cast<char>(payload->data[3] & ~3u);
  return true;
}

std::function<std::uint32_t()> RawCdrType::getSerializedSizeProvider(void* data) {
  const std::size_t size = static_cast<const RawCdrSample*>(data)->size();
  const std::size_t padded = size + paddingOf(size);
  // A size past 4 GiB cannot be a payload: 0 makes the writer refuse it.
  const auto bytes = padded > std::numeric_limits<std::uint32_t>::max()
                         ? std::uint32_t{0}
                         : static_cast<std::uint32_t>(padded);
  return [bytes] { return bytes; };
}

void* RawCdrType::createData() {
  return new RawCdrSample();
}

void RawCdrType::deleteData(void* data) {
  delete static_cast<RawCdrSample*>(data);
}

bool RawCdrType::getKey(void*, rtps::InstanceHandle_t*, bool) {
  return false;
}

}  // namespace skr::ros2_bridge
