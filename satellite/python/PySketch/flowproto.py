# SPDX-License-Identifier: Apache-2.0
"""FlowProtocol 1.0 for Python: enums, command codes, error codes and the Variant codec.

The byte-by-byte specification is docs/flow-protocol.md. Everything here is plain standard
library (struct, little-endian) and parses under Python 2.7 and Python 3.

Values map between Python and the protocol's binary Variant like this:

    None                      <-> null     (tag 0x00)
    bool                      <-> bool     (tag 0x01)
    int in int64 range        <-> int64    (tag 0x02)
    int above INT64_MAX       <-> uint64   (tag 0x03; decoded back to int)
    float                     <-> float64  (tag 0x04)
    str (text)                <-> string   (tag 0x05, UTF-8)
    bytes, bytearray          <-> bytes    (tag 0x06; decoded to bytes)
    list, tuple               <-> list     (tag 0x07; decoded to list)
    dict (text keys)          <-> map      (tag 0x08; keys written in byte order, like the hub)

Under Python 2 a `unicode` is text; a `str` is text when it is valid UTF-8, bytes otherwise;
strings are decoded to native `str` (UTF-8 bytes) so that they compare with literals.
"""
from __future__ import print_function, division, absolute_import

import json
import math
import struct
import sys
import base64

from PySketch.flowcodes import CODES, ERRORS, CHANNEL_KINDS

PY2 = sys.version_info[0] == 2

if PY2:  # pragma: no cover - Python 2 only
    text_type = unicode  # noqa: F821
    integer_types = (int, long)  # noqa: F821
else:
    text_type = str
    integer_types = (int,)

PROTOCOL_MAJOR = 1
# 1.13: SUBSCRIBE_QUEUE, a subscription's own queue size (FlowSat.subscribeChannel's queueBytes);
# 1.12 brings nothing PySketch sends or must read (SESSION_LIMITS is for boards);
# 1.11: PHYS_FALLBACK, a broken direct path resumed with what the owner kept (flowpaths);
# 1.10: PHYS_RECEIVED, what came on a path, reported once a second (flowpaths);
# 1.9: EV_PHYS_MARKER, the subscriber's marker with the owner's message number (flowpaths);
# 1.8 changes only PHYS_OFFER (a TCP endpoint, which PySketch's owner does not offer); 1.7:
# physical mode, subscriber (flowpaths) and owner (flowowner);
# 1.6 brings nothing PySketch sends or must read (DB_READ, LINK_OFFER: its events answer only
# those); 1.5: replicas; 1.4: timed requests; 1.3: blob channels; 1.2: DB_SYNC; no ADMIN (1.1)
PROTOCOL_MINOR = 13

# Path kinds a subscriber asks for (FlowSat.usePaths), as in the C++ library (kPathDirect,
# kPathShm) and in PHYS_REQUEST's `paths` bits.
PATH_DIRECT = 1
PATH_SHM = 2

DEFAULT_PORT = 9000
DEFAULT_ADDRESS = "local:/tmp/Robot"
MAX_DEPTH = 32

INT64_MIN = -(1 << 63)
INT64_MAX = (1 << 63) - 1
UINT64_MAX = (1 << 64) - 1


###############################################################################
# Small enums that work the same under Python 2.7 (no enum module) and Python 3


class EnumValue(int):
    """A member of one of the enums below: an int with a `name` and a `value`."""

    def __new__(cls, enum_name, name, value):
        obj = int.__new__(cls, value)
        obj.name = name
        obj.value = value
        obj.enumName = enum_name
        return obj

    def __repr__(self):
        return "<%s.%s: %d>" % (self.enumName, self.name, self.value)

    def __str__(self):
        return "%s.%s" % (self.enumName, self.name)

    def __reduce__(self):
        return (int, (self.value,))


class _EnumMeta(type):
    def __iter__(cls):
        return iter(cls._members)

    def __len__(cls):
        return len(cls._members)

    def __contains__(cls, item):
        return cls.byValue(item) is not None or cls.byName(item) is not None

    def __call__(cls, value):
        m = cls.byValue(value)
        if m is None:
            m = cls.byName(value)
        if m is None:
            raise ValueError("%r is not a valid %s" % (value, cls.__name__))
        return m

    def __getitem__(cls, name):
        m = cls.byName(name)
        if m is None:
            raise KeyError(name)
        return m


