// SPDX-License-Identifier: Apache-2.0
// Database write throughput under each durability policy (docs/pair-databases.md), against the
// same hub keeping its databases in memory only (no data directory), measured in the same run.
//
//   db_durability [--quick] [--seconds S]
//
// Rows: one client writing with VAR_SET (each answered; under `always` only once on disk);
// eight clients doing the same at once (under `always` their writes share fsyncs); one flow
// writing with VAR_SET_ASYNC and a DB_SYNC_ASYNC barrier after every 1000 writes. The data
// directory is a temporary directory: on tmpfs fsync costs nothing, so the figures say which
// file system /tmp is on.
#include "temp_dir.h"
#include "test_client.h"

#include <skrobot/hub/flow/server.h>
#include <skrobot/runtime/log.h>
#include <skrobot/runtime/loop.h>

#include <fcntl.h>
#include <sys/vfs.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <thread>
#include <vector>

namespace {

using namespace skr;
using Clock = std::chrono::steady_clock;

[[noreturn]] void fail(const std::string& why) {
  std::fprintf(stderr, "db_durability: %s\n", why.c_str());
  std::exit(1);
}

// A hub on its own loop thread; `policy` empty: no data directory (databases in memory).
class Hub {
 public:
  explicit Hub(const std::string& policy) {
    flow::ServerOptions so;
    so.app_name = "skrobot-dbbench-" + std::to_string(::getpid());
    so.unix_path = (dir_.path() / "hub.sock").string();
    so.users_file = dir_.path() / "users.json";
    so.dev_account = std::make_pair(std::string("guest"), std::string("password"));
    if (!policy.empty()) {
      so.data_dir = dir_.path() / "data";
      so.durability = policy == "always" ? flow::Durability::always
                      : policy == "no"   ? flow::Durability::no
                                         : flow::Durability::everysec;
    }
    unix_path_ = so.unix_path;
    LoopOptions lo;
    lo.name = "hub";
    thread_ = std::make_unique<LoopThread>(lo);
    thread_->start();
    Result<void> r;
    thread_->loop().invoke([&] {
      server_ = std::make_unique<flow::FlowServer>(thread_->loop(), so);
      r = server_->start();
    });
    if (!r) fail("hub start: " + r.error().describe());
  }
  ~Hub() {
    thread_->loop().invoke([&] { server_.reset(); });
    thread_.reset();
  }
  Hub(const Hub&) = delete;
  Hub& operator=(const Hub&) = delete;

  [[nodiscard]] test::TestClient client(bool flow) const {
    auto c = test::TestClient::connectUnix(unix_path_);
    if (!c) fail("connect: " + c.error().message);
    auto ok = flow ? c->loginFlow("guest", "password") : c->login("guest", "password");
    if (!ok) fail("login: " + ok.error().message);
    return std::move(c).value();
  }
  [[nodiscard]] const std::filesystem::path& dir() const { return dir_.path(); }

