# SPDX-License-Identifier: Apache-2.0
"""FlowSat: a satellite's flow, the one asynchronous connection that carries all its channels.

Typical use in a sketch (run by the executor, which calls setup() once and loop() until it
returns False):

    sat = FlowSat()
    def setup():
        sat.setLogin("guest", "password")
        sat.setTickTimer(0.02)                      # loop() cadence, seconds
        sat.setNewChanCallBack(onChannelAdded)
        if not sat.connect():                       # ROBOT_ADDRESS, default local:/tmp/Robot
            return False
        sat.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_FLOAT, "sine")   # -> guest.sine
        return True
    def loop():
        sat.tick()                                  # sleeps to keep the cadence, runs callbacks
        return sat.isConnected()

Timing: tick() waits until the next absolute deadline (start + k * tick, so the cadence does
not drift; when a loop() overruns, the missed deadlines are skipped) and meanwhile reads the
flow and runs the callbacks for every event that arrives. setSpeedMonitorEnabled(True) prints,
every `check` seconds, the frequency, the requested tick, the corrected tick (how long tick()
actually waited, i.e. the requested tick minus the sketch's own work), the measured tick and
the error (measured - requested) in seconds and percent.

Callbacks (all run inside tick() or connect()):
    setNewChanCallBack(f(ch))            a channel appeared (also every channel present at
                                         connect, and the creator's own channels: that is how
                                         it learns their chanID)
    setDelChanCallBack(f(ch))            a channel went away
    setStartChanPubReqCallBack(f(ch))    an owned streaming channel got its first subscriber
    setStopChanPubReqCallBack(f(ch))     ... and lost its last (ch.isPublishingEnabled follows)
    setGrabDataCallBack(f(chanID, data)) data (bytes) on a subscribed channel
    setGrabDataViewCallBack(f(chanID, view)) the same data as a read-only memoryview, before
                                         the bytes callback, in place (no copy): relayed, in the
                                         flow's input buffer; from a shared-memory path, the
                                         ring's slot. Valid only during the call
    setRequestCallBack(f(chanID, hash, cmdName, value))  a request on an owned service channel;
                                         answer with sendServiceResponse(chanID, hash, value)
    setResponseCallBack(f(chanID, value)) the answer to sendServiceRequest (f(value) works too)
    setErrorCallBack(f(chanName, code, text)) the hub refused a command, e.g. a channel that
                                         another satellite owns already (f(FlowError) works too);
                                         logged as the sketch's error in any case

Errors in callbacks: an exception raised by a callback is the sketch's, not the hub's. It is
logged with its traceback ("FlowSat: the sketch's <kind> callback <name> raised ...") and then
raised unchanged out of tick() (or whichever call ran the callback); the flow stays connected,
the frame that carried the event is consumed, and the next tick() goes on with the next one.
Under the executor the sketch thus ends with that traceback and exit status 1.

Reconnection: when the hub goes away (it stopped or restarted, closed this connection, or sent
a frame that cannot be decoded), the flow notices at once, calls the del-channel callback for
every channel it knew, and tick() keeps trying to reconnect. An attempt never blocks:
connecting and logging in are driven by the following ticks. Delays between attempts grow
whatever the cause: 50 ms, 100 ms, 200 ms, ... doubling up to 2 s, then every 2 s. They go
back to 50 ms only after a connection that logged in and stayed up for 5 s, so a hub that
accepts the login and then closes the connection sees at most a few logins a second, then one
every 2 s. isConnected() stays True meanwhile (use isOnline() for
the state of the socket), so a sketch whose loop() returns sat.isConnected() keeps running.
Once logged in again, the flow re-selects the current database it had selected, re-creates
the channels this satellite had created (same short names, mime and properties, including
variables it set in their databases with setVariable), re-subscribes to the channels it had
subscribed to (by NAME: ids change after a restart; a channel that is not back yet is
subscribed to when it reappears), then calls the new-channel callback for every channel, its
own included when the hub confirms them, so the sketch refreshes its channel ids.
Subscriptions are kept by name in the same way when a publisher goes away and comes back.
setReconnectEnabled(False) turns this off: isConnected() then becomes False when the hub goes.

Physical mode (FlowProtocol 1.7, flowpaths.py): usePaths(name, PATH_SHM | PATH_DIRECT) asks
the hub for a shared-memory or direct path to a channel's owner whenever the flow subscribes to
it; data then comes to the same callbacks, and through the hub again whenever the path breaks.
With a hub and an owner of 1.9, nothing published while the subscriber switches to its path is
lost (EV_PHYS_MARKER). pathStats() counts it. Python 3 only: under Python 2.7 the channel stays
relayed. As an owner (flowowner.py): addStreamingChannel(..., paths=PATH_SHM | PATH_DIRECT,
slotBytes=N) offers the channel's paths; beginPublish(chan) gives a ring slot to fill in place and
commitPublish(chan, size) publishes it (Python 2.7: the channel is relayed).

Not thread-safe: call it from the sketch's thread only.
"""
from __future__ import print_function, division, absolute_import

import errno
import inspect
import select
import socket
import ssl
import struct
import sys
import time
import traceback
from collections import OrderedDict

from PySketch import log
from PySketch.abstractflow import (
    AbstractFlow, FlowChannel, enumLookup, openSocket, tlsCheckHost, tlsFailure, validShortName,
    wrapTls)
from PySketch.elapsedtime import ElapsedTime, now
from PySketch.flowowner import OWNER_SUPPORTED, Owner
from PySketch.flowpaths import Paths
from PySketch.flowproto import (
    CODE_MINOR, PATH_DIRECT, PATH_SHM, PATHS_MINOR, ChanKind_T, ChannelInfo, Code, EnumValue,
    Error_T, Flow_T, FlowError, ProtocolError, Reader, Variant_T, codeName, decodePhysGrant,
    decodePhysMarker, decodePhysPath, decodePhysRelay, decodePhysResume, decodePhysRevoke,
    decodePhysSwitch, encodeValue, errorName, frame,
    integer_types, payloadBuffer, releaseViews, str16, text_type, u16, u32, u64, utf8)
from PySketch.flowsync import FlowSync
from PySketch.mediaframe import channel_type, type_problem

TIMED_REQUEST_MINOR = CODE_MINOR[Code.SERVICE_REQUEST_TIMED]
SYNC_MINOR = CODE_MINOR[Code.SYNC_PULSE]  # the sync pulse
REPLICA_MINOR = CODE_MINOR[Code.REPLICATE_CHANNEL]  # and REPLICATE_STOP
QUEUE_MINOR = CODE_MINOR[Code.SUBSCRIBE_QUEUE]  # a subscription's own queue size
RATE_MINOR = CODE_MINOR[Code.SUBSCRIBE_RATE]  # a subscription's rate cap
WATCH_MINOR = CODE_MINOR[Code.DB_WATCH]  # database watches
_WOULD_BLOCK = (errno.EAGAIN, errno.EWOULDBLOCK, errno.EINTR)
_OUT_LIMIT = 32 * 1024 * 1024   # queued output beyond this waits for the hub (up to 10 s)
_HANDSHAKE_TIMEOUT = 5.0        # connect + login + channel list during a reconnection
_BACKOFF_MIN = 0.05            # first delay before reconnecting, seconds; doubles ...
_BACKOFF_MAX = 2.0             # ... up to this
_STABLE_ONLINE = 5.0           # a connection online this long resets the delay to the minimum
_GATHER = hasattr(socket.socket, "sendmsg")  # Python 3: a frame's head and payload in one write
_PUBLISH_HEAD = struct.Struct("<IBH")        # u32 length, u8 PUBLISH, u16 chanID
_CHAN_ID = struct.Struct("<H")
_READ_ONLY = hasattr(memoryview, "toreadonly")  # Python 3.8+: views handed out are read-only
_SAID = set()                                # what is logged once per process


def _releaseView(view):
    """Ends a view of ours (Python 3; under 2.7 it ends with its last reference); one a sketch
    made a numpy array of stays until that goes."""
    try:
        view.release()
    except (BufferError, AttributeError):
        pass


def _callableName(f):
    name = getattr(f, "__qualname__", None) or getattr(f, "__name__", None)
    return name or repr(f)


def _arity(f):
    """How many positional arguments `f` takes (None: any number)."""
    try:
        if hasattr(inspect, "signature"):
            n = 0
            for p in inspect.signature(f).parameters.values():
                if p.kind == p.VAR_POSITIONAL:
                    return None
                if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD):
                    n += 1
            return n
        target = f  # pragma: no cover - Python 2
        if not (inspect.isfunction(f) or inspect.ismethod(f)):
            target = f.__call__
        spec = inspect.getargspec(target)
        if spec.varargs:
            return None
        n = len(spec.args)
        if inspect.ismethod(target) and target.__self__ is not None:
            n -= 1
        return n
    except (TypeError, ValueError):
        return None


def _refusedChannel(name, error, message, user):
    """The log line of a channel the hub did not create, with what to do about it."""
    if error == Error_T.already_exists:
        advice = ("another satellite owns a channel of that name (another sketch of user %s, or "
                  "this sketch started twice): choose another name, or stop the other satellite "
                  "and add the channel again" % user)
    else:
        advice = "the channel does not exist until it is added again"
    return "SAT-CHANNEL-REFUSED: the hub refused to create the channel %s (%s: %s): %s" % (
        name, errorName(error), message, advice)


class TickTimer(ElapsedTime):
    """FlowSat._timer: the tick settings; stop() gives the seconds since the satellite was made."""

    def __init__(self, interval=0.01, check=1.0):
        ElapsedTime.__init__(self)
        self.interval = interval
        self.check = check


