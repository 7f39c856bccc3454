# SPDX-License-Identifier: Apache-2.0
"""The Variant codec and frame layouts against docs/flow-protocol.md, and the small modules
(DataBuffer, ElapsedTime, enums, addresses, log). No hub needed."""
from __future__ import unicode_literals

import binascii
import io
import math
import struct
import sys
import time
import unittest

from PySketch.flowproto import integer_types, text_type
from tests.compat import PY2, TextIO, redirect_stderr, redirect_stdout

from PySketch import flowproto
from PySketch.abstractflow import FlowChannel, parseAddress, robotAddress, validShortName
from PySketch.databuffer import DataBuffer
from PySketch.elapsedtime import ElapsedTime
from PySketch.flowproto import (
    ChannelInfo, Code, FlowChanID, Flow_T, ProtocolError, Reader, Variant_T, codeName,
    decodePhysMarker, decodeValue, decodeVariant, encodeValue, encodeVariant, frame)
from PySketch import log


def h(text):
    return binascii.unhexlify(text.replace(" ", ""))


class DocExamples(unittest.TestCase):
    """The examples of docs/flow-protocol.md, byte for byte."""

    def test_examples_encode_exactly(self):
        self.assertEqual(encodeVariant(1), h("02 01 00 00 00 00 00 00 00"))
        self.assertEqual(encodeVariant("hi"), h("05 02 00 00 00 68 69"))
        self.assertEqual(encodeVariant([True, None]), h("07 02 00 00 00 01 01 00"))
        self.assertEqual(encodeVariant({"a": 1.5}),
                         h("08 01 00 00 00 01 00 61 04 00 00 00 00 00 00 f8 3f"))

    def test_examples_decode_exactly(self):
        for value, text in [(1, "02 01 00 00 00 00 00 00 00"), ("hi", "05 02 00 00 00 68 69"),
                            ([True, None], "07 02 00 00 00 01 01 00"),
                            ({"a": 1.5}, "08 01 00 00 00 01 00 61 04 00 00 00 00 00 00 f8 3f")]:
            decoded, end = decodeVariant(h(text))
            self.assertEqual(decoded, value)
            self.assertEqual(end, len(h(text)))

    def test_value_field_has_an_encoding_byte(self):
        self.assertEqual(encodeValue("hi"), h("00 05 02 00 00 00 68 69"))
        self.assertEqual(decodeValue(h("00 05 02 00 00 00 68 69")), "hi")


class RoundTrip(unittest.TestCase):
    def roundTrip(self, value, expected=None):
        data = encodeVariant(value)
        decoded, end = decodeVariant(data)
        self.assertEqual(end, len(data))
        want = value if expected is None else expected
        if PY2 and isinstance(want, text_type):  # 2.7 decodes text to a native (UTF-8) str
            want = want.encode("utf-8")
        self.assertEqual(decoded, want)
        if not (PY2 and isinstance(want, integer_types)):  # 2.7: int or long by size alone
            self.assertEqual(type(decoded), type(want))
        return data

    def test_every_type(self):
        self.assertEqual(self.roundTrip(None), b"\x00")
        self.assertEqual(self.roundTrip(True), b"\x01\x01")
        self.assertEqual(self.roundTrip(False), b"\x01\x00")
        self.assertEqual(self.roundTrip(-1), b"\x02" + b"\xff" * 8)
        self.roundTrip(2 ** 63 - 1)
        self.roundTrip(-2 ** 63)
        self.assertEqual(self.roundTrip(2 ** 63), b"\x03" + struct.pack("<Q", 2 ** 63))
        self.assertEqual(self.roundTrip(2 ** 64 - 1), b"\x03" + b"\xff" * 8)
        self.assertEqual(self.roundTrip(0.1), b"\x04" + struct.pack("<d", 0.1))
        self.roundTrip(-0.0)
        self.roundTrip(float("inf"))
        nan, _ = decodeVariant(encodeVariant(float("nan")))
        self.assertTrue(math.isnan(nan))
        self.assertEqual(self.roundTrip("h\u00e9llo \u2603"),
                         b"\x05\x0a\x00\x00\x00" + "h\u00e9llo \u2603".encode("utf-8"))
        self.assertEqual(self.roundTrip(""), b"\x05\x00\x00\x00\x00")
        self.assertEqual(self.roundTrip(b"\x00\xff"), b"\x06\x02\x00\x00\x00\x00\xff")
        self.roundTrip(bytearray(b"ab"), b"ab")
        self.roundTrip(memoryview(b"ab"), b"ab")
        self.roundTrip([], [])
        self.roundTrip((1, "x"), [1, "x"])
        self.roundTrip({}, {})
        self.roundTrip({"list": [1, [2.5, {"deep": b"\x01"}]], "none": None, "": "empty key"})

    def test_map_keys_are_written_in_byte_order_like_the_hub(self):
        data = encodeVariant({"b": 1, "a": 2, "\u00e9": 3, "B": 4})
        keys = []
        r = Reader(data, 5)
        for _ in range(4):
            keys.append(r.raw(r.u16()))
            r.variant()
        self.assertEqual(keys, [b"B", b"a", b"b", "\u00e9".encode("utf-8")])

    def test_depth_limit(self):
        v = None
        for _ in range(31):
            v = [v]
        self.roundTrip(v)                  # 32 levels: allowed
        with self.assertRaises(ValueError):
            encodeVariant([v])             # 33
        deep = b"\x07\x01\x00\x00\x00" * 32 + b"\x00"
        with self.assertRaises(ProtocolError):
            decodeVariant(deep)

    def test_encoding_refuses_what_has_no_variant(self):
        for bad in (2 ** 64, -2 ** 63 - 1, {1: "x"}, object()):
            with self.assertRaises(ValueError):
                encodeVariant(bad)

    def test_enum_members_and_databuffers_encode_as_their_content(self):
        self.assertEqual(encodeVariant(Variant_T.T_FLOAT), encodeVariant(10))
        self.assertEqual(encodeVariant(DataBuffer(b"xy")), encodeVariant(b"xy"))

    def test_malformed_input_is_refused_before_allocating(self):
        for bad in ["", "09", "01", "01 02", "02 00", "05 05 00 00 00 61", "05 02 00 00 00 ff fe",
                    "06 ff ff ff ff", "07 ff ff ff 7f", "07 02 00 00 00 00",
                    "08 ff ff ff ff 00 00 00", "08 02 00 00 00 01 00 61 00 01 00 61 00",
                    "08 01 00 00 00 01 00 ff 00"]:
            with self.assertRaises(ProtocolError, msg=bad):
                decodeVariant(h(bad))

    def test_json_twin(self):
        self.assertEqual(flowproto.toJsonText({"b": bytearray(b"\x00\x01"), "n": [1, 2.5, None]}),
                         '{"b": {"$base64": "AAE="}, "n": [1, 2.5, null]}')
        text = b'{"b": {"$base64": "AAE="}, "m": {"$map": {"$base64": "x"}}}'
        value = decodeValue(b"\x01" + struct.pack("<I", len(text)) + text)
        self.assertEqual(value, {"b": b"\x00\x01", "m": {"$base64": "x"}})
        with self.assertRaises(ValueError):
            flowproto.toJsonText(float("nan"))


