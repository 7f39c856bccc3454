// SPDX-License-Identifier: Apache-2.0
// Database watches on a flow (DB_WATCH, DB_UNWATCH, EV_DB_PAIR; FlowProtocol 1.14): the snapshot
// then every change, in order; the db_read rule; the end of a watch by DB_UNWATCH, by the
// database's removal (EV_ERROR not_found) and when the flow leaves.
#include "flow_fixture.h"

#include <skrobot/hub/flow/access.h>
#include <skrobot/hub/flow/accounts.h>

#include <json/json.h>

#include <memory>

namespace skr::test {
namespace {

using flow::Code;
using flow::ErrorCode;
using flow::Variant;
namespace msg = flow::msg;
using State = msg::DbPairState;

// One EV_DB_PAIR as text: "set k=1", "removed k", "cleared", "end".
std::string text(const msg::EvDbPair& p) {
  switch (static_cast<State>(p.state)) {
    case State::set:
      return "set " + p.key + "=" + flow::variantToJsonText(p.value);
    case State::removed:
      return "removed " + p.key;
    case State::cleared:
      return "cleared";
    case State::snapshot_end:
      return "end";
  }
  return "state " + std::to_string(p.state);
}

class DbWatch : public FlowFixture {
 protected:
  // The writer's commands were handled once its barrier comes back.
  void handled(TestClient& writer) {
    ASSERT_TRUE(writer.send(msg::DbSyncAsync{++tag_}));
    ASSERT_TRUE(writer.waitFor(Code::ev_db_synced).has_value());
  }
  void set(TestClient& writer, const std::string& key, Variant value) {
    ASSERT_TRUE(writer.send(msg::VarSetAsync{++tag_, key, std::move(value)}));
  }
  // What `watcher` was sent until now, as text (EV_DB_PAIR) or "error <code> <command>": a
  // DB_READ is its barrier (everything the hub sent it before comes first).
  std::vector<std::string> heard(TestClient& watcher) {
    std::vector<std::string> out;
    const uint32_t barrier = ++tag_;
    EXPECT_TRUE(watcher.send(msg::DbRead{barrier, "_flow.0", 2, {}}));  // refused: still a reply
    while (auto f = watcher.recv(5000)) {
      if (auto p = as<msg::EvDbPair>(f)) {
        out.push_back(p->db + ": " + text(*p));
      } else if (auto e = as<msg::EvError>(f)) {
        if (e->tag == barrier) return out;
        out.push_back("error " + std::string(flow::errorCodeName(ErrorCode(e->error))) + " " +
                      std::string(flow::codeName(e->command)) + " " + std::to_string(e->tag));
      } else if (auto v = as<msg::EvDbValue>(f); v && v->tag == barrier) {
        return out;
      }
    }
    ADD_FAILURE() << "no answer to the barrier";
    return out;
  }
  // A writer with database "shared" as its current one, holding a=1 and b="two".
  TestClient writer() {
    TestClient w = flowClient();
    EXPECT_TRUE(w.send(msg::DbCreateAsync{++tag_, "shared"}));
    EXPECT_TRUE(w.send(msg::DbSetCurrent{++tag_, "shared"}));
    set(w, "a", Variant(int64_t(1)));
    set(w, "b", Variant(std::string("two")));
    handled(w);
    return w;
  }
  uint64_t watches() { return stats().db_watches; }
  uint32_t tag_ = 100;
};

TEST_F(DbWatch, ASnapshotThenEveryChangeUntilUnwatched) {
  startHub();
  TestClient w = writer();
  TestClient watcher = flowClient();
  ASSERT_TRUE(watcher.send(msg::DbWatch{7, "shared"}));
  EXPECT_EQ(heard(watcher),
            (std::vector<std::string>{"shared: set a=1", "shared: set b=\"two\"", "shared: end"}));
  EXPECT_EQ(watches(), 1u);

  set(w, "c", Variant(3.5));
  ASSERT_TRUE(w.send(msg::VarDelAsync{++tag_, "a"}));
  set(w, "b", Variant(std::string("three")));
  handled(w);
  EXPECT_EQ(heard(watcher), (std::vector<std::string>{"shared: set c=3.5", "shared: removed a",
                                                      "shared: set b=\"three\""}));

  // Watched again: a new snapshot. Unwatched: nothing more.
  ASSERT_TRUE(watcher.send(msg::DbWatch{8, "shared"}));
  EXPECT_EQ(heard(watcher), (std::vector<std::string>{"shared: set b=\"three\"",
                                                      "shared: set c=3.5", "shared: end"}));
  EXPECT_EQ(watches(), 1u);
  ASSERT_TRUE(watcher.send(msg::DbUnwatch{9, "shared"}));
  set(w, "d", Variant(int64_t(4)));
  handled(w);
  EXPECT_TRUE(heard(watcher).empty());
  EXPECT_EQ(watches(), 0u);
  ASSERT_TRUE(watcher.send(msg::DbUnwatch{10, "shared"}));  // not watched
  EXPECT_EQ(heard(watcher), (std::vector<std::string>{"error not_found DB_UNWATCH 10"}));
}

TEST_F(DbWatch, AnEmptyDatabaseSendsItsEndAndARemovedOneEndsTheWatch) {
  startHub();
  TestClient w = flowClient();
  ASSERT_TRUE(w.send(msg::DbCreateAsync{1, "empty"}));
  handled(w);
  TestClient watcher = flowClient();
  ASSERT_TRUE(watcher.send(msg::DbWatch{7, "empty"}));
  EXPECT_EQ(heard(watcher), (std::vector<std::string>{"empty: end"}));
  ASSERT_TRUE(w.send(msg::DbRemoveAsync{2, "empty"}));
  handled(w);
  EXPECT_EQ(heard(watcher), (std::vector<std::string>{"error not_found DB_WATCH 7"}));
  EXPECT_EQ(watches(), 0u);
  // One of the same name later is not watched.
  ASSERT_TRUE(w.send(msg::DbCreateAsync{3, "empty"}));
  ASSERT_TRUE(w.send(msg::DbSetCurrent{4, "empty"}));
  set(w, "x", Variant(int64_t(1)));
  handled(w);
  EXPECT_TRUE(heard(watcher).empty());
  // Nor is a database that does not exist, or a linked hub's.
  ASSERT_TRUE(watcher.send(msg::DbWatch{8, "nothing"}));
  ASSERT_TRUE(watcher.send(msg::DbWatch{9, "far/shared"}));
  EXPECT_EQ(heard(watcher), (std::vector<std::string>{"error not_found DB_WATCH 8",
                                                      "error unsupported DB_WATCH 9"}));
}

TEST_F(DbWatch, AWatchEndsWhenTheFlowLeaves) {
  startHub();
  TestClient w = writer();
  {
    TestClient watcher = flowClient();
    ASSERT_TRUE(watcher.send(msg::DbWatch{7, "shared"}));
    EXPECT_EQ(heard(watcher).size(), 3u);
    EXPECT_EQ(watches(), 1u);
  }
  ASSERT_TRUE(eventually([&] { return watches() == 0; }));
  set(w, "c", Variant(int64_t(3)));  // nobody is told (ASan: nothing touches the gone flow)
  handled(w);
}

// The db_read rule decides: alice reads "alice", her flow's database and "shared" only.
TEST_F(DbWatch, TheReadRuleDecides) {
  auto o = defaults();
  o.users_file = dir_.path() / "users.json";
  auto users = flow::UsersFile::load(o.users_file);
  ASSERT_TRUE(users);
  ASSERT_TRUE(users->add("alice", "pw"));
  const std::string text = R"({"rules": {"db_read": ["alice", "shared"]}})";
  Json::Value rules;
  std::unique_ptr<Json::CharReader> reader(Json::CharReaderBuilder().newCharReader());
  ASSERT_TRUE(reader->parse(text.data(), text.data() + text.size(), &rules, nullptr));
  auto alice = flow::AccessRules::fromJson(rules, "users.alice");
  ASSERT_TRUE(alice) << alice.error().message;
  ASSERT_TRUE(users->setAccess("alice", *alice));
  ASSERT_TRUE(users->save());
  ASSERT_TRUE(startHub(o));
  TestClient w = writer();
  ASSERT_TRUE(w.send(msg::DbCreateAsync{++tag_, "secret"}));
  handled(w);
  TestClient a = flowClient("alice", "pw");
  ASSERT_TRUE(a.send(msg::DbWatch{7, "secret"}));
  ASSERT_TRUE(a.send(msg::DbWatch{8, "shared"}));
  EXPECT_EQ(heard(a),
            (std::vector<std::string>{"error permission_denied DB_WATCH 7", "shared: set a=1",
                                      "shared: set b=\"two\"", "shared: end"}));
  EXPECT_EQ(watches(), 1u);
}

TEST_F(DbWatch, AnOlderClientCannotWatch) {
  startHub();
  TestClient w = writer();
  TestClient old = olderClient(13);
  ASSERT_EQ(old.call(msg::Empty<Code::go_async>{})->kind(), Code::reply_ok);
  ASSERT_TRUE(old.send(msg::DbWatch{7, "shared"}));
  auto err = as<msg::EvError>(old.waitFor(Code::ev_error));
  ASSERT_TRUE(err);
  EXPECT_EQ(err->error, static_cast<uint16_t>(ErrorCode::unsupported));
  EXPECT_EQ(watches(), 0u);
}

}  // namespace
}  // namespace skr::test
