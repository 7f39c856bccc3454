# SPDX-License-Identifier: Apache-2.0
"""Errors, and who they are blamed on: an exception in a sketch's callback is the sketch's
(reported with its traceback, the flow stays up, no reconnection); a channel that another
satellite owns already is refused later than addStreamingChannel returns, and that refusal is
the sketch's error and reaches its error callback; a hub that keeps dropping the flow sees
growing delays between logins, not a storm; a FlowChannel is accepted wherever a chanID or a
channel name is."""
from __future__ import print_function

import os
import re
import signal
import struct
import textwrap
import threading

from PySketch.abstractflow import FlowChannel
from PySketch.flowproto import Error_T, Flow_T, Variant_T
from PySketch.flowsat import FlowSat

from tests.compat import TextIO, monotonic, redirect_stderr
from tests.hubtest import EXAMPLES, EXECUTOR, HubTestCase, Sketch, pump, tickFor

CREDENTIALS = ["--user", "guest", "--password", "password"]


def logins(hub):
    return len(re.findall(r"FLOW-LOGIN\b.* logged in", hub.log()))


class CallbackErrors(HubTestCase):
    def test_an_exception_in_a_callback_is_the_sketchs(self):
        s = self.sat()
        other = self.connected()

        def onNewChannel(ch):
            if ch.name == "guest.bait":   # not the hub's own (hub.stats, hub.inspect)
                struct.pack("<H", ch)     # the mistake of the issue: struct.error

        s.setNewChanCallBack(onNewChannel)
        self.assertTrue(s.connect())
        other.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY, "bait")
        errs = TextIO()
        raised = []
        with redirect_stderr(errs):
            deadline = monotonic() + 10
            while not raised and monotonic() < deadline:
                other.tick()
                try:
                    s.tick()
                except struct.error as e:
                    raised.append(e)
        self.assertTrue(raised, "the callback's own exception comes out of tick()")
        text = errs.getvalue()
        self.assertIn("the sketch's new-channel callback", text)
        self.assertIn("onNewChannel", text)
        self.assertIn("Traceback", text)
        self.assertIn("struct.pack", text, "the traceback shows the sketch's line")
        self.assertNotIn("broken frame", text)
        self.assertNotIn("lost the hub", text)
        self.assertTrue(s.isOnline(), "the flow stays up")
        tickFor([s, other], 0.5)
        self.assertTrue(s.isOnline())
        self.assertEqual(logins(self.hub), 2, "no reconnection:\n" + self.hub.log())
        # The flow goes on: the next events still arrive.
        s.setNewChanCallBack(None)
        other.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY, "later")
        self.assertTrue(pump([s, other], lambda: s.channelByName("guest.later")))

    def test_a_sketch_whose_callback_raises_ends_with_its_traceback(self):
        work = self.hub.dir
        path = os.path.join(work, "raising.py")
        with open(path, "w") as f:
            f.write(textwrap.dedent("""\
                import struct
                from PySketch.flowsat import FlowSat
                sat = FlowSat()
                def onGrab(chanID, data):
                    struct.pack("<H", sat.channelByID(chanID))  # a FlowChannel, not an int
                def onNewChannel(ch):
                    if ch.name == "guest.feed":
                        sat.subscribeChannel(ch)                 # a FlowChannel is fine here
                def setup():
                    sat.setTickTimer(0.01)
                    sat.setNewChanCallBack(onNewChannel)
                    sat.setGrabDataCallBack(onGrab)
                    return sat.connect()
                def loop():
                    sat.tick()
                    return sat.isConnected()
            """))
        feeder = self.connected()
        feeder.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY, "feed")
        self.assertTrue(pump([feeder], lambda: feeder.channelByName("guest.feed")))
        sketch = Sketch([EXECUTOR] + [path] + CREDENTIALS, self.hub.env())
        self.addCleanup(lambda: sketch.alive() and sketch.stop(signal.SIGKILL))
        feed = feeder.channelByName("guest.feed")
        self.assertTrue(pump([feeder], lambda: feed.isPublishingEnabled), sketch.output())
        feeder.publish(feed, b"x")
        rc = None
        deadline = monotonic() + 10
        while rc is None and monotonic() < deadline:
            feeder.tick()
            rc = sketch.proc.poll()
        self.assertEqual(sketch.wait(), 1, sketch.output())
        out = sketch.output()
        self.assertIn("the sketch's grab-data callback onGrab raised", out)
        self.assertRegex(out, r'File ".*raising\.py", line 5, in onGrab')
        self.assertNotIn("broken frame", out)
        self.assertNotIn("reconnect", out)
        self.assertEqual(logins(self.hub), 2, "the sketch logged in once:\n" + self.hub.log())


REFUSED = (r"\[ERR\] SAT-CHANNEL-REFUSED: the hub refused to create the channel guest\.camera "
           r"\(already_exists: [^)]*guest\.camera[^)]*\): another satellite owns a channel of "
           r"that name \(another sketch of user guest, or this sketch started twice\): choose "
           r"another name, or stop the other satellite and add the channel again")


