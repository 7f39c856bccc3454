# SPDX-License-Identifier: Apache-2.0
"""The shared-memory ring of physical mode, both ends (runtime/src/flow/shm_ring.cpp, the same
byte layout): RingReader for a subscriber (flowpaths.py), RingWriter for an owner (flowowner.py).

A ring is one sealed memfd: a 4 KB header (fixed geometry, then at byte 64 the `latest` word,
(message seq << 16) | slot), then `slots` slots of a page-aligned stride, each a 64-byte slot
header (seq: 2n once message n is in place, 2n + 1 while it is written; size; capture_ns) and
the payload. Each reader has a lease page of its own (the slot it reads + 1, its heartbeat, and
whether it polls) and an eventfd the writer writes after each message. The writer never
rewrites a slot a live reader leases (its heartbeat younger than lease_timeout_ns).

Limits: the atomics are read and written as aligned 8-byte words (struct's native "Q", one load
or store on x86-64); the only fence Python offers is a lock, taken between a lease (or a mark)
and the check of the other side. The torn check catches what a weaker ordering would let
through, so a reader on another architecture may see more torn reads, never wrong bytes
delivered as good. Python 3 on Linux (os.memfd_create, os.eventfd for the writer).
"""
from __future__ import print_function, division, absolute_import

import mmap
import os
import struct
import threading
import time

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX
    fcntl = None

__all__ = ["RingReader", "RingRefused", "RingWriter", "WRITER_SUPPORTED"]

_MAGIC = 0x47524B53  # "SKRG"
_VERSION = 1
_PAGE = 4096
_SLOT_HEADER = 64
_MAX_SLOTS = 4096
_MAX_READERS = 64
_MAX_SLOT_BYTES = 1 << 32
_SEALS = 0x0002 | 0x0004  # F_SEAL_SHRINK | F_SEAL_GROW
_F_SEAL_SEAL = 0x0001
_F_ADD_SEALS = getattr(fcntl, "F_ADD_SEALS", 1033)
_F_GET_SEALS = getattr(fcntl, "F_GET_SEALS", 1034)
_FIXED = struct.Struct("=IHHIIQQq")   # magic, version, header_bytes, slots, max_readers,
#                                       slot_bytes, slot_stride, lease_timeout_ns
_LATEST_AT = 64                        # Header::latest, alignas(64)
_WORD = struct.Struct("@Q")            # one aligned load or store (the atomics)
_IWORD = struct.Struct("@q")
_U32 = struct.Struct("@I")
_SLOT = struct.Struct("=QQq")          # seq, size, capture_ns
_SIZE_CAPTURE = struct.Struct("=Qq")   # size, capture_ns (after seq)
_POLLING_AT = 16                       # Lease::polling, after slot_plus1 and heartbeat_ns
_ONE = struct.pack("@Q", 1)            # what wakes an eventfd

# Geometry defaults, as RingGeometry (shm_ring.h).
DEFAULT_SLOTS = 4
DEFAULT_MAX_READERS = 4
DEFAULT_LEASE_TIMEOUT_NS = 2000000000

WRITER_SUPPORTED = (hasattr(os, "memfd_create") and hasattr(os, "eventfd") and
                    fcntl is not None)

_fenceLock = threading.Lock()


def fence():
    """A full barrier on x86-64 (a locked instruction), between a store and a load that must
    not pass it (the seqlock's lease against the writer's mark)."""
    _fenceLock.acquire()
    _fenceLock.release()


def monotonicNs():
    return time.monotonic_ns()


def strideFor(slotBytes):
    return (_SLOT_HEADER + slotBytes + _PAGE - 1) // _PAGE * _PAGE


def closeFd(fd):
    if fd is not None and fd >= 0:
        try:
            os.close(fd)
        except OSError:
            pass


def releaseView(view):
    """Ends a memoryview handed to a callback; False when the callback kept something made from
    it (a numpy array): the mapping then stays alive as long as that does."""
    try:
        view.release()
        return True
    except (BufferError, AttributeError):
        return False


class RingRefused(Exception):
    """A ring (or its descriptors) that the reader will not map."""


def _sealedSize(fd, what):
    try:
        seals = fcntl.fcntl(fd, _F_GET_SEALS)
    except (OSError, IOError) as e:
        raise RingRefused("%s is not a memfd (%s)" % (what, os.strerror(e.errno or 0)))
    if (seals & _SEALS) != _SEALS:
        raise RingRefused("%s is not sealed against resizing" % what)
    return os.fstat(fd).st_size


def _isEventFd(fd):
    try:
        return os.readlink("/proc/self/fd/%d" % fd) == "anon_inode:[eventfd]"
    except OSError:
        return False


class _Claim(object):
    __slots__ = ("slot", "beginSeq", "start", "size", "seq", "captureNs", "missed")


