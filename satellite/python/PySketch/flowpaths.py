# SPDX-License-Identifier: Apache-2.0
"""Physical mode for PySketch, the subscriber's side (docs/physical-mode.md, FlowProtocol 1.7;
its marker of 1.9).

A channel's owner (a C++ satellite: PhysicalOptions; a module; a FlowSat: flowowner.py) may
offer to send its messages straight to its subscribers, over a Unix socket of its own (a *direct*
path) or through a ring of slots in shared memory (*shm*), while the hub keeps deciding who may
read what. A FlowSat asks for it with

    sat.usePaths("robot.camera", PATH_SHM | PATH_DIRECT)
    sat.subscribeChannel("robot.camera")

and the data then comes to the same grab-data callback as relayed data (bytes, a copy), or, for
zero copy, to a grab-data-view callback that gets a read-only `memoryview` of the slot in place:

    def onView(chanID, view):          # valid only during the call: copy what you keep
        img = ringArray(view, "uint8")   # a numpy view of it (read-only), no copy
        ...
    sat.setGrabDataViewCallBack(onView)

Keeping `view` (or an array made from it) after the callback returns is not an error Python can
catch: the ring stays mapped (nothing crashes), but the slot is rewritten by later messages.

This module mirrors the C++ subscriber (runtime/src/paths/paths_subscriber.cpp) in what it says
to the hub and to the owner:
- on each subscription to a channel it wants paths for, PHYS_REQUEST; the hub answers
  EV_PHYS_PATH (an endpoint and a one-time token) or EV_ERROR (then asked again later);
- it connects to the endpoint, sends HELLO, and reads WELCOME (for shared memory with three
  descriptors: the ring read-only, its lease page, its eventfd); then PHYS_STATE 1, and the hub
  stops relaying the channel to it and sends a marker. Until the marker the path is not
  consumed: a direct socket is read ahead (16 MB at most, then it waits in the socket; a
  hang-up meanwhile is noticed within a second) but its frames are left alone, a ring's eventfd
  is drained but no slot is read;
- the marker EV_PHYS_MARKER (1.9: a hub and an owner of 1.9) carries `seq`, the owner's last
  message relayed: nothing of the channel is relayed after it. The path's messages numbered
  up to `seq` (a DATA frame's `seq`, a ring slot's sequence number) came through the hub too:
  they are dropped (counted in dropped_before_marker); those after it are delivered in order,
  the frames read ahead first. For shared memory the newest slot is read then, and delivered
  when its number is past `seq`. So nothing is delivered twice, and on a direct path nothing
  is lost at the switch (shared memory: newest wins, as ever);
- the marker EV_PHYS_RELAY 0 (a hub before 1.9, or an owner older than 1.9) has no number:
  everything waiting on the path when it comes is dropped (a direct frame half read is dropped
  once complete), what comes after it is delivered; a message published during the switch can
  be lost (neither relayed nor delivered). Either marker counts only when it answers the
  latest PHYS_STATE 1 of a path still open;
- any break (the socket closed, a malformed or over-long frame, a refused WELCOME or ring,
  EV_PHYS_REVOKE) closes the path, sends PHYS_STATE 0 (relayed again) and asks again after
  1 s, 2 s, 4 s, ... up to 30 s (the C++ library's backoff); a refused PHYS_REQUEST is logged
  (SAT-PATH-REFUSED), not handed to the error callback.

Shared memory (shmring.RingReader) reads the layout of
runtime/include/skrobot/runtime/flow/shm_ring.h: a 4 KB header, then slots of a page-aligned stride (a 64-byte slot header, then the payload). Newest
wins: a busy reader reads the latest message and counts those it missed. A slot is leased while
it is read, and its sequence number (a seqlock: odd while written) is checked before and after:
a changed number is a torn read, never delivered to the bytes callback (the view callback has
already seen it: it is counted). A ring that is not a sealed memfd, whose header does not match
its size, or whose slot index or length points outside it is refused; nothing an owner writes
can make Python read outside the mapping or raise out of tick().

Python 2.7 has no socket.recvmsg (descriptor passing) and no monotonic_ns: there usePaths is
accepted, logged once, and the channel stays relayed.

Limits: the atomics of the ring are read and written as aligned 8-byte words (struct's native
"Q", one load or store on x86-64); the only fence Python offers is a lock, taken between the
lease and the check of the slot. The torn check catches what a weaker ordering would let
through, so a reader on another architecture may see more torn reads, never wrong bytes
delivered as good.
"""
from __future__ import print_function, division, absolute_import