class SecondPublisher(HubTestCase):
    """Two satellites of one user create the same channel: the hub refuses the second."""

    def owner_and_second(self):
        first, second = self.connected(), self.connected()
        self.assertTrue(first.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY,
                                                  "camera"))
        self.assertTrue(pump([first, second], lambda: second.channelByName("guest.camera")))
        return first, second

    def test_the_refusal_reaches_the_error_callback_with_the_channels_name(self):
        first, second = self.owner_and_second()
        refusals = []
        second.setErrorCallBack(lambda name, code, text: refusals.append((name, code, text)))
        err = TextIO()
        with redirect_stderr(err):
            # True: sent. The hub's answer comes later.
            self.assertTrue(second.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY,
                                                       "camera"))
            self.assertTrue(pump([first, second], lambda: refusals))
            tickFor([first, second], 0.1)
        self.assertEqual(len(refusals), 1, refusals)
        name, code, text = refusals[0]
        self.assertEqual(name, "guest.camera")
        self.assertEqual(code, Error_T.already_exists)
        self.assertEqual(code.name, "already_exists")
        self.assertIn("guest.camera", text)
        self.assertRegex(err.getvalue(), REFUSED)
        self.assertFalse(second.channelByName("guest.camera").isOwned)

        # What the line advises: once the other satellite is gone, adding it again works.
        first.close()
        self.assertTrue(pump([second], lambda: second.channelByName("guest.camera") is None))
        added = []
        second.setNewChanCallBack(added.append)
        self.assertTrue(second.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY,
                                                   "camera"))
        self.assertTrue(pump([second], lambda: [c for c in added if c.name == "guest.camera"]))
        self.assertTrue(second.channelByName("guest.camera").isOwned)
        self.assertEqual(len(refusals), 1)

    def test_without_a_callback_the_refusal_is_the_sketchs_error(self):
        first, second = self.owner_and_second()
        errors = []
        err = TextIO()
        with redirect_stderr(err):
            self.assertTrue(second.addServiceChannel("camera"))  # any kind of channel
            self.assertTrue(pump([first, second], lambda: "SAT-CHANNEL-REFUSED" in
                                 err.getvalue()))
            # The one-argument form gets a FlowError that names the channel and the command.
            second.setErrorCallBack(errors.append)
            self.assertTrue(second.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY,
                                                       "camera"))
            self.assertTrue(pump([first, second], lambda: errors))
        self.assertRegex(err.getvalue(), REFUSED)
        e = errors[0]
        self.assertEqual((e.channel, e.command, e.code), ("guest.camera", "CHAN_ADD",
                                                          Error_T.already_exists))
        self.assertIn("guest.camera", e.message)

    def test_a_sketch_started_twice_says_why_its_channel_stays_silent(self):
        publisher = os.path.join(EXAMPLES, "publisher.py")
        one = Sketch([EXECUTOR, publisher] + CREDENTIALS, self.hub.env())
        self.addCleanup(lambda: one.alive() and one.stop(signal.SIGKILL))
        one.waitFor(r"channel ready: guest\.sine")
        two = Sketch([EXECUTOR, publisher] + CREDENTIALS, self.hub.env())
        self.addCleanup(lambda: two.alive() and two.stop(signal.SIGKILL))
        two.waitFor(r"\[ERR\] SAT-CHANNEL-REFUSED: the hub refused to create the channel "
                    r"guest\.sine \(already_exists")
        self.assertNotIn("channel ready", two.output(), "the channel is the other sketch's")
        self.assertTrue(two.alive())
        self.assertEqual(two.stop(signal.SIGTERM), 0, two.output())


class _DropsItsFlow(FlowSat):
    """Once online, breaks the flow: sends the hub a frame of length 0 (the hub closes the
    connection) or feeds itself one (a frame from the hub that cannot be decoded)."""

    def __init__(self, how):
        FlowSat.__init__(self)
        self.how = how

    def _online(self, infos):
        FlowSat._online(self, infos)
        if self.how == "hub closes":
            self._outbuf.extend(b"\0\0\0\0")
            self._flush()
        else:
            self._input.append(b"\0\0\0\0")


class ReconnectDelays(HubTestCase):
    def check_bounded(self, how):
        s = self.sat(cls=lambda: _DropsItsFlow(how))
        errs = TextIO()
        with redirect_stderr(errs):
            self.assertTrue(s.connect())
            tickFor([s], 3.0)
        n = logins(self.hub)
        # Attempts at 0, 0.05, 0.15, 0.35, 0.75, 1.55 s (+ each handshake), then every 2 s.
        self.assertGreaterEqual(n, 3, errs.getvalue() + self.hub.log())
        self.assertLessEqual(n, 8, "a reconnection storm: %d logins in 3 s" % n)
        return errs.getvalue()

    def test_a_hub_that_closes_the_flow_sees_growing_delays(self):
        self.check_bounded("hub closes")
        self.assertIn("killing spurious client", self.hub.log())

    def test_a_frame_that_cannot_be_decoded_gives_growing_delays(self):
        self.assertRegex(self.check_bounded("decode"), r"broken frame from the hub: .*frame length 0")


