# SPDX-License-Identifier: Apache-2.0
"""Media frames (docs/channels.md): the 32-byte header `SKMF` and its payload, made from bytes or
a numpy array and parsed into fields and a numpy view, under Python 2.7 and 3, numpy optional.

    from PySketch import mediaframe
    props = mediaframe.channel_properties("bgr8", width=640, height=480, fps=30)
    sat.addStreamingChannel(name="camera", mime=mediaframe.mime_for("bgr8"), props=props)
    ...
    sat.publish(chanID, mediaframe.make_frame(img, "bgr8", seq=n))   # img: 480x640x3 uint8

    view = sat.beginPublish(chanID)       # in place, into a shared-memory slot (flowowner)
    img, size = mediaframe.frame_slot(view, "bgr8", 640, 480, seq=n)
    cv2.cvtColor(src, cv2.COLOR_RGB2BGR, dst=img)
    sat.commitPublish(chanID, size)

    f = mediaframe.parse_frame(data)      # MediaFrameError when it is not a well-formed frame
    img = f.array()                       # (480, 640, 3) uint8 view of `data`, no copy

The table of encodings is PySketch/mediacodes.py, generated from the C++ one
(plugin-api/include/skrobot/media_frame.hpp) and checked against it by CTest protocol.catalogue.
"""
from __future__ import print_function, division, absolute_import

import struct

from PySketch.flowproto import PY2, payloadBuffer, releaseViews
from PySketch.mediacodes import (DERIVED, ENCODINGS, HEADER_BYTES, MESSAGE_ENCODING,
                                 MESSAGE_ENCODINGS, TYPE_KEYS)

_HEADER = struct.Struct("<4sHBBQqHHI")
_MAGIC = b"SKMF"


class Encoding(object):
    """One row of the table: encoding name, format code and the older keys derived from it."""
    __slots__ = ("name", "code", "video", "bits_per_pixel", "even_size", "mime", "pixel_format",
                 "codec", "flow_type")

    def __init__(self, row):
        for k, v in zip(self.__slots__, row):
            setattr(self, k, v)

    @property
    def raw(self):
        return self.bits_per_pixel != 0


BY_NAME = dict((r[0], Encoding(r)) for r in ENCODINGS)
BY_CODE = dict((e.code, e) for e in BY_NAME.values())
_DERIVED = dict(DERIVED)


class MediaFrameError(ValueError):
    """A message that is not a well-formed media frame, or pixels that do not fit their size."""


def encoding(name):
    """The Encoding of `name` ("bgr8", "jpeg", ...); MediaFrameError for an unknown name."""
    e = BY_NAME.get(name)
    if e is None:
        raise MediaFrameError("unknown encoding %r (known: %s)" % (name, ", ".join(
            r[0] for r in ENCODINGS)))
    return e


def mime_for(name):
    """The channel's mime type for frames of encoding `name`."""
    return encoding(name).mime


def channel_properties(name, width=None, height=None, fps=None, sample_rate=None,
                       channels=None):
    """A media channel's properties (a dict for addStreamingChannel's props): message_encoding,
    encoding and the older keys derived from them, plus the numbers given."""
    encoding(name)
    props = dict(_DERIVED[name])
    for k, v in (("width", width), ("height", height), ("fps", fps),
                 ("sample_rate", sample_rate), ("channels", channels)):
        if v is not None:
            props[k] = v
    return props


_TYPES = dict((r[0], (r[1], r[2])) for r in MESSAGE_ENCODINGS)
_TEXT = (str, type(u""))  # Python 2 reads text from the hub as unicode


def type_problem(message_encoding="", schema_name="", schema_encoding="", schema=""):
    """Why a channel may not declare this type (docs/channels.md, "Typed channels"), or None;
    the rules of plugin-api/include/skrobot/channel_type.hpp."""
    any_schema = bool(schema_name or schema_encoding or schema)
    if not message_encoding:
        return "a schema needs a message_encoding" if any_schema else None
    if message_encoding not in _TYPES:
        return "unknown message_encoding %r" % message_encoding
    takes, encodings = _TYPES[message_encoding]
    if not any_schema:
        if takes != "required":
            return None
        return ("message_encoding %s needs a schema (schema_name, schema_encoding, schema)"
                % message_encoding)
    if takes == "none":
        return "message_encoding %s takes no schema" % message_encoding
    if not schema_name:
        return "a schema needs a schema_name"
    if schema_encoding not in encodings:
        return "schema_encoding %r does not go with message_encoding %s (%s)" % (
            schema_encoding, message_encoding, "|".join(encodings))
    if not schema:
        return "schema %s has no text (the schema property)" % schema_name
    return None


