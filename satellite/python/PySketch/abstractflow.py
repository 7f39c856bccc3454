# SPDX-License-Identifier: Apache-2.0
"""What FlowSat (the asynchronous flow) and FlowSync (the synchronous connection) share:
FlowChannel, the hub's address (ROBOT_ADDRESS), credentials, sockets (TLS for tls: addresses,
with Python's ssl module) and frame splitting."""
from __future__ import print_function, division, absolute_import

import errno
import os
import re
import socket
import ssl
import struct
import sys

from PySketch.flowproto import (
    ChanKind_T, Code, DEFAULT_ADDRESS, DEFAULT_PORT, Flow_T, FlowError, PROTOCOL_MAJOR,
    PROTOCOL_MINOR, ProtocolError, Reader, Variant_T, frame, str16, text_type)
from PySketch.frameinput import FrameInput

# The name a satellite gives the hub when the sketch sets none (the executor sets it to the
# sketch's file name).
defaultClientName = None

_SHORT_NAME = re.compile(r"^[A-Za-z0-9_\-][A-Za-z0-9_.\-]{0,127}$")


def enumLookup(enum, v):
    """The member of `enum` named or numbered `v`, or None. (Members are ints: FT_BLOB is 0,
    so never test them with `or`.)"""
    m = enum.byName(v)
    return m if m is not None else enum.byValue(v)


def validShortName(name):
    """A channel's short name: 1-128 of A-Z a-z 0-9 _ - . (not starting with '.')."""
    return isinstance(name, (str, text_type)) and _SHORT_NAME.match(name) is not None


class FlowChannel(object):
    """A channel as a satellite sees it.

    chanID      the hub's id (changes when the channel is re-created, e.g. after a hub restart)
    hashID      unique per channel instance
    name        "<user>.<short name>"
    kind        ChanKind_T.CK_STREAMING, CK_SERVICE or CK_BLOB
    mime        what the payloads are ("" when the owner said nothing)
    props       the channel's database as it was announced (a dict)
    flowType    Flow_T from props["flow_type"] (None when absent)
    dataType    Variant_T from props["data_type"] (None when absent)
    owner       the owner's user name
    isOwned     True for channels this satellite created
    isPublishingEnabled  owned streaming channels: someone subscribes (start/stop callbacks)
    isSubscribed         this satellite subscribes to it
    """

    def __init__(self, chanID=0, name="", kind=ChanKind_T.CK_STREAMING, mime="", props=None,
                 hashID=0, owner="", ownerConnection=0, subscribers=0):
        self.chanID = chanID
        self.hashID = hashID
        self.name = name
        self.kind = ChanKind_T.byValue(kind) or kind
        self.mime = mime
        self.props = dict(props or {})
        self.owner = owner
        self.ownerConnection = ownerConnection
        self.subscribers = subscribers
        self.isOwned = False
        self.isPublishingEnabled = False
        self.isSubscribed = False

    @classmethod
    def fromInfo(cls, info):
        return cls(info.chanID, info.name, info.kind, info.mime, info.props, info.hashID,
                   info.owner, info.ownerConnection, info.subscribers)

    def update(self, info):
        self.hashID = info.hashID
        self.mime = info.mime
        self.props = dict(info.props)
        self.subscribers = info.subscribers

    @property
    def shortName(self):
        return self.name.split(".", 1)[1] if "." in self.name else self.name

    @property
    def flowType(self):
        return enumLookup(Flow_T, self.props.get("flow_type"))

    @property
    def dataType(self):
        return enumLookup(Variant_T, self.props.get("data_type"))

    # Older spellings some sketches use
    @property
    def flow_t(self):
        return self.flowType

    @property
    def data_t(self):
        return self.dataType

    def isStreaming(self):
        return self.kind == ChanKind_T.CK_STREAMING

    def isService(self):
        return self.kind == ChanKind_T.CK_SERVICE

    def isBlob(self):
        return self.kind == ChanKind_T.CK_BLOB

    def __repr__(self):
        kind = getattr(self.kind, "name", self.kind)
        return "FlowChannel(%d, %r, %s)" % (self.chanID, self.name, kind)


###############################################################################
# Addresses


def robotAddress(address=None):
    """The hub's address: `address`, else $ROBOT_ADDRESS, else local:/tmp/Robot."""
    if address:
        return address
    return os.environ.get("ROBOT_ADDRESS") or DEFAULT_ADDRESS


