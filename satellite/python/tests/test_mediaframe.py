# SPDX-License-Identifier: Apache-2.0
"""PySketch.mediaframe against docs/channels.md: raw frames made and parsed byte for byte, sizes
refused, the vocabulary's derived keys, numpy views when numpy is there. No hub needed."""
from __future__ import unicode_literals

import binascii
import unittest

from PySketch import mediaframe
from PySketch.mediacodes import DERIVED, ENCODINGS
from PySketch.mediaframe import MediaFrameError

try:
    import numpy
except ImportError:
    numpy = None

SIZES_4X2 = {"mono8": 8, "rgb8": 24, "bgr8": 24, "rgba8": 32, "bgra8": 32, "mono16": 16,
             "nv12": 12, "i420": 12}


def pattern(n):
    return bytes(bytearray((i * 7 + 3) & 0xFF for i in range(n)))


class RawFrames(unittest.TestCase):

    def test_every_raw_encoding_round_trips_with_its_packed_size(self):
        for name, size in sorted(SIZES_4X2.items()):
            self.assertEqual(mediaframe.payload_bytes(name, 4, 2), size, name)
            pixels = pattern(size)
            msg = mediaframe.make_frame(pixels, name, 4, 2, seq=41, capture_ns=1234)
            self.assertEqual(len(msg), 32 + size)
            self.assertEqual(msg[6], mediaframe.BY_NAME[name].code)
            f = mediaframe.parse_frame(bytes(msg))
            self.assertEqual((f.encoding, f.width, f.height, f.seq, f.capture_ns),
                             (name, 4, 2, 41, 1234))
            self.assertEqual(bytes(f.payload), pixels)
            with self.assertRaises(MediaFrameError):
                mediaframe.make_frame(pattern(size - 1), name, 4, 2)
            with self.assertRaises(MediaFrameError):
                mediaframe.parse_frame(bytes(msg[:-1]))
            with self.assertRaises(MediaFrameError):
                mediaframe.parse_frame(bytes(msg) + b"x")

    def test_header_bytes_are_those_documented(self):
        # The same bytes as media_frame_test's HeaderBytesAreThoseDocumented (C++).
        msg = mediaframe.make_frame(b"abcdef", "bgr8", 2, 1, seq=0x0102030405060708,
                                    capture_ns=9)
        self.assertEqual(binascii.hexlify(bytes(msg)).decode("ascii"),
                         "534b4d4620000500" "0807060504030201" "0900000000000000"
                         "0200010000000000" + binascii.hexlify(b"abcdef").decode("ascii"))

    def test_odd_planar_yuv_zero_sizes_and_huge_claims_are_refused(self):
        self.assertEqual(mediaframe.payload_bytes("nv12", 3, 2), 0)
        self.assertEqual(mediaframe.payload_bytes("i420", 4, 3), 0)
        with self.assertRaises(MediaFrameError):
            mediaframe.make_frame(pattern(9), "nv12", 3, 2)
        with self.assertRaises(MediaFrameError):
            mediaframe.make_frame(b"", "rgb8", 0, 2)
        header = bytearray(mediaframe.make_frame(b"a", "mono8", 1, 1))
        header[6] = mediaframe.BY_NAME["rgba8"].code
        header[24:28] = b"\xff\xff\xff\xff"  # 65535 x 65535 claimed, 1 byte sent
        with self.assertRaises(MediaFrameError) as e:
            mediaframe.parse_frame(bytes(header))
        self.assertIn("rgba8 65535x65535", str(e.exception))
        for code in (0, 11, 255):
            header[6] = code
            with self.assertRaises(MediaFrameError):
                mediaframe.parse_frame(bytes(header))
        with self.assertRaises(MediaFrameError):
            mediaframe.make_frame(b"x", "s16le", 1, 1)
        with self.assertRaises(MediaFrameError):
            mediaframe.make_frame(b"x", "rgb9", 1, 1)

    def test_jpeg_and_audio_frames(self):
        f = mediaframe.parse_frame(bytes(mediaframe.make_frame(b"\xff\xd8jpeg", "jpeg", 640, 360)))
        self.assertEqual((f.encoding, f.width, f.height, bytes(f.payload)),
                         ("jpeg", 640, 360, b"\xff\xd8jpeg"))
        a = mediaframe.parse_frame(bytes(mediaframe.make_audio_frame(b"\x01\x00\x02\x00",
                                                                     22050, 1, seq=7)))
        self.assertEqual((a.encoding, a.sample_rate, a.channels, a.seq), ("s16le", 22050, 1, 7))
        with self.assertRaises(MediaFrameError):
            mediaframe.make_audio_frame(b"\x01\x00\x02", 22050, 1)