def _enum(enum_name, members, doc):
    attrs = {"__doc__": doc}
    values = []
    for name, value in members:
        m = EnumValue(enum_name, name, value)
        attrs[name] = m
        values.append(m)
    attrs["_members"] = tuple(values)

    def byValue(cls, value):
        if isinstance(value, integer_types) and not isinstance(value, bool):
            for m in cls._members:
                if m.value == value:
                    return m
        return None

    def byName(cls, name):
        if isinstance(name, EnumValue):
            name = name.name
        for m in cls._members:
            if m.name == name:
                return m
        return None

    attrs["byValue"] = classmethod(byValue)
    attrs["byName"] = classmethod(byName)
    return _EnumMeta(enum_name, (object,), attrs)


Variant_T = _enum("Variant_T", [
    ("T_NULL", 0), ("T_BOOL", 1),
    ("T_INT8", 2), ("T_UINT8", 3), ("T_INT16", 4), ("T_UINT16", 5),
    ("T_INT32", 6), ("T_UINT32", 7), ("T_INT64", 8), ("T_UINT64", 9),
    ("T_FLOAT", 10), ("T_DOUBLE", 11),
    ("T_STRING", 12), ("T_BYTEARRAY", 13),
    ("T_LIST", 14), ("T_MAP", 15), ("T_PAIR", 16), ("T_JSON", 17),
], "What a channel's payloads hold (PySketch's data types). Written to the channel's "
   "properties as `data_type` by FlowSat.addStreamingChannel; the wire never depends on it.")

Flow_T = _enum("Flow_T", [
    ("FT_BLOB", 0), ("FT_STREAMING", 1), ("FT_SERVICE", 2),
    ("FT_AUDIO_DATA", 3), ("FT_VIDEO_DATA", 4), ("FT_IMAGE_DATA", 5),
    ("FT_SENSOR_DATA", 6), ("FT_CTRL_DATA", 7), ("FT_TEXT", 8),
], "What kind of flow a channel carries (PySketch's flow types). FT_BLOB is opaque data. "
   "Written to the channel's properties as `flow_type`.")

ChanKind_T = _enum("ChanKind_T", [("CK_" + _n.upper(), _v) for _n, _v, _m in CHANNEL_KINDS],
                   "Channel kinds on the wire (ChannelInfo.kind).")

Error_T = _enum("Error_T", [(_n, _v) for _n, _v, _m in ERRORS], "FlowProtocol error codes.")


class FlowChanID(int):
    """A channel id (u16, 1..32767). Callbacks get plain ints; both compare equal."""

    def __repr__(self):
        return "FlowChanID(%d)" % int(self)


class Code(object):
    """Frame codes (docs/flow-protocol.md): Code.LOGIN == 0x01, ... From the protocol catalogue
    (flowcodes.py, generated from the hub's catalogue.h)."""


for _row in CODES:
    setattr(Code, _row[0], _row[1])
CODE_MINOR = dict((_row[1], _row[2]) for _row in CODES)  # the minor that introduced each code
PATHS_MINOR = CODE_MINOR[Code.PHYS_REQUEST]  # PHYS_REQUEST, PHYS_STATE and their events
RECEIVED_MINOR = CODE_MINOR[Code.PHYS_RECEIVED]
FALLBACK_MINOR = CODE_MINOR[Code.PHYS_FALLBACK]


def codeName(code):
    for k, v in Code.__dict__.items():
        if not k.startswith("_") and v == code:
            return k
    return "0x%02x" % code


def errorName(error):
    m = Error_T.byValue(error)
    return m.name if m is not None else "error %d" % error


class FlowError(Exception):
    """A REPLY_ERROR, an EV_ERROR, or a broken frame. `code` is an Error_T value, `message` the
    hub's text; for a refused asynchronous command (FlowSat's error callback) also `command`
    (its name, e.g. "CHAN_ADD") and `channel` (the full name of the channel concerned, or None)."""

    def __init__(self, code, message, command=None, channel=None):
        Exception.__init__(self, "%s: %s" % (errorName(code), message))
        self.code = code
        self.message = message
        self.command = command
        self.channel = channel


class ProtocolError(FlowError):
    def __init__(self, message):
        FlowError.__init__(self, 1, message)


###############################################################################
# Text and bytes that behave the same under both interpreters


_PAYLOADS = ("bytes-like data (bytes, bytearray, memoryview, array.array, a numpy array: "
             "anything with the buffer protocol), text or a DataBuffer")