def parseAddress(address):
    """("local", path) for local:/path, ("tcp", (host, port)) for tcp:host[:port] (default port
    9000; IPv6 as tcp:[::1]:9000), ("tls", (host, port)) for tls:host[:port]. Raises
    ValueError."""
    if address.startswith("local:"):
        path = address[len("local:"):]
        if not path:
            raise ValueError("ROBOT_ADDRESS %r: no socket path" % address)
        return "local", path
    if address.startswith("tcp:") or address.startswith("tls:"):
        kind = address[:3]
        rest = address[len("tcp:"):].lstrip("/")
        port = DEFAULT_PORT
        if rest.startswith("["):
            end = rest.find("]")
            if end < 0:
                raise ValueError("ROBOT_ADDRESS %r: unclosed [" % address)
            host = rest[1:end]
            tail = rest[end + 1:]
            if tail.startswith(":"):
                port = int(tail[1:])
            elif tail:
                raise ValueError("ROBOT_ADDRESS %r: bad port" % address)
        elif rest.count(":") == 1:
            host, p = rest.split(":")
            port = int(p)
        else:
            host = rest
        if not host:
            raise ValueError("ROBOT_ADDRESS %r: no host" % address)
        if not 0 < port < 65536:
            raise ValueError("ROBOT_ADDRESS %r: bad port" % address)
        return kind, (host, port)
    raise ValueError("ROBOT_ADDRESS %r: expected local:/path, tcp:host[:port] or tls:host[:port]"
                     % address)


class TlsSettings(object):
    """TLS for tls: addresses. cafile: the CA certificate that signed the hub's (default
    $ROBOT_TLS_CA, else the system's CA store); certfile and keyfile: a client certificate, for
    a hub that asks for one (default $ROBOT_TLS_CERT, $ROBOT_TLS_KEY). The hub's certificate
    must name the address's host. TLS 1.2 or later."""

    def __init__(self, cafile=None, certfile=None, keyfile=None):
        env = os.environ.get
        self.cafile = cafile or env("ROBOT_TLS_CA") or None
        self.certfile = certfile or env("ROBOT_TLS_CERT") or None
        self.keyfile = keyfile or env("ROBOT_TLS_KEY") or None

    def context(self):
        """An ssl.SSLContext that verifies the hub (Python 3 and 2.7.9+). Raises ssl.SSLError or
        IOError for a bad file."""
        if hasattr(ssl, "PROTOCOL_TLS_CLIENT"):
            ctx = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
        else:  # Python 2.7
            ctx = ssl.SSLContext(ssl.PROTOCOL_SSLv23)
        if hasattr(ctx, "minimum_version"):
            ctx.minimum_version = ssl.TLSVersion.TLSv1_2
        else:
            ctx.options |= (ssl.OP_NO_SSLv2 | ssl.OP_NO_SSLv3 | ssl.OP_NO_TLSv1 |
                            ssl.OP_NO_TLSv1_1)
        ctx.verify_mode = ssl.CERT_REQUIRED
        ctx.check_hostname = True
        if self.cafile:
            ctx.load_verify_locations(cafile=self.cafile)
        else:
            ctx.load_default_certs()
        if self.certfile:
            ctx.load_cert_chain(self.certfile, self.keyfile)
        return ctx


def ipFamily(host):
    """AF_INET or AF_INET6 for a numeric address, None for anything else (a name)."""
    for family in (socket.AF_INET, socket.AF_INET6):
        try:
            socket.inet_pton(family, host)
            return family
        except (socket.error, OSError, ValueError):
            pass
    return None


def _isIpAddress(host):
    return ipFamily(host) is not None


# Python 2.7's hostname check knows DNS names only: numeric hosts are checked by tlsCheckHost.
_CHECK_IP_OURSELVES = sys.version_info[0] == 2


def wrapTls(sock, address, settings, handshake):
    """`sock` (connected, or connecting when handshake is False) wrapped in TLS for the host of
    the tls: `address`. With handshake=True the handshake is done now (blocking, within the
    socket's timeout); else the caller drives do_handshake(), then calls tlsCheckHost()."""
    _, where = parseAddress(address)
    ctx = (settings or TlsSettings()).context()
    if _CHECK_IP_OURSELVES and _isIpAddress(where[0]):
        ctx.check_hostname = False
    tls = ctx.wrap_socket(sock, server_hostname=where[0], do_handshake_on_connect=handshake)
    if handshake:
        tlsCheckHost(tls, address)
    return tls


def tlsCheckHost(sock, address):
    """After the handshake: on Python 2.7, a numeric host must be one of the certificate's IP
    addresses (ssl.CertificateError otherwise). Python 3 checked it during the handshake."""
    _, where = parseAddress(address)
    if not (_CHECK_IP_OURSELVES and _isIpAddress(where[0])):
        return
    want = socket.inet_pton(socket.AF_INET6 if ":" in where[0] else socket.AF_INET, where[0])
    for kind, value in (sock.getpeercert() or {}).get("subjectAltName", ()):
        if kind == "IP Address":
            family = socket.AF_INET6 if ":" in value else socket.AF_INET
            try:
                if socket.inet_pton(family, value.strip()) == want:
                    return
            except (socket.error, ValueError):
                pass
    raise ssl.CertificateError("IP address mismatch: the certificate does not name %s"
                               % where[0])


