// SPDX-License-Identifier: Apache-2.0
// Blob channels through the hub: owner-only writes, reads for everyone, stores that outlive their
// owner's connection and the hub, change events, older clients, readers during a replacement,
// quotas and a resumed upload, with the satellite library's SyncClient and raw frames.
#include "flow_fixture.h"

#include <skrobot/hub/flow/accounts.h>
#include <skrobot/satellite/sync_client.h>

#include <algorithm>
#include <atomic>
#include <fstream>
#include <thread>

namespace skr::test {
namespace {

namespace fs = std::filesystem;
using flow::ChannelKind;
using flow::Code;
using flow::ErrorCode;
using flow::Variant;
namespace msg = flow::msg;
using sat::SyncClient;

class Blobs : public FlowFixture {
 protected:
  void SetUp() override {
    auto o = defaults();
    o.users_file = dir_.path() / "users.json";
    auto users = flow::UsersFile::load(o.users_file);
    ASSERT_TRUE(users);
    for (const char* u : {"alice", "bob", "root", "tight"}) ASSERT_TRUE(users->add(u, "pw"));
    flow::AccessRules root;
    root.setRole(flow::Role::admin);
    ASSERT_TRUE(users->setAccess("root", root));
    ASSERT_TRUE(users->save());
    options_ = o;
    ASSERT_TRUE(startHub(o));
  }

  SyncClient client(const std::string& user, const std::string& pw = "pw") {
    sat::ConnectOptions o;
    o.address.kind = flow::Address::Kind::local;
    o.address.path = opts_.unix_path;
    o.user = user;
    o.password = pw;
    auto c = SyncClient::connect(o);
    EXPECT_TRUE(c) << c.error().message;
    return std::move(c).value();
  }
  static Errc code(const Result<void>& r) { return r ? Errc::ok : r.error().code; }
  template <class T>
  static Errc code(const Result<T>& r) {
    return r ? Errc::ok : r.error().code;
  }

