// SPDX-License-Identifier: Apache-2.0
// The blob store on its own: path rules, confinement under both resolvers (a symlink planted in
// the tree, a directory swapped for a symlink during the walk), the order of a commit's system
// calls, resumed uploads across a restart, versions, quotas.
#include "families/blobs/blob_store.h"
#include "families/blobs/blob_path.h"
#include "temp_dir.h"

#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <future>
#include <mutex>

namespace skr::test {
namespace {

namespace fs = std::filesystem;
using flow::BlobQuota;
using flow::BlobStore;
using flow::blob::Resolver;

// Runs a store call and waits for its answer (answers run on the store's thread here).
template <class T, class F>
Result<T> wait(F&& start) {
  std::promise<Result<T>> p;
  auto f = p.get_future();
  start([&p](Result<T> r) { p.set_value(std::move(r)); });
  return f.get();
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

void spit(const fs::path& p, const std::string& s) {
  std::ofstream(p, std::ios::binary) << s;
}

TEST(BlobPath, RulesOfPaths) {
  using flow::blob::splitPath;
  auto ok = splitPath("maps/floor 1/map.pgm", false);
  ASSERT_TRUE(ok) << ok.error().message;
  EXPECT_EQ(*ok, (std::vector<std::string>{"maps", "floor 1", "map.pgm"}));
  EXPECT_TRUE(splitPath("", true));
  EXPECT_TRUE(splitPath("%2e%2e/..x/.hidden", false));  // names, not separators or parents
  for (const std::string& bad :
       {std::string(""), std::string("/etc/passwd"), std::string("a//b"), std::string("a/"),
        std::string(".."), std::string("a/../../b"), std::string("."), std::string("a/./b"),
        std::string("a\\..\\b"), std::string("a\0b", 3), std::string(256, 'x'),
        std::string(1025, 'y')}) {
    auto r = splitPath(bad, false);
    EXPECT_FALSE(r) << "accepted: " << bad;
    if (!r) {
      EXPECT_EQ(r.error().code, Errc::invalid_argument);
    }
  }
  std::string deep;
  for (int i = 0; i < 33; ++i) deep += "d/";
  deep += "f";
  EXPECT_FALSE(splitPath(deep, false));
}

class Store : public ::testing::TestWithParam<Resolver> {
 protected:
  void SetUp() override {
    if (GetParam() == Resolver::openat2) {
      flow::blob::forceResolver(Resolver::openat2);
      if (flow::blob::resolver() != Resolver::openat2) GTEST_SKIP() << "no openat2 here";
    } else {
      flow::blob::forceResolver(Resolver::walk);
    }
    outside_ = dir_.path() / "outside";
    fs::create_directories(outside_);
    spit(outside_ / "secret", "outside the tree");
    open();
  }
  void TearDown() override {
    store_.reset();
    flow::blob::setWalkHook(nullptr);
    flow::blob::forceResolver(Resolver::openat2);  // back to the probe's choice
  }
  void open(BlobQuota per_channel = {}) {
    store_.reset();
    store_ = std::make_unique<BlobStore>(
        dir_.path() / "blobs", per_channel, [](std::function<void()> fn) { fn(); }, io_);
    auto stored = store_->open();
    ASSERT_TRUE(stored) << stored.error().message;
    stored_ = *stored;
  }
  fs::path files() { return dir_.path() / "blobs" / "guest.maps" / "files"; }
  Result<void> create(const std::string& name = "guest.maps", const std::string& owner = "guest") {
    return wait<void>([&](auto done) { store_->create(name, owner, done); });
  }
  Result<uint64_t> put(const std::string& path, const std::string& data, BlobQuota user = {},
                       const std::string& channel = "guest.maps") {
    auto at = wait<BlobStore::PutAt>(
        [&](auto done) { store_->put(1, channel, user, path, data.size(), 0, done); });
    if (!at) return at.error();
    auto w = wait<BlobStore::Written>(
        [&](auto done) { store_->chunk(1, channel, at->upload_id, 0, data, done); });
    if (!w) return w.error();
    return w->version;
  }
  Result<BlobStore::Read> get(const std::string& path, uint64_t version = 0, uint64_t offset = 0,
                              uint32_t max = 1 << 20, uint32_t reader = 1, size_t head = 0) {
    return wait<BlobStore::Read>([&](auto done) {
      store_->get(reader, "guest.maps", path, version, offset, max, head, done);
    });
  }

  TempDir dir_;
  fs::path outside_;
  std::shared_ptr<flow::BlobIo> io_ = std::make_shared<flow::BlobIo>();
  std::unique_ptr<BlobStore> store_;
  std::vector<BlobStore::Stored> stored_;
};

TEST_P(Store, WritesReadsListsAndPersists) {
  ASSERT_TRUE(create());
  auto v = put("floor1/map.pgm", "P5 map");
  ASSERT_TRUE(v) << v.error().message;
  EXPECT_EQ(slurp(files() / "floor1" / "map.pgm"), "P5 map");
  auto r = get("floor1/map.pgm");
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(r->data, "P5 map");
  EXPECT_EQ(r->version, *v);
  // Room asked for in front of the bytes (a frame header's) is left there.
  r = get("floor1/map.pgm", 0, 3, 100, 2, /*head=*/21);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->head, 21u);
  EXPECT_EQ(r->data.substr(r->head), "map");
  auto list = wait<flow::Variant>([&](auto done) { store_->list("guest.maps", "floor1", done); });
  ASSERT_TRUE(list);
  ASSERT_EQ(list->asList()->size(), 1u);
  open();  // a restart
  ASSERT_EQ(stored_.size(), 1u);
  EXPECT_EQ(stored_[0].name, "guest.maps");
  EXPECT_EQ(stored_[0].owner, "guest");
  r = get("floor1/map.pgm");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->data, "P5 map");
}

TEST_P(Store, NothingOutsideTheTreeIsReadOrWritten) {
  ASSERT_TRUE(create());
  fs::create_directories(files() / "d");
  // Planted by someone with a shell: a directory symlink and a file symlink pointing outside.
  fs::create_directory_symlink(outside_, files() / "d" / "link");
  fs::create_symlink(outside_ / "secret", files() / "f");
  const auto refused = [](const auto& r) {
    return !r &&
           (r.error().code == Errc::permission_denied || r.error().code == Errc::invalid_argument);
  };
  EXPECT_TRUE(refused(get("d/link/secret")));
  EXPECT_TRUE(refused(get("f")));
  EXPECT_TRUE(
      refused(wait<flow::Variant>([&](auto done) { store_->list("guest.maps", "d/link", done); })));
  EXPECT_TRUE(refused(put("d/link/planted", "x")));
  EXPECT_TRUE(refused(wait<flow::BlobEvent>(
      [&](auto done) { store_->mkdir("guest.maps", "d/link/newdir", done); })));
  EXPECT_TRUE(refused(wait<flow::BlobEvent>(
      [&](auto done) { store_->remove("guest.maps", "d/link/secret", done); })));
  EXPECT_TRUE(refused(wait<BlobStore::Written>(
      [&](auto done) { store_->modify("guest.maps", {}, "f", 0, "overwritten", done); })));
  // Listing does not show the symlinks; removing one removes the link, not its target.
  auto list = wait<flow::Variant>([&](auto done) { store_->list("guest.maps", "d", done); });
  ASSERT_TRUE(list);
  EXPECT_TRUE(list->asList()->empty());
  EXPECT_TRUE(wait<flow::BlobEvent>([&](auto done) { store_->remove("guest.maps", "f", done); }));
  EXPECT_EQ(slurp(outside_ / "secret"), "outside the tree");
  EXPECT_FALSE(fs::exists(outside_ / "planted"));
  EXPECT_FALSE(fs::exists(outside_ / "newdir"));
  // Paths that are not paths.
  EXPECT_TRUE(refused(get("../../outside/secret")));
  EXPECT_TRUE(refused(get("/etc/passwd")));
}

TEST_P(Store, AnUploadReplacesTheFileAtItsLastByteOnly) {
  ASSERT_TRUE(create());
  ASSERT_TRUE(put("cal.yaml", "old version"));
  auto at = wait<BlobStore::PutAt>(
      [&](auto done) { store_->put(1, "guest.maps", {}, "cal.yaml", 11, 0, done); });
  ASSERT_TRUE(at);
  ASSERT_TRUE(wait<BlobStore::Written>(
      [&](auto done) { store_->chunk(1, "guest.maps", at->upload_id, 0, "new v", done); }));
  EXPECT_EQ(get("cal.yaml")->data, "old version");  // half an upload is seen by nobody
  // Out of order: refused, nothing lost.
  auto wrong = wait<BlobStore::Written>(
      [&](auto done) { store_->chunk(1, "guest.maps", at->upload_id, 2, "xx", done); });
  EXPECT_FALSE(wrong);
  open();  // the hub restarts: the upload resumes from what it had
  auto again = wait<BlobStore::PutAt>(
      [&](auto done) { store_->put(2, "guest.maps", {}, "cal.yaml", 11, at->upload_id, done); });
  ASSERT_TRUE(again) << again.error().message;
  EXPECT_EQ(again->offset, 5u);
  // Resumed by connection 2: a chunk that connection 1 sent before it was cut is refused, and the
  // offset stays the one the resume was given.
  auto stale = wait<BlobStore::Written>(
      [&](auto done) { store_->chunk(1, "guest.maps", at->upload_id, 5, "ERSION", done); });
  ASSERT_FALSE(stale);
  EXPECT_EQ(stale.error().code, Errc::invalid_argument);
  auto w = wait<BlobStore::Written>(
      [&](auto done) { store_->chunk(2, "guest.maps", at->upload_id, 5, "ersion", done); });
  ASSERT_TRUE(w) << w.error().message;
  EXPECT_NE(w->version, 0u);
  ASSERT_TRUE(w->event);
  EXPECT_EQ(w->event->size, 11u);
  EXPECT_EQ(get("cal.yaml")->data, "new version");
  // No temporary file is left.
  EXPECT_TRUE(fs::is_empty(files().parent_path() / "uploads"));
}

TEST_P(Store, AReaderKeepsTheVersionItStartedWith) {
  ASSERT_TRUE(create());
  const std::string v1(3000, 'a'), v2(3000, 'b');
  ASSERT_TRUE(put("model.bin", v1));
  auto first = get("model.bin", 0, 0, 1000, /*reader=*/7);
  ASSERT_TRUE(first);
  ASSERT_TRUE(put("model.bin", v2));  // replaced during the download
  auto rest = get("model.bin", first->version, 1000, 2000, 7);
  ASSERT_TRUE(rest) << rest.error().message;
  EXPECT_EQ(first->data + rest->data, v1);
  // Another reader asking for the old version learns that it is gone.
  auto gone = get("model.bin", first->version, 1000, 2000, 8);
  ASSERT_FALSE(gone);
  EXPECT_EQ(gone.error().code, Errc::not_found);
  EXPECT_EQ(get("model.bin", 0, 0, 4000, 8)->data, v2);
}

TEST_P(Store, ModifyWritesANewWholeVersion) {
  ASSERT_TRUE(create());
  auto v1 = put("log.txt", "hello world");
  ASSERT_TRUE(v1);
  auto w = wait<BlobStore::Written>(
      [&](auto done) { store_->modify("guest.maps", {}, "log.txt", 6, "robot!", done); });
  ASSERT_TRUE(w) << w.error().message;
  EXPECT_NE(w->version, *v1);
  EXPECT_EQ(get("log.txt")->data, "hello robot!");
  EXPECT_FALSE(wait<BlobStore::Written>(
      [&](auto done) { store_->modify("guest.maps", {}, "log.txt", 99, "x", done); }));
}

TEST_P(Store, QuotasRefuseAndKeepWhatIsStored) {
  open(BlobQuota{100, 3});
  ASSERT_TRUE(create());
  ASSERT_TRUE(put("a", std::string(60, 'a')));
  auto over = put("b", std::string(50, 'b'));
  ASSERT_FALSE(over);
  EXPECT_EQ(over.error().code, Errc::limit_exceeded);
  EXPECT_EQ(get("a")->data, std::string(60, 'a'));
  ASSERT_TRUE(put("a", std::string(90, 'c')));  // a replacement counts the old size out
  ASSERT_TRUE(put("b", ""));
  ASSERT_TRUE(put("c", ""));
  auto files_over = put("d", "");
  ASSERT_FALSE(files_over);
  EXPECT_EQ(files_over.error().code, Errc::limit_exceeded);
  // A user's quota covers all its channels.
  open();
  ASSERT_TRUE(create("guest.other"));
  auto user_over = put("x", std::string(20, 'x'), BlobQuota{100, 0}, "guest.other");
  ASSERT_FALSE(user_over);
  EXPECT_EQ(user_over.error().code, Errc::limit_exceeded);
}

TEST_P(Store, DropRemovesTheTreeAndOnlyIt) {
  ASSERT_TRUE(create());
  ASSERT_TRUE(put("x/y", "z"));
  fs::create_directory_symlink(outside_, files() / "link");
  ASSERT_TRUE(wait<void>([&](auto done) { store_->drop("guest.maps", done); }));
  EXPECT_FALSE(fs::exists(files()));
  EXPECT_EQ(slurp(outside_ / "secret"), "outside the tree");
  open();
  EXPECT_TRUE(stored_.empty());
}

INSTANTIATE_TEST_SUITE_P(Resolvers, Store, ::testing::Values(Resolver::openat2, Resolver::walk),
                         [](const auto& info) {
                           return info.param == Resolver::openat2 ? "openat2" : "walk";
                         });

// The walk's race: a directory swapped for a symlink between opening its parent and opening it.
TEST(BlobWalk, ADirectorySwappedForASymlinkMidWalkIsRefused) {
  flow::blob::forceResolver(Resolver::walk);
  TempDir dir;
  const fs::path files = dir.path() / "blobs" / "guest.maps" / "files";
  const fs::path outside = dir.path() / "outside";
  fs::create_directories(outside / "b");
  spit(outside / "b" / "file", "outside the tree");
  BlobStore store(dir.path() / "blobs", {}, [](std::function<void()> fn) { fn(); });
  ASSERT_TRUE(store.open());
  ASSERT_TRUE(wait<void>([&](auto done) { store.create("guest.maps", "guest", done); }));
  fs::create_directories(files / "a" / "b");
  spit(files / "a" / "b" / "file", "inside");
  const auto read = [&] {
    return wait<BlobStore::Read>(
        [&](auto done) { store.get(1, "guest.maps", "a/b/file", 0, 0, 100, 0, done); });
  };
  ASSERT_EQ(read()->data, "inside");
  int swaps = 0;
  flow::blob::setWalkHook([&](size_t depth) {
    if (depth != 0) return;  // "a" is open, "b" is next
    fs::rename(files / "a" / "b", dir.path() / "moved");
    fs::create_directory_symlink(outside / "b", files / "a" / "b");
    ++swaps;
  });
  auto r = read();
  flow::blob::setWalkHook(nullptr);
  EXPECT_EQ(swaps, 1);
  ASSERT_FALSE(r) << "read through the swapped symlink: " << r->data;
  EXPECT_EQ(r.error().code, Errc::permission_denied);
  flow::blob::forceResolver(Resolver::openat2);
}

// The order of a commit: the data written and fsynced, then renamed, then the directory fsynced.
class RecordingIo : public flow::BlobIo {
 public:
  Result<void> write(int fd, std::string_view data, uint64_t offset) override {
    note("write", fd);
    return BlobIo::write(fd, data, offset);
  }
  Result<void> sync(int fd) override {
    note("sync", fd);
    return BlobIo::sync(fd);
  }
  Result<void> rename(int from_dir, const std::string& from, int to_dir,
                      const std::string& to) override {
    note("rename", to_dir);
    return BlobIo::rename(from_dir, from, to_dir, to);
  }
  Result<void> syncDir(int dir) override {
    note("syncDir", dir);
    return BlobIo::syncDir(dir);
  }
  struct Op {
    std::string what;
    ino_t inode;
  };
  std::vector<Op> ops;
  std::mutex mutex;

