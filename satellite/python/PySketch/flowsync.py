# SPDX-License-Identifier: Apache-2.0
"""FlowSync: a blocking client on a synchronous connection to the hub.

A satellite's flow never blocks; look-ups that wait for an answer (reading a channel's
properties, a synchronous service call) use this separate, short-lived connection:

    sync = sat.newSyncClient()            # same address and credentials as the flow
    sync.setCurrentDbName(ch.name)        # a channel's database holds its properties
    width = sync.getVariable("width")     # None when there is no such variable
    sync.close()

Failures do not raise (except serviceCall): methods return None or False and keep the
reason in `lastError` (a FlowError). FlowSync is also a context manager.
"""
from __future__ import print_function, division, absolute_import

import socket
import struct

import ssl

from PySketch.abstractflow import AbstractFlow, FlowChannel, openSocket, tlsFailure, wrapTls
from PySketch.elapsedtime import now
from PySketch.flowblobs import BlobRequests
from PySketch.flowproto import (
    CODE_MINOR, ChannelInfo, Code, Error_T, FlowError, ProtocolError, Reader, encodeValue, frame,
    str16, integer_types, toBytes, u16)
from PySketch import log

POLL_DEREGISTER_MINOR = CODE_MINOR[Code.POLL_DEREGISTER]