  flow::ServerOptions options_;
};

TEST_F(Blobs, OnlyTheOwnerWritesEveryoneReads) {
  SyncClient alice = client("alice");
  auto ch = alice.createBlobChannel("maps");
  ASSERT_TRUE(ch) << ch.error().message;
  EXPECT_EQ(ch->name, "alice.maps");
  EXPECT_EQ(ch->kind, uint8_t(ChannelKind::blob));
  ASSERT_TRUE(alice.blobPut(ch->id, "floor1/map.pgm", "P5 1 1 255 x"));
  // Creating it again is finding it.
  auto again = alice.createBlobChannel("maps");
  ASSERT_TRUE(again);
  EXPECT_EQ(again->id, ch->id);

  SyncClient bob = client("bob");
  EXPECT_EQ(*bob.blobGet(ch->id, "floor1/map.pgm"), "P5 1 1 255 x");
  auto list = bob.blobList(ch->id, "floor1");
  ASSERT_TRUE(list);
  ASSERT_EQ(list->size(), 1u);
  EXPECT_EQ((*list)[0].name, "map.pgm");
  EXPECT_EQ((*list)[0].size, 12u);
  const uint16_t id = ch->id;
  EXPECT_EQ(code(bob.blobPut(id, "evil", "x")), Errc::permission_denied);
  EXPECT_EQ(code(bob.blobPut(id, "floor1/map.pgm", "x")), Errc::permission_denied);
  EXPECT_EQ(code(bob.blobModify(id, "floor1/map.pgm", 0, "x")), Errc::permission_denied);
  EXPECT_EQ(code(bob.blobMkdir(id, "d")), Errc::permission_denied);
  EXPECT_EQ(code(bob.blobRmdir(id, "floor1")), Errc::permission_denied);
  EXPECT_EQ(code(bob.blobRemove(id, "floor1/map.pgm")), Errc::permission_denied);
  TestClient raw = syncClient("bob", "pw");
  auto abort = as<msg::ReplyError>(raw.call(msg::BlobAbort{id, 1}));
  ASSERT_TRUE(abort);
  EXPECT_EQ(abort->error, uint16_t(ErrorCode::permission_denied));
  TestClient bob_flow = flowClient("bob", "pw");
  ASSERT_TRUE(bob_flow.send(msg::ChanRemove{5, id}));
  auto e = as<msg::EvError>(bob_flow.waitFor(Code::ev_error));
  ASSERT_TRUE(e);
  EXPECT_EQ(e->error, uint16_t(ErrorCode::permission_denied));
  // Nothing changed, and bob's connection is still up.
  EXPECT_EQ(*bob.blobGet(id, "floor1/map.pgm"), "P5 1 1 255 x");
  EXPECT_EQ(stats().protocol_errors, 0u);
  // Paths that leave the tree are refused on the wire too.
  EXPECT_EQ(code(bob.blobGet(id, "../../users.json")), Errc::invalid_argument);
  EXPECT_EQ(code(alice.blobPut(id, "/etc/evil", "x")), Errc::invalid_argument);
  EXPECT_EQ(code(alice.blobPut(id, "a/../../evil", "x")), Errc::invalid_argument);
  EXPECT_FALSE(fs::exists(dir_.path() / "data" / "evil"));
}

TEST_F(Blobs, AStoreOutlivesItsOwnersConnectionAndTheHub) {
  uint16_t id = 0;
  {
    TestClient owner = flowClient("alice", "pw");
    id = addChannel(owner, "calib", ChannelKind::blob);
    ASSERT_NE(id, 0u);
    SyncClient alice = client("alice");
    ASSERT_TRUE(alice.blobPut(id, "camera.yaml", "fx: 500"));
  }  // the calibration tool exits
  SyncClient bob = client("bob");
  auto info = bob.channel("alice.calib");
  ASSERT_TRUE(info);
  EXPECT_EQ(info->owner, "alice");
  EXPECT_EQ(*bob.blobGet(id, "camera.yaml"), "fx: 500");

  stopHub();
  ASSERT_TRUE(startHub(options_));
  SyncClient later = client("bob");
  info = later.channel("alice.calib");
  ASSERT_TRUE(info) << info.error().message;
  EXPECT_EQ(info->owner_connection, 0u);
  EXPECT_EQ(*later.blobGet(info->id, "camera.yaml"), "fx: 500");
  // The owner comes back: the same channel, owned by its new flow.
  TestClient owner = flowClient("alice", "pw");
  const uint16_t back = addChannel(owner, "calib", ChannelKind::blob);
  EXPECT_EQ(back, info->id);
  EXPECT_NE(later.channel("alice.calib")->owner_connection, 0u);
  // An administrator removes it, files and all.
  SyncClient root = client("root");
  ASSERT_TRUE(root.admin("chan_rm", Variant(Variant::Map{{"name", Variant("alice.calib")}})));
  EXPECT_EQ(code(later.channel("alice.calib")), Errc::not_found);
  SyncClient alice = client("alice");
  ASSERT_TRUE(alice.createBlobChannel("other"));  // a barrier behind the drop on the store
  EXPECT_FALSE(fs::exists(dir_.path() / "data" / "blobs" / "alice.calib"));
}

TEST_F(Blobs, SubscribersHearOfChanges) {
  SyncClient alice = client("alice");
  auto ch = alice.createBlobChannel("maps");
  ASSERT_TRUE(ch);
  TestClient bob = flowClient("bob", "pw");
  ASSERT_TRUE(bob.send(msg::Subscribe{1, ch->id}));
  ASSERT_TRUE(alice.blobMkdir(ch->id, "floor2"));
  auto v = alice.blobPut(ch->id, "floor2/map.pgm", "0123456789");
  ASSERT_TRUE(v);
  ASSERT_TRUE(alice.blobRemove(ch->id, "floor2/map.pgm"));
  std::vector<msg::EvBlobChanged> seen;
  for (int i = 0; i < 3; ++i) {
    auto ev = as<msg::EvBlobChanged>(bob.waitFor(Code::ev_blob_changed));
    ASSERT_TRUE(ev) << "event " << i;
    seen.push_back(*ev);
  }
  EXPECT_EQ(seen[0].change, uint8_t(msg::BlobChange::dir_added));
  EXPECT_EQ(seen[0].path, "floor2");
  EXPECT_EQ(seen[1].change, uint8_t(msg::BlobChange::written));
  EXPECT_EQ(seen[1].path, "floor2/map.pgm");
  EXPECT_EQ(seen[1].size, 10u);
  EXPECT_EQ(seen[1].version, *v);
  EXPECT_EQ(seen[1].chan_id, ch->id);
  EXPECT_EQ(seen[2].change, uint8_t(msg::BlobChange::removed));
}

TEST_F(Blobs, OlderClientsNeitherSeeNorMakeBlobChannels) {
  SyncClient alice = client("alice");
  auto ch = alice.createBlobChannel("maps");
  ASSERT_TRUE(ch);
  TestClient old = olderClient(2, "bob", "pw");
  auto list = as<msg::ChannelList>(old.call(msg::Empty<Code::chan_list>{}));
  ASSERT_TRUE(list);
  EXPECT_TRUE(list->channels.empty());
  auto info = as<msg::ReplyError>(old.call(msg::ChanInfoByName{"alice.maps"}));
  ASSERT_TRUE(info);
  EXPECT_EQ(info->error, uint16_t(ErrorCode::not_found));
  auto get = as<msg::ReplyError>(old.call(msg::BlobList{ch->id, ""}));
  ASSERT_TRUE(get);
  EXPECT_EQ(get->error, uint16_t(ErrorCode::unsupported));
  ASSERT_TRUE(old.call(msg::Empty<Code::go_async>{}));
  msg::ChanAdd add;
  add.tag = 9;
  add.kind = uint8_t(ChannelKind::blob);
  add.short_name = "mine";
  ASSERT_TRUE(old.send(add));
  auto e = as<msg::EvError>(old.waitFor(Code::ev_error));
  ASSERT_TRUE(e);
  EXPECT_EQ(e->error, uint16_t(ErrorCode::invalid_argument));
  // A blob channel made meanwhile is not announced to it; a streaming one is.
  ASSERT_TRUE(alice.createBlobChannel("more"));
  TestClient fresh = flowClient("alice", "pw");
  addChannel(fresh, "stream");
  auto added = as<msg::EvChanAdded>(old.waitFor(Code::ev_chan_added));
  ASSERT_TRUE(added);
  EXPECT_EQ(added->info.name, "alice.stream");
  // A blob request on a flow is refused, not a protocol break.
  ASSERT_TRUE(fresh.send(msg::BlobList{ch->id, ""}));
  auto on_flow = as<msg::EvError>(fresh.waitFor(Code::ev_error));
  ASSERT_TRUE(on_flow);
  EXPECT_EQ(on_flow->error, uint16_t(ErrorCode::unsupported));
  // A satellite that sends the hub's event breaks the protocol.
  TestClient rude = syncClient("bob", "pw");
  ASSERT_TRUE(rude.send(msg::EvBlobChanged{ch->id, 1, "x", 0, 0}));
  rude.recvReply(2000);
  EXPECT_TRUE(rude.closedByPeer());
  EXPECT_EQ(stats().protocol_errors, 1u);
}

TEST_F(Blobs, ReadersGetOneWholeVersionWhileTheOwnerReplacesIt) {
  SyncClient alice = client("alice");
  auto ch = alice.createBlobChannel("models");
  ASSERT_TRUE(ch);
  const size_t size = 6 * SyncClient::kBlobChunk + 1234;
  std::vector<std::string> versions;
  for (char c : {'a', 'b', 'c', 'd'}) versions.emplace_back(size, c);
  ASSERT_TRUE(alice.blobPut(ch->id, "net.bin", versions[0]));
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (int i = 1; !done; i = i % 3 + 1)
      ASSERT_TRUE(alice.blobPut(ch->id, "net.bin", versions[i]));
  });
  std::vector<std::thread> readers;
  std::atomic<int> whole{0}, mixed{0};
  for (int r = 0; r < 10; ++r) {
    readers.emplace_back([&] {
      SyncClient me = client("bob");
      for (int k = 0; k < 3; ++k) {
        auto got = me.blobGet(ch->id, "net.bin");
        ASSERT_TRUE(got) << got.error().message;
        if (std::find(versions.begin(), versions.end(), *got) != versions.end()) {
          ++whole;
        } else {
          ++mixed;
        }
      }
    });
  }
  for (auto& t : readers) t.join();
  done = true;
  writer.join();
  EXPECT_EQ(whole, 30);
  EXPECT_EQ(mixed, 0);
}

