# SPDX-License-Identifier: Apache-2.0
"""FlowSat and FlowSync against a real hub (with the in-hub module test_channel_echo)."""
import struct
import threading
import time
import unittest

from PySketch.databuffer import DataBuffer
from PySketch.flowproto import ChanKind_T, Error_T, FlowError, Flow_T, Variant_T
from PySketch.flowsat import FlowSat
from PySketch.flowsync import FlowSync
from PySketch.robotmod import RobotModule

from tests.compat import TextIO, monotonic, redirect_stdout
from tests.hubtest import HubTestCase, pump, tickFor


class Recorder(object):
    """Collects what a FlowSat's callbacks report."""

    def __init__(self, sat):
        self.sat = sat
        self.added = []
        self.removed = []
        self.started = []
        self.stopped = []
        self.data = []
        self.requests = []
        self.responses = []
        self.errors = []
        sat.setNewChanCallBack(self.added.append)
        sat.setDelChanCallBack(self.removed.append)
        sat.setStartChanPubReqCallBack(self.started.append)
        sat.setStopChanPubReqCallBack(self.stopped.append)
        sat.setGrabDataCallBack(lambda chanID, data: self.data.append((chanID, data)))
        sat.setRequestCallBack(lambda *a: self.requests.append(a))
        sat.setResponseCallBack(lambda chanID, value: self.responses.append((chanID, value)))
        sat.setErrorCallBack(self.errors.append)

    def channel(self, name):
        for ch in reversed(self.added):
            if ch.name == name:
                return ch
        return None


