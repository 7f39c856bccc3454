// SPDX-License-Identifier: Apache-2.0
// Roles and rules (flow/access.h): parsed from the users file, and obeyed by every way in.
#include <skrobot/hub/flow/access.h>
#include <skrobot/hub/flow/accounts.h>

#include "flow_fixture.h"
#include "log_capture.h"

#include <gtest/gtest.h>

#include <json/json.h>

namespace skr::flow {
namespace {

using test::as;
using test::Frame;
using test::TestClient;

// The error code of a REPLY_ERROR; 0 for anything else.
uint16_t errorOf(const std::optional<Frame>& f) {
  auto e = as<msg::ReplyError>(f);
  return e ? e->error : 0;
}

Json::Value parse(const std::string& text) {
  Json::Value v;
  std::string errs;
  Json::CharReaderBuilder b;
  std::unique_ptr<Json::CharReader> r(b.newCharReader());
  EXPECT_TRUE(r->parse(text.data(), text.data() + text.size(), &v, &errs)) << errs;
  return v;
}

TEST(AccessRules, DefaultsAllowEverythingButAdministration) {
  const auto d = AccessRules::defaults();
  EXPECT_FALSE(d->admin());
  for (auto a :
       {Action::publish, Action::subscribe, Action::call, Action::db_read, Action::db_write}) {
    EXPECT_TRUE(d->allows(a, "bob.camera"));
    EXPECT_EQ(d->patterns(a), std::vector<std::string>{"**"});
  }
}

TEST(AccessRules, ReadWriteAndRefuse) {
  auto r =
      AccessRules::fromJson(parse(R"({"role": "user", "rules": {"subscribe": ["**", "!bob.secret"],
                                          "call": ["speech.*"]}})"),
                            "users.alice");
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_TRUE(r->allows(Action::subscribe, "bob.camera"));
  EXPECT_FALSE(r->allows(Action::subscribe, "bob.secret"));
  EXPECT_TRUE(r->allows(Action::call, "speech.say"));
  EXPECT_FALSE(r->allows(Action::call, "nao-bridge.command"));
  EXPECT_TRUE(r->allows(Action::db_write, "anything"));  // left out: "**"
  Json::Value back;
  r->toJson(back);
  EXPECT_FALSE(back.isMember("role"));
  EXPECT_EQ(back["rules"]["call"][0].asString(), "speech.*");
  EXPECT_FALSE(back["rules"].isMember("publish"));

  auto admin = AccessRules::fromJson(parse(R"({"role": "admin", "rules": {"call": []}})"), "u");
  ASSERT_TRUE(admin);
  EXPECT_TRUE(admin->admin());
  EXPECT_TRUE(admin->allows(Action::call, "x.y"));  // the role wins over an empty rule

  auto bad_role = AccessRules::fromJson(parse(R"({"role": "root"})"), "users.eve");
  ASSERT_FALSE(bad_role);
  EXPECT_NE(bad_role.error().message.find("users.eve.role"), std::string::npos);
  auto bad_rule = AccessRules::fromJson(parse(R"({"rules": {"sing": ["**"]}})"), "users.eve");
  ASSERT_FALSE(bad_rule);
  EXPECT_NE(bad_rule.error().message.find("users.eve.rules.sing"), std::string::npos);
  auto bad_pattern = AccessRules::fromJson(parse(R"({"rules": {"call": ["a b"]}})"), "users.eve");
  ASSERT_FALSE(bad_pattern);
  EXPECT_NE(bad_pattern.error().message.find("users.eve.rules.call"), std::string::npos);
}

TEST(AccessRules, SurviveTheUsersFile) {
  test::TempDir dir;
  const auto path = dir.path() / "users.json";
  {
    auto users = UsersFile::load(path);
    ASSERT_TRUE(users);
    ASSERT_TRUE(users->add("alice", "pw-alice"));
    AccessRules rules;
    rules.setRole(Role::admin);
    ASSERT_TRUE(rules.setRule(Action::db_read, {"alice*", "robot"}));
    ASSERT_TRUE(users->setAccess("alice", rules));
    EXPECT_FALSE(users->setAccess("nobody", rules));
    ASSERT_TRUE(users->save());
  }
  auto again = UsersFile::load(path);
  ASSERT_TRUE(again);
  const auto a = again->accessOf("alice");
  EXPECT_TRUE(a->admin());
  EXPECT_EQ(a->patterns(Action::db_read), (std::vector<std::string>{"alice*", "robot"}));
  EXPECT_FALSE(again->accessOf("nobody")->admin());
}

