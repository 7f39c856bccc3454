// SPDX-License-Identifier: Apache-2.0
// Synchronous connections served on an I/O thread once they transfer files (io_relay.h): the
// move keeps every request's answer in order (requests already read when it happens included),
// a kicked connection loses its transfer at once, a frame above the limit read over there closes
// that connection only, and blobs.io_threads 0 keeps them on the main loop.
#include "flow_fixture.h"

#include <skrobot/hub/flow/accounts.h>
#include <skrobot/satellite/sync_client.h>

#include <atomic>
#include <chrono>
#include <thread>

namespace skr::test {
namespace {

using flow::Code;
using flow::Variant;
namespace msg = flow::msg;
using sat::SyncClient;

class BlobIoThread : public FlowFixture {
 protected:
  void start(uint32_t io_threads) {
    auto o = defaults();
    o.blob_io_threads = io_threads;
    o.users_file = dir_.path() / "users.json";
    auto users = flow::UsersFile::load(o.users_file);
    ASSERT_TRUE(users);
    for (const char* u : {"alice", "bob", "root"}) ASSERT_TRUE(users->add(u, "pw"));
    flow::AccessRules root;
    root.setRole(flow::Role::admin);
    ASSERT_TRUE(users->setAccess("root", root));
    ASSERT_TRUE(users->save());
    ASSERT_TRUE(startHub(o));
  }

  SyncClient client(const std::string& user) {
    sat::ConnectOptions o;
    o.address.kind = flow::Address::Kind::local;
    o.address.path = opts_.unix_path;
    o.user = user;
    o.password = "pw";
    auto c = SyncClient::connect(o);
    EXPECT_TRUE(c) << c.error().message;
    return std::move(c).value();
  }

