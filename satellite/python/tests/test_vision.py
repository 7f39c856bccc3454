# SPDX-License-Identifier: Apache-2.0
"""face-detect fed from Python: raw bgr8 frames built from numpy arrays (PySketch/mediaframe.py)
find the faces that the JPEG path finds, on the opencv-doc and scikit-image pictures. Python 3
only: OpenCV's Python binding (python3-opencv, installed by tools/bootstrap.sh) reads the
pictures and encodes the JPEGs."""
from __future__ import print_function

import json
import unittest

import cv2

from PySketch import mediaframe
from PySketch.flowproto import Flow_T, Variant_T

from tests.hubtest import HubTestCase, pump

MESSI = "/usr/share/doc/opencv-doc/examples/data/messi5.jpg"
ASTRONAUT = "/usr/lib/python3/dist-packages/skimage/data/astronaut.png"
LONG = 30.0  # the detector's first frame loads its cascade


def coveredBy(a, b):
    """The share of box a (x, y, w, h) that box b covers."""
    w = min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0])
    h = min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1])
    return float(max(w, 0) * max(h, 0)) / (a[2] * a[3]) if a[2] * a[3] else 0.0


class FaceDetectFromPython(HubTestCase):
    project_modules = ({"name": "face-detect",
                        "config": {"input": "guest.camera", "detect_width": 0}},)

    def test_bgr8_frames_find_the_faces_that_jpeg_finds(self):
        s = self.connected()
        results = {}

        def onData(chanID, data):
            ch = s.channelByID(chanID)
            if ch is not None and ch.name == "face-detect.faces":
                r = json.loads(bytes(data).decode("utf-8"))
                results[r["seq"]] = r

        s.setGrabDataCallBack(onData)
        props = mediaframe.channel_properties("bgr8")
        self.assertTrue(s.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY, "camera",
                                              mime=mediaframe.mime_for("bgr8"), props=props))
        self.assertTrue(pump([s], lambda: s.channelByName("guest.camera") is not None
                             and s.channelByName("face-detect.faces") is not None, LONG),
                        self.hub.log()[-2000:])
        self.assertTrue(s.subscribeChannel("face-detect.faces"))
        camera = s.channelByName("guest.camera")
        self.assertTrue(pump([s], lambda: camera.isPublishingEnabled, LONG), self.hub.log()[-2000:])

        seq = 0
        for path in (MESSI, ASTRONAUT):
            image = cv2.imread(path)
            self.assertIsNotNone(image, path)
            ok, jpeg = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 90])
            self.assertTrue(ok)
            h, w = image.shape[:2]
            seq += 1
            jpegSeq = seq
            # One frame at a time: the pipeline keeps only the newest frame, and an outcome older
            # than one already delivered is dropped as late (the raw frame skips the decode and
            # could overtake the JPEG on another worker).
            self.assertTrue(s.publish(camera.chanID, mediaframe.make_frame(
                jpeg.tobytes(), "jpeg", w, h, seq=jpegSeq)))
            self.assertTrue(pump([s], lambda: jpegSeq in results, LONG),
                            (sorted(results), self.hub.log()[-2000:]))
            seq += 1
            rawSeq = seq
            self.assertTrue(s.publish(camera.chanID, mediaframe.make_frame(image, "bgr8",
                                                                           seq=rawSeq)))
            self.assertTrue(pump([s], lambda: rawSeq in results, LONG),
                            (sorted(results), self.hub.log()[-2000:]))
            byJpeg = [(f["x"], f["y"], f["w"], f["h"]) for f in results[jpegSeq]["faces"]]
            byRaw = [(f["x"], f["y"], f["w"], f["h"]) for f in results[rawSeq]["faces"]]
            self.assertTrue(byJpeg, (path, results[jpegSeq]))
            self.assertEqual((results[rawSeq]["width"], results[rawSeq]["height"]), (w, h))
            # Every face the JPEG path found is found again (JPEG's losses move a box a little).
            for j in byJpeg:
                self.assertTrue(any(coveredBy(j, b) > 0.7 for b in byRaw),
                                (path, "jpeg", byJpeg, "bgr8", byRaw))


if __name__ == "__main__":
    unittest.main()
