// SPDX-License-Identifier: Apache-2.0
// The shared-memory ring of physical mode (skrobot/runtime/flow/shm_ring.h): delivery in place,
// newest wins, leases against slow readers, dead readers, and writers that break the rules;
// descriptors passed to another process (skrobot/runtime/flow/fd_passing.h).
#include <skrobot/runtime/flow/fd_passing.h>
#include <skrobot/runtime/flow/shm_ring.h>

#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstring>
#include <string>
#include <thread>

namespace skr::flow::shm {
namespace {

std::span<const std::byte> bytes(const std::string& s) {
  return std::as_bytes(std::span(s.data(), s.size()));
}
std::string text(std::span<const std::byte> b) {
  return std::string(reinterpret_cast<const char*>(b.data()), b.size());
}
bool readable(int fd, int timeout_ms = 0) {
  pollfd p{fd, POLLIN, 0};
  return ::poll(&p, 1, timeout_ms) == 1;
}
bool isOpen(int fd) {
  return ::fcntl(fd, F_GETFD) != -1;
}

RingWriter makeWriter(RingGeometry g = {}) {
  auto w = RingWriter::create("skrobot-test-ring", g);
  EXPECT_TRUE(w.ok()) << (w.ok() ? "" : w.error().describe());
  return std::move(*w);
}
RingReader attach(RingWriter& w) {
  auto fds = w.addReader();
  EXPECT_TRUE(fds.ok()) << (fds.ok() ? "" : fds.error().describe());
  auto r = RingReader::open(fds->ring, fds->lease_page, fds->event);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().describe());
  return std::move(*r);
}

TEST(ShmRing, DeliversInPlaceAndWakesTheReader) {
  RingWriter w = makeWriter();
  RingReader r = attach(w);
  EXPECT_FALSE(readable(r.eventFd()));
  EXPECT_FALSE(r.hasNew());
  EXPECT_EQ(r.readLatest([](auto, auto) { FAIL() << "nothing was published"; }),
            ReadStatus::nothing_new);
  ASSERT_TRUE(w.publish(bytes("hello"), 42));
  EXPECT_TRUE(readable(r.eventFd()));
  EXPECT_TRUE(r.hasNew());
  r.drain();
  EXPECT_FALSE(readable(r.eventFd()));
  std::string got;
  SlotInfo info;
  EXPECT_EQ(r.readLatest([&](std::span<const std::byte> b, const SlotInfo& i) {
    got = text(b);
    info = i;
  }),
            ReadStatus::ok);
  EXPECT_EQ(got, "hello");
  EXPECT_FALSE(r.hasNew()) << "read: nothing new for a reader that polls";
  EXPECT_EQ(info.seq, 1u);
  EXPECT_EQ(info.capture_ns, 42);
  EXPECT_EQ(info.missed, 0u);
  EXPECT_EQ(r.readLatest([](auto, auto) { FAIL() << "read twice"; }), ReadStatus::nothing_new);
  EXPECT_EQ(r.received(), 1u);
}

TEST(ShmRing, ZeroCopyWritesAndTheNewestWins) {
  RingWriter w = makeWriter({4, 64, 2});
  RingReader r = attach(w);
  for (int i = 1; i <= 5; ++i) {
    auto slot = w.beginWrite();
    ASSERT_EQ(slot.size(), 64u);
    const std::string m = "message " + std::to_string(i);
    std::memcpy(slot.data(), m.data(), m.size());
    ASSERT_TRUE(w.commit(m.size()));
  }
  std::string got;
  SlotInfo info;
  ASSERT_EQ(r.readLatest([&](auto b, const SlotInfo& i) {
    got = text(b);
    info = i;
  }),
            ReadStatus::ok);
  EXPECT_EQ(got, "message 5");
  EXPECT_EQ(info.missed, 4u);
  EXPECT_EQ(r.missed(), 4u);
  EXPECT_FALSE(w.publish(bytes(std::string(65, 'x'))));  // too big
  EXPECT_EQ(w.dropped(), 1u);
  EXPECT_FALSE(w.commit(1)) << "commit without beginWrite";
}

TEST(ShmRing, ALateReaderMissesNothingItCouldHaveSeen) {
  RingWriter w = makeWriter();
  ASSERT_TRUE(w.publish(bytes("before")));
  RingReader r = attach(w);
  EXPECT_EQ(r.readLatest([](auto, auto) {}), ReadStatus::nothing_new);
  ASSERT_TRUE(w.publish(bytes("after")));
  SlotInfo info;
  ASSERT_EQ(r.readLatest([&](auto, const SlotInfo& i) { info = i; }), ReadStatus::ok);
  EXPECT_EQ(info.seq, 2u);
  EXPECT_EQ(info.missed, 0u);
}

// A reader busy with a slot keeps it: the writer goes round it, and the bytes do not change.
TEST(ShmRing, ALeasedSlotIsNeverOverwritten) {
  RingWriter w = makeWriter({3, 16, 2});
  RingReader r = attach(w);
  ASSERT_TRUE(w.publish(bytes("first")));
  std::string during, after;
  ASSERT_EQ(r.readLatest([&](std::span<const std::byte> b, auto) {
    during = text(b);
    for (int i = 0; i < 10; ++i) ASSERT_TRUE(w.publish(bytes("later " + std::to_string(i))));
    after = text(b);
  }),
            ReadStatus::ok);
  EXPECT_EQ(during, "first");
  EXPECT_EQ(after, "first");
  EXPECT_EQ(r.torn(), 0u);
  std::string next;
  ASSERT_EQ(r.readLatest([&](auto b, auto) { next = text(b); }), ReadStatus::ok);
  EXPECT_EQ(next, "later 9");
}

// Two readers hold both slots of a two-slot ring: the writer drops (and counts) the message.
TEST(ShmRing, EverySlotLeasedDropsTheNewMessage) {
  RingWriter w = makeWriter({2, 16, 2});
  RingReader a = attach(w);
  RingReader b = attach(w);
  ASSERT_TRUE(w.publish(bytes("one")));
  ASSERT_EQ(a.readLatest([&](auto, auto) {
    ASSERT_TRUE(w.publish(bytes("two")));  // the other slot
    ASSERT_EQ(b.readLatest([&](auto, auto) {
      EXPECT_TRUE(w.beginWrite().empty());
      EXPECT_FALSE(w.publish(bytes("three")));
    }),
              ReadStatus::ok);
  }),
            ReadStatus::ok);
  EXPECT_EQ(w.dropped(), 1u);
  EXPECT_TRUE(w.publish(bytes("four"))) << "free again once the readers let go";
}

// A reader that stops (hangs, or dies holding a slot) loses its lease after lease_timeout_ns:
// the writer reuses the slot, and the reader learns that what it read was torn.
TEST(ShmRing, AStaleLeaseStopsCountingAndTheReaderSeesTheTear) {
  RingWriter w = makeWriter({2, 16, 1, 50'000'000});
  RingReader r = attach(w);
  ASSERT_TRUE(w.publish(bytes("old")));
  ReadStatus s = r.readLatest([&](auto, auto) {
    std::this_thread::sleep_for(std::chrono::milliseconds(120));
    for (int i = 0; i < 4; ++i)
      ASSERT_TRUE(w.publish(bytes("new"))) << "a stale lease blocks nothing";
  });
  EXPECT_EQ(s, ReadStatus::torn);
  EXPECT_EQ(r.torn(), 1u);
  EXPECT_EQ(w.dropped(), 0u);
}

TEST(ShmRing, ARemovedReaderIsWokenNoMore) {
  RingWriter w = makeWriter();
  auto fds = w.addReader();
  ASSERT_TRUE(fds.ok());
  auto r = RingReader::open(fds->ring, fds->lease_page, fds->event);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(w.readers(), 1u);
  w.removeReader(fds->lease);
  EXPECT_EQ(w.readers(), 0u);
  ASSERT_TRUE(w.publish(bytes("x")));
  EXPECT_FALSE(readable(r->eventFd()));
}

TEST(ShmRing, AReaderThatPollsIsNotWokenUntilItStops) {
  RingWriter w = makeWriter();
  RingReader polling = attach(w), woken = attach(w);
  polling.setPolling(true);
  ASSERT_TRUE(w.publish(bytes("one")));
  EXPECT_FALSE(readable(polling.eventFd())) << "no system call for a reader that polls";
  EXPECT_TRUE(readable(woken.eventFd()));
  EXPECT_TRUE(polling.hasNew());
  EXPECT_EQ(polling.readLatest([](auto, auto) {}), ReadStatus::ok);
  polling.setPolling(false);
  EXPECT_FALSE(readable(polling.eventFd())) << "nothing new when it stopped polling";
  polling.setPolling(true);
  ASSERT_TRUE(w.publish(bytes("two")));
  polling.setPolling(false);
  EXPECT_TRUE(readable(polling.eventFd())) << "what came while it polled wakes it when it stops";
  polling.drain();
  ASSERT_TRUE(w.publish(bytes("three")));
  EXPECT_TRUE(readable(polling.eventFd())) << "woken again";
}

TEST(ShmRing, ReadersAreCounted) {
  RingWriter w = makeWriter({4, 16, 2});
  auto a = w.addReader();
  auto b = w.addReader();
  ASSERT_TRUE(a.ok() && b.ok());
  auto c = w.addReader();
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.error().code, Errc::overflow);
  for (auto* f : {&*a, &*b}) {
    ::close(f->ring);
    ::close(f->lease_page);
    ::close(f->event);
  }
}