import errno
import os
import select
import socket
import struct
import sys
import time

from PySketch import log
from PySketch.abstractflow import ipFamily, parseAddress
from PySketch.flowcodes import PATH_FRAMES
from PySketch.flowproto import (
    FALLBACK_MINOR, PATH_DIRECT, PATH_SHM, RECEIVED_MINOR, physFallback, physReceived, physRequest,
    physState, utf8)
from PySketch.shmring import RingReader, RingRefused
from PySketch.shmring import closeFd as _closeFd, releaseView as _release

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX
    fcntl = None

__all__ = ["PATH_DIRECT", "PATH_SHM", "PATHS_SUPPORTED", "RingReader", "RingRefused", "Paths",
           "ringArray"]

# Descriptor passing and a monotonic clock in ns: Python 3 on Linux.
PATHS_SUPPORTED = (sys.version_info[0] >= 3 and hasattr(socket.socket, "recvmsg") and
                   hasattr(time, "monotonic_ns") and fcntl is not None and
                   sys.platform.startswith("linux"))

# --- the path socket (runtime/include/skrobot/runtime/flow/path_framing.h) --------------------------------
HELLO, WELCOME, DATA, BYE = [dict(PATH_FRAMES)[_n] for _n in ("hello", "welcome", "data", "bye")]
MAX_CONTROL_BYTES = 4096
MAX_DATA_BYTES = 64 << 20
MAX_DATA_FRAME = MAX_DATA_BYTES + 32   # what the C++ subscriber accepts (kMaxDataFrame)
_DATA_HEAD = 16                        # u64 seq, i64 capture_ns
MAX_PASSED_FDS = 8                     # skrobot/runtime/flow/fd_passing.h

_RETRY_MIN = 1.0   # seconds: kRetryMinNs, doubled for each failure after the first (5 at most) ...
_RETRY_MAX = 30.0  # ... up to kRetryMaxNs
_HEARTBEAT = 1.0   # seconds between heartbeats of an idle lease
_CONNECT_TIMEOUT = 5.0  # seconds a TCP path's connect may take (kConnectTimeoutNs)
_SCRATCH_BYTES = 256 * 1024  # what one recv() of a direct path reads at most ...
_MAX_READS = 64              # ... and how many of them at a time (16 MB)
_MAX_BEFORE_MARKER = 16 << 20  # what a direct path reads ahead before its marker (kMaxBeforeMarker)
_ALL = 1 << 64               # `after` of EV_PHYS_RELAY 0: every message waiting was relayed

_now = getattr(time, "monotonic", time.time)


def _hungUp(sock):
    """Whether the peer of a socket we do not read closed it (data may still wait in it)."""
    try:
        poller = select.poll()
        poller.register(sock, select.POLLRDHUP | select.POLLHUP | select.POLLERR)
        return bool(poller.poll(0))
    except (AttributeError, OSError, ValueError, select.error):
        return False


def ringArray(view, dtype="uint8"):
    """A numpy array over `view` (the grab-data-view callback's memoryview) without a copy, or
    None without numpy. Read-only for shared memory; valid only during the callback."""
    try:
        import numpy
    except ImportError:
        return None
    return numpy.frombuffer(view, dtype=dtype)


class _Path(object):
    """A path we want to one channel we are subscribed to (paths_impl.h's Path)."""

    def __init__(self, name, chanID):
        self.name = name
        self.chanID = chanID
        self.tag = 0          # PHYS_REQUEST in flight
        self.kind = 0
        self.sock = None
        self.ring = None
        self.inbuf = bytearray()
        self.open = False     # WELCOME came
        self.marker = False   # the hub relays no more: what comes on the path is ours
        self.markersDue = 0   # PHYS_STATE 1 sent, their marker not come yet
        self.after = 0        # from the marker: path messages up to this number were relayed
        self.last = 0         # direct: the number of the last message we have (PHYS_FALLBACK)
        self.dropPartial = False  # the direct frame being read began before EV_PHYS_RELAY 0
        self.paused = False   # before the marker, _MAX_BEFORE_MARKER read: reading waits for it
        self.retryAt = 0.0    # 0: not waiting to ask again
        self.failures = 0
        self.connectingUntil = 0.0  # a TCP connect in progress (HELLO waits in `hello`)
        self.hello = b""
        self.unreported = [0, 0, 0]  # messages, bytes, missed not told the hub yet