// A hub whose users file has a restricted user, an unrestricted one and an administrator.
class Access : public test::FlowFixture {
 protected:
  void SetUp() override {
    auto o = defaults();
    o.users_file = dir_.path() / "users.json";
    auto users = UsersFile::load(o.users_file);
    ASSERT_TRUE(users);
    for (const char* u : {"alice", "bob", "root"}) ASSERT_TRUE(users->add(u, "pw"));
    auto alice = AccessRules::fromJson(parse(R"({"rules": {
        "publish": ["alice.cam*"], "subscribe": ["**", "!bob.secret"], "call": ["bob.open*"],
        "db_read": ["alice", "_flow.*", "shared"], "db_write": ["alice", "_flow.*"]}})"),
                                       "users.alice");
    ASSERT_TRUE(alice) << alice.error().message;
    ASSERT_TRUE(users->setAccess("alice", *alice));
    AccessRules root;
    root.setRole(Role::admin);
    ASSERT_TRUE(users->setAccess("root", root));
    ASSERT_TRUE(users->save());
    ASSERT_TRUE(startHub(o));
  }

  // The error code of the EV_ERROR that answers an asynchronous command of `c`.
  uint16_t asyncError(TestClient& c) {
    auto e = as<msg::EvError>(c.waitFor(Code::ev_error));
    return e ? e->error : 0;
  }
};

TEST_F(Access, RulesDecideWhatAUserMayDo) {
  TestClient bob = flowClient("bob", "pw");
  const uint16_t secret = addChannel(bob, "secret");
  const uint16_t open = addChannel(bob, "open", ChannelKind::service);
  const uint16_t closed = addChannel(bob, "closed", ChannelKind::service);
  TestClient alice = flowClient("alice", "pw");

  // subscribe: everything but bob.secret
  ASSERT_TRUE(alice.send(msg::Subscribe{3, secret}));
  EXPECT_EQ(asyncError(alice), uint16_t(ErrorCode::permission_denied));
  // publish: only her own alice.cam*
  EXPECT_NE(addChannel(alice, "camera"), 0);
  msg::ChanAdd other;
  other.tag = 8;
  other.kind = uint8_t(ChannelKind::streaming);
  other.short_name = "mic";
  ASSERT_TRUE(alice.send(other));
  auto e = as<msg::EvError>(alice.waitFor(Code::ev_error));
  ASSERT_TRUE(e);
  EXPECT_EQ(e->error, uint16_t(ErrorCode::permission_denied));
  EXPECT_NE(e->message.find("alice.mic"), std::string::npos) << e->message;
  // call: bob.open* only; a refused request comes back as its response
  ASSERT_TRUE(alice.send(msg::ServiceRequest{4, closed, "go", Variant()}));
  auto refused = as<msg::EvServiceResponse>(alice.waitFor(Code::ev_service_response));
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->error, uint16_t(ErrorCode::permission_denied));
  ASSERT_TRUE(alice.send(msg::ServiceRequest{5, open, "go", Variant()}));
  EXPECT_TRUE(bob.waitFor(Code::ev_service_request));

  // databases: she reads and writes her own, reads "shared", neither reads nor lists bob's
  TestClient sync = syncClient("alice", "pw");
  TestClient bob_sync = syncClient("bob", "pw");
  EXPECT_EQ(bob_sync.call(msg::DbCreate{"shared"})->kind(), Code::reply_ok);
  EXPECT_EQ(bob_sync.call(msg::DbCreate{"other"})->kind(), Code::reply_ok);
  EXPECT_EQ(errorOf(sync.call(msg::DbSelect{"bob"})), uint16_t(ErrorCode::permission_denied));
  EXPECT_EQ(errorOf(sync.call(msg::DbSelect{"other"})), uint16_t(ErrorCode::permission_denied));
  EXPECT_EQ(sync.call(msg::DbSelect{"shared"})->kind(), Code::reply_ok);
  EXPECT_EQ(errorOf(sync.call(msg::VarSet{"k", Variant(1)})),
            uint16_t(ErrorCode::permission_denied));  // shared: not in her db_write
  EXPECT_EQ(errorOf(sync.call(msg::DbCreate{"mine"})), uint16_t(ErrorCode::permission_denied));
  EXPECT_EQ(sync.call(msg::DbSelect{"alice"})->kind(), Code::reply_ok);
  EXPECT_EQ(sync.call(msg::VarSet{"k", Variant(1)})->kind(), Code::reply_ok);
  auto list = as<msg::ReplyValue>(sync.call(msg::Empty<Code::db_list>{}));
  ASSERT_TRUE(list && list->value.isList());
  for (const auto& name : *list->value.asList()) {
    EXPECT_NE(*name.asString(), "bob");
    EXPECT_NE(*name.asString(), "other");
  }

  // bob, without rules, does all he did before rules existed, and no more
  TestClient bob2 = flowClient("bob", "pw");
  const uint16_t cam = addChannel(alice, "cam2");
  ASSERT_TRUE(bob2.send(msg::Subscribe{6, cam}));
  ASSERT_TRUE(bob2.send(msg::ChanRemove{7, cam}));  // not his
  EXPECT_EQ(asyncError(bob2), uint16_t(ErrorCode::permission_denied));
  EXPECT_EQ(errorOf(bob_sync.call(msg::DbSelect{"alice"})), 0);
  EXPECT_EQ(errorOf(bob_sync.call(msg::VarSet{"x", Variant(2)})),
            uint16_t(ErrorCode::permission_denied));  // alice's user database
}