TEST_F(Blobs, ADisconnectMidDownloadOrMidUploadLeavesTheHubWell) {
  SyncClient alice = client("alice");
  auto ch = alice.createBlobChannel("runs");
  ASSERT_TRUE(ch);
  const std::string data(3 * SyncClient::kBlobChunk, 'r');
  ASSERT_TRUE(alice.blobPut(ch->id, "run.bin", data));
  {
    TestClient reader = syncClient("bob", "pw");
    ASSERT_TRUE(reader.send(msg::BlobGet{ch->id, "run.bin", 0, 0, 1 << 20}));
    ASSERT_TRUE(reader.send(msg::BlobGet{ch->id, "run.bin", 0, 1 << 20, 1 << 20}));
  }  // gone before its answers
  // An upload cut off after its first chunk resumes where the hub got to.
  // More chunks than the client sends ahead of their answers: a cut leaves the upload unfinished.
  const std::string next(10 * SyncClient::kBlobChunk + 77, 'n');
  uint64_t upload = 0;
  {
    SyncClient cut = client("alice");
    int acks = 0;
    auto r = cut.blobPut(ch->id, "run.bin", next, [&](uint64_t, uint64_t) {
      if (++acks == 1) cut.close();
    });
    EXPECT_FALSE(r);
  }
  EXPECT_EQ(*alice.blobGet(ch->id, "run.bin"), data);  // the old version, whole
  const fs::path local = dir_.path() / "next.bin";
  std::ofstream(local, std::ios::binary) << next;
  // blobPut has no id to resume with; the file variant keeps it: interrupt and resume that one.
  {
    SyncClient cut = client("alice");
    int acks = 0;
    auto r = cut.blobPutFile(
        ch->id, local.string(), "run.bin",
        [&](uint64_t, uint64_t) {
          if (++acks == 2) cut.close();
        },
        &upload);
    EXPECT_FALSE(r);
    EXPECT_NE(upload, 0u);
  }
  uint64_t resumed_from = 0;
  auto v = alice.blobPutFile(
      ch->id, local.string(), "run.bin",
      [&](uint64_t done, uint64_t) {
        if (resumed_from == 0) resumed_from = done;
      },
      &upload);
  ASSERT_TRUE(v) << v.error().message;
  EXPECT_GE(resumed_from,
            2 * SyncClient::kBlobChunk);  // the acknowledged chunks were not sent again
  EXPECT_EQ(*alice.blobGet(ch->id, "run.bin"), next);
  EXPECT_EQ(stats().protocol_errors, 0u);
}