// The reader's descriptor cannot write the ring, and nobody can shrink it under the readers.
TEST(ShmRing, TheRingIsReadOnlyForReadersAndSealed) {
  RingWriter w = makeWriter({2, 4096, 1});
  auto fds = w.addReader();
  ASSERT_TRUE(fds.ok());
  EXPECT_EQ(::mmap(nullptr, 4096, PROT_READ | PROT_WRITE, MAP_SHARED, fds->ring, 0), MAP_FAILED);
  EXPECT_EQ(errno, EACCES);
  EXPECT_NE(::ftruncate(w.fd(), 4096), 0) << "sealed against shrinking";
  EXPECT_EQ(errno, EPERM);
  EXPECT_NE(::ftruncate(w.fd(), 1 << 30), 0) << "and growing";
  auto r = RingReader::open(fds->ring, fds->lease_page, fds->event);
  ASSERT_TRUE(r.ok());
  EXPECT_FALSE(isOpen(fds->ring)) << "the mapping keeps the ring; the descriptor is closed";
}

// A writer that ignores the leases and scribbles on the ring: every read is caught as torn, and
// the reader reads nothing outside the ring.
TEST(ShmRing, AMaliciousWriterIsCaught) {
  RingWriter w = makeWriter({2, 64, 1});
  RingReader r = attach(w);
  auto* raw = static_cast<std::byte*>(
      ::mmap(nullptr, 4096 + 2 * 4096, PROT_READ | PROT_WRITE, MAP_SHARED, w.fd(), 0));
  ASSERT_NE(raw, MAP_FAILED);
  auto* latest = reinterpret_cast<std::atomic<uint64_t>*>(raw + 64);
  // Rewriting the slot being read.
  ASSERT_TRUE(w.publish(bytes("genuine")));
  EXPECT_EQ(r.readLatest([&](auto, auto) {
    const uint64_t slot = latest->load() & 0xFFFF;
    auto* seq = reinterpret_cast<std::atomic<uint64_t>*>(raw + 4096 + slot * 4096);
    seq->fetch_add(2);
    std::memcpy(raw + 4096 + slot * 4096 + 64, "forged!", 7);
  }),
            ReadStatus::torn);
  // A length larger than a slot.
  ASSERT_TRUE(w.publish(bytes("again")));
  const uint64_t slot = latest->load() & 0xFFFF;
  std::memcpy(raw + 4096 + slot * 4096 + 8, "\xff\xff\xff\xff\xff\xff\xff\x7f", 8);
  EXPECT_EQ(r.readLatest([](auto, auto) { FAIL() << "a length beyond the slot"; }),
            ReadStatus::torn);
  // A slot index outside the ring.
  latest->store((100ull << 16) | 7);
  EXPECT_EQ(r.readLatest([](auto, auto) { FAIL() << "no slot 7"; }), ReadStatus::torn);
  EXPECT_EQ(r.torn(), 3u);
  ::munmap(raw, 4096 + 2 * 4096);
}

