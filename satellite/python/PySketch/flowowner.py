# SPDX-License-Identifier: Apache-2.0
"""Physical mode for PySketch, the owner's side (docs/physical-mode.md, FlowProtocol 1.11).

A channel a FlowSat creates with paths

    sat.addStreamingChannel(name="camera", paths=PATH_SHM | PATH_DIRECT, slotBytes=w * h * 3)

is offered to its subscribers as the C++ owner offers it (runtime/src/paths/paths_owner.cpp),
and this module does what FlowProtocol asks of an owner:
- PHYS_OFFER after each creation of the channel (each login), with the endpoint of a Unix
  socket of ours, /tmp/skrobot-path-<pid>-<n> (anyone may connect: the token lets one in);
- EV_PHYS_GRANT: one connection presenting its token, once, within 10 s, for the kind granted;
  a HELLO that comes before its grant waits 2 s for it. Anything else: WELCOME with an error,
  logged as SAT-PATH-REFUSED;
- shared memory: the channel's ring (shmring.RingWriter, the layout of shm_ring.cpp), its
  read-only descriptor, a lease page and an eventfd passed with WELCOME (SCM_RIGHTS);
- direct: DATA frames (u64 seq, i64 capture_ns, payload), each one write of its head and payload
  gathered, behind a queue of at most 16 MB per subscriber (then dropped);
- EV_PHYS_SWITCH: PHYS_SWITCHED at once with the last message number of that subscriber's path;
- EV_PHYS_RELAY 0/1: stop (and count with PHYS_COUNT each second) or resume publishing to the hub;
- EV_PHYS_REVOKE: the subscriber's socket closed and its lease freed;
- EV_PHYS_RESUME: the messages kept after the subscriber's last (PHYS_REPLAY), then the end with
  the count of those no longer kept. Kept: the last 1 MiB of direct messages of up to 64 KiB,
  while a direct path is served and for 10 s after the last one closed.
Everything runs inside FlowSat.tick(): sockets are non-blocking and in its select().

Direct paths over TCP (the C++ owner's path_tcp) are not offered by PySketch. Python 2.7 (no
memfd, eventfd or descriptor passing): the channel is created and stays relayed.
"""
from __future__ import print_function, division, absolute_import

import collections
import errno
import os
import random
import socket
import struct
import sys
import time

from PySketch import log
from PySketch.flowcodes import PATH_FRAMES
from PySketch.flowproto import (
    FALLBACK_MINOR, PATH_DIRECT, PATH_SHM, physCount, physOffer, physReplayHead, physSwitched,
    utf8)
from PySketch.shmring import WRITER_SUPPORTED, RingWriter, closeFd

__all__ = ["OWNER_SUPPORTED", "Owner"]

OWNER_SUPPORTED = (sys.version_info[0] >= 3 and WRITER_SUPPORTED and
                   hasattr(socket, "send_fds") and sys.platform.startswith("linux"))

HELLO, WELCOME, DATA, BYE = [dict(PATH_FRAMES)[_n] for _n in ("hello", "welcome", "data", "bye")]
MAX_CONTROL_BYTES = 4096
_DATA_HEAD = struct.Struct("<IBQq")      # length, DATA, seq, capture_ns
_GRANT_LIFETIME = 10.0                    # kGrantLifetimeNs
_HELLO_WAIT = 2.0                         # kHelloWaitNs
_KEPT_MESSAGE_BYTES = 64 << 10            # kKeptMessageBytes
_KEPT_BYTES = 1 << 20                     # kKeptBytes
_MAX_PEER_QUEUE = 16 << 20                # kMaxPeerQueue
_SNDBUF = 8 << 20
_PERMISSION_DENIED = 5                    # flow::ErrorCode::permission_denied
_WOULD_BLOCK = (errno.EAGAIN, errno.EWOULDBLOCK, errno.EINTR)

_now = getattr(time, "monotonic", time.time)


def _control(kind, body):
    return struct.pack("<IB", len(body) + 1, kind) + body


def _str16(text):
    b = utf8(text)[:1000]
    return struct.pack("<H", len(b)) + b


def _welcome(error=0, message=""):
    return _control(WELCOME, struct.pack("<H", error) + _str16(message))


def _bye(reason):
    return _control(BYE, _str16(reason))


