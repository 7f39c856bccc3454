# SPDX-License-Identifier: Apache-2.0
"""A hub restart under running satellites: they notice, reconnect by themselves, re-create
their channels under the same names and re-subscribe by name; data flows again."""
import re
import signal
import time
import unittest

from PySketch.flowproto import Flow_T, Variant_T

from tests.compat import monotonic
from tests.hubtest import EXAMPLES, HubTestCase, Sketch, TIMEOUT, pump, tickFor

CREDENTIALS = ["--user", "guest", "--password", "password"]


class HubRestart(HubTestCase):
    def test_sketches_recover_from_a_hub_restart(self):
        env = self.hub.env()
        pub = Sketch([EXAMPLES + "/publisher.py"] + CREDENTIALS + ["--hz", "50"], env)
        self.addCleanup(lambda: pub.alive() and pub.stop(signal.SIGKILL))
        sub = Sketch([EXAMPLES + "/subscriber.py"] + CREDENTIALS, env)
        self.addCleanup(lambda: sub.alive() and sub.stop(signal.SIGKILL))
        pub.waitFor(r"channel ready: guest\.sine")
        sub.waitFor(r"^guest\.sine: ", count=5)
        pub.waitFor(r"first subscriber: publishing on guest\.sine")

        self.hub.stop()
        sub.waitFor(r"lost the hub")
        pub.waitFor(r"lost the hub")
        time.sleep(0.3)                       # a few failed attempts while the hub is away
        self.assertTrue(pub.alive() and sub.alive(), pub.output() + sub.output())

        restarted = monotonic()   # before start(): a sketch may be back before it returns
        self.hub.start()
        pub.waitFor(r"reconnected to", since=restarted)
        sub.waitFor(r"reconnected to", since=restarted)
        pub.waitFor(r"channel ready: guest\.sine \(id \d+\)", since=restarted)
        sub.waitFor(r"found guest\.sine", since=restarted)
        pub.waitFor(r"first subscriber: publishing on guest\.sine", since=restarted)
        fresh = sub.waitFor(r"^guest\.sine: -?\d", count=10, since=restarted)
        self.assertTrue(all(-1.0 <= float(l.split()[1]) <= 1.0 for l in fresh), fresh)
        log = self.hub.log()
        self.assertRegex(log, r"FLOW-CHANNEL-ADDED guest\.sine id \d+", "the same name")

        self.assertEqual(sub.stop(), 0, sub.output())
        self.assertEqual(pub.stop(), 0, pub.output())

    def test_channels_properties_and_services_come_back(self):
        owner = self.sat(tick=0.005)
        reader = self.sat(tick=0.005)
        events = {"added": [], "removed": [], "started": []}
        owner.setNewChanCallBack(lambda ch: events["added"].append(ch))
        owner.setDelChanCallBack(lambda ch: events["removed"].append(ch))
        owner.setStartChanPubReqCallBack(lambda ch: events["started"].append(ch))
        owner.setRequestCallBack(lambda chanID, h, cmd, v: owner.sendServiceResponse(chanID, h, v))
        got, answers = [], []
        reader.setGrabDataCallBack(lambda chanID, data: got.append(data))
        reader.setResponseCallBack(lambda chanID, v: answers.append(v))
        self.assertTrue(owner.connect() and reader.connect())
        owner.addStreamingChannel(Flow_T.FT_SENSOR_DATA, Variant_T.T_FLOAT, "imu", "x-imu",
                                  props={"rate": 100})
        owner.addServiceChannel("svc")
        reader.subscribeChannel("guest.imu")
        self.assertTrue(pump([owner, reader], lambda: events["started"] and
                             reader.channelByName("guest.svc")))
        owner.setCurrentDbName("guest.imu")
        owner.setVariable("calibrated", True)
        first_imu = owner.channelByName("guest.imu")

        self.hub.stop()
        self.assertTrue(pump([owner, reader], lambda: not owner.isOnline() and
                             not reader.isOnline()))
        self.assertTrue(owner.isConnected() and reader.isConnected(),
                        "a sketch returning isConnected() keeps running")
        self.assertIn("guest.imu", [ch.name for ch in events["removed"]])
        self.assertIsNone(owner.channelByName("guest.imu"))
        self.assertFalse(owner.publish(first_imu.chanID, b"lost"), "offline")
        tickFor([owner, reader], 0.3)

        self.hub.start()
        events["started"] = []
        self.assertTrue(pump([owner, reader], lambda: events["started"] and
                             reader.channelByName("guest.svc")), "re-created, re-subscribed")
        imu = owner.channelByName("guest.imu")
        self.assertTrue(imu.isOwned and imu.isPublishingEnabled)
        self.assertIs(events["added"][-1].name in ("guest.imu", "guest.svc"), True)
        self.assertEqual(imu.mime, "x-imu")
        owner.publishFloat(imu.chanID, [1.0, 2.0])
        self.assertTrue(pump([owner, reader], lambda: got))
        reader.sendServiceRequest(reader.channelID("guest.svc"), "again", "yes")
        self.assertTrue(pump([owner, reader], lambda: answers == ["yes"]))
        with reader.newSyncClient() as sync:
            sync.setCurrentDbName("guest.imu")
            self.assertEqual(sync.getVariable("rate"), 100)
            self.assertEqual(sync.getVariable("calibrated"), True, "setVariable is kept")
            self.assertEqual(sync.getVariable("flow_type"), "FT_SENSOR_DATA")
        self.assertTrue(pump([owner], lambda: owner.currentDbName == "guest.imu"),
                        "the selected database is selected again")

    def test_reconnection_can_be_turned_off(self):
        s = self.sat()
        s.setReconnectEnabled(False)
        self.assertTrue(s.connect())
        self.hub.stop()
        self.assertTrue(pump([s], lambda: not s.isConnected()))
        self.hub.start()
        tickFor([s], 0.3)
        self.assertFalse(s.isConnected() or s.isOnline())


if __name__ == "__main__":
    unittest.main()