class _CountsAttempts(FlowSat):
    def __init__(self):
        FlowSat.__init__(self)
        self.attempts = 0

    def _beginAttempt(self, quiet):
        self.attempts += 1
        return FlowSat._beginAttempt(self, quiet)


class RefusedConnections(HubTestCase):
    def test_a_hub_that_is_away_sees_growing_delays(self):
        s = self.sat(cls=_CountsAttempts)
        self.assertTrue(s.connect())
        self.hub.stop()
        errs = TextIO()
        with redirect_stderr(errs):
            self.assertTrue(pump([s], lambda: not s.isOnline()))
            s.attempts = 0
            tickFor([s], 3.0)
        # Refused at 0.05, 0.15, 0.35, 0.75, 1.55 s after the loss, then every 2 s.
        self.assertGreaterEqual(s.attempts, 3)
        self.assertLessEqual(s.attempts, 7, "%d attempts in 3 s" % s.attempts)
        self.assertTrue(s.isConnected(), "still trying")


class FlowChannelArguments(HubTestCase):
    def test_a_flow_channel_goes_wherever_a_chan_id_or_a_name_does(self):
        owner = self.connected()
        reader = self.connected()
        got, answers, requests = [], [], []
        reader.setGrabDataCallBack(lambda chanID, data: got.append((chanID, data)))
        reader.setResponseCallBack(lambda chanID, v: answers.append(v))

        def onRequest(chanID, h, cmd, v):
            requests.append(cmd)
            owner.sendServiceResponse(owner.channelByID(chanID), h, v)  # a FlowChannel

        owner.setRequestCallBack(onRequest)
        owner.addStreamingChannel(Flow_T.FT_BLOB, Variant_T.T_BYTEARRAY, "fc")
        owner.addServiceChannel("svc")
        self.assertTrue(pump([owner, reader], lambda: reader.channelByName("guest.fc") and
                             reader.channelByName("guest.svc") and
                             owner.channelByName("guest.fc")))
        fc = reader.channelByName("guest.fc")
        mine = owner.channelByName("guest.fc")
        self.assertIs(reader.channelByID(fc), fc)
        self.assertIs(reader.channelByName(fc), fc)
        self.assertEqual(reader.channelID(fc), fc.chanID)

        self.assertTrue(reader.subscribeChannel(fc))
        self.assertTrue(pump([owner, reader], lambda: mine.isPublishingEnabled))
        self.assertTrue(owner.publish(mine, b"one"))
        self.assertTrue(owner.publishInt8(mine, 7))
        self.assertTrue(pump([owner, reader], lambda: len(got) == 2))
        self.assertEqual(got, [(fc.chanID, b"one"), (fc.chanID, b"\x07")])

        svc = reader.channelByName("guest.svc")
        self.assertTrue(reader.sendServiceRequest(svc, "echo", 42))
        self.assertTrue(pump([owner, reader], lambda: answers == [42]))

        owner.setCurrentDbName(mine)
        self.assertTrue(pump([owner], lambda: owner.currentDbName == "guest.fc"))
        stop = []
        ticker = threading.Thread(target=lambda: pump([owner], lambda: stop))
        ticker.start()   # the owner answers while the sync client blocks
        try:
            with reader.newSyncClient() as sync:
                answer = sync.serviceCall(svc, "blocking", "yes")
        finally:
            stop.append(True)
            ticker.join()
        self.assertEqual(answer, "yes")
        with reader.newSyncClient() as sync:
            self.assertEqual(sync.channelByName(fc).chanID, fc.chanID)
            self.assertTrue(sync.setCurrentDbName(fc))
            self.assertEqual(sync.getVariable("flow_type"), "FT_BLOB")
            self.assertTrue(sync.pollRegister(fc))
        self.assertEqual(requests, ["echo", "blocking"])

        self.assertTrue(reader.unsubscribeChannel(fc))
        self.assertTrue(pump([owner, reader], lambda: not mine.isPublishingEnabled))
        self.assertTrue(owner.removeChannel(mine))
        self.assertTrue(pump([owner, reader], lambda: reader.channelByName("guest.fc") is None))

    def test_anything_else_is_a_clear_type_error(self):
        s = self.connected()
        for bad in (1.5, None, [3], True):
            with self.assertRaises(TypeError) as cm:
                s.publish(bad, b"x")
            self.assertIn("chanID (int), its name (str) or a FlowChannel", str(cm.exception))
        with self.assertRaises(ValueError):
            s.publish(70000, b"x")
        self.assertFalse(s.publish("guest.nothing", b"x"), "an unknown name: nothing sent")
        self.assertEqual(s.sendServiceRequest("guest.nothing", "x"), 0)
        self.assertIsNone(s.channelByID(FlowChannel(999, "guest.nothing")))


if __name__ == "__main__":
    import unittest
    unittest.main()