TEST_F(Access, TheAdministratorRemovesAnyChannelAndWritesAnyDatabase) {
  TestClient bob = flowClient("bob", "pw");
  const uint16_t cam = addChannel(bob, "camera");
  TestClient root = flowClient("root", "pw");
  ASSERT_TRUE(root.send(msg::ChanRemove{1, cam}));
  auto gone = as<msg::EvChanRemoved>(bob.waitFor(Code::ev_chan_removed));
  ASSERT_TRUE(gone);
  EXPECT_EQ(gone->chan_id, cam);
  TestClient sync = syncClient("root", "pw");
  EXPECT_EQ(sync.call(msg::DbSelect{"bob"})->kind(), Code::reply_ok);
  EXPECT_EQ(sync.call(msg::VarSet{"k", Variant(1)})->kind(), Code::reply_ok);
}

TEST_F(Access, TheDevelopmentAccountKeepsTheDefaults) {
  TestClient bob = flowClient("bob", "pw");
  const uint16_t cam = addChannel(bob, "camera");
  TestClient guest = flowClient("guest", "password");
  ASSERT_TRUE(guest.send(msg::Subscribe{1, cam}));
  ASSERT_TRUE(guest.send(msg::ChanRemove{2, cam}));  // not an administrator
  EXPECT_EQ(asyncError(guest), uint16_t(ErrorCode::permission_denied));
}

}  // namespace
}  // namespace skr::flow

namespace skr::flow {
namespace {

// A hub whose user "lim" has tight limits of its own, and whose default limits apply to others.
class Limits : public test::FlowFixture {
 protected:
  void SetUp() override {
    auto o = defaults();
    o.users_file = dir_.path() / "users.json";
    o.user_limits = {3, 1024, 64, 1024};
    auto users = UsersFile::load(o.users_file);
    ASSERT_TRUE(users);
    ASSERT_TRUE(users->add("lim", "pw"));
    ASSERT_TRUE(users->add("other", "pw"));
    auto lim =
        AccessRules::fromJson(parse(R"({"limits": {"connections": 2, "channels": 2, "databases": 1,
                             "pending_requests": 1}})"),
                              "users.lim");
    ASSERT_TRUE(lim) << lim.error().message;
    ASSERT_TRUE(users->setAccess("lim", *lim));
    ASSERT_TRUE(users->save());
    ASSERT_TRUE(startHub(o));
  }
};