TEST(ShmRing, ReadersRefuseWhatIsNotARing) {
  auto expectRefused = [](Result<RingReader> r, const std::string& why) {
    ASSERT_FALSE(r.ok()) << why;
    EXPECT_EQ(r.error().code, Errc::protocol_error) << r.error().describe();
  };
  RingWriter w = makeWriter();
  // A pipe, then an unsealed memfd, in the ring's place.
  int p[2];
  ASSERT_EQ(::pipe(p), 0);
  auto fds = w.addReader();
  ASSERT_TRUE(fds.ok());
  const int lease = ::dup(fds->lease_page), event = ::dup(fds->event);
  expectRefused(RingReader::open(p[0], fds->lease_page, fds->event), "a pipe");
  EXPECT_FALSE(isOpen(p[0])) << "descriptors are closed on refusal";
  ::close(p[1]);
  int loose = ::memfd_create("loose", MFD_CLOEXEC);
  ASSERT_EQ(::ftruncate(loose, 3 * 4096), 0);
  expectRefused(RingReader::open(loose, ::dup(lease), ::dup(event)), "an unsealed memfd");
  // A sealed memfd that is not a ring.
  int other = ::memfd_create("other", MFD_CLOEXEC | MFD_ALLOW_SEALING);
  ASSERT_EQ(::ftruncate(other, 3 * 4096), 0);
  ASSERT_EQ(::fcntl(other, F_ADD_SEALS, F_SEAL_SHRINK | F_SEAL_GROW), 0);
  expectRefused(RingReader::open(other, ::dup(lease), ::dup(event)), "no ring header");
  // The ring itself with a lease page that is not sealed.
  int bad_lease = ::memfd_create("lease", MFD_CLOEXEC);
  ASSERT_EQ(::ftruncate(bad_lease, 4096), 0);
  expectRefused(RingReader::open(fds->ring, bad_lease, ::dup(event)), "unsealed lease page");
  ::close(lease);
  ::close(event);
}

