// SPDX-License-Identifier: Apache-2.0
#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/flow/shm_ring.h>

#include <fcntl.h>
#include <sys/eventfd.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <new>
#include <utility>

namespace skr::flow::shm {
namespace {

constexpr uint32_t kMagic = 0x47524B53;  // "SKRG"
constexpr uint16_t kVersion = 1;
constexpr std::size_t kPage = 4096;
constexpr std::size_t kSlotHeader = 64;
constexpr uint32_t kMaxSlots = 4096;
constexpr uint32_t kMaxReaders = 64;
constexpr uint64_t kMaxSlotBytes = 1ull << 32;
constexpr int kSeals = F_SEAL_SHRINK | F_SEAL_GROW;

struct Fixed {  // written once, before any reader
  uint32_t magic;
  uint16_t version;
  uint16_t header_bytes;
  uint32_t slots;
  uint32_t max_readers;
  uint64_t slot_bytes;
  uint64_t slot_stride;
  int64_t lease_timeout_ns;
};
struct Header {
  Fixed fixed;
  alignas(64) std::atomic<uint64_t> latest;  // (message seq << 16) | slot; 0: nothing yet
};
struct SlotHeader {
  std::atomic<uint64_t> seq;  // 2n once message n is in place, 2n + 1 while it is written
  uint64_t size;
  int64_t capture_ns;
};
struct Lease {
  std::atomic<uint64_t> slot_plus1;  // the slot being read + 1; 0: none
  std::atomic<int64_t> heartbeat_ns;
  // 1 while the reader polls the ring itself (RingReader::setPolling): the writer does not write
  // its eventfd. 0 on a new page, and for readers that predate it: always woken.
  std::atomic<uint32_t> polling;
};
static_assert(std::atomic<uint64_t>::is_always_lock_free);
static_assert(sizeof(Header) <= kPage && sizeof(SlotHeader) <= kSlotHeader);

uint64_t strideFor(uint64_t slot_bytes) {
  return (kSlotHeader + slot_bytes + kPage - 1) / kPage * kPage;
}

Error sysError(const std::string& what) {
  return makeError(Errc::io_error, what + ": " + std::strerror(errno));
}
Error refused(const std::string& why) {
  return makeError(Errc::protocol_error, "shared-memory ring refused: " + why);
}

void closeFd(int& fd) noexcept {
  if (fd >= 0) ::close(fd);
  fd = -1;
}

// A sealed memfd of `size` bytes.
Result<int> sealedMemfd(const std::string& name, std::size_t size) {
  int fd = ::memfd_create(name.c_str(), MFD_CLOEXEC | MFD_ALLOW_SEALING);
  if (fd < 0) return sysError("memfd_create " + name);
  if (::ftruncate(fd, static_cast<off_t>(size)) != 0 ||
      ::fcntl(fd, F_ADD_SEALS, kSeals | F_SEAL_SEAL) != 0) {
    Error e = sysError("sizing and sealing " + name);
    ::close(fd);
    return e;
  }
  return fd;
}

// The size of a descriptor that must be a sealed memfd, or the reason it is not one.
Result<std::size_t> sealedSize(int fd, const char* what) {
  const int seals = ::fcntl(fd, F_GET_SEALS);
  if (seals < 0)
    return refused(std::string(what) + " is not a memfd (" + std::strerror(errno) + ")");
  if ((seals & kSeals) != kSeals)
    return refused(std::string(what) + " is not sealed against resizing");
  struct stat st {};
  if (::fstat(fd, &st) != 0) return sysError(std::string("fstat ") + what);
  return static_cast<std::size_t>(st.st_size);
}

Lease* leaseOf(std::byte* page) {
  return std::launder(reinterpret_cast<Lease*>(page));
}

}  // namespace

// --- RingWriter ------------------------------------------------------------------------------

RingWriter::~RingWriter() {
  close();
}

RingWriter::RingWriter(RingWriter&& other) noexcept {
  *this = std::move(other);
}

RingWriter& RingWriter::operator=(RingWriter&& other) noexcept {
  if (this == &other) return *this;
  close();
  fd_ = std::exchange(other.fd_, -1);
  base_ = std::exchange(other.base_, nullptr);
  size_ = std::exchange(other.size_, 0);
  geometry_ = other.geometry_;
  slot_stride_ = other.slot_stride_;
  seq_ = other.seq_;
  dropped_ = other.dropped_;
  writing_ = std::exchange(other.writing_, -1);
  reader_mask_ = std::exchange(other.reader_mask_, 0);
  for (uint32_t i = 0; i < kMaxReaders; ++i) readers_[i] = std::exchange(other.readers_[i], {});
  return *this;
}

void RingWriter::close() noexcept {
  for (uint32_t i = 0; i < kMaxReaders; ++i) {
    if ((reader_mask_ >> i) & 1u) removeReader(i);
  }
  if (base_ != nullptr) ::munmap(base_, size_);
  base_ = nullptr;
  closeFd(fd_);
}

Result<RingWriter> RingWriter::create(const std::string& name, RingGeometry g) {
  if (g.slots < 2 || g.slots > kMaxSlots || g.slot_bytes == 0 || g.slot_bytes > kMaxSlotBytes ||
      g.max_readers == 0 || g.max_readers > kMaxReaders || g.lease_timeout_ns <= 0) {
    return makeError(Errc::invalid_argument, "ring geometry: 2.." + std::to_string(kMaxSlots) +
                                                 " slots of 1 B..4 GiB, 1.." +
                                                 std::to_string(kMaxReaders) + " readers");
  }
  RingWriter w;
  w.geometry_ = g;
  w.slot_stride_ = strideFor(g.slot_bytes);
  w.size_ = kPage + g.slots * w.slot_stride_;
  auto fd = sealedMemfd(name, w.size_);
  if (!fd) return fd.error();
  w.fd_ = *fd;
  void* p = ::mmap(nullptr, w.size_, PROT_READ | PROT_WRITE, MAP_SHARED, w.fd_, 0);
  if (p == MAP_FAILED) return sysError("mmap " + name);
  w.base_ = static_cast<std::byte*>(p);
  new (w.base_) Header{Fixed{kMagic, kVersion, static_cast<uint16_t>(kPage), g.slots, g.max_readers,
                             g.slot_bytes, w.slot_stride_, g.lease_timeout_ns},
                       {}};
  for (uint32_t s = 0; s < g.slots; ++s) new (w.base_ + kPage + s * w.slot_stride_) SlotHeader{};
  return w;
}

Result<RingWriter::ReaderFds> RingWriter::addReader() {
  uint32_t lease = 0;
  while (lease < geometry_.max_readers && ((reader_mask_ >> lease) & 1u)) ++lease;
  if (lease == geometry_.max_readers) {
    return makeError(Errc::overflow, "the ring has its " + std::to_string(lease) + " readers");
  }
  ReaderFds out;
  out.lease = lease;
  // The ring again, read-only: the reader cannot write a byte of it.
  const std::string self = "/proc/self/fd/" + std::to_string(fd_);
  out.ring = ::open(self.c_str(), O_RDONLY | O_CLOEXEC);
  if (out.ring < 0) return sysError("reopening the ring read-only (" + self + ")");
  auto page = sealedMemfd("skrobot-lease", kPage);
  if (!page) {
    closeFd(out.ring);
    return page.error();
  }
  out.lease_page = *page;
  void* p = ::mmap(nullptr, kPage, PROT_READ | PROT_WRITE, MAP_SHARED, out.lease_page, 0);
  out.event = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (p == MAP_FAILED || out.event < 0) {
    Error e = sysError("lease page and eventfd");
    if (p != MAP_FAILED) ::munmap(p, kPage);
    closeFd(out.ring);
    closeFd(out.lease_page);
    closeFd(out.event);
    return e;
  }
  new (p) Lease{};
  Reader& r = readers_[lease];
  r.lease_page = static_cast<std::byte*>(p);
  r.event = ::dup(out.event);  // ours; the reader's copy goes out
  if (r.event < 0) {
    Error e = sysError("dup eventfd");
    ::munmap(p, kPage);
    r = {};
    closeFd(out.ring);
    closeFd(out.lease_page);
    closeFd(out.event);
    return e;
  }
  reader_mask_ |= 1ull << lease;
  return out;
}

void RingWriter::removeReader(uint32_t lease) noexcept {
  if (lease >= kMaxReaders || !((reader_mask_ >> lease) & 1u)) return;
  Reader& r = readers_[lease];
  ::munmap(r.lease_page, kPage);
  closeFd(r.event);
  r = {};
  reader_mask_ &= ~(1ull << lease);
}

uint32_t RingWriter::readers() const noexcept {
  return static_cast<uint32_t>(__builtin_popcountll(reader_mask_));
}

std::span<std::byte> RingWriter::beginWrite() noexcept {
  if (base_ == nullptr) return {};
  auto* h = std::launder(reinterpret_cast<Header*>(base_));
  const uint64_t next = seq_ + 1;
  // Round robin from the slot after the newest, so that the newest is the last one reused.
  const uint64_t latest = h->latest.load(std::memory_order_relaxed);
  const uint32_t start =
      latest == 0 ? 0 : static_cast<uint32_t>(((latest & 0xFFFF) + 1) % geometry_.slots);
  if (writing_ >= 0) {
    // beginWrite again without commit: the slot is still marked, reuse it.
    return {base_ + kPage + static_cast<uint64_t>(writing_) * slot_stride_ + kSlotHeader,
            geometry_.slot_bytes};
  }
  const int64_t now = monotonicNs();
  for (uint32_t k = 0; k < geometry_.slots; ++k) {
    const uint32_t s = (start + k) % geometry_.slots;
    auto* sh = std::launder(reinterpret_cast<SlotHeader*>(base_ + kPage + s * slot_stride_));
    const uint64_t before = sh->seq.load(std::memory_order_relaxed);
    // Mark it first, then look at the leases: a reader leases first, then looks at the mark
    // (both sequentially consistent), so one of the two always sees the other.
    sh->seq.store(2 * next + 1, std::memory_order_seq_cst);
    bool leased = false;
    for (uint32_t i = 0; i < kMaxReaders && !leased; ++i) {
      if (!((reader_mask_ >> i) & 1u)) continue;
      Lease* l = leaseOf(readers_[i].lease_page);
      leased = l->slot_plus1.load(std::memory_order_seq_cst) == s + 1 &&
               now - l->heartbeat_ns.load(std::memory_order_relaxed) < geometry_.lease_timeout_ns;
    }
    if (!leased) {
      writing_ = s;
      return {base_ + kPage + s * slot_stride_ + kSlotHeader, geometry_.slot_bytes};
    }
    sh->seq.store(before, std::memory_order_release);  // untouched: put the mark back
  }
  return {};
}

bool RingWriter::commit(std::size_t size, int64_t capture_ns) noexcept {
  if (writing_ < 0 || size > geometry_.slot_bytes) {
    ++dropped_;
    return false;
  }
  const auto s = static_cast<uint64_t>(writing_);
  writing_ = -1;
  auto* sh = std::launder(reinterpret_cast<SlotHeader*>(base_ + kPage + s * slot_stride_));
  const uint64_t n = ++seq_;
  sh->size = size;
  sh->capture_ns = capture_ns;
  sh->seq.store(2 * n, std::memory_order_release);
  // Published, then each reader's polling flag read (both sequentially consistent): a reader
  // that stops polling sets its flag, then looks for news, so one of the two sees the other.
  std::launder(reinterpret_cast<Header*>(base_))
      ->latest.store((n << 16) | s, std::memory_order_seq_cst);
  const uint64_t one = 1;
  for (uint32_t i = 0; i < kMaxReaders; ++i) {
    if (!((reader_mask_ >> i) & 1u)) continue;
    if (leaseOf(readers_[i].lease_page)->polling.load(std::memory_order_seq_cst) == 0) {
      (void)!::write(readers_[i].event, &one, sizeof one);
    }
  }
  return true;
}

bool RingWriter::publish(std::span<const std::byte> data, int64_t capture_ns) noexcept {
  if (data.size() > geometry_.slot_bytes) {
    ++dropped_;
    return false;
  }
  auto slot = beginWrite();
  if (slot.empty()) {
    ++dropped_;
    return false;
  }
  std::memcpy(slot.data(), data.data(), data.size());
  return commit(data.size(), capture_ns);
}

// --- RingReader ------------------------------------------------------------------------------

RingReader::~RingReader() {
  close();
}

RingReader::RingReader(RingReader&& other) noexcept {
  *this = std::move(other);
}

RingReader& RingReader::operator=(RingReader&& other) noexcept {
  if (this == &other) return *this;
  close();
  eventfd_ = std::exchange(other.eventfd_, -1);
  base_ = std::exchange(other.base_, nullptr);
  size_ = std::exchange(other.size_, 0);
  lease_page_ = std::exchange(other.lease_page_, nullptr);
  geometry_ = other.geometry_;
  slot_stride_ = other.slot_stride_;
  last_seq_ = other.last_seq_;
  polling_ = std::exchange(other.polling_, false);
  received_ = other.received_;
  missed_ = other.missed_;
  torn_ = other.torn_;
  return *this;
}

void RingReader::close() noexcept {
  if (base_ != nullptr) ::munmap(const_cast<std::byte*>(base_), size_);
  if (lease_page_ != nullptr) ::munmap(lease_page_, kPage);
  base_ = nullptr;
  lease_page_ = nullptr;
  closeFd(eventfd_);
}

Result<RingReader> RingReader::open(int ring_fd, int lease_fd, int event_fd) {
  RingReader r;
  r.eventfd_ = event_fd;
  struct Closer {
    int& a;
    int& b;
    ~Closer() {
      closeFd(a);
      closeFd(b);
    }
  } closer{ring_fd, lease_fd};  // the mappings outlive the descriptors
  auto size = sealedSize(ring_fd, "the ring");
  if (!size) return size.error();
  auto lease_size = sealedSize(lease_fd, "the lease page");
  if (!lease_size) return lease_size.error();
  if (*size < kPage + kPage || *lease_size < kPage) return refused("too small");
  void* p = ::mmap(nullptr, *size, PROT_READ, MAP_SHARED, ring_fd, 0);
  if (p == MAP_FAILED) return sysError("mmap the ring");
  r.base_ = static_cast<const std::byte*>(p);
  r.size_ = *size;
  // The header as a copy: the writer may change it under us.
  Fixed h{};
  std::memcpy(&h, r.base_, sizeof h);
  if (h.magic != kMagic || h.version != kVersion || h.header_bytes != kPage) {
    return refused("not a ring of version " + std::to_string(kVersion));
  }
  if (h.slots < 2 || h.slots > kMaxSlots || h.slot_bytes == 0 || h.slot_bytes > kMaxSlotBytes ||
      h.max_readers == 0 || h.max_readers > kMaxReaders || h.lease_timeout_ns <= 0 ||
      h.slot_stride != strideFor(h.slot_bytes) || kPage + h.slots * h.slot_stride != *size) {
    return refused("its geometry does not add up");
  }
  r.geometry_ = RingGeometry{h.slots, h.slot_bytes, h.max_readers, h.lease_timeout_ns};
  r.slot_stride_ = h.slot_stride;
  void* lp = ::mmap(nullptr, kPage, PROT_READ | PROT_WRITE, MAP_SHARED, lease_fd, 0);
  if (lp == MAP_FAILED) return sysError("mmap the lease page");
  r.lease_page_ = static_cast<std::byte*>(lp);
  leaseOf(r.lease_page_)->slot_plus1.store(0);
  r.heartbeat();
  // Messages before we came are not ours to miss.
  const uint64_t latest = std::launder(reinterpret_cast<const Header*>(r.base_))
                              ->latest.load(std::memory_order_acquire);
  r.last_seq_ = latest >> 16;
  return r;
}

void RingReader::drain() noexcept {
  uint64_t n = 0;
  (void)!::read(eventfd_, &n, sizeof n);
}

bool RingReader::hasNew() const noexcept {
  if (base_ == nullptr) return false;
  const auto* h = std::launder(reinterpret_cast<const Header*>(base_));
  return (h->latest.load(std::memory_order_acquire) >> 16) > last_seq_;
}

void RingReader::setPolling(bool on) noexcept {
  if (lease_page_ == nullptr || on == polling_) return;
  polling_ = on;
  leaseOf(lease_page_)->polling.store(on ? 1 : 0, std::memory_order_seq_cst);
  if (!on && hasNew()) {
    // Committed while the writer thought we polled: wake ourselves, as it would have.
    const uint64_t one = 1;
    (void)!::write(eventfd_, &one, sizeof one);
  }
}

void RingReader::heartbeat() noexcept {
  if (lease_page_ != nullptr) {
    leaseOf(lease_page_)->heartbeat_ns.store(monotonicNs(), std::memory_order_relaxed);
  }
}

RingReader::Claim RingReader::claim() noexcept {
  Claim c;
  if (base_ == nullptr) return c;
  const auto* h = std::launder(reinterpret_cast<const Header*>(base_));
  Lease* lease = leaseOf(lease_page_);
  for (int attempt = 0; attempt < 4; ++attempt) {
    const uint64_t latest = h->latest.load(std::memory_order_acquire);
    const uint64_t seq = latest >> 16;
    const auto slot = static_cast<uint32_t>(latest & 0xFFFF);
    if (seq == 0 || seq <= last_seq_) return c;  // nothing new
    if (slot >= geometry_.slots) {
      ++torn_;
      last_seq_ = seq;
      c.status = ReadStatus::torn;
      return c;
    }
    lease->heartbeat_ns.store(monotonicNs(), std::memory_order_relaxed);
    lease->slot_plus1.store(slot + 1, std::memory_order_seq_cst);
    const auto* sh =
        std::launder(reinterpret_cast<const SlotHeader*>(base_ + kPage + slot * slot_stride_));
    const uint64_t begin = sh->seq.load(std::memory_order_seq_cst);
    if (begin != 2 * seq) {
      // Rewritten already, or being written: look at the newest again.
      lease->slot_plus1.store(0, std::memory_order_release);
      continue;
    }
    const uint64_t size = sh->size;
    if (size > geometry_.slot_bytes) {
      lease->slot_plus1.store(0, std::memory_order_release);
      ++torn_;
      last_seq_ = seq;
      c.status = ReadStatus::torn;
      return c;
    }
    c.status = ReadStatus::ok;
    c.slot = slot;
    c.begin_seq = begin;
    c.data = base_ + kPage + slot * slot_stride_ + kSlotHeader;
    c.size = size;
    c.info = SlotInfo{seq, sh->capture_ns, seq - last_seq_ - 1};
    return c;
  }
  return c;  // the writer keeps overtaking us: its next wake-up brings us back
}

ReadStatus RingReader::release(const Claim& c) noexcept {
  const auto* sh =
      std::launder(reinterpret_cast<const SlotHeader*>(base_ + kPage + c.slot * slot_stride_));
  std::atomic_thread_fence(std::memory_order_acquire);
  const uint64_t end = sh->seq.load(std::memory_order_relaxed);
  leaseOf(lease_page_)->slot_plus1.store(0, std::memory_order_release);
  last_seq_ = c.info.seq;
  if (end != c.begin_seq) {
    ++torn_;
    return ReadStatus::torn;
  }
  ++received_;
  missed_ += c.info.missed;
  return ReadStatus::ok;
}

}  // namespace skr::flow::shm