class Vocabulary(unittest.TestCase):

    def test_older_keys_are_derived_from_the_encoding(self):
        p = mediaframe.channel_properties("bgr8", width=640, height=480, fps=30)
        self.assertEqual(p, {"message_encoding": "skrobot.media", "encoding": "bgr8",
                             "pixel_format": "bgr24", "codec": "raw",
                             "flow_type": "FT_VIDEO_DATA", "data_type": "T_BYTEARRAY",
                             "width": 640, "height": 480, "fps": 30})
        self.assertEqual(mediaframe.channel_properties("jpeg")["pixel_format"], "yuvj420p")
        self.assertEqual(mediaframe.channel_properties("mono8")["pixel_format"], "gray")
        audio = mediaframe.channel_properties("s16le", sample_rate=22050, channels=1)
        self.assertEqual(audio["format"], "s16le")
        self.assertNotIn("pixel_format", audio)
        self.assertEqual(mediaframe.mime_for("jpeg"), "image/jpeg")
        self.assertEqual(mediaframe.mime_for("s16le"), "audio/L16")

    def test_the_table_is_one_to_one(self):
        self.assertEqual(len(set(r[0] for r in ENCODINGS)), len(ENCODINGS))
        self.assertEqual(len(set(r[1] for r in ENCODINGS)), len(ENCODINGS))
        self.assertEqual([d[0] for d in DERIVED], [r[0] for r in ENCODINGS])


class TypedChannels(unittest.TestCase):
    """The rules of channel_type.hpp, as tests/support_lib/channel_type_test.cpp checks them."""

    def test_a_json_channel_with_or_without_its_schema(self):
        self.assertEqual(mediaframe.type_properties("json"), {"message_encoding": "json"})
        p = mediaframe.type_properties("json", "skrobot.Faces", "jsonschema", '{"type":"object"}')
        self.assertEqual(p, {"message_encoding": "json", "schema_name": "skrobot.Faces",
                             "schema_encoding": "jsonschema", "schema": '{"type":"object"}'})
        self.assertEqual(mediaframe.channel_type(p),
                         ("json", "skrobot.Faces", "jsonschema", '{"type":"object"}'))
        self.assertEqual(mediaframe.channel_type({"message_encoding": 3}), ("", "", "", ""))

    def test_wrong_types_are_refused_naming_why(self):
        cases = [
            (("cdr",), "needs a schema"),
            (("yaml",), "unknown message_encoding"),
            (("skrobot.media", "x", "jsonschema", "{}"), "takes no schema"),
            (("cdr", "geometry_msgs/msg/Twist", "jsonschema", "x"), "does not go with"),
            (("cdr", "geometry_msgs/msg/Twist", "ros2msg", ""), "has no text"),
            (("json", "", "jsonschema", "{}"), "needs a schema_name"),
            (("", "x", "jsonschema", "{}"), "needs a message_encoding"),
        ]
        for args, why in cases:
            with self.assertRaises(ValueError) as e:
                mediaframe.type_properties(*args)
            self.assertIn(why, str(e.exception), args)
        self.assertIsNone(mediaframe.type_problem("cdr", "geometry_msgs/msg/Twist", "ros2msg",
                                                  "Vector3 linear\nVector3 angular\n"))
        self.assertIsNone(mediaframe.type_problem())


@unittest.skipIf(numpy is None, "numpy is not installed for this interpreter")
class Numpy(unittest.TestCase):

    def test_an_array_in_and_a_view_out(self):
        img = numpy.arange(2 * 4 * 3, dtype=numpy.uint8).reshape(2, 4, 3)
        msg = bytes(mediaframe.make_frame(img, "bgr8", seq=3))
        f = mediaframe.parse_frame(msg)
        self.assertEqual((f.width, f.height), (4, 2))
        out = f.array()
        self.assertEqual(out.shape, (2, 4, 3))
        self.assertTrue((out == img).all())
        self.assertFalse(out.flags.writeable)  # a view of the message, not a copy

    def test_shapes_of_other_encodings(self):
        deep = numpy.array([[1, 258], [65535, 0]], dtype="<u2")
        f = mediaframe.parse_frame(bytes(mediaframe.make_frame(deep, "mono16")))
        self.assertEqual(bytes(f.payload), b"\x01\x00\x02\x01\xff\xff\x00\x00")
        self.assertTrue((f.array() == deep).all())
        yuv = numpy.zeros((6, 4), dtype=numpy.uint8)  # a 4x4 nv12 image as OpenCV holds it
        f = mediaframe.parse_frame(bytes(mediaframe.make_frame(yuv, "nv12")))
        self.assertEqual((f.width, f.height, f.array().shape), (4, 4, (6, 4)))
        with self.assertRaises(MediaFrameError):
            mediaframe.make_frame(numpy.zeros((2, 4, 3), dtype=numpy.uint8), "rgba8")
        # A strided slice is packed in C order.
        wide = numpy.arange(4 * 8, dtype=numpy.uint8).reshape(4, 8)
        f = mediaframe.parse_frame(bytes(mediaframe.make_frame(wide[:, ::2], "mono8")))
        self.assertTrue((f.array() == wide[:, ::2]).all())


if __name__ == "__main__":
    unittest.main()