def _decodeHello(body):
    """(version, path, channel, token) of a HELLO body, or None."""
    try:
        version, path, n = struct.unpack_from("<BBH", body, 0)
        channel = bytes(body[4:4 + n])
        if len(channel) != n:
            return None
        (m,) = struct.unpack_from("<H", body, 4 + n)
        token = bytes(body[6 + n:6 + n + m])
        if len(token) != m or 6 + n + m != len(body) or version != 1:
            return None
        return path, channel.decode("utf-8"), token.decode("utf-8")
    except (struct.error, UnicodeDecodeError):
        return None


class _Served(object):
    """A channel of ours whose paths we offer (paths_impl.h's Served)."""

    def __init__(self, chanID, name, kinds):
        self.chanID = chanID
        self.name = name
        self.kinds = kinds
        self.ring = None
        self.relayNeeded = True
        self.seq = 0                       # direct frames' numbering
        self.kept = collections.deque()    # (seq, bytes) sent on direct paths
        self.keptBytes = 0
        self.keepUntil = 0.0
        self.unrelayed = [0, 0]            # messages, bytes not published to the hub (PHYS_COUNT)


class _Peer(object):
    """A subscriber's connection to our listener (paths_impl.h's Peer)."""

    def __init__(self, sock):
        self.sock = sock
        self.inbuf = bytearray()
        self.out = bytearray()
        self.path = 0           # 0 until WELCOME
        self.chanID = 0
        self.subscriber = 0
        self.lease = -1
        self.pendingHello = None  # a HELLO whose grant has not come yet, until pendingUntil
        self.pendingToken = None
        self.pendingUntil = 0.0
        self.dropped = 0


