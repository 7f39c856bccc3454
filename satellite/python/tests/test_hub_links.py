# SPDX-License-Identifier: Apache-2.0
"""PySketch satellites against a linked hub's channels (docs/hub-links.md): a satellite of hub
"ay" subscribes to and calls the channels of hub "bee" by their prefixed names."""
import threading

from PySketch.flowproto import Flow_T, Variant_T
from PySketch.flowsat import FlowSat

from tests.hubtest import Hub, pump, waitUntil
import unittest


class HubLinks(unittest.TestCase):
    def setUp(self):
        self.bee = Hub("links-b", hub_name="bee")
        self.addCleanup(self.bee.close)
        self.bee.start()
        self.ay = Hub("links-a", hub_name="ay", links=[self.bee])
        self.addCleanup(self.ay.close)
        self.ay.start()
        self.assertTrue(waitUntil(lambda: "HUB-LINK-UP" in self.ay.log()), self.ay.log())
        self.sats = []
        self.addCleanup(lambda: [s.close() for s in self.sats])

    def sat(self, hub):
        s = FlowSat()
        s.setLogin("guest", "password")
        s.setAddress(hub.address)
        s.setTickTimer(0.005)
        self.sats.append(s)
        self.assertTrue(s.connect())
        return s

    def test_streaming_and_services_of_a_linked_hub(self):
        owner = self.sat(self.bee)
        viewer = self.sat(self.ay)
        started, got, answers = [], [], []
        owner.setStartChanPubReqCallBack(started.append)
        owner.setRequestCallBack(lambda chanID, hash, cmd, value:
                                 owner.sendServiceResponse(chanID, hash, {"cmd": cmd, "v": value}))
        viewer.setGrabDataCallBack(lambda chanID, data: got.append(data))
        viewer.setResponseCallBack(lambda chanID, value: answers.append(value))
        self.assertTrue(owner.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY, "counter"))
        self.assertTrue(owner.addServiceChannel("echo"))
        self.assertTrue(pump([owner, viewer], lambda: viewer.channelByName("bee/guest.counter")
                             and viewer.channelByName("bee/guest.echo")),
                        self.ay.log() + self.bee.log())
        self.assertEqual(viewer.channelByName("bee/guest.counter").owner, "bee/guest")

        viewer.subscribeChannel("bee/guest.counter")
        self.assertTrue(pump([owner, viewer], lambda: started), self.ay.log())
        chan = owner.channelByName("guest.counter").chanID
        for i in range(10):
            owner.publish(chan, ("n%d" % i).encode())
        self.assertTrue(pump([owner, viewer], lambda: len(got) == 10))
        self.assertEqual(got, [("n%d" % i).encode() for i in range(10)])

        self.assertTrue(viewer.sendServiceRequest("bee/guest.echo", "hi", [1, 2]))
        self.assertTrue(pump([owner, viewer], lambda: answers))
        self.assertEqual(answers[0], {"cmd": "hi", "v": [1, 2]})

        # A blocking call through the link while the owner runs elsewhere.
        stop = threading.Event()
        thread = threading.Thread(target=lambda: [owner.tick() for _ in iter(stop.is_set, True)])
        thread.start()
        try:
            with viewer.newSyncClient() as sync:
                self.assertEqual(sync.serviceCall("bee/guest.echo", "sync", 7)["v"], 7)
        finally:
            stop.set()
            thread.join()


    def test_a_replica_mirrors_the_linked_hubs_channel_while_its_flow_lasts(self):
        owner = self.sat(self.bee)
        asker = self.sat(self.ay)
        viewer = self.sat(self.ay)
        started, stopped, got, removed = [], [], [], []
        owner.setStartChanPubReqCallBack(started.append)
        owner.setStopChanPubReqCallBack(stopped.append)
        viewer.setGrabDataCallBack(lambda chanID, data: got.append(data))
        viewer.setDelChanCallBack(lambda ch: removed.append(ch.name))
        self.assertTrue(owner.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY, "camera",
                                                  "image/jpeg"))
        self.assertTrue(pump([owner, asker], lambda: asker.channelByName("bee/guest.camera")))
        self.assertIsNotNone(asker.replicate("bee/guest.camera", "front"))
        self.assertTrue(pump([owner, asker, viewer], lambda: viewer.channelByName("guest.front")),
                        self.ay.log())
        self.assertEqual(viewer.channelByName("guest.front").mime, "image/jpeg")
        viewer.subscribeChannel("guest.front")
        self.assertTrue(pump([owner, asker, viewer], lambda: started))
        owner.publish(owner.channelByName("guest.camera").chanID, b"frame")
        self.assertTrue(pump([owner, asker, viewer], lambda: got == [b"frame"]))
        self.assertIsNotNone(asker.stopReplica("front"))
        self.assertTrue(pump([owner, asker, viewer], lambda: "guest.front" in removed and stopped))

    def test_a_linked_hubs_database_is_read_under_its_name(self):
        owner = self.sat(self.bee)
        viewer = self.sat(self.ay)
        with owner.newSyncClient() as sync:
            self.assertTrue(sync.createDatabase("calib"))
            self.assertTrue(sync.setCurrentDbName("calib"))
            self.assertTrue(sync.setVariable("focal", 525.5))
        with viewer.newSyncClient() as sync:
            self.assertTrue(sync.setCurrentDbName("bee/calib"))
            self.assertEqual(sync.getVariable("focal"), 525.5)
            self.assertEqual(sync.variablesKeys(), ["focal"])
            self.assertEqual(sync.getAllVariables(), {"focal": 525.5})
            self.assertFalse(sync.setVariable("focal", 1.0))  # written on its own hub only
            self.assertFalse(sync.setCurrentDbName("sea/calib"))  # no such hub linked


if __name__ == "__main__":
    unittest.main()