class Streaming(HubTestCase):
    def test_python_to_python_streaming(self):
        pub = self.connected()
        sub = self.connected()
        p, s = Recorder(pub), Recorder(sub)
        self.assertTrue(pub.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_FLOAT, "sense"))
        self.assertTrue(pump([pub, sub], lambda: p.channel("guest.sense") and
                             s.channel("guest.sense")))
        mine = p.channel("guest.sense")
        self.assertTrue(mine.isOwned, "the creator learns its channel from the callback")
        self.assertFalse(s.channel("guest.sense").isOwned)
        self.assertEqual(pub.channelByID(mine.chanID), mine)
        self.assertEqual(s.channel("guest.sense").chanID, mine.chanID)
        self.assertEqual(mine.kind, ChanKind_T.CK_STREAMING)
        self.assertIs(mine.flowType, Flow_T.FT_BLOB)
        self.assertIs(mine.dataType, Variant_T.T_FLOAT)

        self.assertTrue(sub.subscribeChannel(mine.chanID))
        self.assertTrue(pump([pub, sub], lambda: mine.isPublishingEnabled))
        sent = [struct.pack("<fffff", 1, 2, 3, 4, float(i)) for i in range(20)]
        for payload in sent:
            self.assertTrue(pub.publish(mine.chanID, payload))
        buf = DataBuffer()
        buf.setFloat([0.5, 1.5])
        pub.publish(mine.chanID, buf)
        pub.publishFloat(mine.chanID, 2.25)
        pub.publishInt8(mine.chanID, -3)
        pub.publishString(mine.chanID, "h\u00e9llo")
        pub.publish(mine.chanID, b"")
        self.assertTrue(pump([pub, sub], lambda: len(s.data) >= 25))
        self.assertEqual([d for _, d in s.data[:20]], sent)
        self.assertTrue(all(c == mine.chanID for c, _ in s.data))
        self.assertEqual(DataBuffer(s.data[20][1]).toFloat(2), [0.5, 1.5])
        self.assertEqual(struct.unpack("<f", s.data[21][1])[0], 2.25)
        self.assertEqual(struct.unpack("<b", s.data[22][1])[0], -3)
        self.assertEqual(s.data[23][1].decode("utf-8"), "h\u00e9llo")
        self.assertEqual(s.data[24][1], b"")
        self.assertIsInstance(s.data[0][1], bytes)

    def test_first_and_last_subscriber(self):
        pub = self.connected()
        sub1 = self.connected()
        sub2 = self.connected()
        p = Recorder(pub)
        pub.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY, "cam", "image/jpeg")
        self.assertTrue(pump([pub, sub1, sub2], lambda: p.channel("guest.cam") and
                             sub1.channelByName("guest.cam") and
                             sub2.channelByName("guest.cam")))
        ch = p.channel("guest.cam")
        self.assertEqual(ch.mime, "image/jpeg")
        self.assertFalse(ch.isPublishingEnabled)
        sync = pub.newSyncClient()
        self.addCleanup(sync.close)

        def subscribers():
            return sync.channelByName("guest.cam").subscribers

        sub1.subscribeChannel(ch.chanID)
        self.assertTrue(pump([pub, sub1, sub2], lambda: len(p.started) == 1))
        self.assertIs(p.started[0], ch)
        self.assertTrue(ch.isPublishingEnabled)

        sub2.subscribeChannel("guest.cam")            # by name works too
        sub1.subscribeChannel(ch.chanID)              # twice: no change
        self.assertTrue(pump([pub, sub1, sub2], lambda: subscribers() == 2))
        tickFor([pub], 0.1)
        self.assertEqual((len(p.started), len(p.stopped)), (1, 0), "only the first one counts")

        sub1.unsubscribeChannel(ch.chanID)
        self.assertTrue(pump([pub, sub1, sub2], lambda: subscribers() == 1))
        tickFor([pub], 0.1)
        self.assertEqual(len(p.stopped), 0, "a subscriber is left")
        self.assertTrue(ch.isPublishingEnabled)

        sub2.close()                                  # leaving by disconnecting counts
        self.assertTrue(pump([pub, sub1], lambda: len(p.stopped) == 1))
        self.assertIs(p.stopped[0], ch)
        self.assertFalse(ch.isPublishingEnabled)

        sub1.subscribeChannel(ch.chanID)
        self.assertTrue(pump([pub, sub1], lambda: len(p.started) == 2))
        self.assertTrue(ch.isPublishingEnabled)

    def test_channel_removal_and_subscription_by_name(self):
        sub = self.connected()
        s = Recorder(sub)
        sub.subscribeChannel("guest.later")           # not there yet: subscribed on arrival
        pub = self.connected()
        p = Recorder(pub)
        pub.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY, "later")
        self.assertTrue(pump([pub, sub], lambda: p.started))
        pub.publish(p.channel("guest.later").chanID, b"one")
        self.assertTrue(pump([pub, sub], lambda: s.data))
        pub.close()
        self.assertTrue(pump([sub], lambda: s.removed))
        self.assertEqual(s.removed[0].name, "guest.later")
        self.assertIsNone(sub.channelByName("guest.later"))

        pub2 = self.connected()                       # the publisher comes back
        p2 = Recorder(pub2)
        pub2.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY, "later")
        self.assertTrue(pump([pub2, sub], lambda: p2.started), "re-subscribed by name")
        pub2.publish(p2.channel("guest.later").chanID, b"two")
        self.assertTrue(pump([pub2, sub], lambda: len(s.data) == 2))
        self.assertEqual(s.data[1], (p2.channel("guest.later").chanID, b"two"))

    def test_channels_present_at_connect_are_announced_at_the_first_tick(self):
        pub = self.connected()
        pub.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY, "early")
        pub.addServiceChannel("early_svc")
        self.assertTrue(pump([pub], lambda: pub.channelByName("guest.early_svc")))
        late = self.connected()                       # callbacks set after connect(), like
        r = Recorder(late)                            # some sketches do
        late.tick()
        self.assertEqual(sorted(c.name for c in r.added if not c.name.startswith("hub.")),
                         ["guest.early", "guest.early_svc"])
        self.assertTrue(r.channel("guest.early_svc").isService())

    def test_errors_are_reported(self):
        a = self.connected()
        b = self.connected()
        ra = Recorder(a)
        a.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY, "mine")
        self.assertTrue(pump([a, b], lambda: b.channelByName("guest.mine")))
        rb = Recorder(b)
        b.publish(b.channelID("guest.mine"), b"not yours")
        self.assertTrue(pump([a, b], lambda: rb.errors))
        self.assertEqual(rb.errors[0].code, Error_T.permission_denied)
        self.assertFalse(ra.errors)
        self.assertFalse(a.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY, "bad name"))
        self.assertFalse(a.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY, "mine"))


