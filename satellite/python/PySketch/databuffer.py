# SPDX-License-Identifier: Apache-2.0
"""DataBuffer: packs and unpacks payloads, little-endian, the way sketches exchange them.

    buf = DataBuffer()
    buf.setFloat([1.0, 2.5])          # replaces the content with two float32
    sat.publish(chanID, buf)          # publish() takes a DataBuffer or bytes
    x, y = DataBuffer(data).toFloat(2)

set*() replace the content, append*() add to it, to*(n) read n values from the start
(n=None: as many as fit). Every to*() returns a list.
"""
from __future__ import print_function, division, absolute_import

import struct

from PySketch.flowproto import toBytes, utf8, native

_FORMATS = {
    "Int8": "b", "UInt8": "B", "Int16": "h", "UInt16": "H", "Int32": "i", "UInt32": "I",
    "Int64": "q", "UInt64": "Q", "Float": "f", "Double": "d",
}


class DataBuffer(object):
    def __init__(self, data=None):
        self._data = bytearray()
        if data is not None:
            self._data.extend(toBytes(data))

    # -- whole content
    def setData(self, data):
        self._data = bytearray(toBytes(data))
        return self

    def append(self, data):
        self._data.extend(toBytes(data))
        return self

    def clear(self):
        self._data = bytearray()

    def size(self):
        return len(self._data)

    def isEmpty(self):
        return len(self._data) == 0

    def toBytes(self):
        return bytes(self._data)

    data = toBytes

    def toByteArray(self):
        return bytearray(self._data)

    def __len__(self):
        return len(self._data)

    def __eq__(self, other):
        try:
            return self.toBytes() == toBytes(other)
        except TypeError:
            return False

    def __ne__(self, other):
        return not self.__eq__(other)

    def __repr__(self):
        return "DataBuffer(%d bytes)" % len(self._data)

    # -- typed content
    def _set(self, fmt, values, append):
        if not isinstance(values, (list, tuple)):
            values = [values]
        packed = struct.pack("<%d%s" % (len(values), fmt), *values)
        if append:
            self._data.extend(packed)
        else:
            self._data = bytearray(packed)
        return self

    def _get(self, fmt, n, offset):
        size = struct.calcsize("<" + fmt)
        avail = (len(self._data) - offset) // size
        if n is None:
            n = avail
        if n > avail:
            raise ValueError("DataBuffer holds %d bytes: not enough for %d x %s"
                             % (len(self._data), n, fmt))
        return list(struct.unpack_from("<%d%s" % (n, fmt), bytes(self._data), offset))

    def setString(self, s):
        self._data = bytearray(utf8(s))
        return self

    def appendString(self, s):
        self._data.extend(utf8(s))
        return self

    def toString(self):
        return native(bytes(self._data))

    def count(self, typeName):
        """How many values of a type ("Float", "Int16", ...) the buffer holds."""
        return len(self._data) // struct.calcsize("<" + _FORMATS[typeName])


def _makeAccessors(name, fmt):
    def setter(self, values):
        return self._set(fmt, values, False)

    def appender(self, values):
        return self._set(fmt, values, True)

    def getter(self, n=None, offset=0):
        return self._get(fmt, n, offset)

    setter.__name__ = "set" + name
    appender.__name__ = "append" + name
    getter.__name__ = "to" + name
    setter.__doc__ = "Replaces the content with %s values (a list or one value)." % name
    appender.__doc__ = "Appends %s values (a list or one value)." % name
    getter.__doc__ = "The first n %s values (all that fit when n is None), as a list." % name
    setattr(DataBuffer, setter.__name__, setter)
    setattr(DataBuffer, appender.__name__, appender)
    setattr(DataBuffer, getter.__name__, getter)


for _name, _fmt in _FORMATS.items():
    _makeAccessors(_name, _fmt)