 private:
  void note(const char* what, int fd) {
    struct stat st {};
    ::fstat(fd, &st);
    const std::lock_guard lock(mutex);
    ops.push_back({what, st.st_ino});
  }
};

TEST(BlobCommit, WriteSyncRenameSyncDirInThatOrder) {
  TempDir dir;
  auto io = std::make_shared<RecordingIo>();
  BlobStore store(
      dir.path() / "blobs", {}, [](std::function<void()> fn) { fn(); }, io);
  ASSERT_TRUE(store.open());
  ASSERT_TRUE(wait<void>([&](auto done) { store.create("guest.maps", "guest", done); }));
  auto at = wait<BlobStore::PutAt>(
      [&](auto done) { store.put(1, "guest.maps", {}, "floor/map", 6, 0, done); });
  ASSERT_TRUE(at);
  io->ops.clear();
  ASSERT_TRUE(wait<BlobStore::Written>(
      [&](auto done) { store.chunk(1, "guest.maps", at->upload_id, 0, "abc", done); }));
  ASSERT_TRUE(wait<BlobStore::Written>(
      [&](auto done) { store.chunk(1, "guest.maps", at->upload_id, 3, "def", done); }));
  std::vector<std::string> seq;
  for (const auto& op : io->ops) seq.push_back(op.what);
  ASSERT_EQ(seq, (std::vector<std::string>{"write", "write", "sync", "rename", "syncDir"}));
  // The file synced is the one written; the directory renamed into and synced is the target's.
  struct stat parent {};
  ASSERT_EQ(::stat((dir.path() / "blobs/guest.maps/files/floor").c_str(), &parent), 0);
  EXPECT_EQ(io->ops[2].inode, io->ops[0].inode);
  EXPECT_EQ(io->ops[3].inode, parent.st_ino);
  EXPECT_EQ(io->ops[4].inode, parent.st_ino);
}

}  // namespace
}  // namespace skr::test