TEST_F(Limits, EachLimitRefusesTheNextOneAndOnlyThat) {
  // channels: 2
  TestClient a = flowClient("lim", "pw");
  EXPECT_NE(addChannel(a, "one"), 0);
  EXPECT_NE(addChannel(a, "two", ChannelKind::service), 0);
  msg::ChanAdd third;
  third.tag = 9;
  third.kind = uint8_t(ChannelKind::streaming);
  third.short_name = "three";
  ASSERT_TRUE(a.send(third));
  auto e = as<msg::EvError>(a.waitFor(Code::ev_error));
  ASSERT_TRUE(e);
  EXPECT_EQ(e->error, uint16_t(ErrorCode::limit_exceeded));
  EXPECT_NE(e->message.find("channels"), std::string::npos) << e->message;

  // connections: 2 (a is one); the third is refused and closed, the others go on
  TestClient b = syncClient("lim", "pw");
  TestClient c = connect();
  auto refused = c.login("lim", "pw");
  ASSERT_FALSE(refused);
  EXPECT_NE(refused.error().message.find("connections"), std::string::npos)
      << refused.error().message;
  EXPECT_TRUE(c.closedByPeer());
  EXPECT_EQ(b.call(msg::Ping{msg::Rest{"x"}})->kind(), Code::reply_ok);

  // databases: 1
  EXPECT_EQ(b.call(msg::DbCreate{"lim-db1"})->kind(), Code::reply_ok);
  EXPECT_EQ(errorOf(b.call(msg::DbCreate{"lim-db2"})), uint16_t(ErrorCode::limit_exceeded));
  EXPECT_EQ(b.call(msg::DbRemove{"lim-db1"})->kind(), Code::reply_ok);  // frees its place
  EXPECT_EQ(b.call(msg::DbCreate{"lim-db2"})->kind(), Code::reply_ok);

  // pending requests: 1, to a service that does not answer yet
  TestClient svc = flowClient("other", "pw");
  const uint16_t slow = addChannel(svc, "slow", ChannelKind::service);
  ASSERT_TRUE(a.send(msg::ServiceRequest{1, slow, "x", Variant()}));
  auto req = as<msg::EvServiceRequest>(svc.waitFor(Code::ev_service_request));
  ASSERT_TRUE(req);
  ASSERT_TRUE(a.send(msg::ServiceRequest{2, slow, "y", Variant()}));
  auto over = as<msg::EvServiceResponse>(a.waitFor(Code::ev_service_response));
  ASSERT_TRUE(over);
  EXPECT_EQ(over->tag, 2u);
  EXPECT_EQ(over->error, uint16_t(ErrorCode::limit_exceeded));
  // Answered, the first one frees its place.
  ASSERT_TRUE(svc.send(msg::ServiceResponse{slow, req->request, Variant("ok")}));
  auto ok = as<msg::EvServiceResponse>(a.waitFor(Code::ev_service_response));
  ASSERT_TRUE(ok);
  EXPECT_EQ(ok->tag, 1u);
  ASSERT_TRUE(a.send(msg::ServiceRequest{3, slow, "z", Variant()}));
  EXPECT_TRUE(svc.waitFor(Code::ev_service_request));

  // "other" has the hub's limits (3 connections): a fourth is refused
  TestClient o2 = syncClient("other", "pw");
  TestClient o3 = syncClient("other", "pw");
  TestClient o4 = connect();
  EXPECT_FALSE(o4.login("other", "pw"));
}

}  // namespace
}  // namespace skr::flow