class Polling(HubTestCase):
    def test_flowsync_polls_the_latest_payload(self):
        pub = self.connected()
        p = Recorder(pub)
        self.assertTrue(pub.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY, "level"))
        self.assertTrue(pump([pub], lambda: p.channel("guest.level")))
        chan = p.channel("guest.level").chanID
        pub.publish(chan, b"before")  # published before anyone polls: not kept
        with pub.newSyncClient() as sync:
            self.assertTrue(pump([pub], lambda: sync.pollRegister(chan)))
            self.assertEqual(sync.pollFetch(chan), (0, b""))
            pub.publish(chan, b"first")
            pub.publish(chan, b"second")
            self.assertTrue(pump([pub], lambda: sync.pollFetch(chan)[1] == b"second"))
            seq, payload = sync.pollFetch(chan)
            self.assertEqual(seq, 3, "the channel's sequence number, the early one included")
            self.assertTrue(sync.pollDeregister(chan))
            self.assertEqual(sync.pollFetch(chan), (0, b""), "nobody polls: nothing kept")
            self.assertFalse(sync.pollDeregister(chan))
            self.assertIn("does not poll", str(sync.lastError))


class Connections(HubTestCase):
    def test_connect_failures(self):
        s = self.sat(password="wrong")
        self.assertFalse(s.connect())
        self.assertFalse(s.isConnected())
        s = self.sat()
        self.assertFalse(s.connect("local:/tmp/no-such-hub-here"))
        self.assertFalse(s.isConnected())
        self.assertFalse(s.connect("nonsense"))
        self.assertFalse(s.publish(1, b"x"), "offline: nothing is sent")
        s.tick()                                      # harmless while closed
        sync = FlowSync(self.hub.address, "guest", "wrong")
        self.assertFalse(sync.connect())
        self.assertEqual(sync.lastError.code, Error_T.auth_failed)

    def test_robot_module_is_the_older_name(self):
        s = self.sat(cls=RobotModule)
        self.assertIsInstance(s, FlowSat)
        self.assertTrue(s.connect())
        self.assertTrue(s.isConnected() and s.isOnline())
        s.setAppName("app")
        s.close()
        self.assertFalse(s.isConnected())

    def test_tick_keeps_an_absolute_cadence(self):
        tick = 0.02
        s = self.connected(tick=tick)
        s.tick()
        grid = s._deadline                            # the next deadline
        for i in range(12):
            if i == 3:
                time.sleep(0.011)                     # some work: absorbed, no drift
            if i == 6:
                time.sleep(2.5 * tick)                # an overrun: missed deadlines skipped
            expected = s._deadline
            s.tick()
            self.assertGreaterEqual(monotonic(), expected, "never returns early")
            steps = (s._deadline - grid) / tick
            self.assertAlmostEqual(steps, round(steps), places=6, msg="deadlines stay on the grid")
            self.assertGreater(s._deadline, monotonic())
        self.assertEqual(s.getTickTimer(), tick)
        self.assertGreaterEqual(s._timer.stop(), 12 * tick)

    def test_speed_monitor_prints_the_cadence(self):
        s = self.connected()
        s.setTickTimer(0.01, 0.1)
        s.setSpeedMonitorEnabled(True, "test")
        out = TextIO()
        with redirect_stdout(out):
            tickFor([s], 0.35)
        line = out.getvalue().splitlines()[0]
        for word in ("SPEED-MONITOR [test]", "Hz", "requested tick 0.010000 s", "corrected tick",
                     "measured tick", "error", "%"):
            self.assertIn(word, line)