 private:
  test::TempDir dir_{"skrobot-dbbench"};
  std::string unix_path_;
  std::unique_ptr<LoopThread> thread_;
  std::unique_ptr<flow::FlowServer> server_;
};

// A 100-byte value, different each time (setting the value a key holds is not a change).
flow::Variant value(uint64_t n) {
  std::string v(100, 'v');
  const std::string digits = std::to_string(n);
  v.replace(0, digits.size(), digits);
  return flow::Variant(std::move(v));
}

// Writes with VAR_SET from `clients` clients for `seconds`; writes per second.
double syncWrites(const Hub& hub, int clients, double seconds) {
  std::atomic<uint64_t> total{0};
  std::vector<std::thread> threads;
  const auto end = Clock::now() + std::chrono::duration<double>(seconds);
  for (int t = 0; t < clients; ++t) {
    threads.emplace_back([&hub, &total, end, t] {
      test::TestClient c = hub.client(false);
      uint64_t n = 0;
      while (Clock::now() < end) {
        auto r = c.call(
            flow::msg::VarSet{"c" + std::to_string(t) + "k" + std::to_string(n % 1000), value(n)});
        if (!r || r->kind() != flow::Code::reply_ok) fail("VAR_SET failed");
        ++n;
      }
      total += n;
    });
  }
  const auto start = Clock::now();
  for (auto& t : threads) t.join();
  return double(total) / std::chrono::duration<double>(Clock::now() - start).count();
}

// VAR_SET_ASYNC in batches of 1000, each closed by a barrier; writes per second.
double asyncWrites(const Hub& hub, double seconds) {
  test::TestClient c = hub.client(true);
  const auto start = Clock::now();
  const auto end = start + std::chrono::duration<double>(seconds);
  uint64_t n = 0;
  for (uint32_t batch = 1; Clock::now() < end; ++batch) {
    for (int i = 0; i < 1000; ++i, ++n) {
      c.send(flow::msg::VarSetAsync{0, "a" + std::to_string(n % 1000), value(n)});
    }
    c.send(flow::msg::DbSyncAsync{batch});
    auto synced = c.waitFor(flow::Code::ev_db_synced, 30000);
    if (!synced) fail("no EV_DB_SYNCED");
  }
  return double(n) / std::chrono::duration<double>(Clock::now() - start).count();
}

// The floor under `always`: a 100-byte append and its fdatasync, in the data directory's file
// system; microseconds each.
double fdatasyncMicros(const std::filesystem::path& dir, int count) {
  const std::string path = (dir / "fsync-probe").string();
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0600);
  if (fd < 0) fail("cannot create " + path);
  const std::string bytes(100, 'x');
  const auto start = Clock::now();
  for (int i = 0; i < count; ++i) {
    if (::write(fd, bytes.data(), bytes.size()) != ssize_t(bytes.size()) || ::fdatasync(fd) != 0) {
      fail("write/fdatasync " + path);
    }
  }
  const double us = std::chrono::duration<double, std::micro>(Clock::now() - start).count();
  ::close(fd);
  ::unlink(path.c_str());
  return us / count;
}

std::string fileSystemOf(const std::filesystem::path& p) {
  struct statfs fs {};
  if (::statfs(p.c_str(), &fs) != 0) return "?";
  switch (static_cast<unsigned long>(fs.f_type)) {
    case 0x01021994UL:
      return "tmpfs";
    case 0xEF53UL:
      return "ext4";
    case 0x794C7630UL:
      return "overlayfs";
    case 0x58465342UL:
      return "xfs";
    case 0x9123683EUL:
      return "btrfs";
    default:
      return "fs type 0x" + [&] {
        char b[16];
        std::snprintf(b, sizeof b, "%lx", static_cast<unsigned long>(fs.f_type));
        return std::string(b);
      }();
  }
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 2.0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--quick") {
      seconds = 0.2;
    } else if (a == "--seconds" && i + 1 < argc) {
      seconds = std::atof(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: db_durability [--quick] [--seconds S]\n");
      return 2;
    }
  }
  skr::log::setLevel(skr::log::Level::error);
  std::printf("database writes, %.1f s per row, 100-byte values\n", seconds);
  double base[3] = {0, 0, 0};
  for (const std::string policy : {"", "no", "everysec", "always"}) {
    Hub hub(policy);
    const double one = syncWrites(hub, 1, seconds);
    const double eight = syncWrites(hub, 8, seconds);
    const double async = asyncWrites(hub, seconds);
    if (policy.empty()) {
      base[0] = one, base[1] = eight, base[2] = async;
      std::printf("data directory on %s; a 100-byte append + fdatasync there takes %.0f us\n",
                  fileSystemOf(hub.dir()).c_str(), fdatasyncMicros(hub.dir(), 500));
      std::printf("%-10s %16s %16s %22s\n", "policy", "VAR_SET 1 client", "VAR_SET 8 clients",
                  "VAR_SET_ASYNC+barrier");
    }
    std::printf("%-10s %9.0f/s %4.2fx %9.0f/s %4.2fx %15.0f/s %4.2fx\n",
                policy.empty() ? "memory" : policy.c_str(), one, one / base[0], eight,
                eight / base[1], async, async / base[2]);
  }
  return 0;
}
