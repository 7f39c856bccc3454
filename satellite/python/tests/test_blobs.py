# SPDX-License-Identifier: Apache-2.0
"""Blob channels from PySketch (FlowSync's blob calls, FlowSat's change events) against a real
hub, under Python 3 and 2.7."""
import hashlib
import os
import random
import tempfile

from PySketch.flowproto import ChanKind_T, Error_T
from PySketch.flowsync import FlowSync

from tests.hubtest import HubTestCase, pump


class Blobs(HubTestCase):
    def sync(self):
        s = FlowSync(self.hub.address, "guest", "password")
        self.assertTrue(s.connect())
        self.addCleanup(s.close)
        return s

    def test_put_get_list_and_the_rest(self):
        s = self.sync()
        ch = s.blobCreate("maps")
        self.assertIsNotNone(ch, s.lastError)
        self.assertEqual(ch.name, "guest.maps")
        self.assertEqual(s.channelByName("guest.maps").chanID, ch.chanID)
        rnd = random.Random(7)
        data = bytes(bytearray(rnd.randrange(256) for _ in range(3 * 256 * 1024 + 99)))
        seen = []
        version = s.blobPut(ch, "floor1/map.pgm", data, lambda done, total: seen.append(done))
        self.assertTrue(version, s.lastError)
        self.assertEqual(seen[-1], len(data))
        self.assertEqual(s.blobGet("guest.maps", "floor1/map.pgm"), data)
        entries = s.blobList(ch.chanID, "floor1")
        self.assertEqual([(e["name"], e["size"], e["dir"]) for e in entries],
                         [("map.pgm", len(data), False)])
        self.assertEqual(entries[0]["version"], version)
        # To and from files.
        d = tempfile.mkdtemp()
        src, back = os.path.join(d, "src.bin"), os.path.join(d, "back.bin")
        with open(src, "wb") as f:
            f.write(data[::-1])
        self.assertTrue(s.blobPutFile(ch, src, "floor1/map.pgm"))
        self.assertEqual(s.blobGetFile(ch, "floor1/map.pgm", back), len(data))
        with open(back, "rb") as f:
            self.assertEqual(hashlib.sha256(f.read()).hexdigest(),
                             hashlib.sha256(data[::-1]).hexdigest())
        # In place, as a new version.
        self.assertTrue(s.blobPut(ch, "note.txt", b"hello world"))
        self.assertTrue(s.blobModify(ch, "note.txt", 6, b"robot"))
        self.assertEqual(s.blobGet(ch, "note.txt"), b"hello robot")
        self.assertTrue(s.blobPut(ch, "empty", b""))
        self.assertEqual(s.blobGet(ch, "empty"), b"")
        self.assertTrue(s.blobMkdir(ch, "floor2"))
        self.assertTrue(s.blobRmdir(ch, "floor2"))
        self.assertTrue(s.blobRemove(ch, "note.txt"))
        # Refusals: errors, and the connection stays.
        self.assertIsNone(s.blobGet(ch, "note.txt"))
        self.assertEqual(s.lastError.code, Error_T.not_found)
        self.assertIsNone(s.blobGet(ch, "../../etc/passwd"))
        self.assertEqual(s.lastError.code, Error_T.invalid_argument)
        self.assertFalse(s.blobRemove(ch, "floor1"))
        self.assertEqual(s.lastError.code, Error_T.invalid_argument)
        self.assertTrue(s.isConnected())
        kinds = dict((c.name, c.kind) for c in s.channels())
        self.assertEqual(kinds["guest.maps"], ChanKind_T.CK_BLOB)

    def test_a_cut_upload_resumes(self):
        s = self.sync()
        ch = s.blobCreate("runs")
        data = os.urandom(40 * 256 * 1024)
        d = tempfile.mkdtemp()
        src = os.path.join(d, "run.bin")
        with open(src, "wb") as f:
            f.write(data)
        acks = []

        def cut(done, total):
            acks.append(done)
            if len(acks) == 3:
                s._sock.close()  # the connection is lost mid-upload
        self.assertIsNone(s.blobPutFile(ch, src, "run.bin", cut))
        upload = s.lastUploadId
        self.assertTrue(upload)
        again = self.sync()
        resumed = []
        put = again.blobPutFile(ch, src, "run.bin",
                                lambda done, total: resumed.append(done), upload)
        self.assertTrue(put, again.lastError and again.lastError.message)
        self.assertGreaterEqual(resumed[0], 3 * 256 * 1024)
        self.assertEqual(again.blobGet(ch, "run.bin"), data)

    def test_subscribers_hear_of_changes(self):
        s = self.sync()
        ch = s.blobCreate("calib")
        sat = self.connected()
        changes = []
        sat.setBlobChangedCallBack(lambda *a: changes.append(a))
        sat.subscribeChannel("guest.calib")  # kept by name: made once the channel is listed
        self.assertTrue(pump([sat], lambda: sat._byName.get("guest.calib") is not None and
                             sat._byName["guest.calib"].isSubscribed))
        pump([sat], lambda: False, 0.3)  # the SUBSCRIBE reaches the hub
        version = s.blobPut(ch, "camera.yaml", b"fx: 500")
        self.assertTrue(pump([sat], lambda: len(changes) >= 1))
        self.assertEqual(changes[0], (ch.chanID, 1, "camera.yaml", 7, version))