class Databases(HubTestCase):
    def test_channel_properties_are_read_through_flowsync(self):
        cam = self.connected()
        props = {"resolution": "640x480", "fps": 30, "fov": 1.2, "intrinsics": [1.0, 2.0],
                 "calib": b"\x00\x01"}
        cam.addStreamingChannel(Flow_T.FT_VIDEO_DATA, Variant_T.T_BYTEARRAY, "camera",
                                "image/jpeg", props=props)
        reader = self.connected()
        self.assertTrue(pump([cam, reader], lambda: reader.channelByName("guest.camera")))
        announced = reader.channelByName("guest.camera")
        self.assertEqual(announced.props["resolution"], "640x480")

        sync = reader.newSyncClient()
        self.addCleanup(sync.close)
        self.assertTrue(sync.isConnected())
        self.assertTrue(sync.setCurrentDbName(announced.name))
        self.assertEqual(sync.getVariable("resolution").split("x"), ["640", "480"])
        self.assertEqual(sync.getVariable("fps"), 30)
        self.assertEqual(sync.getVariable("fov"), 1.2)
        self.assertEqual(sync.getVariable("intrinsics"), [1.0, 2.0])
        self.assertEqual(sync.getVariable("calib"), b"\x00\x01")
        self.assertEqual(sync.getVariable("flow_type"), "FT_VIDEO_DATA")
        self.assertEqual(sync.getVariable("data_type"), "T_BYTEARRAY")
        self.assertIsNone(sync.getVariable("nothing"))
        self.assertEqual(sync.lastError.code, Error_T.not_found)
        self.assertTrue(sync.isConnected(), "a missing variable keeps the connection")
        self.assertFalse(sync.existsVariable("nothing"))
        self.assertTrue(sync.existsVariable("fps"))
        self.assertEqual(sync.variablesKeys(), sorted(list(props) + ["data_type", "flow_type"]))

        # The owner changes its channel's database from the flow (asynchronous).
        cam.setCurrentDbName("guest.camera")
        cam.setVariable("mode", 2)
        cam.setCurrentDbName("guest")
        self.assertTrue(pump([cam], lambda: sync.getVariable("mode") == 2))
        self.assertTrue(pump([cam], lambda: cam.currentDbName == "guest"))
        self.assertFalse(sync.setVariable("mode", 3), "only the owner writes")
        self.assertEqual(sync.lastError.code, Error_T.permission_denied)

    def test_values_cross_the_hub_unchanged(self):
        sat = self.connected()
        sync = sat.newSyncClient()
        self.addCleanup(sync.close)
        self.assertTrue(sync.createDatabase("pytest_values"))
        self.assertTrue(sync.setCurrentDbName("pytest_values"))
        values = {"null": None, "t": True, "f": False, "neg": -2 ** 63, "big": 2 ** 64 - 1,
                  "pi": 3.14159, "text": "h\u00e9llo \u2603", "bytes": b"\x00\xff\x10",
                  "list": [1, "two", [3.0, None]], "map": {"k": {"deep": [True]}, "": 0},
                  "empty_list": [], "empty_map": {}}
        for k, v in values.items():
            self.assertTrue(sync.setVariable(k, v), k)
        for k, v in values.items():
            self.assertEqual(sync.getVariable(k), v, k)
        self.assertEqual(sync.getAllVariables(), values)
        self.assertIn("pytest_values", sync.databases())
        self.assertTrue(sync.saveDatabase("pytest_values"))
        self.assertTrue(sync.syncDatabases())  # a barrier: everything above is on disk
        self.assertTrue(sync.delVariable("t"))
        self.assertNotIn("t", sync.variablesKeys())
        self.assertTrue(sync.removeDatabase("pytest_values"))
        self.assertLess(sync.ping(b"x"), 5.0)

    def test_flow_database_commands(self):
        sat = self.connected()
        changed = []
        sat.setDbChangedCallBack(changed.append)
        sat.createDatabase("pytest_flowdb")
        sat.setCurrentDbName("pytest_flowdb")
        sat.setVariable("answer", 42)
        self.assertTrue(pump([sat], lambda: changed == ["pytest_flowdb"]))
        with sat.newSyncClient() as sync:
            sync.setCurrentDbName("pytest_flowdb")
            self.assertTrue(pump([sat], lambda: sync.getVariable("answer") == 42))
        # The barrier for writes without a reply: called once they are on disk.
        synced = []
        sat.setVariable("answer", 43)
        self.assertIsNotNone(sat.syncDatabases(lambda: synced.append(True)))
        self.assertTrue(pump([sat], lambda: synced == [True]))