namespace skr::flow {
namespace {

Variant::Map mapOf(const Variant& v) {
  return v.asMap() != nullptr ? *v.asMap() : Variant::Map{};
}

TEST_F(Access, AdministrationOverTheProtocol) {
  TestClient bob = flowClient("bob", "pw");
  addChannel(bob, "camera");
  TestClient root = syncClient("root", "pw");
  TestClient bob_sync = syncClient("bob", "pw");

  // Only an administrator: others get permission_denied and keep their connection.
  EXPECT_EQ(errorOf(bob_sync.call(msg::Admin{"flows", Variant()})),
            uint16_t(ErrorCode::permission_denied));
  EXPECT_EQ(bob_sync.call(msg::Ping{msg::Rest{"x"}})->kind(), Code::reply_ok);

  // flows: every logged-in connection, with its id
  auto flows = as<msg::ReplyValue>(root.call(msg::Admin{"flows", Variant()}));
  ASSERT_TRUE(flows && flows->value.isList());
  int64_t bob_flow = 0;
  for (const auto& f : *flows->value.asList()) {
    auto m = mapOf(f);
    if (*m["user"].asString() == "bob" && m["flow"] == Variant(true)) bob_flow = *m["id"].asInt64();
  }
  ASSERT_NE(bob_flow, 0);

  // chan_rm: any channel; its owner is told
  auto removed = as<msg::ReplyValue>(
      root.call(msg::Admin{"chan_rm", Variant(Variant::Map{{"name", "bob.camera"}})}));
  ASSERT_TRUE(removed);
  EXPECT_TRUE(bob.waitFor(Code::ev_chan_removed));
  EXPECT_EQ(errorOf(root.call(msg::Admin{"chan_rm", Variant(Variant::Map{{"name", "x.y"}})})),
            uint16_t(ErrorCode::not_found));

  // db_rm: a named database of someone else
  EXPECT_EQ(bob_sync.call(msg::DbCreate{"bobs"})->kind(), Code::reply_ok);
  EXPECT_TRUE(
      as<msg::ReplyValue>(root.call(msg::Admin{"db_rm", Variant(Variant::Map{{"name", "bobs"}})})));
  EXPECT_EQ(errorOf(bob_sync.call(msg::DbSelect{"bobs"})), uint16_t(ErrorCode::not_found));

  // kick: that connection is closed, nobody else
  auto kicked = as<msg::ReplyValue>(
      root.call(msg::Admin{"kick", Variant(Variant::Map{{"connection", bob_flow}})}));
  ASSERT_TRUE(kicked);
  EXPECT_TRUE(bob.closedByPeer());
  EXPECT_EQ(bob_sync.call(msg::Ping{msg::Rest{"x"}})->kind(), Code::reply_ok);

  // bad arguments and unknown commands are invalid_argument
  EXPECT_EQ(errorOf(root.call(msg::Admin{"kick", Variant("7")})),
            uint16_t(ErrorCode::invalid_argument));
  EXPECT_EQ(errorOf(root.call(msg::Admin{"reboot", Variant()})),
            uint16_t(ErrorCode::invalid_argument));
}

TEST_F(Access, AProtocol10ClientGetsUnsupportedForNewerRequests) {
  TestClient old = connect();
  msg::Login login;
  login.minor = 0;  // a 1.0 client
  login.user = "root";
  login.password = "pw";
  login.client_name = "old";
  auto ok = as<msg::LoginOk>(old.call(login));
  ASSERT_TRUE(ok);
  EXPECT_EQ(ok->minor, kProtocolMinor);  // the hub says what it speaks
  EXPECT_EQ(errorOf(old.call(msg::Admin{"flows", Variant()})), uint16_t(ErrorCode::unsupported));
  EXPECT_EQ(old.call(msg::Ping{msg::Rest{"x"}})->kind(), Code::reply_ok);  // still connected
}

}  // namespace
}  // namespace skr::flow

#include <skrobot/hub/module_host.h>

namespace skr::flow {
namespace {

// A module acts under the account its config entry names: its rules and limits.
TEST_F(Access, AModuleActsUnderTheAccountItsConfigNames) {
  std::unique_ptr<ModuleHost> host;
  std::vector<ModuleFailure> failures;
  const auto start = [&](const std::string& account) {
    onHub([&] {
      host = std::make_unique<ModuleHost>(hub_->loop(), std::vector<std::filesystem::path>{},
                                          server_.get());
      ModuleEntry e;
      e.name = "test_channel_echo";
      e.path = std::filesystem::path(SKROBOT_TEST_MODULE_DIR) / "test_channel_echo.so";
      e.account = account;
      host->start({e});
      failures = host->failures();
    });
  };
  const auto stop = [&] { onHub([&] { host.reset(); }); };

  start("nobody");  // not in the users file
  ASSERT_EQ(failures.size(), 1u);
  EXPECT_EQ(failures[0].tag, "MODULE-ACCOUNT");
  EXPECT_NE(failures[0].reason.find("nobody"), std::string::npos) << failures[0].reason;
  stop();

  {
    test::LogCapture log;
    start("alice");  // may publish only alice.cam*: the module cannot create its channels
    ASSERT_EQ(failures.size(), 1u);
    EXPECT_EQ(failures[0].tag, "MODULE-START");
    bool refused = false;
    for (const auto& l : log.lines()) {
      refused |= l.find("may not publish on test_channel_echo.out") != std::string::npos;
    }
    EXPECT_TRUE(refused);
    stop();
  }

  start("bob");  // no rules: as before accounts existed
  EXPECT_TRUE(failures.empty()) << failures[0].reason;
  TestClient sync = syncClient();
  EXPECT_TRUE(as<msg::ChannelInfoReply>(sync.call(msg::ChanInfoByName{"test_channel_echo.out"})));
  stop();
}

}  // namespace
}  // namespace skr::flow