def payloadBuffer(data):
    """A payload as one flat run of bytes, copied only where it must be. Returns (buf, views):
    buf is bytes, or under Python 3 a memoryview of format "B" over the caller's own object
    (its length is the payload's size), or under Python 2.7 something bytearray.extend()
    takes; `views` are the memoryviews made here: releaseViews(views) once buf has been used,
    so that the caller may resize its bytearray again. Text becomes UTF-8, a DataBuffer (any
    object with toBytes()) its bytes. A buffer that is not C-contiguous (a numpy slice with a
    step, a transposed array) is copied once, in C order, as numpy's tobytes() does. Anything
    else: TypeError naming what is accepted."""
    if isinstance(data, bytes):
        return data, ()
    if isinstance(data, text_type):
        return data.encode("utf-8"), ()
    to = getattr(data, "toBytes", None)
    if to is not None:
        return to(), ()
    if PY2:  # pragma: no cover - Python 2 only
        return _payloadBuffer27(data), ()
    try:
        view = memoryview(data)
    except TypeError:
        raise TypeError("expected %s, got %s" % (_PAYLOADS, type(data).__name__))
    if view.format == "B" and view.ndim == 1 and view.c_contiguous:
        return view, (view,)
    if view.c_contiguous:
        try:
            flat = view.cast("B")
            return flat, (flat, view)
        except TypeError:  # a format that this Python's cast() refuses: copied below
            pass
    flat = view.tobytes()
    view.release()
    return flat, ()


def _payloadBuffer27(data):  # pragma: no cover - Python 2 only
    import array
    if isinstance(data, (bytearray, buffer)):  # noqa: F821 (Python 2's buffer)
        return data
    if isinstance(data, array.array):  # the old buffer protocol only
        return buffer(data)  # noqa: F821
    try:
        view = memoryview(data)
    except TypeError:
        try:
            return buffer(data)  # noqa: F821
        except TypeError:
            raise TypeError("expected %s, got %s" % (_PAYLOADS, type(data).__name__))
    if view.format == "B" and view.ndim == 1:
        return view
    return view.tobytes()


def releaseViews(views):
    """Releases the memoryviews payloadBuffer() made (Python 3; nothing to do under 2.7)."""
    for v in views:
        v.release()


def toBytes(data):
    """bytes (py3) / str (py2) from anything payloadBuffer() takes: bytes, text, a DataBuffer,
    bytearray, memoryview, array.array, a numpy array. A copy, unless `data` is bytes."""
    if isinstance(data, bytes):
        return data
    buf, views = payloadBuffer(data)
    try:
        if isinstance(buf, memoryview):
            return buf.tobytes()
        return bytes(buf)
    finally:
        releaseViews(views)


def utf8(s):
    """Text to UTF-8 bytes (a py2 `str` is taken as already encoded)."""
    if isinstance(s, text_type):
        return s.encode("utf-8")
    if isinstance(s, (bytes, bytearray)):
        return bytes(s)
    return text_type(s).encode("utf-8")


def native(b):
    """UTF-8 bytes to the native `str` (py3: decoded text; py2: the bytes themselves)."""
    if PY2:  # pragma: no cover
        return bytes(b)
    return bytes(b).decode("utf-8", "replace")


def _isText(v):
    if isinstance(v, text_type):
        return True
    if PY2 and isinstance(v, str):  # pragma: no cover
        try:
            v.decode("utf-8")
            return True
        except UnicodeDecodeError:
            return False
    return False


###############################################################################
# Writing


def u8(v):
    return struct.pack("<B", v)


def u16(v):
    return struct.pack("<H", v)


def u32(v):
    return struct.pack("<I", v)


def u64(v):
    return struct.pack("<Q", v)


def str16(s):
    b = utf8(s)
    if len(b) > 0xFFFF:
        raise ValueError("text of %d bytes exceeds 65535" % len(b))
    return struct.pack("<H", len(b)) + b


def str32(s):
    b = utf8(s)
    return struct.pack("<I", len(b)) + b


def frame(code, body=b""):
    """One frame: u32 length (code + body), u8 code, body."""
    return struct.pack("<IB", len(body) + 1, code) + body


def physRequest(tag, chanID, paths):
    """PHYS_REQUEST: a path of one of the kinds `paths` (PATH_DIRECT | PATH_SHM bits)."""
    return frame(Code.PHYS_REQUEST, struct.pack("<IHB", tag, chanID, paths))