class Services(HubTestCase):
    echo_module = True

    def test_python_provider_and_python_caller(self):
        provider = self.connected()
        caller = self.connected()
        p = Recorder(provider)
        c = Recorder(caller)

        def answer(chanID, hash, cmdName, value):
            p.requests.append((chanID, hash, cmdName, value))
            provider.sendServiceResponse(chanID, str(hash) if cmdName == "as_text" else hash,
                                         {"cmd": cmdName, "got": value, "from": provider.lastRequester})

        provider.setRequestCallBack(answer)
        self.assertTrue(provider.addServiceChannel("calc"))
        self.assertTrue(pump([provider, caller], lambda: c.channel("guest.calc")))
        svc = c.channel("guest.calc")
        self.assertTrue(svc.isService())
        self.assertTrue(caller.sendServiceRequest(svc.chanID, "add", [1, 2]))
        self.assertTrue(caller.sendServiceRequest(svc.chanID, "as_text", {"x": b"\x01"}))
        self.assertTrue(pump([provider, caller], lambda: len(c.responses) == 2))
        self.assertEqual(c.responses[0], (svc.chanID, {"cmd": "add", "got": [1, 2],
                                                       "from": "guest"}))
        self.assertEqual(c.responses[1][1]["got"], {"x": b"\x01"})
        self.assertEqual([r[2] for r in p.requests], ["add", "as_text"])
        self.assertNotEqual(p.requests[0][1], p.requests[1][1], "each request has its hash")

        # A response callback that takes only the value, as some sketches write it.
        values = []
        caller.setResponseCallBack(lambda value: values.append(value))
        caller.sendServiceRequest(svc.chanID, "one", None)
        self.assertTrue(pump([provider, caller], lambda: values))
        self.assertEqual(values[0]["cmd"], "one")

        # A blocking call on a synchronous connection while the provider runs elsewhere.
        stop = threading.Event()
        thread = threading.Thread(target=lambda: [provider.tick() for _ in iter(stop.is_set, True)])
        thread.start()
        try:
            with caller.newSyncClient() as sync:
                self.assertEqual(sync.serviceCall("guest.calc", "sync", 7)["got"], 7)
        finally:
            stop.set()
            thread.join()

    def test_a_request_nobody_answers_times_out(self):
        """1.4: the caller's timeout reaches the response callback as a failure."""
        provider = self.connected()
        caller = self.connected()
        provider.setRequestCallBack(lambda chanID, hash, cmd, v: None)  # never answers
        self.assertTrue(provider.addServiceChannel("deaf"))
        self.assertTrue(pump([provider, caller], lambda: caller.channelByName("guest.deaf")))
        got = []
        caller.setResponseCallBack(lambda chanID, v: got.append(v))
        self.assertTrue(caller.sendServiceRequest("guest.deaf", "hello", 1, timeoutMs=100))
        self.assertTrue(pump([provider, caller], lambda: got))
        self.assertIn("did not answer in time", got[0])

    def test_provider_answers_the_caller_back(self):
        """Both directions: each satellite owns a service and calls the other's."""
        a = self.connected()
        b = self.connected()
        for sat, name in ((a, "svc_a"), (b, "svc_b")):
            sat.setRequestCallBack(lambda chanID, hash, cmd, v, sat=sat:
                                   sat.sendServiceResponse(chanID, hash, cmd + ":" + str(v)))
            sat.addServiceChannel(name)
        got = {"a": [], "b": []}
        a.setResponseCallBack(lambda chanID, v: got["a"].append(v))
        b.setResponseCallBack(lambda chanID, v: got["b"].append(v))
        self.assertTrue(pump([a, b], lambda: a.channelByName("guest.svc_b") and
                             b.channelByName("guest.svc_a")))
        a.sendServiceRequest(a.channelID("guest.svc_b"), "ping", 1)
        b.sendServiceRequest(b.channelID("guest.svc_a"), "pong", 2)
        self.assertTrue(pump([a, b], lambda: got["a"] and got["b"]))
        self.assertEqual(got, {"a": ["ping:1"], "b": ["pong:2"]})

    def test_python_caller_and_the_in_hub_c_module(self):
        caller = self.connected()
        c = Recorder(caller)
        self.assertTrue(pump([caller], lambda: c.channel("test_channel_echo.svc")))
        svc = c.channel("test_channel_echo.svc")
        self.assertEqual(svc.owner, "test_channel_echo")
        value = {"list": [1, 2.5, "x"], "flag": True, "none": None}
        caller.sendServiceRequest(svc.chanID, "hello", value)
        self.assertTrue(pump([caller], lambda: c.responses))
        self.assertEqual(c.responses[0], (svc.chanID, {"cmd": "hello", "echo": value}))
        with caller.newSyncClient() as sync:
            with self.assertRaises(FlowError) as e:
                sync.serviceCall("nobody.svc", "x")
            self.assertEqual(e.exception.code, Error_T.not_found)
            self.assertEqual(sync.serviceCall(svc.chanID, "sync", [3]), {"cmd": "sync", "echo": [3]})

    def test_sync_call_answered_at_once_by_a_module_leaves_the_connection_usable(self):
        """An in-hub module answers inside its request handler: the blocking call must still get
        its reply, and the connection must stay usable."""
        caller = self.connected()
        with caller.newSyncClient(timeout=2.0) as sync:
            svc = sync.channelByName("test_channel_echo.svc")
            self.assertEqual(sync.serviceCall(svc.chanID, "a", 1), {"cmd": "a", "echo": 1})
            self.assertIsNotNone(sync.ping(), sync.lastError)

    def test_unanswered_request_fails_when_the_owner_leaves(self):
        provider = self.connected()
        provider.setRequestCallBack(lambda *a: None)   # never answers
        provider.addServiceChannel("mute")
        caller = self.connected()
        c = Recorder(caller)
        self.assertTrue(pump([provider, caller], lambda: c.channel("guest.mute")))
        caller.sendServiceRequest(c.channel("guest.mute").chanID, "hello", 1)
        tickFor([provider, caller], 0.1)
        provider.close()
        self.assertTrue(pump([caller], lambda: c.responses))
        self.assertTrue(c.errors and c.errors[0].code == Error_T.owner_gone)


