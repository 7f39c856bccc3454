// SPDX-License-Identifier: Apache-2.0
// Physical mode through the hub (protocol 1.7, two endpoints 1.8, the owner's switch 1.9, the
// subscribers' reports 1.10): offers, grants with one-time tokens, the relay skipped for a
// subscriber whose path works (from the point the owner picks) and resumed when it breaks,
// revocation when a subscriber leaves, counts in the statistics, and refusals.
#include "flow_fixture.h"

#include <skrobot/hub/flow/access.h>
#include <skrobot/hub/flow/accounts.h>
#include <skrobot/hub/flow/hub_stats.h>

#include <algorithm>
#include <optional>
#include <thread>

namespace skr::test {
namespace {

using flow::ChannelKind;
using flow::Code;
using flow::ErrorCode;
using flow::Variant;
namespace msg = flow::msg;

class PhysicalPaths : public FlowFixture {
 protected:
  static void settle(TestClient& c) {
    ASSERT_TRUE(c.send(msg::DbSetCurrent{6, "guest"}));
    ASSERT_TRUE(c.waitFor(Code::ev_db_changed));
  }
  static uint16_t error(TestClient& c) {
    auto e = as<msg::EvError>(c.waitFor(Code::ev_error));
    return e ? e->error : uint16_t(0);
  }
  static void subscribe(TestClient& c, uint16_t id) {
    ASSERT_TRUE(c.send(msg::Subscribe{1, id}));
    settle(c);
  }
  // The subscriber_paths of channel `id` in the hub's snapshot, sorted.
  std::vector<std::string> paths(uint16_t id) {
    flow::HubSnapshot snap;
    onHub([&] { snap = server_->snapshot(); });
    for (const auto& c : snap.channels) {
      if (c.id != id) continue;
      EXPECT_EQ(c.subscriber_paths.size(), c.subscriber_flows.size());
      std::vector<std::string> out = c.subscriber_paths;
      std::sort(out.begin(), out.end());
      return out;
    }
    return {};
  }
  // Owner and subscriber with an offer of both kinds on a unix: endpoint (and a tcp: one, for
  // direct paths to other machines); the subscriber follows.
  struct Pair {
    TestClient owner, sub;
    uint16_t id = 0;
  };
  // A flow of a client that speaks protocol 1.<minor>.
  TestClient olderFlow(uint16_t minor) {
    TestClient c = olderClient(minor);
    EXPECT_TRUE(c.call(msg::Empty<Code::go_async>{}));
    return c;
  }
  // The subscriber asks for a direct path and gets one: the owner's grant.
  static std::optional<msg::EvPhysGrant> directPath(Pair& p) {
    EXPECT_TRUE(p.sub.send(msg::PhysRequest{7, p.id, msg::kPhysDirect}));
    EXPECT_TRUE(p.sub.waitFor(Code::ev_phys_path));
    auto grant = as<msg::EvPhysGrant>(p.owner.waitFor(Code::ev_phys_grant));
    if (!grant) return std::nullopt;
    return *grant;
  }
  // The owner answers the hub's EV_PHYS_SWITCH with `seq`; the subscriber gets its marker.
  static void switchOver(Pair& p, uint64_t seq) {
    auto sw = as<msg::EvPhysSwitch>(p.owner.waitFor(Code::ev_phys_switch));
    ASSERT_TRUE(sw) << "the owner is asked where the switch goes";
    ASSERT_TRUE(p.owner.send(msg::PhysSwitched{p.id, sw->subscriber, sw->switch_id, seq}));
    auto marker = as<msg::EvPhysMarker>(p.sub.waitFor(Code::ev_phys_marker));
    ASSERT_TRUE(marker) << "the subscriber's marker";
    EXPECT_EQ(marker->seq, seq);
  }
  Pair offered(std::optional<TestClient> owner = {}, std::optional<TestClient> sub = {}) {
    Pair p{owner ? std::move(*owner) : flowClient(), sub ? std::move(*sub) : flowClient(), 0};
    p.id = addChannel(p.owner, "camera");
    EXPECT_TRUE(p.owner.send(msg::PhysOffer{2, p.id, msg::kPhysDirect | msg::kPhysShm,
                                            "unix:/tmp/skrobot-path-x tcp:127.0.0.1:9"}));
    settle(p.owner);
    subscribe(p.sub, p.id);
    return p;
  }
};

TEST_F(PhysicalPaths, AGrantGoesToBothEndsWithOneToken) {
  startHub();
  Pair p = offered();
  ASSERT_TRUE(p.sub.send(msg::PhysRequest{7, p.id, msg::kPhysShm | msg::kPhysDirect}));
  auto path = as<msg::EvPhysPath>(p.sub.waitFor(Code::ev_phys_path));
  ASSERT_TRUE(path);
  EXPECT_EQ(path->tag, 7u);
  EXPECT_EQ(path->chan_id, p.id);
  EXPECT_EQ(path->path, msg::kPhysShm) << "both on this machine's socket: shared memory";
  EXPECT_EQ(path->endpoint, "unix:/tmp/skrobot-path-x");
  EXPECT_EQ(path->token.size(), 32u);
  auto grant = as<msg::EvPhysGrant>(p.owner.waitFor(Code::ev_phys_grant));
  ASSERT_TRUE(grant);
  EXPECT_EQ(grant->token, path->token);
  EXPECT_EQ(grant->path, msg::kPhysShm);
  EXPECT_EQ(grant->name.substr(0, 6), "guest/");
  ASSERT_TRUE(p.sub.send(msg::PhysState{p.id, 1}));
  switchOver(p, 0);
  EXPECT_EQ(paths(p.id), (std::vector<std::string>{"shm"}));
  // Asking again: a new token, and the old grant is revoked at the owner.
  ASSERT_TRUE(p.sub.send(msg::PhysRequest{8, p.id, msg::kPhysDirect}));
  auto again = as<msg::EvPhysPath>(p.sub.waitFor(Code::ev_phys_path));
  ASSERT_TRUE(again);
  EXPECT_EQ(again->path, msg::kPhysDirect);
  EXPECT_EQ(again->endpoint, "unix:/tmp/skrobot-path-x") << "on this machine: its Unix socket";
  EXPECT_NE(again->token, path->token);
  auto revoked = as<msg::EvPhysRevoke>(p.owner.waitFor(Code::ev_phys_revoke));
  ASSERT_TRUE(revoked);
  EXPECT_EQ(revoked->subscriber, grant->subscriber);
}

TEST_F(PhysicalPaths, AWorkingPathTakesTheSubscriberOffTheRelayUntilItBreaks) {
  startHub();
  Pair p = offered();
  TestClient relayed = flowClient();
  ASSERT_TRUE(directPath(p));
  ASSERT_TRUE(p.sub.send(msg::PhysState{p.id, 1}));
  switchOver(p, 0);
  auto relay = as<msg::EvPhysRelay>(p.owner.waitFor(Code::ev_phys_relay));
  ASSERT_TRUE(relay) << "nobody is relayed to any more";
  EXPECT_EQ(relay->needed, 0);
  ASSERT_TRUE(p.owner.send(msg::Publish{p.id, msg::Rest{"on the path"}}));
  EXPECT_FALSE(p.sub.waitFor(Code::ev_data, 200)) << "not relayed to a subscriber on a path";
  // A second subscriber, relayed: the owner must publish again.
  subscribe(relayed, p.id);
  relay = as<msg::EvPhysRelay>(p.owner.waitFor(Code::ev_phys_relay));
  ASSERT_TRUE(relay);
  EXPECT_EQ(relay->needed, 1);
  ASSERT_TRUE(p.owner.send(msg::Publish{p.id, msg::Rest{"both"}}));
  EXPECT_TRUE(relayed.waitFor(Code::ev_data));
  EXPECT_FALSE(p.sub.waitFor(Code::ev_data, 200));
  // The statistics say which subscriber takes which path (the network page draws it).
  EXPECT_EQ(paths(p.id), (std::vector<std::string>{"direct", "relay"}));
  // The path broke: relayed again, still subscribed.
  ASSERT_TRUE(p.sub.send(msg::PhysState{p.id, 0}));
  settle(p.sub);
  EXPECT_EQ(paths(p.id), (std::vector<std::string>{"relay", "relay"}));
  ASSERT_TRUE(p.owner.send(msg::Publish{p.id, msg::Rest{"relayed again"}}));
  auto d = as<msg::EvData>(p.sub.waitFor(Code::ev_data));
  ASSERT_TRUE(d);
  EXPECT_EQ(d->payload.bytes, "relayed again");
}

// 1.9: the subscriber leaves the relay where the owner says, so that the marker names the last
// message relayed; an answer to a switch given up since changes nothing.
TEST_F(PhysicalPaths, TheOwnerPicksWhereTheSubscriberLeavesTheRelay) {
  startHub();
  Pair p = offered();
  auto grant = directPath(p);
  ASSERT_TRUE(grant);
  ASSERT_TRUE(p.sub.send(msg::PhysState{p.id, 1}));
  auto sw = as<msg::EvPhysSwitch>(p.owner.waitFor(Code::ev_phys_switch));
  ASSERT_TRUE(sw);
  EXPECT_EQ(sw->chan_id, p.id);
  EXPECT_EQ(sw->subscriber, grant->subscriber);
  // Until the owner answers, the subscriber is relayed.
  ASSERT_TRUE(p.owner.send(msg::Publish{p.id, msg::Rest{"before"}}));
  auto d = as<msg::EvData>(p.sub.waitFor(Code::ev_data));
  ASSERT_TRUE(d);
  EXPECT_EQ(d->payload.bytes, "before");
  EXPECT_EQ(paths(p.id), (std::vector<std::string>{"relay"}));
  // An answer to another switch, and one from someone else, change nothing.
  ASSERT_TRUE(p.owner.send(msg::PhysSwitched{p.id, sw->subscriber, sw->switch_id + 1, 5}));
  ASSERT_TRUE(p.sub.send(msg::PhysSwitched{p.id, sw->subscriber, sw->switch_id, 5}));
  EXPECT_EQ(error(p.sub), uint16_t(ErrorCode::permission_denied));
  settle(p.owner);
  EXPECT_EQ(paths(p.id), (std::vector<std::string>{"relay"}));
  // The answer: relayed up to message 41, the rest on the path.
  ASSERT_TRUE(p.owner.send(msg::PhysSwitched{p.id, sw->subscriber, sw->switch_id, 41}));
  auto marker = as<msg::EvPhysMarker>(p.sub.waitFor(Code::ev_phys_marker));
  ASSERT_TRUE(marker);
  EXPECT_EQ(marker->chan_id, p.id);
  EXPECT_EQ(marker->seq, 41u);
  EXPECT_EQ(paths(p.id), (std::vector<std::string>{"direct"}));
  ASSERT_TRUE(p.owner.send(msg::Publish{p.id, msg::Rest{"after"}}));
  EXPECT_FALSE(p.sub.waitFor(Code::ev_data, 200)) << "not relayed after the owner's point";
  // Broken while a switch waits for its answer: the late answer is ignored.
  ASSERT_TRUE(p.sub.send(msg::PhysState{p.id, 0}));
  ASSERT_TRUE(p.sub.send(msg::PhysState{p.id, 1}));
  auto second = as<msg::EvPhysSwitch>(p.owner.waitFor(Code::ev_phys_switch));
  ASSERT_TRUE(second);
  EXPECT_NE(second->switch_id, sw->switch_id);
  ASSERT_TRUE(p.sub.send(msg::PhysState{p.id, 0}));
  settle(p.sub);
  ASSERT_TRUE(p.owner.send(msg::PhysSwitched{p.id, sw->subscriber, second->switch_id, 50}));
  settle(p.owner);
  EXPECT_FALSE(p.sub.waitFor(Code::ev_phys_marker, 200));
  EXPECT_EQ(paths(p.id), (std::vector<std::string>{"relay"}));
}

// An owner older than 1.9 is not asked: the subscriber leaves the relay at once, and its marker
// is EV_PHYS_RELAY 0. A subscriber older than 1.9 gets that marker from a newer owner's switch.
TEST_F(PhysicalPaths, OlderOwnersAndSubscribersGetTheMarkerOf18) {
  startHub();
  {
    Pair p = offered(olderFlow(8));
    ASSERT_TRUE(directPath(p));
    ASSERT_TRUE(p.sub.send(msg::PhysState{p.id, 1}));
    auto marker = as<msg::EvPhysRelay>(p.sub.waitFor(Code::ev_phys_relay));
    ASSERT_TRUE(marker);
    EXPECT_EQ(marker->needed, 0);
    EXPECT_FALSE(p.owner.waitFor(Code::ev_phys_switch, 200));
  }
  Pair p = offered(flowClient(), olderFlow(8));
  ASSERT_TRUE(directPath(p));
  ASSERT_TRUE(p.sub.send(msg::PhysState{p.id, 1}));
  auto sw = as<msg::EvPhysSwitch>(p.owner.waitFor(Code::ev_phys_switch));
  ASSERT_TRUE(sw);
  EXPECT_FALSE(p.sub.waitFor(Code::ev_phys_relay, 200)) << "not before the owner's answer";
  ASSERT_TRUE(p.owner.send(msg::PhysSwitched{p.id, sw->subscriber, sw->switch_id, 3}));
  auto marker = as<msg::EvPhysRelay>(p.sub.waitFor(Code::ev_phys_relay));
  ASSERT_TRUE(marker);
  EXPECT_EQ(marker->needed, 0);
}

// 1.11: a direct path that broke (PHYS_FALLBACK) keeps its subscriber off the relay until the
// owner has replayed what came after the subscriber's last message, to it alone, and said what it
// no longer kept; an owner that does not end its replay within 5 s leaves the subscriber relayed
// without it.
TEST_F(PhysicalPaths, ADirectPathThatBreaksIsResumedWithWhatTheOwnerKept) {
  startHub();
  Pair p = offered();
  TestClient relayed = flowClient();
  subscribe(relayed, p.id);
  auto grant = directPath(p);
  ASSERT_TRUE(grant);
  ASSERT_TRUE(p.sub.send(msg::PhysState{p.id, 1}));
  switchOver(p, 5);
  ASSERT_TRUE(p.sub.send(msg::PhysFallback{p.id, 7}));
  auto resume = as<msg::EvPhysResume>(p.owner.waitFor(Code::ev_phys_resume));
  ASSERT_TRUE(resume) << "the owner is asked for what the path lost";
  EXPECT_EQ(resume->chan_id, p.id);
  EXPECT_EQ(resume->subscriber, grant->subscriber);
  EXPECT_EQ(resume->after, 7u);
  // Another resume's replay, and one from someone else, change nothing.
  const uint32_t sub = resume->subscriber, id = resume->resume_id;
  ASSERT_TRUE(p.owner.send(msg::PhysReplay{p.id, sub, id + 1, 0, 0, msg::Rest{"other"}}));
  ASSERT_TRUE(relayed.send(msg::PhysReplay{p.id, sub, id, 0, 0, msg::Rest{"stranger"}}));
  EXPECT_EQ(error(relayed), uint16_t(ErrorCode::permission_denied));
  ASSERT_TRUE(p.owner.send(msg::PhysReplay{p.id, sub, id, 0, 0, msg::Rest{"m8"}}));
  ASSERT_TRUE(p.owner.send(msg::PhysReplay{p.id, sub, id, 0, 0, msg::Rest{"m9"}}));
  ASSERT_TRUE(p.owner.send(msg::PhysReplay{p.id, sub, id, 1, 2, msg::Rest{}}));
  ASSERT_TRUE(p.owner.send(msg::Publish{p.id, msg::Rest{"m12"}}));
  std::vector<std::string> got;
  while (got.size() < 3) {
    auto d = as<msg::EvData>(p.sub.waitFor(Code::ev_data));
    ASSERT_TRUE(d) << "got " << got.size();
    got.emplace_back(d->payload.bytes);
  }
  EXPECT_EQ(got, (std::vector<std::string>{"m8", "m9", "m12"}));
  auto r = as<msg::EvData>(relayed.waitFor(Code::ev_data));
  ASSERT_TRUE(r);
  EXPECT_EQ(r->payload.bytes, "m12") << "a replay is for its subscriber alone";
  flow::HubSnapshot snap;
  onHub([&] { snap = server_->snapshot(); });
  for (const auto& f : snap.flows) {
    if (f.id == sub) {
      EXPECT_EQ(f.dropped, 2u) << "what the owner no longer kept";
    }
  }
  // An owner that does not answer: relayed after 5 s without what it missed.
  ASSERT_TRUE(p.sub.send(msg::PhysRequest{8, p.id, msg::kPhysDirect}));
  ASSERT_TRUE(p.sub.waitFor(Code::ev_phys_path));
  ASSERT_TRUE(p.owner.waitFor(Code::ev_phys_grant));
  ASSERT_TRUE(p.sub.send(msg::PhysState{p.id, 1}));
  switchOver(p, 20);
  ASSERT_TRUE(p.sub.send(msg::PhysFallback{p.id, 20}));
  ASSERT_TRUE(p.owner.waitFor(Code::ev_phys_resume));
  ASSERT_TRUE(p.owner.send(msg::Publish{p.id, msg::Rest{"early"}}));
  EXPECT_FALSE(p.sub.waitFor(Code::ev_data, 200)) << "not relayed before the replay";
  ASSERT_TRUE(p.owner.send(msg::Publish{p.id, msg::Rest{"late"}}));
  std::this_thread::sleep_for(std::chrono::milliseconds(6000));
  ASSERT_TRUE(p.owner.send(msg::Publish{p.id, msg::Rest{"relayed"}}));
  auto d = as<msg::EvData>(p.sub.waitFor(Code::ev_data));
  ASSERT_TRUE(d);
  EXPECT_EQ(d->payload.bytes, "relayed");
}

// An owner older than 1.11 is not asked: PHYS_FALLBACK is PHYS_STATE 0.
TEST_F(PhysicalPaths, AnOwnerOlderThan111RelaysAtOnceOnAFallback) {
  startHub();
  Pair old = offered(olderFlow(10));
  ASSERT_TRUE(directPath(old));
  ASSERT_TRUE(old.sub.send(msg::PhysState{old.id, 1}));
  switchOver(old, 0);
  ASSERT_TRUE(old.sub.send(msg::PhysFallback{old.id, 0}));
  settle(old.sub);
  EXPECT_FALSE(old.owner.waitFor(Code::ev_phys_resume, 200));
  ASSERT_TRUE(old.owner.send(msg::Publish{old.id, msg::Rest{"at once"}}));
  auto d = as<msg::EvData>(old.sub.waitFor(Code::ev_data));
  ASSERT_TRUE(d);
  EXPECT_EQ(d->payload.bytes, "at once");
}

TEST_F(PhysicalPaths, LeavingOrUnsubscribingRevokesTheGrant) {
  startHub();
  Pair p = offered();
  auto grant = directPath(p);
  ASSERT_TRUE(grant);
  ASSERT_TRUE(p.sub.send(msg::PhysState{p.id, 1}));
  settle(p.sub);
  ASSERT_TRUE(p.sub.send(msg::Unsubscribe{3, p.id}));
  auto revoked = as<msg::EvPhysRevoke>(p.owner.waitFor(Code::ev_phys_revoke));
  ASSERT_TRUE(revoked);
  EXPECT_EQ(revoked->subscriber, grant->subscriber);
  // Another subscriber with a grant leaves: revoked as well.
  TestClient other = flowClient();
  subscribe(other, p.id);
  ASSERT_TRUE(other.send(msg::PhysRequest{7, p.id, msg::kPhysDirect}));
  ASSERT_TRUE(other.waitFor(Code::ev_phys_path));
  auto second = as<msg::EvPhysGrant>(p.owner.waitFor(Code::ev_phys_grant));
  ASSERT_TRUE(second);
  other.close();
  revoked = as<msg::EvPhysRevoke>(p.owner.waitFor(Code::ev_phys_revoke));
  ASSERT_TRUE(revoked);
  EXPECT_EQ(revoked->subscriber, second->subscriber);
}

// An administrator kicks a subscriber (FlowProtocol ADMIN "kick"): its path goes with its flow.
TEST_F(PhysicalPaths, AKickedSubscriberLosesItsPath) {
  auto o = defaults();
  o.users_file = dir_.path() / "users.json";
  auto users = flow::UsersFile::load(o.users_file);
  ASSERT_TRUE(users);
  ASSERT_TRUE(users->add("root", "pw"));
  flow::AccessRules admin;
  admin.setRole(flow::Role::admin);
  ASSERT_TRUE(users->setAccess("root", admin));
  ASSERT_TRUE(users->save());
  ASSERT_TRUE(startHub(o));
  Pair p = offered();
  auto grant = directPath(p);
  ASSERT_TRUE(grant);
  ASSERT_TRUE(p.sub.send(msg::PhysState{p.id, 1}));
  switchOver(p, 0);
  EXPECT_EQ(paths(p.id), std::vector<std::string>{"direct"});
  TestClient root = syncClient("root", "pw");
  const auto kicked = as<msg::ReplyValue>(root.call(msg::Admin{
      "kick", Variant(Variant::Map{{"connection", static_cast<int64_t>(grant->subscriber)}})}));
  ASSERT_TRUE(kicked);
  auto revoked = as<msg::EvPhysRevoke>(p.owner.waitFor(Code::ev_phys_revoke));
  ASSERT_TRUE(revoked) << "the owner closes the kicked flow's path";
  EXPECT_EQ(revoked->subscriber, grant->subscriber);
  EXPECT_TRUE(p.sub.closedByPeer());
  onHub([&] {
    for (const auto& f : server_->snapshot().flows) EXPECT_NE(f.id, grant->subscriber);
  });
  EXPECT_TRUE(paths(p.id).empty());
}

TEST_F(PhysicalPaths, TrafficOnPathsIsCounted) {
  startHub();
  Pair p = offered();
  ASSERT_TRUE(p.owner.send(msg::Publish{p.id, msg::Rest{"12345"}}));
  ASSERT_TRUE(p.owner.send(msg::PhysCount{p.id, 10, 1000}));
  settle(p.owner);
  flow::HubSnapshot snap;
  onHub([&] { snap = server_->snapshot(); });
  bool found = false;
  for (const auto& c : snap.channels) {
    if (c.id != p.id) continue;
    found = true;
    EXPECT_EQ(c.messages, 11u);
    EXPECT_EQ(c.bytes, 1005u);
  }
  EXPECT_TRUE(found);
}

// PHYS_RECEIVED (1.10): what a subscriber with a grant got on its path counts in its flow's
// traffic and what it skipped in the channel's drops; from one without a grant, or for a channel
// removed since (its last report crosses the removal), it is ignored.
TEST_F(PhysicalPaths, WhatASubscriberGetsOnItsPathCountsInItsFlow) {
  startHub();
  Pair p = offered();
  TestClient stranger = flowClient();
  subscribe(stranger, p.id);
  ASSERT_TRUE(stranger.send(msg::PhysReceived{p.id, 50, 5000, 50}));  // no grant: ignored
  EXPECT_FALSE(stranger.waitFor(Code::ev_error, 200));
  const auto grant = directPath(p);
  ASSERT_TRUE(grant);
  ASSERT_TRUE(p.sub.send(msg::PhysReceived{p.id, 10, 1000, 3}));
  ASSERT_TRUE(p.sub.send(msg::PhysReceived{p.id, 2, 200, 0}));
  ASSERT_TRUE(p.sub.send(msg::PhysReceived{999, 1, 1, 0}));
  EXPECT_FALSE(p.sub.waitFor(Code::ev_error, 200));
  flow::HubSnapshot snap;
  onHub([&] { snap = server_->snapshot(); });
  uint64_t path_messages = 0, dropped = 0;  // in every flow: the stranger's report is not there
  for (const auto& f : snap.flows) {
    path_messages += f.path_messages;
    dropped += f.dropped;
    if (f.id != grant->subscriber) continue;
    EXPECT_EQ(f.path_messages, 12u);
    EXPECT_EQ(f.path_bytes, 1200u);
    EXPECT_GE(f.messages_out, 12u);
    EXPECT_EQ(f.dropped, 3u);
  }
  EXPECT_EQ(path_messages, 12u);
  EXPECT_EQ(dropped, 3u);
  for (const auto& c : snap.channels) {
    if (c.id == p.id) {
      EXPECT_EQ(c.dropped, 3u);
    }
  }
}

TEST_F(PhysicalPaths, Refusals) {
  startHub();
  TestClient owner = flowClient();
  const uint16_t id = addChannel(owner, "camera");
  TestClient other = flowClient();
  // Only the owner offers; a bad endpoint; shared memory over TCP; unknown kinds.
  ASSERT_TRUE(other.send(msg::PhysOffer{1, id, msg::kPhysDirect, "unix:/tmp/x"}));
  EXPECT_EQ(error(other), uint16_t(ErrorCode::permission_denied));
  ASSERT_TRUE(owner.send(msg::PhysOffer{1, id, msg::kPhysDirect, "/tmp/x"}));
  EXPECT_EQ(error(owner), uint16_t(ErrorCode::invalid_argument));
  ASSERT_TRUE(owner.send(msg::PhysOffer{1, id, msg::kPhysShm, "tcp:127.0.0.1:9"}));
  EXPECT_EQ(error(owner), uint16_t(ErrorCode::invalid_argument));
  ASSERT_TRUE(owner.send(msg::PhysOffer{1, id, 0x80, "unix:/tmp/x"}));
  EXPECT_EQ(error(owner), uint16_t(ErrorCode::invalid_argument));
  // Two endpoints (1.8): one of each kind, separated by one space.
  for (const char* bad : {"unix:/tmp/x unix:/tmp/y", "tcp:127.0.0.1:9 tcp:127.0.0.1:8",
                          "unix:/tmp/x  tcp:127.0.0.1:9", "unix:/tmp/x tcp:", "unix:/tmp/x "}) {
    ASSERT_TRUE(owner.send(msg::PhysOffer{1, id, msg::kPhysDirect, bad}));
    EXPECT_EQ(error(owner), uint16_t(ErrorCode::invalid_argument)) << bad;
  }
  // No offer yet; not subscribed.
  subscribe(other, id);
  ASSERT_TRUE(other.send(msg::PhysRequest{2, id, msg::kPhysDirect}));
  EXPECT_EQ(error(other), uint16_t(ErrorCode::not_found));
  ASSERT_TRUE(owner.send(msg::PhysOffer{1, id, msg::kPhysShm, "unix:/tmp/x"}));
  settle(owner);
  TestClient stranger = flowClient();
  ASSERT_TRUE(stranger.send(msg::PhysRequest{3, id, msg::kPhysShm}));
  EXPECT_EQ(error(stranger), uint16_t(ErrorCode::invalid_argument));
  // A kind the owner does not serve; a state without a grant.
  ASSERT_TRUE(other.send(msg::PhysRequest{4, id, msg::kPhysDirect}));
  EXPECT_EQ(error(other), uint16_t(ErrorCode::unsupported));
  ASSERT_TRUE(stranger.send(msg::PhysState{id, 1}));
  EXPECT_EQ(error(stranger), uint16_t(ErrorCode::not_found));
  // A path that broke after its grant went (the owner left, a revocation): nothing to refuse.
  ASSERT_TRUE(stranger.send(msg::PhysState{id, 0}));
  EXPECT_FALSE(stranger.waitFor(Code::ev_error, 200));
  // Events are the hub's: a satellite that sends one breaks the protocol.
  ASSERT_TRUE(stranger.send(msg::EvPhysRelay{id, 0}));
  EXPECT_FALSE(stranger.waitFor(Code::ev_error, 1000)) << "closed, not answered";
  // A 1.6 client: physical mode is newer than its protocol.
  TestClient old = olderClient(6);
  ASSERT_TRUE(old.call(msg::Empty<Code::go_async>{}));
  ASSERT_TRUE(old.send(msg::PhysRequest{5, id, msg::kPhysShm}));
  EXPECT_EQ(error(old), uint16_t(ErrorCode::unsupported));
}

}  // namespace
}  // namespace skr::test