class Frames(unittest.TestCase):
    def test_frame_header(self):
        self.assertEqual(frame(Code.PING, b"ab"), h("03 00 00 00 10 61 62"))
        self.assertEqual(frame(Code.GO_ASYNC), h("01 00 00 00 0f"))

    def test_login_frame(self):
        from PySketch.flowsat import FlowSat
        s = FlowSat()
        s.setLogin("guest", "pw")
        s.setNodeName("n")
        body = h("01 00 0e 00 00") + b"\x05\x00guest" + b"\x02\x00pw" + b"\x01\x00n"  # 1.14, binary
        self.assertEqual(s._loginFrame(), struct.pack("<I", len(body) + 1) + b"\x01" + body)

    def test_a_channel_whose_type_breaks_the_rules_is_refused_before_it_is_sent(self):
        from PySketch.flowsat import FlowSat
        from PySketch.mediaframe import type_properties
        s = FlowSat()
        err = TextIO()
        with redirect_stderr(err):
            self.assertFalse(s.addStreamingChannel(name="twist", props={"message_encoding": "cdr"}))
        self.assertIn("twist's type: message_encoding cdr needs a schema", err.getvalue())
        self.assertTrue(s.addStreamingChannel(name="pose", props=type_properties("json")))

    def test_phys_marker(self):
        # EV_PHYS_MARKER (1.9): u16 chan_id, u64 seq, little-endian.
        self.assertEqual(codeName(0xFD), "EV_PHYS_MARKER")
        self.assertEqual((Code.PHYS_SWITCHED, Code.EV_PHYS_SWITCH), (0xF4, 0xFC))
        self.assertEqual(decodePhysMarker(h("05 00 03 00 00 00 00 01 00 00")), (5, (1 << 40) + 3))
        for bad in ("05 00 03 00 00 00 00 01 00", "05 00 03 00 00 00 00 01 00 00 00"):
            with self.assertRaises(ProtocolError, msg=bad):
                decodePhysMarker(h(bad))

    def test_channel_info(self):
        body = (struct.pack("<HQB", 7, 99, 1) + b"\x09\x00guest.cam" + b"\x05\x00guest" +
                struct.pack("<I", 3) + b"\x0a\x00image/jpeg" + struct.pack("<I", 2) +
                encodeValue({"resolution": "640x480", "flow_type": "FT_VIDEO_DATA",
                             "data_type": "T_BYTEARRAY"}))
        r = Reader(body)
        info = ChannelInfo.read(r)
        r.done("ChannelInfo")
        ch = FlowChannel.fromInfo(info)
        self.assertEqual((ch.chanID, ch.hashID, ch.name, ch.shortName, ch.owner, ch.mime),
                         (7, 99, "guest.cam", "cam", "guest", "image/jpeg"))
        self.assertTrue(ch.isStreaming())
        self.assertEqual(ch.subscribers, 2)
        self.assertIs(ch.flowType, Flow_T.FT_VIDEO_DATA)
        self.assertIs(ch.dataType, Variant_T.T_BYTEARRAY)
        self.assertEqual(ch.props["resolution"], "640x480")
        self.assertFalse(ch.isPublishingEnabled)