def physState(chanID, active):
    """PHYS_STATE: our granted path works (1: stop relaying to us) or broke (0)."""
    return frame(Code.PHYS_STATE, struct.pack("<HB", chanID, 1 if active else 0))


def physFallback(chanID, last):
    """PHYS_FALLBACK (1.11), instead of PHYS_STATE 0 for a direct path that broke after its
    marker: `last` is the number of the last message we have; the hub relays to us again once
    the owner has replayed what came after it."""
    return frame(Code.PHYS_FALLBACK, struct.pack("<HQ", chanID, last))


def physReceived(chanID, messages, nbytes, missed):
    """PHYS_RECEIVED (1.10): messages, their bytes and the skipped ones on our path since the
    last report, for the hub's statistics of our flow."""
    return frame(Code.PHYS_RECEIVED, struct.pack("<HQQQ", chanID, messages, nbytes, missed))


def physOffer(tag, chanID, paths, endpoint):
    """PHYS_OFFER: the owner serves these kinds (bits) of paths of `chanID` at `endpoint`."""
    return frame(Code.PHYS_OFFER, struct.pack("<IHB", tag, chanID, paths) + str16(endpoint))


def physCount(chanID, messages, nbytes):
    """PHYS_COUNT: what the owner delivered on paths only since its last count."""
    return frame(Code.PHYS_COUNT, struct.pack("<HQQ", chanID, messages, nbytes))


def physSwitched(chanID, subscriber, switchID, seq):
    """PHYS_SWITCHED (1.9): the answer to EV_PHYS_SWITCH, with the owner's last message number
    on that subscriber's path."""
    return frame(Code.PHYS_SWITCHED, struct.pack("<HIIQ", chanID, subscriber, switchID, seq))


def physReplayHead(chanID, subscriber, resumeID, done, lost, size):
    """PHYS_REPLAY (1.11) without its payload (`size` bytes, written after it): a kept message
    (done 0) or the end with the `lost` count (done 1, no payload)."""
    return struct.pack("<IBHIIBQ", 1 + 19 + size, Code.PHYS_REPLAY, chanID, subscriber, resumeID,
                       done, lost)


def _sortKey(item):
    return utf8(item[0])


def _encode(v, out, depth):
    if depth > MAX_DEPTH:
        raise ValueError("value nests deeper than %d levels" % MAX_DEPTH)
    if v is None:
        out.append(b"\x00")
    elif isinstance(v, bool):
        out.append(b"\x01\x01" if v else b"\x01\x00")
    elif isinstance(v, integer_types):
        if INT64_MIN <= v <= INT64_MAX:
            out.append(struct.pack("<Bq", 2, v))
        elif INT64_MAX < v <= UINT64_MAX:
            out.append(struct.pack("<BQ", 3, v))
        else:
            raise ValueError("integer %d does not fit 64 bits" % v)
    elif isinstance(v, float):
        out.append(struct.pack("<Bd", 4, v))
    elif _isText(v):
        b = utf8(v)
        out.append(struct.pack("<BI", 5, len(b)))
        out.append(b)
    elif isinstance(v, (bytes, bytearray, memoryview)):
        b = toBytes(v)
        out.append(struct.pack("<BI", 6, len(b)))
        out.append(b)
    elif isinstance(v, (list, tuple)):
        out.append(struct.pack("<BI", 7, len(v)))
        for item in v:
            _encode(item, out, depth + 1)
    elif isinstance(v, dict):
        items = []
        for k, item in v.items():
            if not _isText(k):
                raise ValueError("map keys must be text, got %r" % (k,))
            items.append((utf8(k), item))
        items.sort(key=lambda kv: kv[0])
        out.append(struct.pack("<BI", 8, len(items)))
        for k, item in items:
            if len(k) > 0xFFFF:
                raise ValueError("map key of %d bytes exceeds 65535" % len(k))
            out.append(struct.pack("<H", len(k)))
            out.append(k)
            _encode(item, out, depth + 1)
    elif hasattr(v, "toBytes"):  # a DataBuffer
        _encode(v.toBytes(), out, depth)
    elif isinstance(v, EnumValue):
        _encode(int(v), out, depth)
    else:
        # numpy scalars and the like
        try:
            if float(v) == int(v):
                _encode(int(v), out, depth)
            else:
                _encode(float(v), out, depth)
        except (TypeError, ValueError):
            raise ValueError("cannot encode a %s as a Variant" % type(v).__name__)


