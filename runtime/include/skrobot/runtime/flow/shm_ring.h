// SPDX-License-Identifier: Apache-2.0
// The shared-memory path of physical mode (docs/physical-mode.md): one writer (a channel's owner)
// and readers on the same machine share a ring of slots in a memfd. The writer fills a slot in
// place and commits it; each reader is woken through an eventfd of its own and reads the newest
// message in place, with no copy. Newest wins: a reader that was busy skips to the latest message
// and counts what it missed.
//
// Safety against the other side, which is another process:
// - The memfd is sealed against shrinking and growing, so a reader's mapping can never turn into
//   SIGBUS; a reader refuses a descriptor without those seals, or too small for its header.
// - A reader gets the ring read-only (a descriptor opened O_RDONLY: it cannot write a byte of it)
//   and a lease page of its own (a second small memfd shared with the writer alone), so a reader
//   can disturb nobody but itself. It bounds-checks what it reads (slot index, length).
// - Torn reads are detected: each slot has a sequence number, odd while written, checked before
//   and after the reader's callback (a seqlock). A reader leases the slot it reads and a writer
//   skips leased slots, so an honest writer never tears a read; a malicious one is caught.
// - A lease counts only while its reader's heartbeat is fresh (lease_timeout_ns), so a reader
//   that hangs or dies holds a slot for that long at most; removeReader() frees it at once.
//
// Layout (the machine's byte order): page 0 the header, then `slots` slots of `slot_stride` bytes
// (a 64-byte slot header, then the payload; page-aligned). A lease page holds the slot its reader
// reads (+1; 0 none), the reader's heartbeat, and whether it polls (then it is not woken).
//
// Threads: a RingWriter and a RingReader are each used by one thread at a time.
#pragma once

#include <skrobot/runtime/result.h>

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

namespace skr::flow::shm {

struct RingGeometry {
  uint32_t slots = 4;
  uint64_t slot_bytes = 1u << 20;  // the largest message
  uint32_t max_readers = 4;        // at most 64
  int64_t lease_timeout_ns = 2'000'000'000;
};

// What a reader learns about a message besides its bytes.
struct SlotInfo {
  uint64_t seq = 0;        // the writer's message number, from 1
  int64_t capture_ns = 0;  // what the writer said (e.g. the media frame's capture time)
  uint64_t missed = 0;     // messages published since the previous one this reader got
};

enum class ReadStatus { nothing_new, ok, torn };

class RingWriter {
 public:
  RingWriter() = default;
  ~RingWriter();
  RingWriter(RingWriter&& other) noexcept;
  RingWriter& operator=(RingWriter&& other) noexcept;
  RingWriter(const RingWriter&) = delete;
  RingWriter& operator=(const RingWriter&) = delete;

  // A new ring: a memfd named `name` (shown in /proc/<pid>/fd), sized, sealed and mapped.
  [[nodiscard]] static Result<RingWriter> create(const std::string& name, RingGeometry geometry);

  [[nodiscard]] int fd() const noexcept { return fd_; }
  [[nodiscard]] const RingGeometry& geometry() const noexcept { return geometry_; }

  // Descriptors for a new reader (pass them with sendmsg, then close them here): the ring
  // read-only, its lease page, the eventfd that wakes it. Errc::overflow when max_readers are
  // attached. `lease` names the reader for removeReader().
  struct ReaderFds {
    int ring = -1, lease_page = -1, event = -1;
    uint32_t lease = 0;
  };
  [[nodiscard]] Result<ReaderFds> addReader();
  // Its lease no longer counts and it is woken no more (a reader gone, or whose grant was revoked).
  void removeReader(uint32_t lease) noexcept;
  [[nodiscard]] uint32_t readers() const noexcept;

  // The next slot to fill in place: the oldest that no live reader leases. Empty when every slot
  // is leased (counted in dropped() if nothing is committed). Valid until commit() or the next
  // beginWrite().
  [[nodiscard]] std::span<std::byte> beginWrite() noexcept;
  // Publishes the first `size` bytes (<= slot_bytes) of the slot from beginWrite() and wakes
  // every reader. False without a slot.
  bool commit(std::size_t size, int64_t capture_ns = 0) noexcept;
  // beginWrite, copy, commit. False (counted) when no slot is free or the message is too big.
  bool publish(std::span<const std::byte> data, int64_t capture_ns = 0) noexcept;