namespace skr::flow {
namespace {

TEST_F(Access, AccountsAreManagedOverTheProtocol) {  // 3 argon2id
  TestClient root = syncClient("root", "pw");
  const auto admin = [&root](const std::string& command, Variant::Map args) {
    return root.call(msg::Admin{command, Variant(std::move(args))});
  };
  TestClient bob = syncClient("bob", "pw");
  EXPECT_EQ(errorOf(bob.call(
                msg::Admin{"user_add", Variant(Variant::Map{{"user", "x"}, {"password", "y"}})})),
            uint16_t(ErrorCode::permission_denied));

  ASSERT_TRUE(as<msg::ReplyValue>(admin("user_add", {{"user", "carol"}, {"password", "c1"}})));
  EXPECT_EQ(errorOf(admin("user_add", {{"user", "carol"}, {"password", "c1"}})),
            uint16_t(ErrorCode::already_exists));
  EXPECT_EQ(errorOf(admin("user_add", {{"user", "bad name"}, {"password", "c1"}})),
            uint16_t(ErrorCode::invalid_argument));
  EXPECT_TRUE(connect().login("carol", "c1"));

  TestClient owner = flowClient("bob", "pw");
  const uint16_t cam = addChannel(owner, "cam");
  ASSERT_TRUE(as<msg::ReplyValue>(
      admin("user_rule", {{"user", "carol"},
                          {"action", "subscribe"},
                          {"patterns", Variant::List{Variant("**"), Variant("!bob.cam")}}})));
  EXPECT_EQ(errorOf(admin("user_rule", {{"user", "carol"}, {"action", "sing"}})),
            uint16_t(ErrorCode::invalid_argument));
  TestClient carol = flowClient("carol", "c1");
  ASSERT_TRUE(carol.send(msg::Subscribe{1, cam}));
  auto e = as<msg::EvError>(carol.waitFor(Code::ev_error));
  ASSERT_TRUE(e);
  EXPECT_EQ(e->error, uint16_t(ErrorCode::permission_denied));

  ASSERT_TRUE(as<msg::ReplyValue>(admin("user_passwd", {{"user", "carol"}, {"password", "c2"}})));
  EXPECT_FALSE(connect().login("carol", "c1"));
  ASSERT_TRUE(as<msg::ReplyValue>(admin("user_role", {{"user", "carol"}, {"role", "admin"}})));
  auto users = as<msg::ReplyValue>(admin("users", {}));
  ASSERT_TRUE(users && users->value.isList());
  bool carol_admin = false;
  for (const auto& u : *users->value.asList()) {
    auto m = mapOf(u);
    carol_admin |= *m["user"].asString() == "carol" && *m["role"].asString() == "admin";
  }
  EXPECT_TRUE(carol_admin);

  // What the hub changed is on disk.
  auto file = UsersFile::load(opts_.users_file);
  ASSERT_TRUE(file);
  EXPECT_TRUE(file->accessOf("carol")->admin());
  EXPECT_EQ(file->accessOf("carol")->patterns(Action::subscribe),
            (std::vector<std::string>{"**", "!bob.cam"}));

  ASSERT_TRUE(as<msg::ReplyValue>(admin("user_del", {{"user", "carol"}})));
  EXPECT_EQ(errorOf(admin("user_del", {{"user", "carol"}})), uint16_t(ErrorCode::not_found));
  EXPECT_FALSE(connect().login("carol", "c2"));
}

}  // namespace
}  // namespace skr::flow