class RingReader(object):
    """The reading end of a shared-memory ring (shm_ring.h's RingReader): maps the ring
    read-only and its lease page read-write, and reads the newest message in place."""

    def __init__(self):
        self.eventFd = -1
        self._ring = None       # mmap, read-only
        self._view = None       # memoryview of it, for the callbacks' slices
        self._lease = None      # mmap of our lease page
        self.size = 0
        self.slots = self.slotBytes = self.stride = 0
        self.maxReaders = 0
        self.leaseTimeoutNs = 0
        self.lastSeq = 0
        self.received = self.missed = self.torn = 0
        self.keptViews = 0      # callbacks that kept something made from their view

    @classmethod
    def open(cls, ringFd, leaseFd, eventFd):
        """Maps a ring received from its owner, taking the three descriptors (closed on failure
        too, the ring's and the lease page's once mapped). RingRefused with the reason."""
        r = cls()
        r.eventFd = eventFd
        try:
            size = _sealedSize(ringFd, "the ring")
            leaseSize = _sealedSize(leaseFd, "the lease page")
            if size < 2 * _PAGE or leaseSize < _PAGE:
                raise RingRefused("too small")
            if not _isEventFd(eventFd):
                raise RingRefused("the wake-up descriptor is not an eventfd")
            try:
                r._ring = mmap.mmap(ringFd, size, mmap.MAP_SHARED, mmap.PROT_READ)
            except (OSError, ValueError, OverflowError) as e:
                raise RingRefused("cannot map the ring: %s" % e)
            r.size = size
            # The header as a copy: the writer may change it under us.
            (magic, version, headerBytes, slots, maxReaders, slotBytes, stride,
             leaseTimeout) = _FIXED.unpack_from(r._ring, 0)
            if magic != _MAGIC or version != _VERSION or headerBytes != _PAGE:
                raise RingRefused("not a ring of version %d" % _VERSION)
            if (slots < 2 or slots > _MAX_SLOTS or slotBytes == 0 or slotBytes > _MAX_SLOT_BYTES or
                    maxReaders == 0 or maxReaders > _MAX_READERS or leaseTimeout <= 0 or
                    stride != strideFor(slotBytes) or _PAGE + slots * stride != size):
                raise RingRefused("its geometry does not add up")
            r.slots, r.slotBytes, r.stride = slots, slotBytes, stride
            r.maxReaders, r.leaseTimeoutNs = maxReaders, leaseTimeout
            try:
                r._lease = mmap.mmap(leaseFd, _PAGE, mmap.MAP_SHARED,
                                     mmap.PROT_READ | mmap.PROT_WRITE)
            except (OSError, ValueError) as e:
                raise RingRefused("cannot map the lease page: %s" % e)
            _WORD.pack_into(r._lease, 0, 0)
            r.heartbeat()
            r._view = memoryview(r._ring)
            # Messages before we came are not ours to miss.
            r.lastSeq = _WORD.unpack_from(r._ring, _LATEST_AT)[0] >> 16
            fl = fcntl.fcntl(eventFd, fcntl.F_GETFL)
            fcntl.fcntl(eventFd, fcntl.F_SETFL, fl | os.O_NONBLOCK)
        except RingRefused:
            r.close()
            raise
        except (OSError, IOError, ValueError, struct.error) as e:
            r.close()
            raise RingRefused(str(e))
        finally:
            closeFd(ringFd)
            closeFd(leaseFd)
        return r

    def fileno(self):
        return self.eventFd

    def drain(self):
        try:
            os.read(self.eventFd, 8)
        except (OSError, IOError):
            pass

    def heartbeat(self):
        if self._lease is not None:
            _IWORD.pack_into(self._lease, 8, monotonicNs())

    def claim(self):
        """Leases the newest message not read yet: a _Claim, None (nothing new, or the writer
        keeps overtaking us: its next wake-up brings us back), or False (torn: counted)."""
        if self._ring is None:
            return None
        ring, lease = self._ring, self._lease
        for _ in range(4):
            latest = _WORD.unpack_from(ring, _LATEST_AT)[0]
            seq, slot = latest >> 16, latest & 0xFFFF
            if seq == 0 or seq <= self.lastSeq:
                return None
            if slot >= self.slots:
                self.torn += 1
                self.lastSeq = seq
                return False
            _IWORD.pack_into(lease, 8, monotonicNs())
            _WORD.pack_into(lease, 0, slot + 1)
            fence()
            head = _PAGE + slot * self.stride
            begin = _WORD.unpack_from(ring, head)[0]
            if begin != 2 * seq:
                # Rewritten already, or being written: look at the newest again.
                _WORD.pack_into(lease, 0, 0)
                continue
            _, size, captureNs = _SLOT.unpack_from(ring, head)
            if size > self.slotBytes:
                _WORD.pack_into(lease, 0, 0)
                self.torn += 1
                self.lastSeq = seq
                return False
            c = _Claim()
            c.slot, c.beginSeq, c.seq, c.captureNs = slot, begin, seq, captureNs
            c.start = head + _SLOT_HEADER
            c.size = size
            c.missed = seq - self.lastSeq - 1
            return c
        return None

    def view(self, c):
        """The claimed slot's bytes in place (read-only memoryview)."""
        return self._view[c.start:c.start + c.size]

    def copy(self, c):
        """The claimed slot's bytes (a copy), or None when the ring was closed meanwhile."""
        if self._ring is None:
            return None
        return self._ring[c.start:c.start + c.size]

    def release(self, c):
        """Ends a claim: True when the slot did not change during the read, False (torn, or the
        ring was closed meanwhile: a callback unsubscribed)."""
        if self._ring is None:
            return False
        fence()
        end = _WORD.unpack_from(self._ring, _PAGE + c.slot * self.stride)[0]
        _WORD.pack_into(self._lease, 0, 0)
        self.lastSeq = c.seq
        if end != c.beginSeq:
            self.torn += 1
            return False
        self.received += 1
        self.missed += c.missed
        return True

    def close(self):
        """Unmaps (a mapping a callback kept a view of stays until that view goes)."""
        if self._view is not None:
            releaseView(self._view)
            self._view = None
        for m in (self._ring, self._lease):
            if m is not None:
                try:
                    m.close()
                except (BufferError, OSError, ValueError):
                    pass
        self._ring = self._lease = None
        closeFd(self.eventFd)
        self.eventFd = -1