TEST_F(Blobs, ALargePipelinedUploadArrivesByteForByte) {
  // Chunks sent ahead of their answers share the hub's read buffer, which a large chunk takes
  // with it to the store's thread: every byte must land where it belongs.
  SyncClient alice = client("alice");
  auto ch = alice.createBlobChannel("big");
  ASSERT_TRUE(ch);
  std::string data(5 * SyncClient::kBlobChunk + 4099, '\0');
  for (size_t i = 0; i < data.size(); ++i) data[i] = static_cast<char>((i * 7 + i / 4096) % 251);
  ASSERT_TRUE(alice.blobPut(ch->id, "net.bin", data));
  const auto back = alice.blobGet(ch->id, "net.bin");
  ASSERT_TRUE(back);
  EXPECT_TRUE(*back == data);
  // BLOB_MODIFY of a large part in place, the same way.
  const std::string middle(SyncClient::kBlobChunk, 'm');
  ASSERT_TRUE(alice.blobModify(ch->id, "net.bin", 1000, middle));
  data.replace(1000, middle.size(), middle);
  EXPECT_TRUE(*alice.blobGet(ch->id, "net.bin") == data);
}

TEST_F(Blobs, PipelinedRequestsAreAnsweredInOrder) {
  SyncClient alice = client("alice");
  auto ch = alice.createBlobChannel("maps");
  ASSERT_TRUE(ch);
  ASSERT_TRUE(alice.blobPut(ch->id, "a.txt", std::string(100000, 'a')));
  // Everything sent at once: blob requests, a refusal made at once, and a request of another
  // kind; the answers come back in the order of the requests.
  TestClient c = syncClient("bob", "pw");
  std::string frames;
  const auto add = [&](const auto& m) { ASSERT_TRUE(flow::encode(frames, m)); };
  add(msg::BlobGet{ch->id, "a.txt", 0, 0, 1000});
  add(msg::BlobList{ch->id, ""});
  add(msg::BlobList{9999, ""});  // no such channel: refused before the store is asked
  add(msg::Ping{msg::Rest{"between"}});
  add(msg::BlobGet{ch->id, "a.txt", 0, 0, 50000});
  add(msg::BlobMkdir{ch->id, "not-bobs"});  // bob is not the owner
  add(msg::Ping{msg::Rest{"last"}});
  ASSERT_TRUE(c.sendRaw(frames));
  auto first = as<msg::BlobData>(c.recvReply());
  ASSERT_TRUE(first);
  EXPECT_EQ(first->data.bytes.size(), 1000u);
  auto list = as<msg::ReplyValue>(c.recvReply());
  ASSERT_TRUE(list);
  EXPECT_EQ(list->value.asList()->size(), 1u);
  auto none = as<msg::ReplyError>(c.recvReply());
  ASSERT_TRUE(none);
  EXPECT_EQ(none->error, uint16_t(ErrorCode::not_found));
  auto ping = c.recvReply();
  ASSERT_TRUE(ping);
  EXPECT_EQ(ping->body, "between");
  auto second = as<msg::BlobData>(c.recvReply());
  ASSERT_TRUE(second);
  EXPECT_EQ(second->data.bytes.size(), 50000u);
  auto denied = as<msg::ReplyError>(c.recvReply());
  ASSERT_TRUE(denied);
  EXPECT_EQ(denied->error, uint16_t(ErrorCode::permission_denied));
  auto last = c.recvReply();
  ASSERT_TRUE(last);
  EXPECT_EQ(last->body, "last");
}