def encodeVariant(value):
    """A Python value as a binary Variant (tag + bytes)."""
    out = []
    _encode(value, out, 1)
    return b"".join(out)


def encodeValue(value):
    """A `value` field: u8 encoding 0 (binary), then the Variant."""
    return b"\x00" + encodeVariant(value)


def toJsonText(value):
    """The JSON twin of a value (bytes become {"$base64": ...})."""
    def conv(v):
        if isinstance(v, (bytearray, memoryview)) or (isinstance(v, bytes) and not _isText(v)):
            return {"$base64": base64.b64encode(toBytes(v)).decode("ascii")}
        if isinstance(v, (list, tuple)):
            return [conv(x) for x in v]
        if isinstance(v, dict):
            return dict((k, conv(x)) for k, x in v.items())
        if isinstance(v, float) and (math.isnan(v) or math.isinf(v)):
            raise ValueError("non-finite floats have no JSON form")
        return v
    return json.dumps(conv(value), sort_keys=True)


def fromJsonText(text):
    def conv(v):
        if isinstance(v, dict):
            if len(v) == 1 and "$base64" in v:
                return base64.b64decode(v["$base64"])
            if len(v) == 1 and "$map" in v:
                return dict((_nativeKey(k), conv(x)) for k, x in v["$map"].items())
            return dict((_nativeKey(k), conv(x)) for k, x in v.items())
        if isinstance(v, list):
            return [conv(x) for x in v]
        if PY2 and isinstance(v, text_type):  # pragma: no cover
            return v.encode("utf-8")
        return v
    return conv(json.loads(native(text) if not PY2 else text))


def _nativeKey(k):
    if PY2 and isinstance(k, text_type):  # pragma: no cover
        return k.encode("utf-8")
    return k


###############################################################################
# Reading


class Reader(object):
    """Reads a frame body; every length is checked against the bytes left."""

    def __init__(self, data, offset=0):
        self.data = data
        self.pos = offset
        self.end = len(data)

    def left(self):
        return self.end - self.pos

    def _need(self, n, what):
        if self.end - self.pos < n:
            raise ProtocolError("truncated %s: needs %d bytes, %d left" % (what, n, self.left()))

    def _unpack(self, fmt, n, what):
        self._need(n, what)
        v = struct.unpack_from(fmt, self.data, self.pos)[0]
        self.pos += n
        return v

    def u8(self, what="u8"):
        return self._unpack("<B", 1, what)

    def u16(self, what="u16"):
        return self._unpack("<H", 2, what)

    def u32(self, what="u32"):
        return self._unpack("<I", 4, what)

    def u64(self, what="u64"):
        return self._unpack("<Q", 8, what)

    def i64(self, what="i64"):
        return self._unpack("<q", 8, what)

    def f64(self, what="f64"):
        return self._unpack("<d", 8, what)

    def raw(self, n, what="bytes"):
        self._need(n, what)
        b = bytes(self.data[self.pos:self.pos + n])
        self.pos += n
        return b

    def str16(self, what="str16"):
        return native(self.raw(self.u16(what), what))

    def str32raw(self, what="str32"):
        return self.raw(self.u32(what), what)

    def rest(self):
        b = bytes(self.data[self.pos:self.end])
        self.pos = self.end
        return b

    def done(self, what):
        if self.pos != self.end:
            raise ProtocolError("%s: %d trailing bytes" % (what, self.end - self.pos))

    def variant(self, depth=1):
        if depth > MAX_DEPTH:
            raise ProtocolError("variant nests deeper than %d levels" % MAX_DEPTH)
        tag = self.u8("variant tag")
        if tag == 0:
            return None
        if tag == 1:
            b = self.u8("bool")
            if b > 1:
                raise ProtocolError("bad bool byte 0x%02x" % b)
            return b == 1
        if tag == 2:
            return self.i64("int64")
        if tag == 3:
            return self.u64("uint64")
        if tag == 4:
            return self.f64("float64")
        if tag == 5:
            raw = self.str32raw("string")
            try:
                text = raw.decode("utf-8")
            except UnicodeDecodeError:
                raise ProtocolError("string is not valid UTF-8")
            return raw if PY2 else text
        if tag == 6:
            return self.str32raw("bytes")
        if tag == 7:
            n = self.u32("list count")
            if n > self.left():
                raise ProtocolError("list count %d exceeds the %d bytes left" % (n, self.left()))
            return [self.variant(depth + 1) for _ in range(n)]
        if tag == 8:
            n = self.u32("map count")
            if n > self.left() // 3:
                raise ProtocolError("map count %d exceeds the %d bytes left" % (n, self.left()))
            out = {}
            for _ in range(n):
                key = self.raw(self.u16("map key"), "map key")
                try:
                    key.decode("utf-8")
                except UnicodeDecodeError:
                    raise ProtocolError("map key is not valid UTF-8")
                key = native(key)
                if key in out:
                    raise ProtocolError("duplicate map key %r" % (key,))
                out[key] = self.variant(depth + 1)
            return out
        raise ProtocolError("unknown variant tag 0x%02x" % tag)

    def value(self):
        """A `value` field: u8 encoding, then a binary Variant or str32 JSON text."""
        enc = self.u8("value encoding")
        if enc == 0:
            return self.variant()
        if enc == 1:
            text = self.str32raw("JSON value")
            try:
                return fromJsonText(text)
            except ValueError as e:
                raise ProtocolError("bad JSON value: %s" % e)
        raise ProtocolError("unknown value encoding %d" % enc)