class FlowSync(AbstractFlow, BlobRequests):
    def __init__(self, address=None, user=None, password=None, clientName=None, timeout=10.0):
        AbstractFlow.__init__(self)
        if address:
            self._address = address
        if user is not None:
            self._userName = user
        if password is not None:
            self._passwd = password
        if clientName:
            self._nodeName = clientName
        self._timeout = timeout

    # -- connection
    def connect(self, address=None):
        """Connects and logs in (blocking). Returns bool."""
        if address:
            self._address = address
        self.close()
        try:
            self._sock, _ = openSocket(self.address(), True, self._timeout)
            if self._isTls():
                try:
                    self._sock = wrapTls(self._sock, self.address(), self._tlsSettings(), True)
                except (ssl.SSLError, ssl.CertificateError) as e:
                    raise FlowError(Error_T.io_error, tlsFailure(e, self.address()))
            code, body = self._roundTrip(self._loginFrame())
            if code != Code.REPLY_OK:
                raise self._replyError(body)
            self._readLoginOk(body)
            return True
        except (socket.error, OSError, ValueError, FlowError) as e:
            self._fail(e)
            log.err("FlowSync: cannot connect to %s as %s: %s"
                    % (self.address(), self._userName, e))
            return False

    def isConnected(self):
        return self._sock is not None

    def close(self):
        self._closeSocket()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    # -- the wire
    def _recvFrame(self, deadline):
        while True:
            f = self._nextFrame()
            if f is not None:
                return f
            left = deadline - now()
            if left <= 0:
                raise FlowError(Error_T.timeout, "no reply from the hub in %.1f s" % self._timeout)
            self._sock.settimeout(left)
            if not self._input.recvInto(self._sock):
                raise FlowError(Error_T.io_error, "the hub closed the connection")

    def _roundTrip(self, data, timeout=None):
        deadline = now() + (timeout if timeout is not None else self._timeout)
        self._sock.settimeout(max(0.001, deadline - now()))
        self._sock.sendall(data)
        return self._recvFrame(deadline)

    def _fail(self, e):
        if not isinstance(e, FlowError):
            e = FlowError(Error_T.io_error, str(e))
        self.lastError = e
        if e.code not in (Error_T.not_found, Error_T.permission_denied, Error_T.invalid_argument,
                          Error_T.already_exists, Error_T.timeout, Error_T.owner_gone,
                          Error_T.overflow, Error_T.unsupported):
            self._closeSocket()

    def _request(self, code, body=b"", timeout=None):
        """A Reader on the REPLY_OK body; raises FlowError."""
        if self._sock is None:
            raise FlowError(Error_T.not_logged_in, "FlowSync is not connected")
        try:
            rc, rbody = self._roundTrip(frame(code, body), timeout)
        except (socket.error, OSError) as e:
            raise FlowError(Error_T.io_error, str(e))
        if rc == Code.REPLY_ERROR:
            raise self._replyError(rbody)
        if rc != Code.REPLY_OK:
            raise ProtocolError("unexpected frame 0x%02x on a synchronous connection" % rc)
        return Reader(rbody)

    def _call(self, default, code, body=b"", parse=None, timeout=None):
        try:
            r = self._request(code, body, timeout)
            if parse is None:
                return True
            v = parse(r)
            r.done("reply")
            return v
        except FlowError as e:
            self._fail(e)
            return default

    # -- databases
    def setCurrentDbName(self, name):
        """Selects the database the variable calls use (a FlowChannel selects its own).
        Returns bool."""
        if isinstance(name, FlowChannel):
            name = name.name
        ok = self._call(False, Code.DB_SELECT, str16(name))
        if ok:
            self.currentDbName = name
        return ok

    def getCurrentDbName(self):
        return self.currentDbName

    def getVariable(self, key, default=None):
        """The value of `key` in the current database, or `default` when absent."""
        return self._call(default, Code.VAR_GET, str16(key), lambda r: r.value())

    def existsVariable(self, key):
        """True when `key` is in the current database."""
        try:
            self._request(Code.VAR_GET, str16(key))
            return True
        except FlowError as e:
            self._fail(e)
            return False

    def setVariable(self, key, value):
        return self._call(False, Code.VAR_SET, str16(key) + encodeValue(value))

    def delVariable(self, key):
        return self._call(False, Code.VAR_DEL, str16(key))

    removeVariable = delVariable

    def variablesKeys(self):
        """The keys of the current database, sorted."""
        return self._call([], Code.VAR_KEYS, b"", lambda r: r.value())

    def getAllVariables(self):
        """Every pair of the current database, as a dict."""
        return self._call({}, Code.VAR_GET_ALL, b"", lambda r: r.value())

    def databases(self):
        return self._call([], Code.DB_LIST, b"", lambda r: r.value())

    def createDatabase(self, name):
        return self._call(False, Code.DB_CREATE, str16(name))

    def saveDatabase(self, name=""):
        return self._call(False, Code.DB_SAVE, str16(name))

    def removeDatabase(self, name):
        return self._call(False, Code.DB_REMOVE, str16(name))

    def syncDatabases(self):
        """Returns True once every database change the hub made before it is on disk, whatever
        the hub's durability policy (protocol 1.2)."""
        return self._call(False, Code.DB_SYNC)

    # -- channels
    def channels(self):
        """Every channel of the hub, as FlowChannel objects."""
        def parse(r):
            return [FlowChannel.fromInfo(ChannelInfo.read(r)) for _ in range(r.u32())]
        return self._call([], Code.CHAN_LIST, b"", parse)

    def channelByName(self, name):
        if isinstance(name, FlowChannel):
            name = name.name
        return self._call(None, Code.CHAN_INFO, str16(name),
                          lambda r: FlowChannel.fromInfo(ChannelInfo.read(r)))

    def serviceCall(self, chan, cmdName, value=None, timeout=10.0):
        """A blocking service request; `chan` is a chanID, a channel name or a FlowChannel.
        Returns the owner's answer; raises FlowError (timeout, owner_gone, not_found, ...)."""
        if isinstance(chan, FlowChannel):
            chan = chan.chanID
        if not isinstance(chan, integer_types):
            ch = self.channelByName(chan)
            if ch is None:
                raise self.lastError or FlowError(Error_T.not_found, "no channel %s" % chan)
            chan = ch.chanID
        body = (u16(chan) + struct.pack("<I", int(timeout * 1000)) + str16(cmdName) +
                encodeValue(value))
        try:
            r = self._request(Code.SERVICE_CALL, body, timeout + self._timeout)
            return r.value()
        except FlowError as e:
            self._fail(e)
            raise

    def pollRegister(self, chanID):
        """Asks the hub to keep the latest payload of a streaming channel."""
        if isinstance(chanID, FlowChannel):
            chanID = chanID.chanID
        return self._call(False, Code.POLL_REGISTER, u16(chanID))

    def pollFetch(self, chanID):
        """(seq, payload) of the latest payload, or None. seq is the channel's sequence number of
        that payload; 0 while nothing was published since the first client registered."""
        if isinstance(chanID, FlowChannel):
            chanID = chanID.chanID
        return self._call(None, Code.POLL_FETCH, u16(chanID),
                          lambda r: (r.u64(), r.rest()))

    def pollDeregister(self, chanID):
        """This client no longer polls the channel: the hub keeps its payload only while some
        client does (protocol 1.4; FlowError unsupported from an older hub)."""
        if self.hubMinor < POLL_DEREGISTER_MINOR:
            raise FlowError(Error_T.unsupported, "this hub (FlowProtocol 1.%d) has no "
                            "POLL_DEREGISTER: it needs 1.%d" % (self.hubMinor,
                                                               POLL_DEREGISTER_MINOR))
        if isinstance(chanID, FlowChannel):
            chanID = chanID.chanID
        return self._call(False, Code.POLL_DEREGISTER, u16(chanID))

    def ping(self, data=b""):
        """Round-trip time to the hub in seconds, or None."""
        t = now()
        echoed = self._call(None, Code.PING, toBytes(data), lambda r: r.rest())
        return None if echoed is None else now() - t
