# SPDX-License-Identifier: Apache-2.0
"""FlowProtocol 1.14 from PySketch: watchDatabase (the pairs, a snapshot end, then every change;
a refusal and the database's removal end the watch at the error callback) and
subscribeChannel(..., maxHz=N) (a rate cap, newest wins: a burst on a channel that then falls
still ends on its newest message)."""
from __future__ import print_function

import unittest

from PySketch.flowproto import (DB_PAIR_CLEARED, DB_PAIR_REMOVED, DB_PAIR_SET,
                                DB_PAIR_SNAPSHOT_END, Error_T, Flow_T, Variant_T)

from tests.hubtest import HubTestCase, pump

STATES = {DB_PAIR_SET: "set", DB_PAIR_REMOVED: "removed", DB_PAIR_CLEARED: "cleared",
          DB_PAIR_SNAPSHOT_END: "end"}


class Watch(HubTestCase):

    def test_a_watch_gets_the_pairs_then_every_change_until_the_database_goes(self):
        writer = self.connected()
        writer.createDatabase("settings")
        writer.setCurrentDbName("settings")
        writer.setVariable("mode", "auto")
        done = []
        writer.syncDatabases(lambda: done.append(1))
        self.assertTrue(pump([writer], lambda: done))

        watcher = self.connected()
        heard, errors = [], []
        watcher.setErrorCallBack(lambda e: errors.append(e))

        def pair(db, key, state, value):
            heard.append((db, STATES[state], key, value))
        self.assertTrue(watcher.watchDatabase("settings", pair))
        self.assertTrue(pump([watcher], lambda: len(heard) >= 2))
        self.assertEqual(heard, [("settings", "set", "mode", "auto"), ("settings", "end", "", None)])
        del heard[:]
        writer.setVariable("speed", 2)
        writer.delVariable("mode")
        self.assertTrue(pump([writer, watcher], lambda: len(heard) >= 2))
        self.assertEqual(heard, [("settings", "set", "speed", 2),
                                 ("settings", "removed", "mode", None)])

        # The database removed: the watch ends, at the error callback.
        writer.removeDatabase("settings")
        self.assertTrue(pump([writer, watcher], lambda: errors))
        self.assertEqual(errors[0].code, Error_T.not_found)
        self.assertEqual(errors[0].command, "DB_WATCH")
        self.assertFalse(watcher.isWatching("settings"))
        # A database that does not exist: refused the same way.
        self.assertTrue(watcher.watchDatabase("nothing", pair))
        self.assertTrue(pump([watcher], lambda: len(errors) >= 2))
        self.assertEqual(errors[1].code, Error_T.not_found)
        self.assertFalse(watcher.isWatching("nothing"))

    def test_unwatched_nothing_more_comes(self):
        writer = self.connected()
        writer.createDatabase("panel")
        writer.setCurrentDbName("panel")
        watcher = self.connected()
        heard = []
        self.assertTrue(watcher.watchDatabase("panel", lambda *p: heard.append(p)))
        self.assertTrue(pump([writer, watcher], lambda: heard))
        self.assertEqual(heard[-1][2], DB_PAIR_SNAPSHOT_END)
        self.assertTrue(watcher.unwatchDatabase("panel"))
        del heard[:]
        writer.setVariable("x", 1)
        done = []
        writer.syncDatabases(lambda: done.append(1))
        self.assertTrue(pump([writer], lambda: done))
        pump([watcher], lambda: False, timeout=0.3)
        self.assertEqual(heard, [])


class Rate(HubTestCase):

    def test_a_capped_subscription_ends_on_the_newest_message(self):
        pub = self.connected()
        self.assertTrue(pub.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY, "preview"))
        self.assertTrue(pump([pub], lambda: pub.channelByName("guest.preview")))
        mine = pub.channelByName("guest.preview")
        sub = self.connected()
        got = []
        sub.setGrabDataCallBack(lambda chanID, data: got.append(bytes(data)))
        self.assertTrue(pump([sub], lambda: sub.channelByName("guest.preview")))
        self.assertTrue(sub.subscribeChannel("guest.preview", maxHz=2))
        self.assertTrue(pump([pub, sub], lambda: mine.isPublishingEnabled))
        for i in range(5):
            self.assertTrue(pub.publish(mine.chanID, str(i).encode()))
        pub.tick()
        # The first at once, the newest when the 500 ms interval ends; the three between skipped.
        self.assertTrue(pump([pub, sub], lambda: b"4" in got, timeout=3.0), got)
        pump([sub], lambda: False, timeout=0.2)
        self.assertEqual(got, [b"0", b"4"])


if __name__ == "__main__":
    unittest.main()