def type_properties(message_encoding, schema_name="", schema_encoding="", schema=""):
    """A typed channel's properties (a dict for addStreamingChannel's props): message_encoding
    and, where it has one, the schema's name, encoding and text. ValueError when the type breaks
    the rules (type_problem)."""
    problem = type_problem(message_encoding, schema_name, schema_encoding, schema)
    if problem:
        raise ValueError("channel type: " + problem)
    props = {TYPE_KEYS[0]: message_encoding}
    if schema_name:
        props.update(zip(TYPE_KEYS[1:], (schema_name, schema_encoding, schema)))
    return props


def channel_type(props):
    """(message_encoding, schema_name, schema_encoding, schema) of a channel's properties, ""
    where they say nothing."""
    props = props or {}
    values = [props.get(k, "") for k in TYPE_KEYS]
    return tuple(v if isinstance(v, _TEXT) else "" for v in values)


def payload_bytes(name, width, height):
    """Bytes of a raw payload of width x height; 0 when `name` is not raw or the size is not
    allowed (zero, or odd for nv12/i420)."""
    e = encoding(name)
    if not e.raw or width <= 0 or height <= 0:
        return 0
    if e.even_size and (width % 2 or height % 2):
        return 0
    return width * height * e.bits_per_pixel // 8


def _header(code, seq, capture_ns, a, b, rate):
    return _HEADER.pack(_MAGIC, HEADER_BYTES, code, 0, seq, capture_ns, a, b, rate)


def _join(header, data):
    out = bytearray(header)
    buf, views = payloadBuffer(data)
    try:
        out.extend(buf)
    finally:
        releaseViews(views)
    return out


def _shapeSize(data, e):
    """(width, height) from a numpy array's shape (rows first), or (None, None)."""
    shape = getattr(data, "shape", None)
    if not shape or len(shape) < 2:
        return None, None
    rows, cols = shape[0], shape[1]
    if e.even_size:  # nv12/i420 as OpenCV holds them: h*3/2 rows of w bytes
        return cols, rows * 2 // 3
    return cols, rows


def make_frame(data, name, width=None, height=None, seq=0, capture_ns=0):
    """A video frame (bytearray, for publish) of encoding `name` from `data`: bytes-like (a JPEG
    file, or packed raw pixels) or a numpy array (width and height from its shape unless given;
    nv12/i420 as an (h*3/2, w) array). MediaFrameError when a raw payload is not exactly
    width*height*bytes per pixel (docs/channels.md) or the encoding is not video."""
    e = encoding(name)
    if not e.video:
        raise MediaFrameError("%s is audio: use make_audio_frame" % name)
    if width is None or height is None:
        w, h = _shapeSize(data, e)
        width = w if width is None else width
        height = h if height is None else height
    if width is None or height is None:
        raise MediaFrameError("give width and height (or a numpy array of shape (h, w, ...))")
    if not (0 <= width <= 0xFFFF and 0 <= height <= 0xFFFF):
        raise MediaFrameError("%dx%d does not fit the header's 16-bit sizes" % (width, height))
    out = _join(_header(e.code, seq, capture_ns, width, height, 0), data)
    if e.raw:
        want = payload_bytes(name, width, height)
        got = len(out) - HEADER_BYTES
        if want == 0 or got != want:
            raise MediaFrameError("%s %dx%d needs %s bytes of pixels, got %d" % (
                name, width, height, want or "an even, non-zero size and", got))
    return out


def make_audio_frame(data, sample_rate, channels=1, seq=0, capture_ns=0):
    """A PCM s16le frame: `data` interleaved samples (bytes-like or an int16 numpy array);
    `seq` is the index of its first sample since the stream began."""
    out = _join(_header(BY_NAME["s16le"].code, seq, capture_ns, channels, 0, sample_rate), data)
    if channels <= 0 or sample_rate <= 0 or (len(out) - HEADER_BYTES) % (2 * channels):
        raise MediaFrameError("PCM needs channels > 0, a rate > 0 and whole samples")
    return out