def decodeVariant(data, offset=0):
    """(value, offset after it) from a binary Variant at `offset`."""
    r = Reader(data, offset)
    v = r.variant()
    return v, r.pos


def decodeValue(data):
    r = Reader(data)
    v = r.value()
    r.done("value")
    return v


def decodePhysPath(body):
    """EV_PHYS_PATH: (tag, chanID, path, endpoint, token)."""
    r = Reader(body)
    out = (r.u32("tag"), r.u16("chan_id"), r.u8("path"), r.str16("endpoint"), r.str16("token"))
    r.done("EV_PHYS_PATH")
    return out


def decodePhysRelay(body):
    """EV_PHYS_RELAY: (chanID, needed)."""
    r = Reader(body)
    out = (r.u16("chan_id"), r.u8("needed"))
    r.done("EV_PHYS_RELAY")
    return out


def decodePhysMarker(body):
    """EV_PHYS_MARKER (1.9): (chanID, seq), the owner's last message relayed."""
    r = Reader(body)
    out = (r.u16("chan_id"), r.u64("seq"))
    r.done("EV_PHYS_MARKER")
    return out


def decodePhysRevoke(body):
    """EV_PHYS_REVOKE: (chanID, subscriber flow id)."""
    r = Reader(body)
    out = (r.u16("chan_id"), r.u32("subscriber"))
    r.done("EV_PHYS_REVOKE")
    return out


def decodePhysGrant(body):
    """EV_PHYS_GRANT: (chanID, subscriber, name, path, token)."""
    r = Reader(body)
    out = (r.u16("chan_id"), r.u32("subscriber"), r.str16("name"), r.u8("path"),
           r.str16("token"))
    r.done("EV_PHYS_GRANT")
    return out


def decodePhysSwitch(body):
    """EV_PHYS_SWITCH (1.9): (chanID, subscriber, switchID)."""
    r = Reader(body)
    out = (r.u16("chan_id"), r.u32("subscriber"), r.u32("switch_id"))
    r.done("EV_PHYS_SWITCH")
    return out


def decodePhysResume(body):
    """EV_PHYS_RESUME (1.11): (chanID, subscriber, resumeID, after)."""
    r = Reader(body)
    out = (r.u16("chan_id"), r.u32("subscriber"), r.u32("resume_id"), r.u64("after"))
    r.done("EV_PHYS_RESUME")
    return out


class ChannelInfo(object):
    """ChannelInfo as the hub sends it (see docs/flow-protocol.md)."""
    __slots__ = ("chanID", "hashID", "kind", "name", "owner", "ownerConnection", "mime",
                 "subscribers", "props")

    @classmethod
    def read(cls, r):
        i = cls()
        i.chanID = r.u16("chan_id")
        i.hashID = r.u64("hash")
        i.kind = r.u8("kind")
        i.name = r.str16("name")
        i.owner = r.str16("owner")
        i.ownerConnection = r.u32("owner_connection")
        i.mime = r.str16("mime")
        i.subscribers = r.u32("subscribers")
        props = r.value()
        i.props = props if isinstance(props, dict) else {}
        return i