class RingWriter(object):
    """The writing end of a ring (shm_ring.h's RingWriter): one sealed memfd mapped read-write,
    a lease page and an eventfd per reader (addReader), the newest message in the slot after
    the newest that no live reader leases."""

    def __init__(self):
        self.fd = -1
        self._ring = None
        self._view = None
        self.size = 0
        self.slots = self.slotBytes = self.stride = 0
        self.maxReaders = 0
        self.leaseTimeoutNs = 0
        self.seq = 0              # messages published (the ring's numbering)
        self.dropped = 0
        self._writing = -1        # the slot marked by beginWrite, not committed yet
        self._readers = {}        # lease index -> (lease page mmap, our eventfd)

    @classmethod
    def create(cls, name, slots=DEFAULT_SLOTS, slotBytes=1 << 20, maxReaders=DEFAULT_MAX_READERS,
               leaseTimeoutNs=DEFAULT_LEASE_TIMEOUT_NS):
        """A new ring; ValueError for a geometry shm_ring.cpp refuses, OSError when the system
        does."""
        if (slots < 2 or slots > _MAX_SLOTS or slotBytes <= 0 or slotBytes > _MAX_SLOT_BYTES or
                maxReaders <= 0 or maxReaders > _MAX_READERS or leaseTimeoutNs <= 0):
            raise ValueError("ring geometry: 2..%d slots of 1 B..4 GiB, 1..%d readers"
                             % (_MAX_SLOTS, _MAX_READERS))
        w = cls()
        w.slots, w.slotBytes, w.maxReaders = slots, slotBytes, maxReaders
        w.leaseTimeoutNs = leaseTimeoutNs
        w.stride = strideFor(slotBytes)
        w.size = _PAGE + slots * w.stride
        try:
            w.fd = _sealedMemfd(name, w.size)
            w._ring = mmap.mmap(w.fd, w.size, mmap.MAP_SHARED, mmap.PROT_READ | mmap.PROT_WRITE)
            w._view = memoryview(w._ring)
            _FIXED.pack_into(w._ring, 0, _MAGIC, _VERSION, _PAGE, slots, maxReaders, slotBytes,
                             w.stride, leaseTimeoutNs)
            # The slot headers and `latest` are zero: a fresh memfd is.
        except Exception:
            w.close()
            raise
        return w

    def published(self):
        return self.seq

    def readers(self):
        return len(self._readers)

    def addReader(self):
        """A new reader: (lease index, ring fd read-only, lease page fd, eventfd), the three
        descriptors the caller's to pass (WELCOME) and then close; OSError when there is no
        room (all max_readers leases taken) or the system refuses."""
        lease = 0
        while lease < self.maxReaders and lease in self._readers:
            lease += 1
        if lease == self.maxReaders:
            raise OSError("the ring has its %d readers" % lease)
        # The ring again, read-only: the reader cannot write a byte of it.
        ringFd = os.open("/proc/self/fd/%d" % self.fd, os.O_RDONLY | os.O_CLOEXEC)
        pageFd = eventFd = ours = -1
        page = None
        try:
            pageFd = _sealedMemfd("skrobot-lease", _PAGE)
            page = mmap.mmap(pageFd, _PAGE, mmap.MAP_SHARED, mmap.PROT_READ | mmap.PROT_WRITE)
            eventFd = os.eventfd(0, os.EFD_CLOEXEC | os.EFD_NONBLOCK)
            ours = os.dup(eventFd)
        except Exception:
            if page is not None:
                page.close()
            for fd in (ringFd, pageFd, eventFd, ours):
                closeFd(fd)
            raise
        self._readers[lease] = (page, ours)
        return lease, ringFd, pageFd, eventFd

    def removeReader(self, lease):
        r = self._readers.pop(lease, None)
        if r is not None:
            r[0].close()
            closeFd(r[1])

    def _leased(self, slot, now):
        for page, _ in self._readers.values():
            if (_WORD.unpack_from(page, 0)[0] == slot + 1 and
                    now - _IWORD.unpack_from(page, 8)[0] < self.leaseTimeoutNs):
                return True
        return False

    def beginWrite(self):
        """A writable memoryview of the slot to fill (slotBytes long), or None when every slot
        is leased. Called again before commit: the same slot."""
        if self._ring is None:
            return None
        if self._writing >= 0:
            start = _PAGE + self._writing * self.stride + _SLOT_HEADER
            return self._view[start:start + self.slotBytes]
        ring = self._ring
        nxt = self.seq + 1
        # Round robin from the slot after the newest, so that the newest is the last one reused.
        latest = _WORD.unpack_from(ring, _LATEST_AT)[0]
        first = 0 if latest == 0 else ((latest & 0xFFFF) + 1) % self.slots
        now = monotonicNs()
        for k in range(self.slots):
            s = (first + k) % self.slots
            head = _PAGE + s * self.stride
            before = _WORD.unpack_from(ring, head)[0]
            # Mark it first, then look at the leases: a reader leases first, then looks at the
            # mark, so one of the two always sees the other.
            _WORD.pack_into(ring, head, 2 * nxt + 1)
            fence()
            if not self._leased(s, now):
                self._writing = s
                return self._view[head + _SLOT_HEADER:head + _SLOT_HEADER + self.slotBytes]
            _WORD.pack_into(ring, head, before)  # untouched: put the mark back
        return None

    def commit(self, size, captureNs=0):
        """Publishes the first `size` bytes of the slot beginWrite gave; False (counted in
        dropped) without one, or when size is over slotBytes."""
        if self._writing < 0 or size < 0 or size > self.slotBytes:
            self.dropped += 1
            return False
        s = self._writing
        self._writing = -1
        ring = self._ring
        head = _PAGE + s * self.stride
        self.seq += 1
        n = self.seq
        _SIZE_CAPTURE.pack_into(ring, head + 8, size, captureNs)
        _WORD.pack_into(ring, head, 2 * n)
        _WORD.pack_into(ring, _LATEST_AT, (n << 16) | s)
        # Published, then each reader's polling flag read: a reader that stops polling sets
        # its flag, then looks for news, so one of the two sees the other.
        fence()
        for page, event in self._readers.values():
            if _U32.unpack_from(page, _POLLING_AT)[0] == 0:
                try:
                    os.write(event, _ONE)
                except OSError:
                    pass  # full (never read): the reader is woken all the same
        return True

    def slotBytesAt(self, size):
        """The committed slot's first `size` bytes (after commit, until the next beginWrite)."""
        latest = _WORD.unpack_from(self._ring, _LATEST_AT)[0]
        start = _PAGE + (latest & 0xFFFF) * self.stride + _SLOT_HEADER
        return self._view[start:start + size]

    def publish(self, data, captureNs=0):
        """Copies `data` (a bytes-like object) into a slot: False (dropped) when it is too long
        or every slot is leased."""
        size = len(data)
        if size > self.slotBytes:
            self.dropped += 1
            return False
        slot = self.beginWrite()
        if slot is None:
            self.dropped += 1
            return False
        try:
            slot[:size] = data
        finally:
            slot.release()
        return self.commit(size, captureNs)

    def close(self):
        for lease in list(self._readers):
            self.removeReader(lease)
        if self._view is not None:
            releaseView(self._view)
            self._view = None
        if self._ring is not None:
            try:
                self._ring.close()
            except (BufferError, OSError, ValueError):
                pass  # a slot view still held by the sketch: unmapped when it goes
            self._ring = None
        closeFd(self.fd)
        self.fd = -1


def _sealedMemfd(name, size):
    fd = os.memfd_create(name, os.MFD_CLOEXEC | os.MFD_ALLOW_SEALING)
    try:
        os.ftruncate(fd, size)
        fcntl.fcntl(fd, _F_ADD_SEALS, _SEALS | _F_SEAL_SEAL)
    except Exception:
        os.close(fd)
        raise
    return fd