class InHubModule(HubTestCase):
    echo_module = True

    def test_exchange_with_the_in_hub_module(self):
        pub = self.connected()
        sub = self.connected()
        p, s = Recorder(pub), Recorder(sub)
        self.assertTrue(pump([sub], lambda: s.channel("test_channel_echo.out")))
        out = s.channel("test_channel_echo.out")
        self.assertEqual(out.props, {"rate_hz": 0, "note": "echo of guest.in"})
        self.assertEqual(out.mime, "text/plain")
        sub.subscribeChannel(out.chanID)
        pub.addStreamingChannel(Flow_T.FT_TEXT, Variant_T.T_STRING, "in")
        # The module subscribes to guest.in as soon as it exists: the owner hears about it.
        self.assertTrue(pump([pub, sub], lambda: p.started))
        self.assertEqual(p.started[0].name, "guest.in")
        chan = p.channel("guest.in").chanID
        # The module republishes only while it has a listener; our subscription may still be
        # on its way, so publish until the echoes come back.
        n = [0]

        def send_and_check():
            n[0] += 1
            pub.publishString(chan, "message %d" % n[0])
            return len(s.data) >= 3

        self.assertTrue(pump([pub, sub], send_and_check))
        texts = [d.decode() for _, d in s.data]
        self.assertTrue(all(t.startswith("message ") for t in texts), texts)
        self.assertTrue(all(c == out.chanID for c, _ in s.data))
        numbers = [int(t.split()[1]) for t in texts]
        self.assertEqual(numbers, sorted(numbers))
        with sub.newSyncClient() as sync:
            sync.setCurrentDbName("test_channel_echo")
            self.assertTrue(pump([pub, sub], lambda: (sync.getVariable("echoed") or 0) >= 3))


if __name__ == "__main__":
    unittest.main()