class Paths(object):
    """The subscriber's paths of one FlowSat. Runs inside its tick(): FlowSat calls the on*
    methods for the hub's events, adds fds() to its select() and calls ready() and tick()."""

    def __init__(self, flow):
        self._flow = flow
        self._wanted = {}     # full channel name -> kinds
        self._paths = {}      # chanID -> _Path
        self._lastTick = 0.0
        self._stats = dict(served_direct=0, served_shm=0, path_messages=0,
                           dropped_before_marker=0, torn=0, fallbacks=0, missed=0)
        self._said = set()
        self._scratch = self._scratchView = None  # what _recv reads into

    # --- what the sketch asks -------------------------------------------------------------------

    def want(self, name, kinds):
        if not PATHS_SUPPORTED:
            if "unsupported" not in self._said:
                self._said.add("unsupported")
                log.wrn("FlowSat: this Python (%d.%d) cannot take paths (no descriptor passing): "
                        "%s stays relayed by the hub" % (sys.version_info[0], sys.version_info[1],
                                                         name))
            return False
        kinds = int(kinds) & (PATH_DIRECT | PATH_SHM)
        if kinds == 0:
            self._wanted.pop(name, None)
        else:
            self._wanted[name] = kinds
        return True

    def wants(self, name):
        return name in self._wanted

    def stats(self):
        return dict(self._stats)

    # --- the flow's events ----------------------------------------------------------------------

    def onSubscribed(self, name, chanID):
        """Subscribed to `name` (again): ask for a path (a path already there is dropped first)."""
        old = self._paths.get(chanID)
        if old is not None:
            self._dropPath(old, tellHub=True)
        if name not in self._wanted:
            return
        p = _Path(name, chanID)
        self._paths[chanID] = p
        self._request(p)

    def onUnsubscribed(self, chanID):
        p = self._paths.pop(chanID, None)
        if p is not None:
            self._closeIo(p)

    def onPath(self, tag, chanID, kind, endpoint, token):
        p = self._paths.get(chanID)
        if p is None or p.tag != tag or tag == 0:
            return
        p.tag = 0
        p.kind = kind
        # The hub answers in order: a marker for an earlier PHYS_STATE 1 of this channel came
        # before this grant, or never comes (1.9: a switch PHYS_STATE 0 cancelled, a grant
        # replaced).
        p.markersDue = 0
        if kind not in (PATH_DIRECT, PATH_SHM):
            return self._fail(p, "a path of unknown kind %d" % kind)
        sock, pending = self._connect(endpoint)
        if sock is None:
            return self._fail(p, "cannot connect to %s" % endpoint)
        p.sock = sock
        name, tok = utf8(p.name), utf8(token)
        body = struct.pack("<BBH", 1, kind, len(name)) + name + struct.pack("<H", len(tok)) + tok
        p.hello = struct.pack("<IB", len(body) + 1, HELLO) + body
        if pending:  # another machine: HELLO once select() says the socket is writable
            p.connectingUntil = _now() + _CONNECT_TIMEOUT
            return
        self._sendHello(p)

    def _sendHello(self, p):
        p.connectingUntil = 0.0
        try:
            p.sock.setblocking(True)  # a HELLO is small: it fits in a fresh socket's buffer
            p.sock.sendall(p.hello)
            p.sock.setblocking(False)
        except (socket.error, OSError):
            return self._fail(p, "cannot send HELLO")
        p.hello = b""

    def onRefused(self, tag, message=""):
        """EV_ERROR for a PHYS_REQUEST: True when it was ours (relayed, asked again later; not
        an error of the sketch's: an owner that has not offered its paths yet is the usual
        case)."""
        for p in self._paths.values():
            if p.tag == tag and tag != 0:
                p.tag = 0
                p.failures += 1
                p.retryAt = _now() + self._backoff(p)
                log.msg("FlowSat: SAT-PATH-REFUSED %s: %s; relayed, asking again in %d s"
                        % (p.name, message, int(self._backoff(p) + 0.5)))
                return True
        return False

    def onStateRefused(self, chanID):
        """EV_ERROR for our PHYS_STATE: no marker comes for it."""
        p = self._paths.get(chanID)
        if p is not None and p.markersDue > 0:
            p.markersDue -= 1

    def onRelay(self, chanID, needed):
        """EV_PHYS_RELAY: to a subscriber, 0 is the marker after its PHYS_STATE 1, from a hub
        before 1.9 or an owner older than 1.9."""
        if needed == 0:
            self._marker(chanID, None)

    def onMarker(self, chanID, seq):
        """EV_PHYS_MARKER (1.9): the marker, with the owner's last message relayed."""
        self._marker(chanID, seq)

    def _marker(self, chanID, after):
        """The hub relays no more. Until now the path was left waiting (a direct socket read
        ahead, a ring not read). With `after`, the path's copies of what was relayed (up to
        that message number) are dropped and the rest delivered; without it (None), what waits
        on the path may have been relayed as well: it is all dropped (a direct frame half read
        is dropped when complete), then the rest is taken, and a message published during the
        switch can be lost."""
        p = self._paths.get(chanID)
        if p is None:
            return
        if p.markersDue > 0:
            p.markersDue -= 1
        if p.markersDue > 0 or not p.open or p.marker:
            return  # the marker of a path that broke since: not this one's
        p.marker = True
        p.after = _ALL if after is None else after
        p.last = 0 if after is None else after  # what was relayed up to the marker
        p.paused = False
        sock = p.sock
        if sock is not None:
            self._frames(p)   # what was read ahead
            if self._paths.get(chanID) is p and p.sock is sock:
                self._recv(p)  # and what waits in the socket
        if p.ring is not None and self._paths.get(chanID) is p:
            p.ring.drain()
            self._readRing(p)
        if self._paths.get(chanID) is not p or not p.open or after is not None:
            return
        p.dropPartial = bool(p.inbuf)
        p.after = 0

    def onRevoke(self, chanID):
        p = self._paths.get(chanID)
        if p is not None and (p.open or p.sock is not None):
            self._fail(p, "revoked by the hub")

    def reset(self):
        """The flow closed: paths are void (asked again when subscribed again)."""
        for p in list(self._paths.values()):
            self._closeIo(p)
        self._paths = {}

    def closeAll(self, why):
        for p in list(self._paths.values()):
            if p.sock is not None or p.ring is not None:
                self._fail(p, why)

    # --- the loop -------------------------------------------------------------------------------

    def fds(self):
        out = []
        for p in self._paths.values():
            if p.sock is not None and not p.connectingUntil and not p.paused:
                out.append(p.sock)
            if p.ring is not None:
                out.append(p.ring)
        return out

    def connecting(self):
        """Path sockets whose TCP connect is in progress: select() them for writing."""
        return [p.sock for p in self._paths.values() if p.sock is not None and p.connectingUntil]

    def writable(self, ready):
        """A TCP connect finished (from select()): HELLO, or the path fails."""
        for obj in ready:
            for p in list(self._paths.values()):
                if obj is p.sock and p.sock is not None and p.connectingUntil:
                    rc = p.sock.getsockopt(socket.SOL_SOCKET, socket.SO_ERROR)
                    if rc != 0:
                        self._fail(p, "cannot connect: %s" % os.strerror(rc))
                    else:
                        self._sendHello(p)

    def ready(self, ready):
        """Handles readable path sockets and eventfds (from select())."""
        for obj in ready:
            for p in list(self._paths.values()):
                if obj is p.sock and p.sock is not None:
                    if not p.open:
                        self._welcome(p)
                    else:
                        self._recv(p)
                elif obj is p.ring and p.ring is not None:
                    p.ring.drain()
                    if p.marker:  # before it, the latest slot is read when it comes
                        self._readRing(p)

    def tick(self):
        """About once a second: leases kept alive, paths asked again, paused paths checked."""
        t = _now()
        if t - self._lastTick < _HEARTBEAT:
            return
        self._lastTick = t
        for p in list(self._paths.values()):
            if p.connectingUntil and p.connectingUntil <= t:
                self._fail(p, "the owner's TCP endpoint does not answer")
            if p.paused and p.sock is not None and _hungUp(p.sock):
                self._fail(p, "the owner closed the path")
            if p.ring is not None:
                p.ring.heartbeat()
            self._report(p)
            if not p.open and p.tag == 0 and p.retryAt and p.retryAt <= t:
                self._request(p)

    # --- inside ---------------------------------------------------------------------------------

    @staticmethod
    def _backoff(p):
        """After `failures` (from 1) in a row: 1 s, doubling to 30 s (paths_impl.h retryAt)."""
        return min(_RETRY_MAX, _RETRY_MIN * (1 << max(0, min(p.failures - 1, 5))))

    def _request(self, p):
        kinds = self._wanted.get(p.name)
        if not kinds:
            return
        p.tag = self._flow._nextTag()
        p.retryAt = 0.0
        self._flow._send(physRequest(p.tag, p.chanID, kinds))

    def _connect(self, endpoint):
        """(socket, pending): a Unix socket connected; a TCP one connecting without blocking
        (pending: wait for it to be writable); (None, False) when it cannot be."""
        endpoint = endpoint if isinstance(endpoint, str) else endpoint.decode("utf-8", "replace")
        try:
            if endpoint.startswith("unix:"):
                where = endpoint[5:]
                if not where or len(utf8(where)) >= 108:
                    return None, False
                s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
                family_addr = where
            elif endpoint.startswith("tcp:"):
                _, (host, port) = parseAddress(endpoint)  # tcp:host:port, tcp:[v6]:port
                family = ipFamily(host)  # a numeric address: no name lookup in the loop
                if family is None:
                    return None, False
                s = socket.socket(family, socket.SOCK_STREAM)
                s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                family_addr = (host, port)
            else:
                return None, False
        except (socket.error, OSError, ValueError):
            return None, False
        try:
            if isinstance(family_addr, tuple):  # TCP
                s.setblocking(False)
                rc = s.connect_ex(family_addr)
                if rc == 0:
                    return s, False
                if rc in (errno.EINPROGRESS, errno.EWOULDBLOCK, errno.EAGAIN):
                    return s, True
                s.close()
                return None, False
            # A local connect does not wait on the network: done blocking, with a bound.
            s.settimeout(2.0)
            s.connect(family_addr)
            return s, False
        except (socket.error, OSError, ValueError):
            s.close()
            return None, False

    def _closeIo(self, p):
        p.connectingUntil = 0.0
        p.paused = False
        p.hello = b""
        if p.ring is not None:
            p.ring.close()
            p.ring = None
        if p.sock is not None:
            try:
                p.sock.close()
            except (socket.error, OSError):
                pass
            p.sock = None
        p.inbuf = bytearray()

    def _counted(self, p, nbytes):
        """A message of `nbytes` delivered from p: in our statistics and in p's next report."""
        self._stats["path_messages"] += 1
        p.unreported[0] += 1
        p.unreported[1] += nbytes

    def _report(self, p):
        """What came on p since the last report, to a hub of 1.10 (PHYS_RECEIVED)."""
        u = p.unreported
        if u[0] == 0 and u[2] == 0:
            return
        if self._flow.hubMinor >= RECEIVED_MINOR:
            self._flow._send(physReceived(p.chanID, u[0], u[1], u[2]))
        p.unreported = [0, 0, 0]

    def _dropPath(self, p, tellHub):
        wasOpen = p.open
        self._closeIo(p)
        self._paths.pop(p.chanID, None)
        if wasOpen and tellHub:
            self._flow._send(physState(p.chanID, False))

    def _fail(self, p, why):
        """The path broke: relayed again, asked again after the backoff (failPath)."""
        if self._paths.get(p.chanID) is not p:
            self._closeIo(p)
            return
        wasOpen = p.open
        # A direct path that carried our messages: the owner (1.11) replays what it lost.
        resume = (p.open and p.marker and p.kind == PATH_DIRECT
                  and self._flow.hubMinor >= FALLBACK_MINOR)
        last = p.last
        self._report(p)
        self._closeIo(p)
        p.open = False
        p.marker = False
        p.after = 0
        p.last = 0
        p.dropPartial = False
        p.tag = 0
        p.failures += 1
        self._stats["fallbacks"] += 1
        p.retryAt = _now() + self._backoff(p)
        if resume:
            self._flow._send(physFallback(p.chanID, last))
        elif wasOpen:
            self._flow._send(physState(p.chanID, False))  # relayed again
        log.wrn("FlowSat: SAT-PATH-FALLBACK %s: %s; relayed by the hub meanwhile" % (p.name, why))

    def _welcome(self, p):
        """The owner's first answer, with its descriptors (one recvmsg, as in C++)."""
        fds = []
        try:
            data, anc, flags, _ = p.sock.recvmsg(
                64 * 1024, socket.CMSG_SPACE(4 * (MAX_PASSED_FDS + 1)),
                getattr(socket, "MSG_CMSG_CLOEXEC", 0))
        except (socket.error, OSError) as e:
            if e.errno in (errno.EAGAIN, errno.EWOULDBLOCK, errno.EINTR):
                return
            return self._fail(p, str(e))
        for level, kind, payload in anc:
            if level == socket.SOL_SOCKET and kind == socket.SCM_RIGHTS:
                n = len(payload) // 4
                fds.extend(struct.unpack("=%di" % n, payload[:4 * n]))
        try:
            if flags & getattr(socket, "MSG_CTRUNC", 8) or len(fds) > MAX_PASSED_FDS:
                return self._fail(p, "too many descriptors with WELCOME")
            if not data:
                return self._fail(p, "the owner closed the path")
            p.inbuf.extend(data)
            buf = p.inbuf
            n = struct.unpack_from("<I", buf, 0)[0] if len(buf) >= 4 else None
            if n is not None and (n == 0 or n > MAX_CONTROL_BYTES):
                return self._fail(p, "the owner did not answer with WELCOME")
            if n is None or len(buf) < 4 + n:
                return self._fail(p, "a WELCOME in pieces")
            if buf[4] != WELCOME or n < 5:
                return self._fail(p, "the owner did not answer with WELCOME")
            error, mlen = struct.unpack_from("<HH", buf, 5)
            if 1 + 4 + mlen != n:
                return self._fail(p, "the owner did not answer with WELCOME")
            if error != 0:
                message = bytes(buf[9:9 + mlen]).decode("utf-8", "replace")
                return self._fail(p, "refused: " + message)
            del p.inbuf[:4 + n]
            if p.kind == PATH_SHM:
                if len(fds) != 3:
                    return self._fail(p, "a shared-memory WELCOME without its three descriptors")
                ringFd, leaseFd, eventFd = fds
                fds = []
                try:
                    p.ring = RingReader.open(ringFd, leaseFd, eventFd)
                except RingRefused as e:
                    return self._fail(p, "shared-memory ring refused: %s" % e)
        finally:
            for fd in fds:
                _closeFd(fd)
        p.open = True
        p.failures = 0
        p.markersDue += 1
        self._flow._send(physState(p.chanID, True))
        log.msg("FlowSat: SAT-PATH-OPEN %s by %s" % (
            p.name, "shared memory" if p.kind == PATH_SHM else "a direct socket"))
        # What came with WELCOME waits for the marker.

    def _recv(self, p):
        """Reads what the path's socket has now; its frames are taken once the marker came.
        Before it, at most _MAX_BEFORE_MARKER is read ahead, then reading waits for it (a
        hang-up meanwhile is seen by tick())."""
        sock = p.sock
        if self._scratch is None:
            self._scratch = bytearray(_SCRATCH_BYTES)
            self._scratchView = memoryview(self._scratch)
        for _ in range(_MAX_READS):
            # Into one buffer that is reused, then appended: a large frame costs one copy here
            # and no allocation of its size per read.
            try:
                got = sock.recv_into(self._scratch)
            except (socket.error, OSError) as e:
                if e.errno in (errno.EAGAIN, errno.EWOULDBLOCK, errno.EINTR):
                    return
                return self._fail(p, os.strerror(e.errno or 0) or str(e))
            if not got:
                self._frames(p)  # what came before the close is ours, after the marker
                if self._paths.get(p.chanID) is p and p.sock is sock:
                    self._fail(p, "the owner closed the path")
                return
            p.inbuf += self._scratchView[:got]
            if not p.marker:
                if len(p.inbuf) >= _MAX_BEFORE_MARKER:
                    p.paused = True  # the rest waits in the socket (then at the owner)
                    return
            else:
                # Each read's frames at once: a length over the limit ends the path before
                # more is read, and what is buffered stays one frame and a read.
                self._frames(p)
            if self._paths.get(p.chanID) is not p or p.sock is not sock or got < _SCRATCH_BYTES:
                return
        # More is waiting: select() says so again, after the hub's socket had its turn.

    def _frames(self, p):
        """DATA frames in the input, once the marker came: those the hub relayed too (their
        number up to the marker's, or all that waited at EV_PHYS_RELAY 0) dropped, the rest
        delivered in order."""
        if not p.marker:
            return  # the hub may still relay what comes here
        buf = p.inbuf
        used = 0
        chan = p.chanID
        try:
            while True:
                if len(buf) - used < 4:
                    break
                n = struct.unpack_from("<I", buf, used)[0]
                if n == 0 or n > MAX_DATA_FRAME:
                    return self._fail(p, "a path frame of %d bytes" % n)
                if len(buf) - used < 4 + n:
                    break
                kind = buf[used + 4]
                start, end = used + 5, used + 4 + n
                used = end
                if kind == BYE:
                    return self._fail(p, "the owner said goodbye")
                if kind != DATA or end - start < _DATA_HEAD:
                    return self._fail(p, "an unexpected path frame")
                p.last = struct.unpack_from("<Q", buf, start)[0]
                if p.dropPartial or p.last <= p.after:
                    p.dropPartial = False
                    self._stats["dropped_before_marker"] += 1
                    continue
                self._counted(p, end - start - _DATA_HEAD)
                # In place: the view callback sees the path's input, the bytes callback a copy.
                self._flow._deliverData(chan, buf, start + _DATA_HEAD, end)
                if self._paths.get(chan) is not p or p.inbuf is not buf:
                    return  # the callback unsubscribed, or the path closed under it
        finally:
            if used and p.inbuf is buf:
                try:
                    del buf[:used]
                except BufferError:  # a view made in the callback was kept: leave it the old one
                    p.inbuf = bytearray(buf[used:])

    def _readRing(self, p):
        """The newest slot, once the marker came: delivered when its number is past the
        marker's, else dropped (relayed too)."""
        ring = p.ring
        c = ring.claim()
        if c is False:
            self._stats["torn"] += 1
            return
        if c is None:
            return
        # Skipped since the last read, or since the marker: those up to it were relayed.
        missed = min(c.missed, c.seq - 1 - p.after) if c.seq > p.after else 0
        self._stats["missed"] += missed
        p.unreported[2] += missed
        if c.seq <= p.after:
            ring.release(c)
            self._stats["dropped_before_marker"] += 1
            return
        flow = self._flow
        data = None
        ok = False
        try:
            if flow._onGrabView is not None:
                view = ring.view(c)
                try:
                    flow._call("grab-data-view", flow._onGrabView, p.chanID, view)
                finally:
                    if not _release(view):
                        ring.keptViews += 1
                        if "kept" not in self._said:
                            self._said.add("kept")
                            log.wrn("FlowSat: a grab-data-view callback kept its view of %s "
                                    "(a numpy array?): it shows later messages; copy instead"
                                    % p.name)
            if flow._onGrab is not None:
                data = ring.copy(c)
        finally:
            closed = ring._ring is None  # the view callback unsubscribed, or reset the paths
            ok = ring.release(c)
            if not ok and not closed:
                self._stats["torn"] += 1
        if not ok:
            return
        self._counted(p, c.size)
        if data is not None:
            flow._call("grab-data", flow._onGrab, p.chanID, data)