def tlsFailure(e, address):
    """A TLS error in words: the reason and, when the certificate was refused, why."""
    why = getattr(e, "verify_message", None) or str(e)
    if "eof" in why.lower():
        why += " (the hub closed the connection: is its TCP port plain? then use a tcp: address)"
    return "TLS with %s: %s" % (address, why)


def openSocket(address, blocking=True, timeout=10.0):
    """A socket to the hub. With blocking=False the connection may still be in progress (TCP):
    returns (sock, done)."""
    kind, where = parseAddress(address)
    if kind == "local":
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        target = where
    else:
        infos = socket.getaddrinfo(where[0], where[1], 0, socket.SOCK_STREAM)
        family, stype, proto, _, target = infos[0]
        sock = socket.socket(family, stype, proto)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    try:
        if blocking:
            sock.settimeout(timeout)
            sock.connect(target)
            return sock, True
        sock.setblocking(False)
        rc = sock.connect_ex(target)
        if rc == 0:
            return sock, True
        if kind != "local" and rc in (errno.EINPROGRESS, errno.EWOULDBLOCK, errno.EALREADY):
            return sock, False
        raise socket.error(rc, os.strerror(rc))
    except Exception:
        sock.close()
        raise


###############################################################################
# The parts every connection has


class AbstractFlow(object):
    """Credentials, the client name, the LOGIN frame and frame splitting."""

    def __init__(self):
        # $ROBOT_USER and $ROBOT_PASSWORD (a hub's supervised satellite gets its account's
        # there, docs/robot.md), else the development account; setLogin() overrides them.
        self._userName = os.environ.get("ROBOT_USER") or "guest"
        self._passwd = os.environ.get("ROBOT_PASSWORD") or "password"
        self._appName = None
        self._nodeName = None
        self._address = None
        self._tls = None
        self._sock = None
        self._input = FrameInput()
        self.connectionID = None
        self.hubMinor = 0
        self.hubAppName = None
        self.currentDbName = None
        self.lastError = None

    # -- identity
    def setLogin(self, user, password):
        self._userName = user
        self._passwd = password

    def setAppName(self, name):
        self._appName = name

    def setNodeName(self, name):
        self._nodeName = name

    def userName(self):
        return self._userName

    def clientName(self):
        name = self._nodeName or self._appName or defaultClientName
        if not name:
            name = os.path.splitext(os.path.basename(sys.argv[0] or "python"))[0]
        return name

    def setAddress(self, address):
        """Overrides ROBOT_ADDRESS for the next connect()."""
        self._address = address

    def address(self):
        return robotAddress(self._address)

    def setTls(self, cafile=None, certfile=None, keyfile=None):
        """TLS files for tls: addresses (see TlsSettings; unset ones come from ROBOT_TLS_*)."""
        self._tls = TlsSettings(cafile, certfile, keyfile)

    def _tlsSettings(self):
        return self._tls or TlsSettings()

    def _isTls(self):
        return self.address().startswith("tls:")

    # -- frames
    def _loginFrame(self):
        body = (struct.pack("<HHB", PROTOCOL_MAJOR, PROTOCOL_MINOR, 0) + str16(self._userName) +
                str16(self._passwd) + str16(self.clientName()))
        return frame(Code.LOGIN, body)

    def _readLoginOk(self, body):
        r = Reader(body)
        major = r.u16()
        # The connection's minor: what both sides know.
        self.hubMinor = min(r.u16(), PROTOCOL_MINOR)
        if major != PROTOCOL_MAJOR:
            raise ProtocolError("hub speaks FlowProtocol %d" % major)
        self.connectionID = r.u32()
        self.hubAppName = r.str16()
        self._userName = r.str16()
        self.currentDbName = r.str16()

    @staticmethod
    def _replyError(body):
        r = Reader(body)
        code = r.u16("error")
        message = r.str16("message")
        return FlowError(code, message)

    def setMaxFrameBytes(self, n):
        """The largest frame taken from the hub (default 16 MiB, as the hub's
        server.max_frame_bytes and the C++ library): a longer announced length breaks the
        connection before anything is allocated for it (logged SAT-PROTOCOL)."""
        self._input.maxFrameBytes = int(n)

    def _nextFrame(self):
        """(code, body) of the next complete frame in the input buffer (body: bytes), or None."""
        f = self._input.next()
        if f is None:
            return None
        return f[0], self._input.body(f[1], f[2])

    def _closeSocket(self):
        if self._sock is not None:
            try:
                self._sock.close()
            except (socket.error, OSError):
                pass
        self._sock = None
        self._input.clear()