class _Speed(object):
    def __init__(self):
        self.reset(now())

    def reset(self, t):
        self.since = t
        self.count = 0
        self.waited = 0.0
        self.lastReturn = None
        self.sumPeriod = 0.0
        self.periods = 0


class FlowSat(AbstractFlow):
    def __init__(self):
        AbstractFlow.__init__(self)
        self._timer = TickTimer()
        self._deadline = None
        self._speedMonitor = False
        self._speedLabel = None
        self._speed = _Speed()

        self._state = "closed"     # closed | offline | connecting | login | listing | online
        self._wanted = False       # connect() succeeded and close() was not called
        self._reconnect = True
        self._everOnline = False
        self._gen = 0              # bumped whenever the socket is dropped
        self._outbuf = bytearray()
        self._attemptStarted = 0.0
        self._nextAttempt = 0.0
        self._backoff = _BACKOFF_MIN
        self._onlineSince = None
        self._userError = None     # the exception a sketch's callback is raising
        self._listed = None
        self._failure = None
        self._tlsWants = None      # the TLS handshake waits for "read" or "write"
        self._deferred = []        # channels listed at login, announced at the next tick
        self._hold = False         # connect(): leave events in the buffer for tick()
        self._keptView = False     # a view callback kept its view: logged once

        self._channels = OrderedDict()     # chanID -> FlowChannel
        self._byName = {}                  # name -> FlowChannel
        self._specs = OrderedDict()        # short name -> what addXChannel asked for
        self._pendingAdds = {}             # tag -> short name
        self._wantedSubs = set()           # channel names this satellite subscribes to
        self._subscribedIDs = set()        # ... and their ids on this connection
        self._wantedQueues = {}            # channel name -> queue bytes asked for (1.13)
        self._wantedRates = {}             # channel name -> max_hz asked for (1.14)
        self._watches = {}                 # database name -> [callback, tag of its DB_WATCH]
        self._pendingRequests = {}         # tag -> chanID
        self._pendingSyncs = {}            # tag -> callback of syncDatabases()
        self._selectedDb = None            # what setCurrentDbName asked for
        self._tag = 0
        self._errorsLogged = {}
        self._paths = Paths(self)          # physical mode, the subscriber's side
        self._owner = Owner(self)          # ... and the owner's
        self._scratch = {}                 # chanID -> beginPublish's buffer without a ring slot
        self._slots = {}                   # chanID -> the ring slot beginPublish gave

        self._onNewChan = None
        self._onDelChan = None
        self._onStartPub = None
        self._onStopPub = None
        self._onGrab = None
        self._onGrabView = None
        self._onRequest = None
        self._onResponse = None
        self._responseArity = None
        self._onChanHeader = None
        self._onDbChanged = None
        self._onBlobChanged = None
        self._onError = None
        self._errorArity = None
        self.lastRequester = None

        # The sync pulse (docs/sync-pulse.md): the sources followed, by name -> every Nth pulse.
        self._follows = {}
        self._replicas = {}                # short name -> source, asked again on reconnection
        self._syncTimeout = None   # seconds without a pulse before the own timer takes over
        self._syncStrict = False   # ... or tick() waits for pulses
        self._pulse = None         # (chanID, seq, sourceTimeNs, dropped) not handed to tick()
        self._doneFor = None       # (chanID, seq): SYNC_DONE goes at the next tick()
        self._lastPulseAt = None
        self._syncLost = False
        self._onSync = None
        self._onSyncLost = None
        self._quietDbSwitches = []  # EV_DB_CHANGED names of our own switches (_noteTickMode)
        self.syncDropped = 0       # pulses the hub dropped because our loop was still busy
        self.lastPulse = None      # (chanID, seq, sourceTimeNs) of the last pulse

    ###########################################################################
    # Settings

    def setTickTimer(self, tick, check=None):
        """loop() cadence in seconds; `check`: the speed monitor's report period (default 1 s,
        at least one tick)."""
        tick = float(tick)
        if tick <= 0:
            raise ValueError("tick must be > 0")
        self._timer.interval = tick
        self._timer.check = max(float(check), tick) if check else max(1.0, tick)
        self._deadline = None
        self._noteTickMode()

    def getTickTimer(self):
        return self._timer.interval

    def setSpeedMonitorEnabled(self, enabled, label=None):
        self._speedMonitor = bool(enabled)
        self._speedLabel = label
        self._speed.reset(now())

    def setReconnectEnabled(self, enabled):
        self._reconnect = bool(enabled)

    def setNewChanCallBack(self, f):
        self._onNewChan = f

    def setDelChanCallBack(self, f):
        self._onDelChan = f

    def setStartChanPubReqCallBack(self, f):
        self._onStartPub = f

    def setStopChanPubReqCallBack(self, f):
        self._onStopPub = f

    def setGrabDataCallBack(self, f):
        self._onGrab = f

    def setGrabDataViewCallBack(self, f):
        """f(chanID, view): each message on a subscribed channel as a read-only memoryview,
        before the grab-data callback (which still gets bytes, when set), without a copy:
        relayed, where the message lies in the flow's input buffer (frameinput.py); from a
        shared-memory path, the ring's slot itself. mediaframe.parse_frame(view).array() or
        ringArray(view) make a numpy array of it. It is valid only until f returns (the view is
        released then; an array made from it shows later messages): copy what you keep
        (view.tobytes(), array.copy())."""
        self._onGrabView = f

    def setRequestCallBack(self, f):
        self._onRequest = f

    def setResponseCallBack(self, f):
        self._onResponse = f
        self._responseArity = _arity(f) if f is not None else None

    def setChanHeaderCallBack(self, f):
        """f(ch) when a channel's properties change (EV_CHAN_HEADER)."""
        self._onChanHeader = f

    def setDbChangedCallBack(self, f):
        """f(name) when the current database of the flow changed."""
        self._onDbChanged = f

    def setBlobChangedCallBack(self, f):
        """f(chanID, change, path, size, version) when a file of a blob channel this flow
        subscribes to changed; change is 1 written, 2 removed, 3 directory made, 4 directory
        removed (protocol 1.3)."""
        self._onBlobChanged = f

    def setSyncCallBack(self, f):
        """f(chanID, seq, dropped) for each pulse of a followed source, before tick() returns
        on it; dropped > 0: the hub dropped that many because this loop was still busy."""
        self._onSync = f

    def setSyncLostCallBack(self, f):
        """f(chanID) once when the pulses stop for longer than followSync's timeout."""
        self._onSyncLost = f

    def setErrorCallBack(self, f):
        """f(chanName, code, text) for every asynchronous command the hub refused and every
        failed service request, after the refusal was logged as the sketch's error: chanName is
        the full name of the channel concerned (for a channel that addStreamingChannel or
        addServiceChannel asked for: "<user>.<name>"), None when there is none; code is the
        Error_T member (Error_T.already_exists, ...); text is the hub's message. A callback
        that takes one argument gets a FlowError instead, with the same as .channel, .code and
        .message, and the command's name as .command ("CHAN_ADD")."""
        self._onError = f
        self._errorArity = _arity(f) if f is not None else None

    ###########################################################################
    # Connection

    def connect(self, address=None, timeout=10.0):
        """Connects to the hub at `address` (default: $ROBOT_ADDRESS, else local:/tmp/Robot),
        logs in and becomes a flow. Blocks up to `timeout` s. Returns bool."""
        if address:
            self._address = address
        if self._state == "online":
            return True
        self._drop()
        self._failure = None
        deadline = now() + timeout
        self._hold = True
        try:
            if self._beginAttempt(quiet=False):
                while self._state not in ("online", "offline", "closed"):
                    left = deadline - now()
                    if left <= 0:
                        self._failure = "no answer from the hub in %.1f s" % timeout
                        self._drop()
                        break
                    self._pump(left)
        finally:
            self._hold = False
        if self._state != "online":
            log.err("FlowSat: cannot connect to %s as %s: %s"
                    % (self.address(), self._userName, self._failure or "connection lost"))
            self._wanted = False
            self._drop()
            self._state = "closed"
            return False
        self._wanted = True
        return True

    def isConnected(self):
        """True from a successful connect() until close(), also while reconnecting to a hub
        that went away (unless setReconnectEnabled(False))."""
        if self._state == "online":
            return True
        return self._wanted and self._reconnect

    def isOnline(self):
        """True while the flow is connected and logged in."""
        return self._state == "online"

    def close(self):
        """Disconnects; the hub removes this satellite's channels."""
        self._wanted = False
        self._drop()
        self._owner.close()   # the listener's socket file and the rings go too
        self._state = "closed"
        self._forgetChannels(callbacks=False)

    disconnect = close

    def _beginAttempt(self, quiet):
        self._attemptStarted = now()
        self._listed = None
        try:
            sock, done = openSocket(self.address(), blocking=False)
        except (socket.error, OSError, ValueError) as e:
            self._failure = str(e)
            if not quiet:
                return False
            self._scheduleRetry()
            return False
        self._sock = sock
        self._gen += 1
        self._outbuf = bytearray()
        self._state = "connecting"
        if done:
            self._connected()
        return True

    def _connected(self):
        if self._isTls() and not isinstance(self._sock, ssl.SSLSocket):
            try:
                self._sock = wrapTls(self._sock, self.address(), self._tlsSettings(), False)
            except (ssl.SSLError, ssl.CertificateError, IOError, OSError) as e:
                self._attemptFailed(tlsFailure(e, self.address()))
                return
            self._state = "tls"
            self._tlsStep()
            return
        self._state = "login"
        self._outbuf.extend(self._loginFrame())
        self._flush()

    def _tlsStep(self):
        """Advances the TLS handshake of a non-blocking socket; LOGIN once it is done."""
        try:
            self._sock.do_handshake()
            tlsCheckHost(self._sock, self.address())
        except ssl.SSLWantReadError:
            self._tlsWants = "read"
            return
        except ssl.SSLWantWriteError:
            self._tlsWants = "write"
            return
        except (ssl.SSLError, ssl.CertificateError, socket.error, OSError) as e:
            self._attemptFailed(tlsFailure(e, self.address()))
            return
        self._tlsWants = None
        self._connected()

    def _attemptFailed(self, why):
        self._failure = why
        self._closeSocket()
        self._gen += 1
        self._scheduleRetry()   # connect() reports it, or tick() retries

    def _scheduleRetry(self):
        self._state = "offline"
        self._nextAttempt = now() + self._backoff
        self._backoff = min(self._backoff * 2, _BACKOFF_MAX)

    def _drop(self):
        """Closes the socket, keeps everything needed to reconnect."""
        self._closeSocket()
        self._outbuf = bytearray()
        self._gen += 1
        self._subscribedIDs = set()
        self._pendingAdds = {}
        self._pendingRequests = {}
        self._pendingSyncs = {}
        self._deferred = []
        self._paths.reset()
        self._owner.reset()
        self._dropSlots()
        if self._state != "closed":
            self._state = "offline"

    def _lost(self, why):
        """The connection broke: forget the hub's channels and start reconnecting."""
        was_online = self._state == "online"
        self._failure = why
        self._drop()
        if not self._wanted:
            return
        if was_online:
            log.wrn("FlowSat: lost the hub at %s (%s)%s" % (
                self.address(), why, ", reconnecting" if self._reconnect else ""))
            if self._onlineSince is not None and now() - self._onlineSince >= _STABLE_ONLINE:
                self._backoff = _BACKOFF_MIN
            self._onlineSince = None
            if self._reconnect:
                self._scheduleRetry()   # before the callbacks: one may raise
            self._forgetChannels(callbacks=True)
            if self._reconnect:
                return
        if self._reconnect:
            self._scheduleRetry()
        else:
            self._wanted = False
            self._state = "closed"

    def _forgetChannels(self, callbacks):
        gone = list(self._channels.values())
        self._channels = OrderedDict()
        self._byName = {}
        for ch in gone:
            ch.isPublishingEnabled = False
            ch.isSubscribed = False
            if callbacks and self._onDelChan is not None:
                self._call("del-channel", self._onDelChan, ch)

    def _maintain(self, t):
        """Reconnection attempts and handshake time-outs, from tick()."""
        if not self._wanted:
            return
        if self._state == "offline" and t >= self._nextAttempt:
            self._beginAttempt(quiet=True)
        elif self._state in ("connecting", "tls", "login", "listing"):
            if t - self._attemptStarted > _HANDSHAKE_TIMEOUT:
                self._closeSocket()
                self._gen += 1
                self._failure = "handshake timed out"
                self._scheduleRetry()

    ###########################################################################
    # I/O

    def _pump(self, timeout):
        """Waits up to `timeout` s for the socket, then reads, dispatches and writes."""
        sock = self._sock
        if sock is None:
            if timeout > 0:
                time.sleep(timeout)
            return
        wlist = [sock] if (self._outbuf or self._state == "connecting" or
                           (self._state == "tls" and self._tlsWants == "write")) else []
        rlist = [sock] + self._paths.fds()
        wlist += self._paths.connecting()
        if self._state == "online":
            rlist += self._owner.fds()
            wlist += self._owner.writing()
        try:
            r, w, _ = select.select(rlist, wlist, [], max(0.0, timeout))
        except (select.error, OSError, ValueError) as e:
            if getattr(e, "args", (None,))[0] == errno.EINTR:
                return
            self._lost(str(e))
            return
        gen = self._gen
        if self._state == "online":
            paths = [x for x in r if x is not sock]
            r = [x for x in r if x is sock]
            connected = [x for x in w if x is not sock]
            w = [x for x in w if x is sock]
            try:
                if connected:
                    self._paths.writable(connected)
                    self._owner.writable(connected)
                if paths:
                    self._paths.ready(paths)
                    self._owner.ready(paths)
                self._paths.tick()
                self._owner.tick()
            except Exception as e:
                if e is self._userError:  # a callback's, logged: raised out of tick()
                    self._userError = None
                raise
            if gen != self._gen:
                return
        if w and self._state == "connecting":
            rc = sock.getsockopt(socket.SOL_SOCKET, socket.SO_ERROR)
            if rc != 0:
                self._failure = "connect: %s" % errno.errorcode.get(rc, rc)
                self._closeSocket()
                self._gen += 1
                self._scheduleRetry()
                return
            self._connected()
        elif self._state == "tls":
            if r or w:
                self._tlsStep()
            return
        elif w:
            self._flush()
        if gen != self._gen or not r:
            return
        self._readAvailable()

    def _readAvailable(self):
        """Reads what the hub sent into the flow's input (FrameInput: one buffer reused, no copy
        per read) and dispatches each frame as soon as it is whole, so that the buffer holds a
        frame and a read rather than all that waits."""
        sock = self._sock
        gen = self._gen
        inp = self._input
        tls = isinstance(sock, ssl.SSLSocket)
        eof = None
        while True:
            try:
                room = inp.room()
                got = inp.recvInto(sock)
            except ProtocolError as e:  # a frame over the limit: refused before its allocation
                log.err("FlowSat: SAT-PROTOCOL broken frame from the hub: %s" % e)
                self._lost("protocol error")
                return
            except (ssl.SSLWantReadError, ssl.SSLWantWriteError):
                break
            except ssl.SSLError as e:
                eof = tlsFailure(e, self.address())
                break
            except socket.error as e:
                if e.args and e.args[0] in _WOULD_BLOCK:
                    break
                eof = str(e)
                break
            if not got:
                eof = "the hub closed the connection"
                break
            self._processBuffered()
            if gen != self._gen:
                return
            # A TLS socket returns one record per call and may hold more decrypted bytes than
            # select() can see: read until it would block.
            if got < room and not tls:
                break
        self._processBuffered()
        if gen == self._gen and eof is not None:
            self._lost(eof)

    def _processBuffered(self):
        """Dispatches the frames already received (and the channels listed at login)."""
        gen = self._gen
        inp = self._input
        try:
            while gen == self._gen:
                if self._hold and self._state == "online":
                    return
                if self._deferred:
                    self._announceListed()
                    continue
                f = inp.next()
                if f is None:
                    break
                code, start, end = f
                if code == Code.EV_DATA and self._state == "online":
                    self._relayedData(start, end)
                else:
                    self._handle(code, inp.body(start, end))
        except Exception as e:
            if e is self._userError:
                self._userError = None
                raise
            if not isinstance(e, (ProtocolError, struct.error)):
                raise
            if gen == self._gen:
                log.err("FlowSat: SAT-PROTOCOL broken frame from the hub: %s" % e)
                self._lost("protocol error")
            return

    def _announceListed(self):
        todo, self._deferred = self._deferred, []
        gen = self._gen
        for i, ch in enumerate(todo):
            if gen != self._gen:
                return
            if self._channels.get(ch.chanID) is ch and self._onNewChan is not None:
                try:
                    self._call("new-channel", self._onNewChan, ch)
                except Exception:
                    self._deferred = todo[i + 1:] + self._deferred  # announced at the next tick
                    raise

    def _flush(self):
        while self._outbuf and self._sock is not None:
            try:
                n = self._sock.send(self._outbuf)
            except (ssl.SSLWantReadError, ssl.SSLWantWriteError):
                return
            except socket.error as e:
                if e.args and e.args[0] in _WOULD_BLOCK:
                    return
                self._lost(str(e))
                return
            del self._outbuf[:n]

    def _send(self, data):
        """Queues a frame on the flow; False when offline."""
        if self._state != "online":
            return False
        self._outbuf.extend(data)
        self._flush()
        return self._bounded()

    def _sendPublish(self, chanID, payload):
        """PUBLISH with `payload` (payloadBuffer's): under Python 3 on a plain socket, its head
        and the payload go out in one gathered write when nothing waits before them, and only
        what the socket does not take is copied into the output buffer; otherwise (TLS, Python
        2.7, output waiting) the payload is copied there once. Either way the caller's buffer
        is free again when this returns."""
        if self._state != "online":
            return False
        size = len(payload)
        if self._outbuf:
            self._flush()
            if self._state != "online":
                return False  # the connection broke
        if not _GATHER or self._outbuf or isinstance(self._sock, ssl.SSLSocket):
            out = self._outbuf
            start = len(out)
            out.extend(_PUBLISH_HEAD.pack(0, Code.PUBLISH, chanID))
            out.extend(payload)
            _PUBLISH_HEAD.pack_into(out, start, len(out) - start - 4, Code.PUBLISH, chanID)
            self._flush()
            return self._bounded()
        head = _PUBLISH_HEAD.pack(size + 3, Code.PUBLISH, chanID)
        try:
            sent = self._sock.sendmsg([head, payload])
        except socket.error as e:
            if not (e.args and e.args[0] in _WOULD_BLOCK):
                self._lost(str(e))
                return False
            sent = 0
        if sent < len(head):
            self._outbuf.extend(head[sent:])
            sent = len(head)
        if sent - len(head) < size:
            with memoryview(payload) as whole:
                with whole[sent - len(head):] as rest:
                    self._outbuf.extend(rest)
        return self._bounded()

    def _bounded(self):
        """Past _OUT_LIMIT of queued output, waits (up to 10 s) until the hub has read half of
        it; False when it does not."""
        if len(self._outbuf) > _OUT_LIMIT:
            deadline = now() + 10.0
            gen = self._gen
            while gen == self._gen and len(self._outbuf) > _OUT_LIMIT // 2:
                left = deadline - now()
                if left <= 0:
                    self._lost("the hub does not read")
                    return False
                try:
                    select.select([], [self._sock], [], left)
                except (select.error, OSError, ValueError):
                    pass
                self._flush()
        return True

    def _nextTag(self):
        self._tag = self._tag % 0xFFFFFFFF + 1
        return self._tag

    ###########################################################################
    # Frames from the hub

    def _handle(self, code, body):
        st = self._state
        if st == "online":
            self._event(code, body)
        elif st == "login":
            if code == Code.REPLY_OK:
                self._readLoginOk(body)
                self._state = "listing"
                self._listed = None
                self._outbuf.extend(frame(Code.CHAN_LIST) + frame(Code.GO_ASYNC))
                self._flush()
            elif code == Code.REPLY_ERROR:
                e = self._replyError(body)
                self._failure = str(e)
                self._loginRefused(e)
            else:
                raise ProtocolError("%s before the login reply" % codeName(code))
        elif st == "listing":
            if code == Code.REPLY_ERROR:
                e = self._replyError(body)
                self._failure = str(e)
                self._closeSocket()
                self._gen += 1
                self._scheduleRetry()
            elif code != Code.REPLY_OK:
                raise ProtocolError("%s before GO_ASYNC was answered" % codeName(code))
            elif self._listed is None:
                r = Reader(body)
                self._listed = [ChannelInfo.read(r) for _ in range(r.u32())]
                r.done("CHAN_LIST reply")
            else:
                self._online(self._listed)
        else:
            raise ProtocolError("%s while not logged in" % codeName(code))

    def _loginRefused(self, e):
        self._closeSocket()
        self._gen += 1
        if self._wanted:
            log.err("FlowSat: the hub refused the login of %s: %s" % (self._userName, e))
            self._scheduleRetry()
        else:
            self._state = "offline"

    def _online(self, infos):
        again = self._everOnline
        self._state = "online"
        self._everOnline = True
        self._onlineSince = now()
        self._failure = None
        if again:
            log.msg("FlowSat: reconnected to %s (connection %s)" % (self.address(),
                                                                 self.connectionID))
        self._channels = OrderedDict()
        self._byName = {}
        self._pulse = self._doneFor = None  # pulses of the last connection
        self._quietDbSwitches = []
        fresh = [self._addChannel(info) for info in infos]
        for short in list(self._specs.keys()):
            self._sendChanAdd(short)
        if self.hubMinor >= REPLICA_MINOR:
            for short, source in self._replicas.items():
                self._send(frame(Code.REPLICATE_CHANNEL,
                                 u32(self._nextTag()) + str16(source) + str16(short)))
        # After the channels: the selected database may be one of theirs.
        if self._selectedDb and self._selectedDb != self.currentDbName:
            self._send(frame(Code.DB_SET_CURRENT, u32(self._nextTag()) + str16(self._selectedDb)))
        for ch in fresh:
            self._autoSubscribe(ch)
        if self._watches and self.hubMinor < WATCH_MINOR:
            log.err("FlowSat: this hub (FlowProtocol 1.%d) has no database watches (1.%d): %s "
                    "not watched" % (self.hubMinor, WATCH_MINOR, ", ".join(sorted(self._watches))))
            self._watches = {}
        for db in list(self._watches.keys()):
            self._sendWatch(db)
        self._noteTickMode()
        # The new-channel callbacks run from the next tick(), in order with the events that
        # follow (a sketch may set its callbacks after connect()).
        self._deferred = fresh

    def _addChannel(self, info):
        ch = FlowChannel.fromInfo(info)
        ch.isOwned = info.ownerConnection != 0 and info.ownerConnection == self.connectionID
        old = self._byName.get(ch.name)
        if old is not None:
            self._channels.pop(old.chanID, None)
        self._channels[ch.chanID] = ch
        self._byName[ch.name] = ch
        return ch

    def _autoSubscribe(self, ch):
        if ch.name in self._wantedSubs and ch.kind == ChanKind_T.CK_STREAMING:
            self._subscribe(ch.chanID)
            ch.isSubscribed = True
        if ch.name in self._follows and ch.kind == ChanKind_T.CK_SYNC:
            self._send(frame(Code.SYNC_FOLLOW, u32(self._nextTag()) + u16(ch.chanID) +
                             u32(self._follows[ch.name])))

    def _event(self, code, body):
        r = Reader(body)
        if code == Code.EV_CHAN_ADDED:
            tag = r.u32()
            info = ChannelInfo.read(r)
            r.done("EV_CHAN_ADDED")
            short = self._pendingAdds.pop(tag, None)
            ch = self._addChannel(info)
            spec = self._specs.get(short) if short is not None else None
            if spec is not None and spec.get("paths") and self.hubMinor >= PATHS_MINOR:
                self._owner.serve(info.chanID, info.name, spec["paths"], spec["ring"])
            self._autoSubscribe(ch)
            if self._onNewChan is not None:
                self._call("new-channel", self._onNewChan, ch)
        elif code == Code.EV_CHAN_REMOVED:
            chan = r.u16()
            r.u64()
            name = r.str16()
            ch = self._channels.pop(chan, None)
            if ch is None:
                ch = FlowChannel(chan, name)
            elif self._byName.get(ch.name) is ch:
                del self._byName[ch.name]
            self._subscribedIDs.discard(chan)
            self._paths.onUnsubscribed(chan)
            self._owner.unserve(chan)
            self._dropSlots(chan)
            ch.isPublishingEnabled = False
            ch.isSubscribed = False
            if self._onDelChan is not None:
                self._call("del-channel", self._onDelChan, ch)
        elif code == Code.EV_CHAN_HEADER:
            info = ChannelInfo.read(r)
            ch = self._channels.get(info.chanID)
            if ch is None:
                ch = self._addChannel(info)
            else:
                ch.update(info)
            if self._onChanHeader is not None:
                self._call("channel-header", self._onChanHeader, ch)
        elif code in (Code.EV_START_PUBLISH, Code.EV_STOP_PUBLISH):
            chan = r.u16()
            start = code == Code.EV_START_PUBLISH
            ch = self._channels.get(chan)
            if ch is None:
                return
            ch.isPublishingEnabled = start
            f = self._onStartPub if start else self._onStopPub
            if f is not None:
                self._call("start-publishing" if start else "stop-publishing", f, ch)
        elif code == Code.EV_SERVICE_REQUEST:
            chan = r.u16()
            request = r.u64()
            cmd = r.str16()
            self.lastRequester = r.str16()
            value = r.value()
            if self._onRequest is not None:
                self._call("request", self._onRequest, chan, request, cmd, value)
            else:
                self.sendServiceResponse(chan, request, None)
        elif code == Code.EV_SERVICE_RESPONSE:
            chan = r.u16()
            tag = r.u32()
            error = r.u16()
            value = r.value()
            self._pendingRequests.pop(tag, None)
            if error != 0:
                log.wrn("FlowSat: service request on channel %d failed: %s: %s"
                        % (chan, errorName(error), value))
                self._reportError(Code.SERVICE_REQUEST, self._chanName(chan), error, str(value))
            if self._onResponse is not None:
                if self._responseArity == 1:
                    self._call("response", self._onResponse, value)
                else:
                    self._call("response", self._onResponse, chan, value)
        elif code == Code.EV_DB_CHANGED:
            self.currentDbName = r.str16()
            if self._quietDbSwitches and self._quietDbSwitches[0] == self.currentDbName:
                self._quietDbSwitches.pop(0)
            elif self._onDbChanged is not None:
                self._call("db-changed", self._onDbChanged, self.currentDbName)
        elif code == Code.EV_ERROR:
            command = r.u8()
            tag = r.u32()
            chan = r.u16()
            error = r.u16()
            message = r.str16()
            self._commandFailed(command, tag, chan, error, message)
        elif code == Code.EV_DB_PAIR:
            db, key, state = r.str16(), r.str16(), r.u8()
            value = r.value()
            watch = self._watches.get(db)
            if watch is not None:
                self._call("db-watch", watch[0], db, key, state, value)
        elif code == Code.EV_DB_SYNCED:
            callback = self._pendingSyncs.pop(r.u32(), None)
            if callback is not None:
                self._call("db-synced", callback)
        elif code == Code.EV_BLOB_CHANGED:
            chan, change = r.u16(), r.u8()
            path = r.str16()
            size, version = r.u64(), r.u64()
            if self._onBlobChanged is not None:
                self._call("blob-changed", self._onBlobChanged, chan, change, path, size, version)
        elif code == Code.EV_SYNC_PULSE:
            chan, seq, sourceTime, dropped = r.u16(), r.u64(), r.u64(), r.u32()
            self._lastPulseAt = now()
            if self._syncLost:
                self._syncLost = False
                log.msg("FlowSat: pulses of channel %d again" % chan)
            self._pulse = (chan, seq, sourceTime, dropped)
            self.lastPulse = (chan, seq, sourceTime)
            self.syncDropped += dropped
            if self._onSync is not None:
                self._call("sync", self._onSync, chan, seq, dropped)
        elif code == Code.EV_DROPPED:
            chan = r.u16()
            count = r.u32()
            self._logOnce(("dropped", chan), "FlowSat: the hub dropped %d frames of channel %d "
                          "(this satellite reads too slowly)" % (count, chan))
        elif code == Code.EV_PHYS_PATH:
            self._paths.onPath(*decodePhysPath(body))
        elif code == Code.EV_PHYS_RELAY:
            chan, needed = decodePhysRelay(body)
            if not self._owner.onRelay(chan, needed):  # ours, or a channel we follow
                self._paths.onRelay(chan, needed)
        elif code == Code.EV_PHYS_MARKER:
            self._paths.onMarker(*decodePhysMarker(body))
        elif code == Code.EV_PHYS_REVOKE:
            chan, subscriber = decodePhysRevoke(body)
            self._owner.onRevoke(chan, subscriber)
            self._paths.onRevoke(chan)
        elif code == Code.EV_PHYS_GRANT:
            self._owner.onGrant(*decodePhysGrant(body))
        elif code == Code.EV_PHYS_SWITCH:
            self._owner.onSwitch(*decodePhysSwitch(body))
        elif code == Code.EV_PHYS_RESUME:
            self._owner.onResume(*decodePhysResume(body))
        # Anything else (a later minor version's events) is ignored.

    def _commandFailed(self, command, tag, chan, error, message):
        if command == Code.PHYS_REQUEST and self._paths.onRefused(tag, message):
            return  # relayed meanwhile, asked again later: logged there, not a sketch's error
        name = self._chanName(chan)
        if command == Code.CHAN_ADD:
            short = self._pendingAdds.pop(tag, None)
            if short is not None:
                self._specs.pop(short, None)  # not re-created on reconnection: add it again
                name = "%s.%s" % (self._userName, short)
                self._logOnce((command, name, error), _refusedChannel(name, error, message,
                                                                      self._userName))
                self._reportError(command, name, error, message)
                return
        elif command == Code.DB_WATCH:  # refused, or the database went: the watch ends
            for db, watch in list(self._watches.items()):
                if watch[1] == tag:
                    del self._watches[db]
                    name = db
        elif (command in (Code.SUBSCRIBE_QUEUE, Code.SUBSCRIBE_RATE) and
              error == Error_T.limit_exceeded.value):
            # Subscribed all the same, with the hub's cap as its queue.
            self._logOnce((command, chan, error), "FlowSat: %s: %s" % (name, message))
            self._reportError(command, name, error, message)
            return
        elif command in (Code.SUBSCRIBE, Code.SUBSCRIBE_QUEUE, Code.SUBSCRIBE_RATE):
            self._subscribedIDs.discard(chan)
        elif command == Code.PHYS_STATE:
            self._paths.onStateRefused(chan)
        self._logOnce((command, chan, error), "FlowSat: %s failed: %s: %s"
                      % (codeName(command), errorName(error), message))
        self._reportError(command, name, error, message)

    def _chanName(self, chan):
        ch = self._channels.get(chan) if chan else None
        return ch.name if ch is not None else None

    def _reportError(self, command, chanName, error, message):
        """The error callback, in the form it takes (setErrorCallBack)."""
        if self._onError is None:
            return
        if self._errorArity == 3:
            code = Error_T.byValue(error)
            self._call("error", self._onError, chanName, error if code is None else code, message)
        else:
            self._call("error", self._onError,
                       FlowError(error, message, codeName(command), chanName))

    def _relayedData(self, start, end):
        """EV_DATA whose body is the flow input's buf[start:end]: delivered in place."""
        if end - start < 2:
            raise ProtocolError("EV_DATA of %d bytes" % (end - start))
        if self._onGrab is None and self._onGrabView is None:
            return
        inp = self._input
        chan = _CHAN_ID.unpack_from(inp.buf, start)[0]
        inp.pin()
        try:
            self._deliverData(chan, inp.buf, start + 2, end)
        finally:
            inp.unpin()

    def _deliverData(self, chan, data, start, end):
        """A message of a subscribed channel: data[start:end] (the flow's input buffer, or a
        direct path's), relayed or from a direct path. The view callback gets a read-only
        memoryview of it in place, released when it returns; the bytes callback one copy."""
        refs = sys.getrefcount(data)
        whole = memoryview(data)
        view = whole[start:end]
        mine = (whole, view)
        if _READ_ONLY:
            view = view.toreadonly()
        try:
            if self._onGrabView is not None:
                self._call("grab-data-view", self._onGrabView, chan, view)
            if self._onGrab is not None:
                # One copy; str under Python 2.7.
                self._call("grab-data", self._onGrab, chan, view.tobytes())
        finally:
            for v in mine + (view,):
                _releaseView(v)
        del whole, view, mine, v
        if sys.getrefcount(data) > refs and not self._keptView and data is self._input.buf:
            # Something made from the view outlived the call (a slice, a numpy array): it is
            # still valid memory, but the input buffer is reused under it.
            self._keptView = True
            log.wrn("FlowSat: a grab-data-view callback kept its view of channel %d (a numpy "
                    "array?): it shows later messages; copy what you keep" % chan)

    def _call(self, kind, f, *args):
        """Runs a sketch's callback. Its exception is logged as the sketch's, with its
        traceback, and raised unchanged to whoever called tick(); _processBuffered lets it
        through instead of taking it for a decoding error."""
        try:
            return f(*args)
        except Exception as e:
            self._userError = e
            log.err("FlowSat: the sketch's %s callback %s raised an exception (not a hub "
                    "error; the connection stays up):\n%s"
                    % (kind, _callableName(f), traceback.format_exc().rstrip()))
            raise

    def _logOnce(self, key, text):
        """Logs a line at most once a second per key (publishing errors come in floods)."""
        t = now()
        if t - self._errorsLogged.get(key, -10.0) >= 1.0:
            self._errorsLogged[key] = t
            log.err(text)

    ###########################################################################
    # The loop

    def tick(self):
        """Call once per loop(): dispatches pending events and sleeps until the next tick (the
        next pulse when following a sync source: followSync)."""
        if self._doneFor is not None:  # the loop() of the last pulse is over
            chan, seq = self._doneFor
            self._doneFor = None
            self._send(frame(Code.SYNC_DONE, u16(chan) + u64(seq)))
        if self._follows:
            return self._syncTick()
        interval = self._timer.interval
        enter = now()
        if self._deadline is None:
            self._deadline = enter + interval
        self._maintain(enter)
        self._flush()
        if self._sock is not None:
            self._processBuffered()
        self._pump(0.0)
        while True:
            t = now()
            self._maintain(t)
            left = self._deadline - t
            if left <= 0:
                break
            if self._state == "offline" and self._wanted:
                left = min(left, max(0.0, self._nextAttempt - t))
                if left <= 0:
                    continue
            self._pump(left)
        t = now()
        self._deadline += interval
        if self._deadline <= t:  # overran: skip the deadlines already missed
            self._deadline += interval * (int((t - self._deadline) / interval) + 1)
        if self._speedMonitor:
            self._measure(enter, t)

    def _syncTimeoutNow(self):
        return self._syncTimeout if self._syncTimeout is not None else 1.0

    def _syncTick(self):
        """tick() while following: returns on the next pulse; past the timeout, on the own
        timer meanwhile (or, strict, not at all)."""
        interval = self._timer.interval
        enter = now()
        if self._lastPulseAt is None:
            self._lastPulseAt = enter  # following began: the timeout counts from here
        self._maintain(enter)
        self._flush()
        if self._sock is not None:
            self._processBuffered()
        self._pump(0.0)
        while self._pulse is None:
            t = now()
            self._maintain(t)
            left = self._lastPulseAt + self._syncTimeoutNow() - t
            if left <= 0:
                if not self._syncLost:
                    self._syncLost = True
                    log.wrn("FlowSat: no sync pulse for %.3f s: %s" % (
                        self._syncTimeoutNow(), "waiting for them (strict)" if self._syncStrict
                        else "ticking on the own timer meanwhile"))
                    if self._onSyncLost is not None:
                        chans = [c.chanID for c in self._channels.values()
                                 if c.name in self._follows]
                        self._call("sync-lost", self._onSyncLost, chans[0] if chans else None)
                if self._syncStrict:
                    left = interval
                else:
                    if self._deadline is None:
                        self._deadline = t + interval
                    left = self._deadline - t
                    if left <= 0:
                        self._deadline += interval
                        if self._deadline <= t:
                            self._deadline = t + interval
                        return
            self._pump(min(left, interval))
        chan, seq, _, _ = self._pulse
        self._pulse = None
        self._doneFor = (chan, seq)
        self._deadline = None

    def _measure(self, enter, t):
        s = self._speed
        s.count += 1
        s.waited += t - enter
        if s.lastReturn is not None:
            s.sumPeriod += t - s.lastReturn
            s.periods += 1
        s.lastReturn = t
        if t - s.since < self._timer.check or s.periods == 0:
            return
        requested = self._timer.interval
        measured = s.sumPeriod / s.periods
        corrected = s.waited / s.count
        error = measured - requested
        label = " [%s]" % self._speedLabel if self._speedLabel else ""
        log.msg("SPEED-MONITOR%s: frequency %.2f Hz, requested tick %.6f s, corrected tick %.6f s, "
                "measured tick %.6f s, error %+.6f s (%+.2f %%)"
                % (label, 1.0 / measured if measured > 0 else 0.0, requested, corrected,
                   measured, error, 100.0 * error / requested))
        last = s.lastReturn
        s.reset(t)
        s.lastReturn = last

    ###########################################################################
    # Channels

    def _flowTypeName(self, v):
        m = enumLookup(Flow_T, v)
        return m.name if m is not None else None

    def _dataTypeName(self, v):
        m = enumLookup(Variant_T, v)
        return m.name if m is not None else None

    def _addSpec(self, kind, name, mime, props, paths=0, ring=None):
        if not validShortName(name):
            log.err("FlowSat: bad channel name %r: 1 to 128 of A-Z a-z 0-9 _ - . "
                    "(not starting with '.')" % (name,))
            return False
        if name in self._specs:
            log.err("FlowSat: channel %s.%s was already added" % (self._userName, name))
            return False
        if props is not None and not isinstance(props, dict):
            log.err("FlowSat: channel properties must be a dict")
            return False
        # A typed channel's type (docs/channels.md, "Typed channels") follows the rules.
        problem = type_problem(*channel_type(props))
        if problem:
            log.err("FlowSat: channel %s's type: %s" % (name, problem))
            return False
        self._specs[name] = {"kind": kind, "mime": mime or "", "props": dict(props or {}),
                             "paths": paths, "ring": ring}
        if self._state == "online":
            self._sendChanAdd(name)
        return True

    def _sendChanAdd(self, short):
        spec = self._specs[short]
        tag = self._nextTag()
        self._pendingAdds[tag] = short
        body = (u32(tag) + struct.pack("<B", spec["kind"]) + str16(short) + str16(spec["mime"]) +
                encodeValue(spec["props"]))
        self._send(frame(Code.CHAN_ADD, body))

    def addStreamingChannel(self, flow_type=Flow_T.FT_BLOB, data_type=Variant_T.T_BYTEARRAY,
                            name=None, mime="", props=None, paths=0, ringSlots=4,
                            slotBytes=None, ringReaders=4):
        """Creates the streaming channel "<user>.<name>". Its id arrives with the new-channel
        callback. `props` (a dict) become the channel's database; flow_type and data_type are
        added to it as "flow_type" and "data_type" (their names). Returns bool: the command was
        accepted locally (a bad name, or a name this flow added already: False). The hub may
        still refuse it later, typically because another satellite owns a channel of that name:
        that is logged as the sketch's error (SAT-CHANNEL-REFUSED) and reported to the error
        callback with the channel's name. Before connect() or while reconnecting, the channel
        is created as soon as the flow is online.

        paths (PATH_SHM, PATH_DIRECT bits; physical mode, flowowner.py): this satellite offers
        the channel's subscribers paths of these kinds, after each login. PATH_SHM needs
        slotBytes, the largest message, and takes ringSlots (>= 2) slots for at most
        ringReaders readers at once. Python 3 on Linux and a hub of 1.7; otherwise logged once,
        and the channel is relayed."""
        if paths:
            paths = int(paths) & (PATH_DIRECT | PATH_SHM)
            if paths & PATH_SHM and not (isinstance(slotBytes, integer_types) and slotBytes > 0):
                log.err("FlowSat: channel %s: paths=PATH_SHM needs slotBytes (the largest "
                        "message, > 0)" % name)
                return False
            if not OWNER_SUPPORTED:
                if "owner" not in _SAID:
                    _SAID.add("owner")
                    log.wrn("FlowSat: this Python (%d.%d) cannot offer paths (no memfd, eventfd "
                            "or descriptor passing): %s stays relayed by the hub"
                            % (sys.version_info[0], sys.version_info[1], name))
                paths = 0
        ring = (int(ringSlots), int(slotBytes or 0), int(ringReaders))
        p = dict(props or {}) if isinstance(props, dict) or props is None else props
        if isinstance(p, dict):
            ft = self._flowTypeName(flow_type)
            dt = self._dataTypeName(data_type)
            if ft is not None and "flow_type" not in p:
                p["flow_type"] = ft
            if dt is not None and "data_type" not in p:
                p["data_type"] = dt
        return self._addSpec(ChanKind_T.CK_STREAMING.value, name, mime, p, paths, ring)

    def addServiceChannel(self, name, mime="", props=None):
        """Creates the service channel "<user>.<name>". Returns bool."""
        return self._addSpec(ChanKind_T.CK_SERVICE.value, name, mime, props)

    def addSyncSource(self, name):
        """Creates the sync source "<user>.<name>" (a channel of kind sync, protocol 1.4):
        pulse(name) sends its pulses. Returns bool, like addStreamingChannel."""
        self._needsSync()
        return self._addSpec(ChanKind_T.CK_SYNC.value, name, "", None)

    def pulse(self, chan):
        """A pulse of one of our sync sources (chanID, name or FlowChannel), stamped with the
        monotonic clock (comparable with a follower's only on the same machine)."""
        chanID = self._chanID(chan)
        if chanID is None:
            return False
        return self._send(frame(Code.SYNC_PULSE, u16(chanID) + u64(int(now() * 1e9))))

    def followSync(self, name, every=1, timeout=None, strict=False):
        """Follows the sync source `name` ("<user>.<name>"): tick() returns on each of its
        pulses (every `every`th) instead of at the tick timer's cadence, and the hub learns that
        the loop is done with a pulse when the next tick() starts (pulses that come meanwhile
        are dropped for us and counted: syncDropped, setSyncCallBack). Without a pulse for
        `timeout` seconds (default 1 s) tick() runs on the own
        timer again (setSyncLostCallBack) until pulses return; with strict=True it waits for
        them instead. Kept across reconnections and re-creations of the source."""
        self._needsSync()
        self._follows[name] = max(int(every), 1)
        self._syncTimeout = timeout
        self._syncStrict = bool(strict)
        self._lastPulseAt = None
        ch = self._byName.get(name)
        if ch is not None and self._state == "online":
            self._autoSubscribe(ch)
        self._noteTickMode()
        return True

    def unfollowSync(self, name=None):
        """Stops following `name` (None: every source); tick() keeps its own timer again."""
        names = list(self._follows) if name is None else [name]
        for n in names:
            if self._follows.pop(n, None) is None:
                continue
            ch = self._byName.get(n)
            if ch is not None and self._state == "online":
                self._send(frame(Code.SYNC_UNFOLLOW, u32(self._nextTag()) + u16(ch.chanID)))
        if not self._follows:
            self._pulse = self._doneFor = None
            self._deadline = None
        self._noteTickMode()
        return True

    def _noteTickMode(self):
        """Writes the loop's tick mode and interval to the flow's database (_flow.<connection
        id>), where the hub keeps the flow's figures. The two database switches it takes do not
        reach the db-changed callback."""
        if self._state != "online" or self.connectionID is None:
            return
        mode = ("sync-strict" if self._syncStrict else "sync") if self._follows else "timer"
        back = self._selectedDb or self.currentDbName or self._userName
        mine = "_flow.%d" % self.connectionID
        tag = self._nextTag
        self._quietDbSwitches += [mine, back]
        self._send(frame(Code.DB_SET_CURRENT, u32(tag()) + str16(mine)))
        for key, value in (("tick_mode", mode), ("tick_interval_ms", self._timer.interval * 1e3)):
            self._send(frame(Code.VAR_SET_ASYNC, u32(tag()) + str16(key) + encodeValue(value)))
        self._send(frame(Code.DB_SET_CURRENT, u32(tag()) + str16(back)))

    def _needsSync(self):
        if self._state == "online" and self.hubMinor < SYNC_MINOR:
            raise FlowError(Error_T.unsupported, "this hub (FlowProtocol 1.%d) has no sync "
                            "pulse: it needs 1.%d" % (self.hubMinor, SYNC_MINOR))

    def _chanID(self, chan):
        """The chanID of `chan`: a chanID (int), a FlowChannel, or the name of a channel this
        flow knows (None when it knows none of that name). Anything else: TypeError."""
        if isinstance(chan, FlowChannel):
            return chan.chanID
        if isinstance(chan, integer_types) and not isinstance(chan, bool):
            if not 0 <= chan <= 0xFFFF:
                raise ValueError("FlowSat: chanID %d is out of range (0..65535)" % chan)
            return chan
        if isinstance(chan, (str, text_type)):
            return self.channelID(chan)
        raise TypeError("FlowSat: a channel is given by its chanID (int), its name (str) or a "
                        "FlowChannel, not %s %r" % (type(chan).__name__, chan))

    def _chanKey(self, chan):
        """subscribe/unsubscribe: a name (kept across reconnections) or a chanID."""
        if isinstance(chan, FlowChannel):
            return chan.name or chan.chanID
        if isinstance(chan, (str, text_type)):
            return chan
        return self._chanID(chan)

    def removeChannel(self, chanID):
        """Removes a channel this satellite created (chanID, name or FlowChannel)."""
        chanID = self._chanID(chanID)
        if chanID is None:
            return False
        ch = self._channels.get(chanID)
        if ch is not None and ch.isOwned:
            self._specs.pop(ch.shortName, None)
        return self._send(frame(Code.CHAN_REMOVE, u32(self._nextTag()) + u16(chanID)))

    def setChannelProperties(self, chanID, props):
        """Sets (a None value removes) keys of an owned channel's database."""
        chanID = self._chanID(chanID)
        if chanID is None:
            return False
        ch = self._channels.get(chanID)
        if ch is not None and ch.shortName in self._specs:
            sp = self._specs[ch.shortName]["props"]
            for k, v in props.items():
                if v is None:
                    sp.pop(k, None)
                else:
                    sp[k] = v
        return self._send(frame(Code.CHAN_SET_PROPS,
                                u32(self._nextTag()) + u16(chanID) + encodeValue(props)))

    def _subscribe(self, chanID, force=False):
        if chanID in self._subscribedIDs and not force:
            return True
        ch = self._channels.get(chanID)
        queue = self._wantedQueues.get(ch.name) if ch is not None else None
        rate = self._wantedRates.get(ch.name) if ch is not None else None
        if rate and self.hubMinor >= RATE_MINOR:
            sent = self._send(frame(Code.SUBSCRIBE_RATE, u32(self._nextTag()) + u16(chanID) +
                                    u32(queue or 0) + u16(rate)))
        elif queue is not None and self.hubMinor >= QUEUE_MINOR:
            sent = self._send(frame(Code.SUBSCRIBE_QUEUE,
                                    u32(self._nextTag()) + u16(chanID) + u32(queue)))
        else:
            if rate:
                self._logOnce(("rate", self.connectionID), "FlowSat: this hub (FlowProtocol "
                              "1.%d) caps no subscription's rate (1.%d): %s comes at full rate"
                              % (self.hubMinor, RATE_MINOR, ch.name))
            if queue is not None:
                self._logOnce(("queue", self.connectionID), "FlowSat: this hub (FlowProtocol "
                              "1.%d) sizes no queue per subscription (1.%d): %s gets its default"
                              % (self.hubMinor, QUEUE_MINOR, ch.name))
            sent = self._send(frame(Code.SUBSCRIBE, u32(self._nextTag()) + u16(chanID)))
        if sent:
            self._subscribedIDs.add(chanID)
            self._pathsFor(chanID)
            return True
        return False

    def _pathsFor(self, chanID):
        """After subscribing: a path to ask for, when usePaths named the channel."""
        ch = self._channels.get(chanID)
        if ch is None or not self._paths.wants(ch.name):
            return
        if self.hubMinor < PATHS_MINOR:
            self._logOnce(("paths", self.connectionID), "FlowSat: this hub (FlowProtocol 1.%d) "
                          "has no paths (1.%d): %s stays relayed" % (self.hubMinor, PATHS_MINOR,
                                                                     ch.name))
            return
        self._paths.onSubscribed(ch.name, chanID)

    def subscribeChannel(self, chan, queueBytes=None, maxHz=None):
        """Subscribes to a streaming channel, given its chanID, its name or its FlowChannel.
        The subscription is kept by name: it comes back after a reconnection or when the
        channel reappears. queueBytes: what the hub may hold for this subscription before it
        drops the oldest data (video: a few frames, docs/python-satellites.md "Queue sizes");
        the hub clamps it to its server.subscriber_queue_max_bytes (then the error callback
        hears limit_exceeded, and the subscription stands). None: the hub's default. Needs a hub
        of FlowProtocol 1.13; an older one gives its default (logged once). maxHz: at most that
        many messages a second reach this subscriber, newest wins (the hub holds back the
        newest and sends it when the interval ends, so a channel that falls still ends on its
        newest message): for previews and dashboards. None or 0: no cap. Needs a hub of 1.14;
        an older one sends every message (logged once). Called again on a subscribed channel,
        it changes the size and the cap."""
        chan = self._chanKey(chan)
        name = None
        if isinstance(chan, (str, text_type)):
            name = chan
        else:
            ch = self._channels.get(chan)
            name = ch.name if ch is not None else None
        changed = False
        if name is not None:
            if queueBytes is not None:
                queueBytes = max(0, min(int(queueBytes), 0xFFFFFFFF))
                changed = self._wantedQueues.get(name) != queueBytes
                self._wantedQueues[name] = queueBytes
            if maxHz is not None:
                maxHz = max(0, min(int(maxHz), 0xFFFF))
                changed = changed or self._wantedRates.get(name, 0) != maxHz
                self._wantedRates[name] = maxHz
        if isinstance(chan, (str, text_type)):
            self._wantedSubs.add(chan)
            ch = self._byName.get(chan)
            if ch is None:
                return True
            chan = ch.chanID
        ch = self._channels.get(chan)
        if ch is not None:
            self._wantedSubs.add(ch.name)
            ch.isSubscribed = True
        return self._subscribe(chan, force=changed and self.hubMinor >= QUEUE_MINOR)

    def unsubscribeChannel(self, chan):
        chan = self._chanKey(chan)
        if isinstance(chan, (str, text_type)):
            self._wantedSubs.discard(chan)
            ch = self._byName.get(chan)
            if ch is None:
                return True
            chan = ch.chanID
        ch = self._channels.get(chan)
        if ch is not None:
            self._wantedSubs.discard(ch.name)
            self._wantedQueues.pop(ch.name, None)
            self._wantedRates.pop(ch.name, None)
            ch.isSubscribed = False
        self._subscribedIDs.discard(chan)
        self._paths.onUnsubscribed(chan)
        return self._send(frame(Code.UNSUBSCRIBE, u32(self._nextTag()) + u16(chan)))

    ###########################################################################
    # Physical mode, as a subscriber (flowpaths.py)

    def usePaths(self, chan, kinds=PATH_SHM | PATH_DIRECT):
        """Asks the hub for a path of these kinds (PATH_SHM, PATH_DIRECT) to the channel `chan`
        (its name, chanID or FlowChannel) whenever this flow subscribes to it: its data then
        comes straight from its owner, to the same callbacks, and through the hub again whenever
        the path breaks (asked again after 1 s, doubling to 30 s). 0: relayed only. Needs a hub
        of FlowProtocol 1.7 and Python 3; otherwise logged once, and relayed. Returns bool
        (False: this Python takes no paths)."""
        if not isinstance(chan, (str, text_type)):
            ch = self.channelByID(chan)
            if ch is None:
                return False
            chan = ch.name
        if not self._paths.want(chan, kinds):
            return False
        ch = self._byName.get(chan)
        if ch is not None and ch.chanID in self._subscribedIDs and self._state == "online":
            if self._paths.wants(chan):
                self._pathsFor(ch.chanID)
            else:
                self._paths.onSubscribed(chan, ch.chanID)  # drops the path: relayed
        return True

    def pathStats(self):
        """The path figures, as the C++ library's pathStats(): served_direct and served_shm
        (the subscribers our channels' paths serve now), path_messages (received on paths),
        dropped_before_marker, torn, fallbacks and missed (shared memory: published while this
        reader was busy, never read)."""
        st = self._paths.stats()
        st.update(self._owner.stats())
        return st

    def resetPaths(self):
        """Closes every path as if it broke, ours to our subscribers included: relayed again,
        asked again after the backoff."""
        self._owner.closeAll("reset by the application")
        self._paths.closeAll("reset by the application")

    def channelByID(self, chanID):
        """The FlowChannel this flow knows by that chanID (a name or FlowChannel works too)."""
        chanID = self._chanID(chanID)
        return self._channels.get(chanID) if chanID is not None else None

    def channelByName(self, name):
        if isinstance(name, FlowChannel):
            name = name.name
        return self._byName.get(name)

    def channelID(self, name):
        if isinstance(name, FlowChannel):
            name = name.name
        ch = self._byName.get(name)
        return ch.chanID if ch is not None else None

    def channels(self):
        return list(self._channels.values())

    def channelsNames(self):
        return [ch.name for ch in self._channels.values()]

    ###########################################################################
    # Publishing

    def publish(self, chanID, data):
        """Publishes a payload on an owned streaming channel (chanID, name or FlowChannel, like
        every publish* method): bytes, or any object with the buffer protocol (bytearray,
        memoryview, array.array, a numpy array: its bytes in C order), a DataBuffer, or text
        (UTF-8). No intermediate bytes object is built: under Python 3 the frame goes out as a
        gathered write straight from the caller's buffer, and only what the socket cannot take
        at once is copied into the flow's output buffer (a buffer that is not C-contiguous is
        copied once first). The caller may change or reuse its buffer as soon as publish()
        returns. Returns False when offline (or when the connection breaks during the call);
        data of any other type: TypeError."""
        chanID = self._chanID(chanID)
        payload, views = payloadBuffer(data)
        try:
            if chanID is None:
                return False
            if self._owner.serves(chanID):
                if self._state != "online":
                    return False
                # Our paths first (a copy into a ring slot); the hub only while someone is
                # relayed.
                if not self._owner.publish(chanID, payload, 0):
                    return True
            return self._sendPublish(chanID, payload)
        finally:
            releaseViews(views)

    def beginPublish(self, chan, size=None):
        """A writable memoryview to build the next message of the owned channel `chan` in
        place: a free slot of its shared-memory ring (len = slotBytes; no copy for its readers),
        or, without a ring slot (no ring, every slot leased, Python 2.7, offline), a buffer of
        this flow's reused for the channel (len = slotBytes, or `size` for a channel without
        one). Fill the first bytes, then commitPublish(chan, size). Valid until commitPublish;
        None for an unknown channel, or without slotBytes or size. With numpy:
            a = numpy.frombuffer(view, numpy.uint8, count=h * w * 3).reshape(h, w, 3)
        (mediaframe.frame_slot writes a media header and gives the pixel area)."""
        chanID = self._chanID(chan)
        if chanID is None:
            return None
        self._dropSlots(chanID)
        if self._state == "online":
            view = self._owner.beginPublish(chanID)
            if view is not None:
                self._slots[chanID] = (view, True)
                return view
        n = size
        spec = self._specs.get(self._shortName(chanID))
        if spec is not None and spec.get("ring") and spec["ring"][1] > 0:
            n = max(spec["ring"][1], size or 0)
        if not n:
            return None
        buf = self._scratch.get(chanID)
        if buf is None or len(buf) < n:
            buf = self._scratch[chanID] = bytearray(n)
        view = memoryview(buf)[:n]
        self._slots[chanID] = (view, False)
        return view

    def commitPublish(self, chan, size, capture_ns=0):
        """Publishes the first `size` bytes of what beginPublish gave: in the ring slot (its
        readers read it in place), on direct paths, and through the hub while someone is
        relayed. Returns bool (False: no beginPublish before, size beyond the buffer, or
        offline)."""
        chanID = self._chanID(chan)
        view, inRing = self._slots.pop(chanID, (None, False)) if chanID is not None else \
            (None, False)
        if view is None:
            return False
        try:
            if size < 0 or size > len(view):
                return False
            if inRing:
                done = self._owner.commitPublish(chanID, size, capture_ns)
                if done is None:
                    return False
                data, relay = done
                try:
                    return self._sendPublish(chanID, data) if relay else True
                finally:
                    data.release()
            data = view[:size] if _GATHER else view[:size].tobytes()
            try:
                if self._owner.serves(chanID) and self._state == "online":
                    if not self._owner.publish(chanID, data, capture_ns):
                        return True
                return self._sendPublish(chanID, data)
            finally:
                _releaseView(data)
        finally:
            _releaseView(view)

    def _dropSlots(self, chanID=None):
        """Forgets beginPublish's views (of one channel, or all)."""
        for k in ([chanID] if chanID is not None else list(self._slots)):
            view = self._slots.pop(k, None)
            if view is not None:
                _releaseView(view[0])

    def _shortName(self, chanID):
        ch = self._channels.get(chanID)
        prefix = "%s." % self._userName
        if ch is None or not ch.name.startswith(prefix):
            return None
        return ch.name[len(prefix):]

    def _publishPacked(self, chanID, fmt, values):
        if not isinstance(values, (list, tuple)):
            values = [values]
        return self.publish(chanID, struct.pack("<%d%s" % (len(values), fmt), *values))

    def publishInt8(self, chanID, v):
        return self._publishPacked(chanID, "b", v)

    def publishUInt8(self, chanID, v):
        return self._publishPacked(chanID, "B", v)

    def publishInt16(self, chanID, v):
        return self._publishPacked(chanID, "h", v)

    def publishUInt16(self, chanID, v):
        return self._publishPacked(chanID, "H", v)

    def publishInt32(self, chanID, v):
        return self._publishPacked(chanID, "i", v)

    def publishUInt32(self, chanID, v):
        return self._publishPacked(chanID, "I", v)

    def publishInt64(self, chanID, v):
        return self._publishPacked(chanID, "q", v)

    def publishUInt64(self, chanID, v):
        return self._publishPacked(chanID, "Q", v)

    def publishFloat(self, chanID, v):
        """One float32, or a list of them, little-endian."""
        return self._publishPacked(chanID, "f", v)

    def publishDouble(self, chanID, v):
        return self._publishPacked(chanID, "d", v)

    def publishString(self, chanID, s):
        """Text as UTF-8 bytes."""
        return self.publish(chanID, utf8(s))

    ###########################################################################
    # Services

    def sendServiceRequest(self, chanID, cmdName, value=None, timeoutMs=0):
        """Sends a request to a service channel (non-blocking); the answer arrives at the
        response callback. The channel: chanID, name or FlowChannel. Without an answer within
        timeoutMs (0: the hub's server.request_timeout_ms) the callback gets the timeout as a
        failure. Returns the request's tag (true) or 0 when offline or when no channel has that
        name; a timeout asked of a hub older than 1.4 raises FlowError (unsupported)."""
        chanID = self._chanID(chanID)
        if chanID is None:
            return 0
        tag = self._nextTag()
        if timeoutMs:
            if self.hubMinor < TIMED_REQUEST_MINOR:
                raise FlowError(Error_T.unsupported, "this hub (FlowProtocol 1.%d) does not time "
                                "requests out: it needs 1.%d" % (self.hubMinor, TIMED_REQUEST_MINOR))
            body = u32(tag) + u16(chanID) + u32(timeoutMs) + str16(cmdName) + encodeValue(value)
            sent = self._send(frame(Code.SERVICE_REQUEST_TIMED, body))
        else:
            body = u32(tag) + u16(chanID) + str16(cmdName) + encodeValue(value)
            sent = self._send(frame(Code.SERVICE_REQUEST, body))
        if not sent:
            return 0
        self._pendingRequests[tag] = chanID
        return tag

    def sendServiceResponse(self, chanID, hash, value):
        """Answers the request `hash` (as given to the request callback) on an owned service
        channel (chanID, name or FlowChannel)."""
        chanID = self._chanID(chanID)
        if chanID is None:
            return False
        return self._send(frame(Code.SERVICE_RESPONSE,
                                u16(chanID) + u64(int(hash)) + encodeValue(value)))

    ###########################################################################
    # Pair databases (asynchronous: failures are logged)

    def setCurrentDbName(self, name):
        """Selects the flow's current database (a channel's name, or its FlowChannel, selects
        its properties)."""
        if isinstance(name, FlowChannel):
            name = name.name
        self._selectedDb = name
        return self._send(frame(Code.DB_SET_CURRENT, u32(self._nextTag()) + str16(name)))

    def setVariable(self, key, value):
        """Sets `key` in the current database."""
        db = self._selectedDb
        if db is not None and db.startswith(self._userName + "."):
            spec = self._specs.get(db[len(self._userName) + 1:])
            if spec is not None:
                spec["props"][key] = value
        return self._send(frame(Code.VAR_SET_ASYNC,
                                u32(self._nextTag()) + str16(key) + encodeValue(value)))

    def delVariable(self, key):
        db = self._selectedDb
        if db is not None and db.startswith(self._userName + "."):
            spec = self._specs.get(db[len(self._userName) + 1:])
            if spec is not None:
                spec["props"].pop(key, None)
        return self._send(frame(Code.VAR_DEL_ASYNC, u32(self._nextTag()) + str16(key)))

    removeVariable = delVariable

    def watchDatabase(self, db, callback):
        """Watches database `db` (FlowProtocol 1.14): callback(db, key, state, value) gets its
        pairs (state DB_PAIR_SET), then one DB_PAIR_SNAPSHOT_END, then every change as it is
        made: DB_PAIR_SET, DB_PAIR_REMOVED, DB_PAIR_CLEARED (flowproto's constants); none is
        missed. Kept across reconnections (a new snapshot each time). The user's db_read rule
        decides; a refusal, or the database's removal, ends the watch and comes to the error
        callback (DB_WATCH). Called again for the same database: the callback is replaced and a
        new snapshot comes. FlowError unsupported from a hub older than 1.14."""
        if self._state == "online" and self.hubMinor < WATCH_MINOR:
            raise FlowError(Error_T.unsupported, "this hub (FlowProtocol 1.%d) has no database "
                            "watches: it needs 1.%d" % (self.hubMinor, WATCH_MINOR))
        self._watches[db] = [callback, None]
        if self._state == "online":
            return self._sendWatch(db)
        return True

    def unwatchDatabase(self, db):
        """Ends a watch of watchDatabase() (what the hub sent before may still come: ignored)."""
        watch = self._watches.pop(db, None)
        if watch is None or watch[1] is None or self._state != "online":
            return False
        return self._send(frame(Code.DB_UNWATCH, u32(self._nextTag()) + str16(db)))

    def isWatching(self, db):
        return db in self._watches

    def _sendWatch(self, db):
        tag = self._nextTag()
        self._watches[db][1] = tag
        return self._send(frame(Code.DB_WATCH, u32(tag) + str16(db)))

    def createDatabase(self, name):
        return self._send(frame(Code.DB_CREATE_ASYNC, u32(self._nextTag()) + str16(name)))

    def saveDatabase(self, name=""):
        return self._send(frame(Code.DB_SAVE_ASYNC, u32(self._nextTag()) + str16(name)))

    def removeDatabase(self, name):
        return self._send(frame(Code.DB_REMOVE_ASYNC, u32(self._nextTag()) + str16(name)))

    def replicate(self, source, shortName):
        """Asks the hub to mirror the streaming channel `source` (a linked hub's, typically:
        "arm/guest.camera") as this satellite's channel <user>.<shortName>, subscribed on the
        source only while it has subscribers (docs/hub-links.md, "Replicas"). Kept while this
        flow lasts and asked again after a reconnection; a refusal comes to the error callback.
        Returns the tag, or None when offline; FlowError unsupported from a hub older than 1.5."""
        if self._state == "online" and self.hubMinor < REPLICA_MINOR:
            raise FlowError(Error_T.unsupported, "this hub (FlowProtocol 1.%d) has no replicas: "
                            "it needs 1.%d" % (self.hubMinor, REPLICA_MINOR))
        self._replicas[shortName] = source
        tag = self._nextTag()
        if not self._send(frame(Code.REPLICATE_CHANNEL, u32(tag) + str16(source) +
                                str16(shortName))):
            return None
        return tag

    def stopReplica(self, shortName):
        """Ends a replica made by replicate(). Returns the tag, or None."""
        if self._replicas.pop(shortName, None) is None:
            return None
        tag = self._nextTag()
        if not self._send(frame(Code.REPLICATE_STOP, u32(tag) + str16(shortName))):
            return None
        return tag

    def syncDatabases(self, callback=None):
        """A barrier for the writes above, which have no reply: `callback()` is called once every
        change this flow sent before it is on disk (protocol 1.2). Returns the tag, or None."""
        tag = self._nextTag()
        if not self._send(frame(Code.DB_SYNC_ASYNC, u32(tag))):
            return None
        if callback is not None:
            self._pendingSyncs[tag] = callback
        return tag

    def newSyncClient(self, timeout=10.0):
        """A FlowSync on a new synchronous connection, logged in with the same address and
        credentials (check isConnected(); close() it when done)."""
        sync = FlowSync(self.address(), self._userName, self._passwd,
                        self.clientName() + "-sync", timeout)
        sync.connect()
        return sync