class SmallModules(unittest.TestCase):
    def test_enums(self):
        self.assertIn("T_BYTEARRAY", [m.name for m in Variant_T])
        self.assertEqual(Variant_T(Variant_T.T_STRING.value), Variant_T.T_STRING)
        self.assertEqual(Variant_T["T_FLOAT"], Variant_T.T_FLOAT)
        self.assertEqual(Flow_T.FT_BLOB.name, "FT_BLOB")
        self.assertTrue(hasattr(Flow_T, "FT_STREAMING"))
        self.assertEqual(str(Flow_T.FT_BLOB), "Flow_T.FT_BLOB")
        self.assertEqual(FlowChanID(5), 5)
        with self.assertRaises(ValueError):
            Flow_T(999)

    def test_databuffer(self):
        b = DataBuffer()
        b.setFloat([1.0, 2.5, -3.0])
        self.assertEqual(b.toBytes(), struct.pack("<fff", 1.0, 2.5, -3.0))
        self.assertEqual(DataBuffer(b.toBytes()).toFloat(3), [1.0, 2.5, -3.0])
        self.assertEqual(DataBuffer(b.toBytes()).toFloat(2), [1.0, 2.5])
        self.assertEqual(b.toFloat(), [1.0, 2.5, -3.0])
        b.setInt16(-2).appendUInt8([1, 2]).appendDouble(0.5)
        self.assertEqual(b.toBytes(), struct.pack("<hBBd", -2, 1, 2, 0.5))
        self.assertEqual(b.toInt16(1), [-2])
        self.assertEqual(b.toDouble(1, offset=4), [0.5])
        native = "h\u00e9".encode("utf-8") if PY2 else "h\u00e9"   # 2.7: a UTF-8 str
        self.assertEqual(DataBuffer().setString("h\u00e9").toString(), native)
        self.assertEqual(len(DataBuffer(bytearray(b"abc"))), 3)
        with self.assertRaises(ValueError):
            DataBuffer(b"abc").toFloat(1)

    def test_elapsed_time(self):
        t = ElapsedTime()
        time.sleep(0.02)
        first = t.stop()
        self.assertGreaterEqual(first, 0.019)
        self.assertGreaterEqual(t.stop(), first, "stop() does not reset")
        t.start()
        self.assertLess(t.stop(), first)
        self.assertIsInstance(t.stop(), float)

    def test_addresses(self):
        self.assertEqual(parseAddress("local:/tmp/Robot"), ("local", "/tmp/Robot"))
        self.assertEqual(parseAddress("tcp:robot.local"), ("tcp", ("robot.local", 9000)))
        self.assertEqual(parseAddress("tcp:10.0.0.2:9100"), ("tcp", ("10.0.0.2", 9100)))
        self.assertEqual(parseAddress("tcp:[::1]:9001"), ("tcp", ("::1", 9001)))
        self.assertEqual(parseAddress("tcp:[::1]"), ("tcp", ("::1", 9000)))
        for bad in ("", "local:", "udp:x", "tcp:", "tcp:h:0", "tcp:h:x"):
            with self.assertRaises(ValueError, msg=bad):
                parseAddress(bad)
        import os
        saved = os.environ.pop("ROBOT_ADDRESS", None)
        try:
            self.assertEqual(robotAddress(), "local:/tmp/Robot")
            os.environ["ROBOT_ADDRESS"] = "tcp:h"
            self.assertEqual(robotAddress(), "tcp:h")
            self.assertEqual(robotAddress("local:/x"), "local:/x")
        finally:
            os.environ.pop("ROBOT_ADDRESS", None)
            if saved is not None:
                os.environ["ROBOT_ADDRESS"] = saved

    def test_short_names(self):
        for good in ("sense", "a.b-c_D9", "x" * 128):
            self.assertTrue(validShortName(good), good)
        for bad in ("", ".hidden", "a b", "x" * 129, "caf\u00e9", None):
            self.assertFalse(validShortName(bad), bad)

    def test_log(self):
        out, errs = TextIO(), TextIO()
        with redirect_stdout(out), redirect_stderr(errs):
            log.msg("hello", [1, 2])
            log.dbg("debugging")
            log.wrn("careful")
            log.err("broken")
            log.cri("on fire")
            log.printPair("speed", 3)
        self.assertRegex(out.getvalue(), r"\[MSG\] hello \[1, 2\]")
        self.assertIn("[DBG] debugging", out.getvalue())
        self.assertIn("[MSG] speed: 3", out.getvalue())
        for text in ("[WRN] careful", "[ERR] broken", "[CRI] on fire"):
            self.assertIn(text, errs.getvalue())
        log.setLevel("wrn")
        try:
            out = TextIO()
            with redirect_stdout(out):
                log.msg("hidden")
            self.assertEqual(out.getvalue(), "")
        finally:
            log.setLevel("dbg")


if __name__ == "__main__":
    unittest.main()