TEST(ShmRing, BadGeometryIsRefused) {
  for (RingGeometry g : {RingGeometry{1, 16, 1}, RingGeometry{4, 0, 1}, RingGeometry{4, 16, 0},
                         RingGeometry{4, 16, 65}, RingGeometry{4, 16, 1, 0}}) {
    auto w = RingWriter::create("bad", g);
    ASSERT_FALSE(w.ok());
    EXPECT_EQ(w.error().code, Errc::invalid_argument);
  }
}

// The descriptors cross to another process over a Unix socket; the child reads in place.
TEST(ShmRing, AnotherProcessReadsTheRing) {
  RingWriter w = makeWriter({4, 1 << 20, 1});
  int sv[2];
  ASSERT_EQ(::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::close(sv[0]);
    auto got = receiveWithFds(sv[1], 64);
    if (!got.ok() || got->fds.size() != 3) ::_exit(10);
    auto r = RingReader::open(got->fds[0], got->fds[1], got->fds[2]);
    if (!r.ok()) ::_exit(11);
    (void)!::write(sv[1], "r", 1);  // ready
    if (!readable(r->eventFd(), 5000)) ::_exit(12);
    std::size_t size = 0;
    bool pattern = true;
    const ReadStatus s = r->readLatest([&](std::span<const std::byte> b, auto) {
      size = b.size();
      for (std::size_t i = 0; i < b.size(); ++i) pattern &= b[i] == std::byte(i % 251);
    });
    ::_exit(s == ReadStatus::ok && size == (1u << 20) && pattern ? 0 : 13);
  }
  ::close(sv[1]);
  auto fds = w.addReader();
  ASSERT_TRUE(fds.ok());
  const std::array<int, 3> out{fds->ring, fds->lease_page, fds->event};
  ASSERT_TRUE(sendWithFds(sv[0], "ring", out).ok());
  for (int fd : out) ::close(fd);
  char ready = 0;
  ASSERT_EQ(::read(sv[0], &ready, 1), 1);
  auto slot = w.beginWrite();
  for (std::size_t i = 0; i < slot.size(); ++i) slot[i] = std::byte(i % 251);
  ASSERT_TRUE(w.commit(slot.size()));
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  EXPECT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  ::close(sv[0]);
}

TEST(FdPassing, TooManyDescriptorsAreRefusedAndClosed) {
  int sv[2];
  ASSERT_EQ(::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, sv), 0);
  std::array<int, 9> many{};
  for (int& fd : many) fd = ::eventfd(0, EFD_CLOEXEC);
  EXPECT_FALSE(sendWithFds(sv[0], "x", many).ok()) << "the sender checks too";
  // Sent raw, past the check.
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(int) * 9)] = {};
  char byte = 'x';
  iovec iov{&byte, 1};
  msghdr msg{};
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  msg.msg_control = control;
  msg.msg_controllen = sizeof control;
  cmsghdr* c = CMSG_FIRSTHDR(&msg);
  c->cmsg_level = SOL_SOCKET;
  c->cmsg_type = SCM_RIGHTS;
  c->cmsg_len = CMSG_LEN(sizeof(int) * 9);
  std::memcpy(CMSG_DATA(c), many.data(), sizeof(int) * 9);
  ASSERT_EQ(::sendmsg(sv[0], &msg, 0), 1);
  auto got = receiveWithFds(sv[1], 16);
  ASSERT_FALSE(got.ok());
  EXPECT_EQ(got.error().code, Errc::protocol_error);
  for (int fd : many) ::close(fd);
  ::close(sv[0]);
  ::close(sv[1]);
}

}  // namespace
}  // namespace skr::flow::shm