class Owner(object):
    """The owner's paths of one FlowSat: FlowSat calls the on* methods for the hub's events, adds
    fds() and writing() to its select(), and calls ready(), writable() and tick()."""

    def __init__(self, flow):
        self._flow = flow
        self._listener = None
        self._listenPath = ""
        self._served = {}       # chanID -> _Served
        self._idleRings = {}    # channel name -> RingWriter of a channel not created now
        self._grants = {}       # token -> (chanID, subscriber, path, expires)
        self._peers = {}        # socket -> _Peer
        self._lastTick = 0.0
        self._stats = dict(served_direct=0, served_shm=0)

    def stats(self):
        return dict(self._stats)

    def serves(self, chanID):
        return chanID in self._served

    # --- the channel ----------------------------------------------------------------------------

    def serve(self, chanID, name, kinds, ring):
        """Our channel `name` was created (again) as `chanID`: offer its paths. `ring`: (slots,
        slotBytes) for shared memory."""
        kinds = int(kinds) & (PATH_DIRECT | PATH_SHM)
        if kinds == 0 or not OWNER_SUPPORTED:
            return
        self._ensureListener()
        if self._listener is None:
            return
        sv = _Served(chanID, name, kinds)
        # A channel created again (a reconnection) keeps its ring, and its readers come back.
        sv.ring = self._idleRings.pop(name, None)
        if kinds & PATH_SHM and sv.ring is None:
            try:
                sv.ring = RingWriter.create("skrobot:" + name, ring[0], ring[1], ring[2])
            except (OSError, ValueError) as e:
                log.wrn("FlowSat: SAT-PATH %s: no shared memory (%s); direct only" % (name, e))
                kinds &= ~PATH_SHM
        sv.kinds = kinds
        self._served[chanID] = sv
        if kinds:
            self._flow._send(physOffer(self._flow._nextTag(), chanID, kinds,
                                       "unix:" + self._listenPath))

    def unserve(self, chanID):
        """Our channel is gone (not the flow): its peers closed, its grants dropped; its ring
        waits for a channel of the same name."""
        sv = self._served.get(chanID)
        if sv is None:
            return
        for token in [t for t, g in self._grants.items() if g[0] == chanID]:
            del self._grants[token]
        for p in [p for p in self._peers.values() if p.chanID == chanID]:
            self._closePeer(p, "the channel was removed")
        self._park(sv)
        del self._served[chanID]

    def _park(self, sv):
        if sv.ring is not None:
            self._idleRings[sv.name] = sv.ring
            sv.ring = None

    def reset(self):
        """The flow closed: peers closed, grants void (rings and the listener stay)."""
        for p in list(self._peers.values()):
            self._closePeer(p, "the owner lost the hub")
        self._grants = {}
        for sv in self._served.values():
            self._park(sv)
        self._served = {}

    def closeAll(self, why):
        for p in list(self._peers.values()):
            self._closePeer(p, why)

    def close(self):
        self.reset()
        for ring in self._idleRings.values():
            ring.close()
        self._idleRings = {}
        if self._listener is not None:
            self._listener.close()
            self._listener = None
            try:
                os.unlink(self._listenPath)
            except OSError:
                pass

    def _ensureListener(self):
        if self._listener is not None:
            return
        path = "/tmp/skrobot-path-%d-%d" % (os.getpid(), random.getrandbits(32))
        s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            s.bind(path)
            s.listen(64)
            s.setblocking(False)
            os.chmod(path, 0o666)  # anyone may connect: the token lets one in
        except (socket.error, OSError) as e:
            s.close()
            log.wrn("FlowSat: SAT-PATH cannot listen at %s: %s; paths are not offered"
                    % (path, e))
            return
        self._listener = s
        self._listenPath = path

    # --- the hub's events -----------------------------------------------------------------------

    def onGrant(self, chanID, subscriber, name, path, token):
        if chanID not in self._served:
            return
        self._grants[token] = (chanID, subscriber, path, _now() + _GRANT_LIFETIME)
        # The hub tells both ends at once: the subscriber's HELLO may have come first.
        for p in list(self._peers.values()):
            if p.pendingToken == token:
                hello = p.pendingHello
                p.pendingHello = p.pendingToken = None
                self._welcome(p, hello)
                return

    def onRevoke(self, chanID, subscriber):
        for token in [t for t, g in self._grants.items()
                      if g[0] == chanID and g[1] == subscriber]:
            del self._grants[token]
        for p in [p for p in self._peers.values()
                  if p.chanID == chanID and p.subscriber == subscriber]:
            self._closePeer(p, "revoked by the hub")

    def onRelay(self, chanID, needed):
        """EV_PHYS_RELAY for a channel of ours: True (taken)."""
        sv = self._served.get(chanID)
        if sv is None:
            return False
        sv.relayNeeded = needed != 0
        return True

    def onSwitch(self, chanID, subscriber, switchID):
        """EV_PHYS_SWITCH (1.9): PHYS_SWITCHED at once, with the last number of its path."""
        sv = self._served.get(chanID)
        if sv is None:
            return
        for p in self._peers.values():
            if p.chanID != chanID or p.subscriber != subscriber or p.path == 0:
                continue
            seq = sv.ring.published() if p.path == PATH_SHM and sv.ring is not None else sv.seq
            self._flow._send(physSwitched(chanID, subscriber, switchID, seq))
            return
        # No such peer (it left since): its subscriber falls back, and the hub drops the switch.

    def onResume(self, chanID, subscriber, resumeID, after):
        """EV_PHYS_RESUME (1.11): what we kept after `after`, then the end; relayed from here."""
        sv = self._served.get(chanID)
        if sv is None:
            return  # gone with its channel: the hub relays without us
        replayed = 0
        for seq, payload in sv.kept:
            if seq <= after:
                continue
            self._flow._send(physReplayHead(chanID, subscriber, resumeID, 0, 0, len(payload)) +
                             payload)
            replayed += 1
        lost = sv.seq - after - replayed if sv.seq > after else 0
        self._flow._send(physReplayHead(chanID, subscriber, resumeID, 1, lost, 0))
        sv.relayNeeded = True  # the subscriber is relayed from here on
        if lost:
            log.wrn("FlowSat: SAT-PATH-LOST %s: %d messages for flow %d were no longer kept when "
                    "its path broke" % (sv.name, lost, subscriber))

    # --- publishing -----------------------------------------------------------------------------

    def publish(self, chanID, payload, captureNs=0):
        """Delivers on our paths (a copy into a ring slot when the ring has readers); True when
        it must also go through the hub (someone is relayed)."""
        sv = self._served.get(chanID)
        if sv is None:
            return True
        if sv.ring is not None and sv.ring.readers() > 0:
            sv.ring.publish(payload, captureNs)
        return self._sendDirect(sv, payload, captureNs)

    def beginPublish(self, chanID):
        """The ring slot to fill in place (a writable memoryview), or None (no ring, or every
        slot leased)."""
        sv = self._served.get(chanID)
        if sv is None or sv.ring is None:
            return None
        return sv.ring.beginWrite()

    def commitPublish(self, chanID, size, captureNs=0):
        """Commits the slot of beginPublish: (its bytes, relay) or None without one."""
        sv = self._served.get(chanID)
        if sv is None or sv.ring is None or not sv.ring.commit(size, captureNs):
            return None
        # The direct paths and the hub get the bytes from the slot, unchanged until the next
        # beginPublish.
        data = sv.ring.slotBytesAt(size)
        return data, self._sendDirect(sv, data, captureNs)

    def _sendDirect(self, sv, payload, captureNs):
        sv.seq += 1
        size = len(payload)
        head = None
        direct = False
        for p in list(self._peers.values()):
            if p.chanID != sv.chanID or p.path != PATH_DIRECT:
                continue
            direct = True
            if head is None:
                head = _DATA_HEAD.pack(1 + 16 + size, DATA, sv.seq, captureNs)
            if len(p.out) + len(head) + size > _MAX_PEER_QUEUE:
                p.dropped += 1  # a slow direct subscriber: this one is dropped
                continue
            if p.out:
                p.out += head
                p.out += payload
                continue
            # Straight to the socket when nothing waits: head and payload in one write.
            try:
                done = p.sock.sendmsg([head, payload])
            except (socket.error, OSError) as e:
                if e.errno not in _WOULD_BLOCK:
                    continue  # broken: its reading side sees the close
                done = 0
            if done < len(head):
                p.out += head[done:]
                p.out += payload
            elif done - len(head) < size:
                p.out += memoryview(payload)[done - len(head):]
        if (direct or (sv.keepUntil and _now() < sv.keepUntil)) and \
                self._flow.hubMinor >= FALLBACK_MINOR:
            self._keep(sv, payload)
        if not sv.relayNeeded:
            sv.unrelayed[0] += 1
            sv.unrelayed[1] += size
        return sv.relayNeeded

    def _keep(self, sv, payload):
        if len(payload) <= _KEPT_MESSAGE_BYTES:
            sv.kept.append((sv.seq, bytes(payload)))
            sv.keptBytes += len(payload)
        while sv.kept and sv.keptBytes > _KEPT_BYTES:
            sv.keptBytes -= len(sv.kept.popleft()[1])

    # --- the loop -------------------------------------------------------------------------------

    def fds(self):
        """What select() reads for us."""
        out = list(self._peers.keys())
        if self._listener is not None:
            out.append(self._listener)
        return out

    def writing(self):
        """Peer sockets with output waiting."""
        return [s for s, p in self._peers.items() if p.out]

    def ready(self, ready):
        for obj in ready:
            if obj is self._listener and obj is not None:
                self._accept()
            else:
                p = self._peers.get(obj)
                if p is not None:
                    self._read(p)

    def writable(self, ready):
        for obj in ready:
            p = self._peers.get(obj)
            if p is None or not p.out:
                continue
            try:
                n = p.sock.send(p.out)
            except (socket.error, OSError) as e:
                if e.errno not in _WOULD_BLOCK:
                    self._closePeer(p, os.strerror(e.errno or 0) or str(e))
                continue
            del p.out[:n]

    def tick(self):
        """About once a second: PHYS_COUNT, expired grants, HELLOs whose grant never came."""
        t = _now()
        if t - self._lastTick < 1.0:
            return
        self._lastTick = t
        for chanID, sv in self._served.items():
            if sv.unrelayed[0]:
                self._flow._send(physCount(chanID, sv.unrelayed[0], sv.unrelayed[1]))
                sv.unrelayed = [0, 0]
        for token in [k for k, g in self._grants.items() if g[3] < t]:
            del self._grants[token]
        for p in list(self._peers.values()):
            if p.pendingHello is not None and p.pendingUntil <= t:
                self._refuse(p, "no such grant (a token is good once, for 10 s)")

    # --- peers ----------------------------------------------------------------------------------

    def _accept(self):
        while True:
            try:
                s, _ = self._listener.accept()
            except (socket.error, OSError):
                return
            s.setblocking(False)
            try:
                # Room for a large frame in the kernel: fewer trips through the loop per frame.
                s.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, _SNDBUF)
            except (socket.error, OSError):
                pass
            self._peers[s] = _Peer(s)

    def _read(self, p):
        try:
            data = p.sock.recv(4096)
        except (socket.error, OSError) as e:
            if e.errno in _WOULD_BLOCK:
                return
            return self._closePeer(p, os.strerror(e.errno or 0) or str(e))
        if not data:
            return self._closePeer(p, "the subscriber left")
        # Nothing is expected after HELLO but BYE or the close.
        if p.path != 0 or p.pendingHello is not None:
            return
        p.inbuf += data
        if len(p.inbuf) < 4:
            return
        (n,) = struct.unpack_from("<I", p.inbuf, 0)
        if n == 0 or n > MAX_CONTROL_BYTES or (len(p.inbuf) >= 5 and p.inbuf[4] != HELLO):
            return self._closePeer(p, "not a path HELLO")
        if len(p.inbuf) >= 4 + n:
            self._welcome(p, bytes(p.inbuf[5:4 + n]))

    def _refuse(self, p, why):
        try:
            p.sock.send(_welcome(_PERMISSION_DENIED, why))
        except (socket.error, OSError):
            pass
        log.wrn("FlowSat: SAT-PATH-REFUSED a path connection: %s" % why)
        self._closePeer(p, why)

    def _welcome(self, p, body):
        hello = _decodeHello(body)
        if hello is None:
            return self._refuse(p, "a malformed HELLO")
        path, channel, token = hello
        g = self._grants.get(token)
        if g is None and p.pendingUntil == 0.0:
            # Its grant may still be on its way to us (the hub sends both at once): wait a while.
            p.pendingHello = body
            p.pendingToken = token
            p.pendingUntil = _now() + _HELLO_WAIT
            return
        if g is None or g[3] < _now() or g[2] != path:
            return self._refuse(p, "no such grant (a token is good once, for 10 s)")
        del self._grants[token]  # once
        chanID, subscriber = g[0], g[1]
        sv = self._served.get(chanID)
        if sv is None or sv.name != channel:
            return self._refuse(p, "not the granted channel")
        p.chanID, p.subscriber = chanID, subscriber
        ok = _welcome()
        if path == PATH_SHM:
            if sv.ring is None:
                return self._refuse(p, "no shared memory here")
            try:
                lease, ringFd, pageFd, eventFd = sv.ring.addReader()
            except OSError as e:
                return self._refuse(p, str(e))
            try:
                # WELCOME is small: a fresh socket takes it whole, without waiting.
                sent = socket.send_fds(p.sock, [ok], [ringFd, pageFd, eventFd])
            except (socket.error, OSError) as e:
                sent = -1
                why = str(e)
            finally:
                for fd in (ringFd, pageFd, eventFd):
                    closeFd(fd)
            if sent != len(ok):
                sv.ring.removeReader(lease)
                return self._closePeer(p, why if sent < 0 else "cannot write WELCOME")
            p.lease = lease
            self._stats["served_shm"] += 1
        elif path == PATH_DIRECT:
            try:
                sent = p.sock.send(ok)
            except (socket.error, OSError):
                sent = -1
            if sent != len(ok):
                return self._closePeer(p, "cannot write WELCOME")
            self._stats["served_direct"] += 1
        else:
            return self._refuse(p, "a path of unknown kind %d" % path)
        p.path = path
        p.inbuf = bytearray()
        log.msg("FlowSat: SAT-PATH-OPEN %s to flow %d by %s" % (
            sv.name, subscriber, "shared memory" if path == PATH_SHM else "a direct socket"))

    def _closePeer(self, p, why):
        if self._peers.pop(p.sock, None) is None:
            return
        sv = self._served.get(p.chanID)
        if p.path == PATH_SHM:
            if sv is not None and sv.ring is not None:
                sv.ring.removeReader(p.lease)
            self._stats["served_shm"] -= 1
        elif p.path == PATH_DIRECT:
            self._stats["served_direct"] -= 1
            # Its subscriber may fall back and ask for what it missed: keep on keeping a while.
            if sv is not None:
                sv.keepUntil = _now() + _GRANT_LIFETIME
        if p.path:
            try:
                if not p.out:  # not in the middle of a frame
                    p.sock.send(_bye(why))
            except (socket.error, OSError):
                pass
            log.msg("FlowSat: SAT-PATH-CLOSED flow %d: %s" % (p.subscriber, why))
        try:
            p.sock.close()
        except (socket.error, OSError):
            pass