TEST_F(Blobs, QuotasAreErrorsAndKeepWhatIsStored) {
  stopHub();
  auto o = options_;
  o.blob_channel_files = 2;
  auto users = flow::UsersFile::load(o.users_file);
  ASSERT_TRUE(users);
  auto limited = flow::AccessRules::fromJson(
      [] {
        Json::Value v(Json::objectValue);
        v["limits"]["blob_mib"] = 1;
        v["limits"]["channels"] = 2;
        return v;
      }(),
      "users.tight");
  ASSERT_TRUE(limited) << limited.error().message;
  ASSERT_TRUE(users->setAccess("tight", *limited));
  ASSERT_TRUE(users->save());
  ASSERT_TRUE(startHub(o));
  SyncClient tight = client("tight");
  auto ch = tight.createBlobChannel("data");
  ASSERT_TRUE(ch);
  ASSERT_TRUE(tight.blobPut(ch->id, "a", std::string(600000, 'a')));
  auto over = tight.blobPut(ch->id, "b", std::string(600000, 'b'));
  ASSERT_FALSE(over);
  EXPECT_EQ(over.error().code, Errc::limit_exceeded);
  EXPECT_NE(over.error().message.find("tight"), std::string::npos);
  ASSERT_TRUE(tight.blobPut(ch->id, "b", "small"));
  auto files = tight.blobPut(ch->id, "c", "x");
  ASSERT_FALSE(files);
  EXPECT_EQ(files.error().code, Errc::limit_exceeded);
  EXPECT_EQ(tight.blobGet(ch->id, "a")->size(), 600000u);
  // Blob channels count against the user's channels, connected or not.
  ASSERT_TRUE(tight.createBlobChannel("second"));
  auto third = tight.createBlobChannel("third");
  ASSERT_FALSE(third);
  EXPECT_EQ(third.error().code, Errc::limit_exceeded);
}

}  // namespace
}  // namespace skr::test