def frame_slot(view, name, width, height, seq=0, capture_ns=0):
    """A raw video frame built in place in `view` (a writable buffer: FlowSat.beginPublish's
    slot): writes the 32-byte header of encoding `name` (width x height) at its start and returns
    (pixels, size): the numpy array of its pixel area, shaped as MediaFrame.array() gives it
    ((h, w, 3) for bgr8, ...), to fill (cv2's dst=, numpy's out=, or a slice assignment), and
    the message's size for commitPublish. MediaFrameError for an encoding that is not raw
    video, a size it does not allow, or a view too small; ImportError without numpy."""
    import numpy
    e = encoding(name)
    want = payload_bytes(name, width, height) if e.video else 0
    if want == 0 or width > 0xFFFF or height > 0xFFFF:
        raise MediaFrameError("frame_slot needs raw video of an allowed size, not %s %dx%d"
                              % (name, width, height))
    size = HEADER_BYTES + want
    if len(view) < size:
        raise MediaFrameError("%s %dx%d needs %d bytes, the slot has %d"
                              % (name, width, height, size, len(view)))
    view[:HEADER_BYTES] = _header(e.code, seq, capture_ns, width, height, 0)
    f = MediaFrame()
    f.encoding, f.width, f.height, f.channels = name, width, height, 0
    f.payload = memoryview(view)[HEADER_BYTES:size]
    return f.array(), size


class MediaFrame(object):
    """A parsed frame. `payload` is a memoryview of the message under Python 3 (no copy; valid
    as long as the message is) and a str under 2.7."""
    __slots__ = ("encoding", "format", "flags", "seq", "capture_ns", "width", "height",
                 "channels", "sample_rate", "payload")

    def array(self):
        """The payload as a numpy array without a copy (read-only when the message is bytes),
        or None without numpy: (h, w) mono8/mono16, (h, w, 3|4) colour, (h*3/2, w) nv12/i420,
        (samples, channels) int16 audio, a flat uint8 array for JPEG."""
        try:
            import numpy
        except ImportError:
            return None
        e = BY_NAME[self.encoding]
        if not e.video:
            return numpy.frombuffer(self.payload, dtype="<i2").reshape(-1, self.channels)
        if not e.raw:
            return numpy.frombuffer(self.payload, dtype="uint8")
        if e.even_size:
            shape = (self.height * 3 // 2, self.width)
        else:
            shape = {8: (self.height, self.width), 16: (self.height, self.width),
                     24: (self.height, self.width, 3),
                     32: (self.height, self.width, 4)}[e.bits_per_pixel]
        dtype = "<u2" if e.bits_per_pixel == 16 else "uint8"
        return numpy.frombuffer(self.payload, dtype=dtype).reshape(shape)


def parse_frame(msg):
    """A MediaFrame from a message (bytes, bytearray, memoryview); MediaFrameError naming what is
    wrong when it is not a well-formed media frame (docs/channels.md). Sizes are checked before
    the payload is touched."""
    if len(msg) < HEADER_BYTES:
        raise MediaFrameError("%d bytes: shorter than the 32-byte header" % len(msg))
    magic, hsize, code, flags, seq, capture_ns, a, b, rate = _HEADER.unpack_from(msg, 0)
    if magic != _MAGIC:
        raise MediaFrameError("no SKMF magic")
    if hsize < HEADER_BYTES or hsize > len(msg):
        raise MediaFrameError("header size %d" % hsize)
    e = BY_CODE.get(code)
    if e is None:
        raise MediaFrameError("unknown format code %d" % code)
    size = len(msg) - hsize
    f = MediaFrame()
    f.encoding, f.format, f.flags, f.seq, f.capture_ns = e.name, code, flags, seq, capture_ns
    f.width = f.height = f.channels = f.sample_rate = 0
    if e.video:
        f.width, f.height = a, b
        if e.raw:
            want = payload_bytes(e.name, a, b)
            if want == 0 or want != size:
                raise MediaFrameError("%s %dx%d: %d bytes of pixels, %s expected" % (
                    e.name, a, b, size, want or "an even, non-zero size"))
    else:
        f.channels, f.sample_rate = a, rate
        if a == 0 or rate == 0 or size % (2 * a):
            raise MediaFrameError("PCM: %d channels at %d Hz, %d bytes" % (a, rate, size))
    f.payload = msg[hsize:] if PY2 else memoryview(msg)[hsize:]
    return f


__all__ = ["BY_CODE", "BY_NAME", "Encoding", "HEADER_BYTES", "MESSAGE_ENCODING", "MediaFrame",
           "MediaFrameError", "channel_properties", "encoding", "frame_slot", "make_audio_frame",
           "make_frame",
           "mime_for", "parse_frame", "payload_bytes"]