  [[nodiscard]] uint64_t published() const noexcept { return seq_; }
  [[nodiscard]] uint64_t dropped() const noexcept { return dropped_; }

 private:
  void close() noexcept;

  int fd_ = -1;
  std::byte* base_ = nullptr;
  std::size_t size_ = 0;
  RingGeometry geometry_;
  uint64_t slot_stride_ = 0;
  uint64_t seq_ = 0;  // messages committed (ours: never read back from the shared pages)
  uint64_t dropped_ = 0;
  int64_t writing_ = -1;  // the slot between beginWrite and commit
  uint64_t reader_mask_ = 0;
  struct Reader {
    int event = -1;
    std::byte* lease_page = nullptr;
  };
  Reader readers_[64];
};

class RingReader {
 public:
  RingReader() = default;
  ~RingReader();
  RingReader(RingReader&& other) noexcept;
  RingReader& operator=(RingReader&& other) noexcept;
  RingReader(const RingReader&) = delete;
  RingReader& operator=(const RingReader&) = delete;

  // Maps a ring received from its writer, taking ownership of the three descriptors (closed on
  // failure too). Refuses (Errc::protocol_error, with the reason) descriptors that are not
  // sealed memfds of the sizes the header says, or a header that is not a ring's.
  [[nodiscard]] static Result<RingReader> open(int ring_fd, int lease_fd, int event_fd);

  // Readable when something was published since drain() (watch it with poll or the loop).
  [[nodiscard]] int eventFd() const noexcept { return eventfd_; }
  void drain() noexcept;

  // Reads the newest message not read yet in place: `fn(bytes, info)` runs while the slot is
  // leased. torn: the slot changed under the read (a writer that ignored the lease, or one that
  // wrote nonsense): do not trust what fn saw. The view is valid only inside fn.
  template <typename Fn>
  ReadStatus readLatest(Fn&& fn) {
    Claim c = claim();
    if (c.status != ReadStatus::ok) return c.status;
    fn(std::span<const std::byte>(c.data, c.size), c.info);
    return release(c);
  }
  // Keeps the lease alive while nothing is read (readLatest renews it too).
  void heartbeat() noexcept;
  // Whether a message newer than the last one read was committed: one load of shared memory, no
  // system call (for a reader that polls instead of waiting for the eventfd).
  [[nodiscard]] bool hasNew() const noexcept;
  // While on, the writer leaves this reader's eventfd alone (it saves a system call per message):
  // for a reader that calls hasNew() often enough by itself. Turning it off wakes the reader
  // through its eventfd if a message came meanwhile.
  void setPolling(bool on) noexcept;

  [[nodiscard]] const RingGeometry& geometry() const noexcept { return geometry_; }
  [[nodiscard]] uint64_t received() const noexcept { return received_; }
  [[nodiscard]] uint64_t missed() const noexcept { return missed_; }
  [[nodiscard]] uint64_t torn() const noexcept { return torn_; }

 private:
  struct Claim {
    ReadStatus status = ReadStatus::nothing_new;
    uint32_t slot = 0;
    uint64_t begin_seq = 0;
    const std::byte* data = nullptr;
    std::size_t size = 0;
    SlotInfo info;
  };
  Claim claim() noexcept;
  ReadStatus release(const Claim& c) noexcept;
  void close() noexcept;

  int eventfd_ = -1;
  const std::byte* base_ = nullptr;  // the ring, read-only
  std::size_t size_ = 0;
  std::byte* lease_page_ = nullptr;  // ours, writable
  RingGeometry geometry_;
  uint64_t slot_stride_ = 0;
  uint64_t last_seq_ = 0;
  bool polling_ = false;
  uint64_t received_ = 0, missed_ = 0, torn_ = 0;
};

}  // namespace skr::flow::shm