  // The id of `user`'s synchronous connection, from the administrators' "flows".
  int64_t syncConnectionOf(SyncClient& root, const std::string& user) {
    auto flows = root.admin("flows", Variant());
    if (!flows || !flows->isList()) return 0;
    for (const auto& f : *flows->asList()) {
      const Variant::Map* m = f.asMap();
      if (m == nullptr) continue;
      const auto u = m->find("user"), flow = m->find("flow"), id = m->find("id");
      if (u != m->end() && u->second == Variant(user) && flow != m->end() &&
          flow->second == Variant(false) && id != m->end()) {
        return *id->second.asInt64();
      }
    }
    return 0;
  }
};

TEST_F(BlobIoThread, AConnectionMovesAtItsFirstBlobRequestAndKeepsItsAnswersInOrder) {
  start(1);
  SyncClient alice = client("alice");
  ASSERT_TRUE(alice.ping());
  EXPECT_EQ(stats().connections_moved, 0u);  // no file transferred yet
  auto ch = alice.createBlobChannel("maps");
  ASSERT_TRUE(ch) << ch.error().message;
  EXPECT_EQ(stats().connections_moved, 1u);
  const std::string data(5 * SyncClient::kBlobChunk + 123, 'm');
  ASSERT_TRUE(alice.blobPut(ch->id, "floor/map.pgm", data));
  ASSERT_TRUE(alice.ping());
  EXPECT_EQ(*alice.blobGet(ch->id, "floor/map.pgm"), data);

  // Requests read with the one that moves the connection go with it, and keep their order.
  TestClient bob = syncClient("bob", "pw");
  std::string burst;
  ASSERT_TRUE(flow::encode(burst, msg::BlobList{ch->id, "floor"}));
  ASSERT_TRUE(flow::encode(burst, msg::Ping{msg::Rest{"one"}}));
  ASSERT_TRUE(flow::encode(burst, msg::BlobList{ch->id, ""}));
  ASSERT_TRUE(flow::encode(burst, msg::Ping{msg::Rest{"two"}}));
  // ... and the start of a fifth, whose rest comes later: the I/O thread must get it whole.
  std::string fifth;
  ASSERT_TRUE(flow::encode(fifth, msg::Ping{msg::Rest{"three"}}));
  burst += fifth.substr(0, 3);
  ASSERT_TRUE(bob.sendRaw(burst));  // one write: the hub reads them together
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  ASSERT_TRUE(bob.sendRaw(std::string_view(fifth).substr(3)));
  for (const char* pong : {"one", "two"}) {
    auto listed = as<msg::ReplyValue>(bob.recv());
    ASSERT_TRUE(listed);
    EXPECT_TRUE(listed->value.isList());
    auto f = bob.recv();
    ASSERT_TRUE(f);
    EXPECT_EQ(f->body, pong);
  }
  auto third = bob.recv();
  ASSERT_TRUE(third);
  EXPECT_EQ(third->body, "three");
  ASSERT_TRUE(bob.send(msg::Ping{msg::Rest{"four"}}));  // and the connection reads on
  auto fourth = bob.recv();
  ASSERT_TRUE(fourth);
  EXPECT_EQ(fourth->body, "four");
  EXPECT_EQ(stats().connections_moved, 2u);
  EXPECT_EQ(stats().protocol_errors, 0u);
}

TEST_F(BlobIoThread, AKickedConnectionLosesItsTransferAtOnce) {
  start(1);
  SyncClient alice = client("alice");
  SyncClient root = client("root");
  auto ch = alice.createBlobChannel("runs");
  ASSERT_TRUE(ch);
  const std::string old(64, 'o');
  ASSERT_TRUE(alice.blobPut(ch->id, "run.bin", old));
  const int64_t alice_id = syncConnectionOf(root, "alice");
  ASSERT_NE(alice_id, 0);

  // Mid-upload: the rest is not taken, the file keeps its old version.
  const std::string next(32 * SyncClient::kBlobChunk, 'n');
  int acks = 0;
  auto up = alice.blobPut(ch->id, "run.bin", next, [&](uint64_t, uint64_t) {
    if (++acks == 2) {
      EXPECT_TRUE(root.admin("kick", Variant(Variant::Map{{"connection", alice_id}})));
    }
  });
  ASSERT_FALSE(up);
  // The hub closed the connection: the client did not wait for an answer until its timeout.
  EXPECT_NE(up.error().code, Errc::timeout) << up.error().message;
  EXPECT_LT(acks, 2 + SyncClient::kBlobWindow + 1) << "chunks were still taken after the kick";

  // Mid-download likewise.
  SyncClient bob = client("bob");
  SyncClient reader = client("bob");
  ASSERT_TRUE(reader.ping());
  int64_t reader_id = 0;
  {
    auto flows = root.admin("flows", Variant());
    ASSERT_TRUE(flows && flows->isList());
    for (const auto& f : *flows->asList()) {
      const Variant::Map* m = f.asMap();
      if (m != nullptr && m->at("user") == Variant("bob") && m->at("flow") == Variant(false)) {
        reader_id = std::max(reader_id, *m->at("id").asInt64());  // the later one
      }
    }
  }
  ASSERT_NE(reader_id, 0);
  SyncClient writer = client("alice");
  ASSERT_TRUE(writer.blobPut(ch->id, "big.bin", next));
  uint64_t pieces = 0;
  auto down = reader.blobGetStream(ch->id, "big.bin", [&](std::string_view) -> Result<void> {
    if (++pieces == 2) {
      EXPECT_TRUE(root.admin("kick", Variant(Variant::Map{{"connection", reader_id}})));
    }
    return {};
  });
  ASSERT_FALSE(down);
  EXPECT_NE(down.error().code, Errc::timeout) << down.error().message;
  EXPECT_LT(pieces, 2u + SyncClient::kBlobWindow + 1);

  // Nobody else noticed.
  EXPECT_EQ(*bob.blobGet(ch->id, "run.bin"), old);
  EXPECT_EQ(*bob.blobGet(ch->id, "big.bin"), next);
  EXPECT_EQ(stats().protocol_errors, 0u);
}

TEST_F(BlobIoThread, AFrameAboveTheLimitReadThereClosesThatConnectionOnly) {
  start(1);
  SyncClient alice = client("alice");
  auto ch = alice.createBlobChannel("maps");
  ASSERT_TRUE(ch);
  TestClient bob = syncClient("bob", "pw");
  ASSERT_TRUE(bob.send(msg::BlobList{ch->id, ""}));
  auto listed = as<msg::ReplyValue>(bob.recv());
  ASSERT_TRUE(listed);
  const uint32_t huge = 0xFFFFFFF0u;
  ASSERT_TRUE(bob.sendRaw(std::string_view(reinterpret_cast<const char*>(&huge), 4)));
  EXPECT_TRUE(bob.closedByPeer());
  EXPECT_EQ(stats().protocol_errors, 1u);
  EXPECT_EQ(stats().connections_moved, 2u);
  ASSERT_TRUE(alice.blobPut(ch->id, "a.txt", "still here"));
  EXPECT_EQ(*alice.blobGet(ch->id, "a.txt"), "still here");
}

TEST_F(BlobIoThread, NoIoThreadsKeepsThemOnTheMainLoop) {
  start(0);
  SyncClient alice = client("alice");
  auto ch = alice.createBlobChannel("maps");
  ASSERT_TRUE(ch);
  const std::string data(3 * SyncClient::kBlobChunk, 'x');
  ASSERT_TRUE(alice.blobPut(ch->id, "x.bin", data));
  EXPECT_EQ(*alice.blobGet(ch->id, "x.bin"), data);
  EXPECT_EQ(stats().connections_moved, 0u);
}

}  // namespace
}  // namespace skr::test
