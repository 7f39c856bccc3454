// SPDX-License-Identifier: Apache-2.0
// Blob channel transfers against their floors, measured in the same run (issue 45's targets):
//   - upload and download through the hub (SyncClient, Unix socket and TCP loopback), per size;
//   - the upload floor: a local program receiving the same bytes from a raw socket pair and
//     writing them into a file with the store's durability (write, fsync, rename);
//   - the download floor: a raw socket copy of that file from the page cache;
//   - the round trip of a ping-pong through the hub during the largest upload and download,
//     against the same ping-pong during the floor's copy of the same size (the two cores are
//     shared either way).
// Several runs; the median of each ratio is printed last.
//
//   blob_transfer [--quick] [--sizes MB,MB,...] [--runs N] [--io-threads N]
//   default sizes 100,1024, 3 runs, blobs.io_threads 1; --quick: 1,16 once
#include <skrobot/hub/flow/accounts.h>
#include <skrobot/hub/flow/server.h>
#include <skrobot/runtime/loop.h>
#include <skrobot/satellite/sync_client.h>

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "temp_dir.h"

namespace {

using namespace skr;
using Clock = std::chrono::steady_clock;
using sat::SyncClient;

[[noreturn]] void fail(const std::string& why) {
  std::fprintf(stderr, "blob_transfer: %s\n", why.c_str());
  std::exit(1);
}

double seconds(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

// --- the floors -------------------------------------------------------------------------------

// Two connected sockets: a socketpair, or a TCP loopback pair.
std::pair<int, int> rawPair(bool tcp) {
  if (!tcp) {
    int fds[2];
    if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, fds) != 0) fail("socketpair");
    return {fds[0], fds[1]};
  }
  const int l = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  if (::bind(l, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || ::listen(l, 1) != 0 ||
      ::getsockname(l, reinterpret_cast<sockaddr*>(&a), &len) != 0) {
    fail("loopback listener");
  }
  const int c = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (::connect(c, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) fail("connect");
  const int s = ::accept4(l, nullptr, nullptr, SOCK_CLOEXEC);
  ::close(l);
  const int one = 1;
  ::setsockopt(c, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  ::setsockopt(s, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  return {c, s};
}

// The upload floor: seconds to receive `data` from a raw pair and write it into a new file with
// the store's durability (1 MiB writes, each started back to the disk at once as the store does;
// fsync; rename into place; the directory fsynced).
double socketToFile(bool tcp, const std::filesystem::path& p, const std::string& data) {
  auto [a, b] = rawPair(tcp);
  const auto t0 = Clock::now();
  std::thread writer([&, a = a] {
    size_t off = 0;
    while (off < data.size()) {
      const ssize_t n =
          ::send(a, data.data() + off, std::min<size_t>(1 << 20, data.size() - off), MSG_NOSIGNAL);
      if (n <= 0) fail("raw send");
      off += size_t(n);
    }
  });
  const std::filesystem::path part = p.string() + ".part";
  const int fd = ::open(part.c_str(), O_CREAT | O_TRUNC | O_WRONLY | O_CLOEXEC, 0600);
  if (fd < 0) fail("open " + part.string());
  std::string buf(1 << 20, '\0');
  size_t got = 0;
  while (got < data.size()) {
    size_t fill = 0;
    while (fill < buf.size() && got + fill < data.size()) {
      const ssize_t n =
          ::recv(b, buf.data() + fill, std::min(buf.size(), data.size() - got) - fill, 0);
      if (n <= 0) fail("raw recv");
      fill += size_t(n);
    }
    if (::write(fd, buf.data(), fill) != ssize_t(fill)) fail("write");
    (void)::sync_file_range(fd, off_t(got), off_t(fill), SYNC_FILE_RANGE_WRITE);
    got += fill;
  }
  writer.join();
  ::fsync(fd);
  ::close(fd);
  std::filesystem::rename(part, p);
  const int dir = ::open(p.parent_path().c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  ::fsync(dir);
  ::close(dir);
  const double s = seconds(t0, Clock::now());
  ::close(a);
  ::close(b);
  return s;
}

// The download floor: seconds to send the file `p` (in the page cache: just written) over a raw
// pair, read in 1 MiB pieces, and receive it into a buffer on the other end.
double fileToSocket(bool tcp, const std::filesystem::path& p, size_t size) {
  auto [a, b] = rawPair(tcp);
  const auto t0 = Clock::now();
  std::thread reader([&, a = a] {
    const int fd = ::open(p.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) fail("open " + p.string());
    std::string buf(1 << 20, '\0');
    for (;;) {
      const ssize_t n = ::read(fd, buf.data(), buf.size());
      if (n < 0) fail("read");
      if (n == 0) break;
      size_t off = 0;
      while (off < size_t(n)) {
        const ssize_t m = ::send(a, buf.data() + off, size_t(n) - off, MSG_NOSIGNAL);
        if (m <= 0) fail("raw send");
        off += size_t(m);
      }
    }
    ::close(fd);
  });
  std::string buf(1 << 20, '\0');
  size_t got = 0;
  while (got < size) {
    const ssize_t n = ::recv(b, buf.data(), buf.size(), 0);
    if (n <= 0) fail("raw recv");
    got += size_t(n);
  }
  reader.join();
  const double s = seconds(t0, Clock::now());
  ::close(a);
  ::close(b);
  return s;
}

// --- the hub ----------------------------------------------------------------------------------

class Hub {
 public:
  Hub(const std::filesystem::path& dir, uint32_t io_threads) {
    flow::ServerOptions so;
    so.app_name = "skrobot-blob-bench-" + std::to_string(::getpid());
    so.unix_path = (dir / "hub.sock").string();
    so.data_dir = dir / "data";
    so.users_file = dir / "users.json";
    so.tcp_enabled = true;
    so.tcp_port = 0;
    so.blob_io_threads = io_threads;
    auto users = flow::UsersFile::load(so.users_file);
    if (!users || !users->add("bench", "bench-password") || !users->save()) fail("users file");
    unix_path_ = so.unix_path;
    thread_ = std::make_unique<LoopThread>(LoopOptions{.name = "hub"});
    thread_->start();
    Result<void> r;
    thread_->loop().invoke([&] {
      server_ = std::make_unique<flow::FlowServer>(thread_->loop(), so);
      r = server_->start();
      port_ = server_->tcpPort();
    });
    if (!r) fail("hub start: " + r.error().message);
  }
  ~Hub() {
    thread_->loop().invoke([&] { server_.reset(); });
    thread_.reset();
  }
  Hub(const Hub&) = delete;
  Hub& operator=(const Hub&) = delete;

  SyncClient client(bool tcp) const {
    sat::ConnectOptions o;
    if (tcp) {
      o.address.kind = flow::Address::Kind::tcp;
      o.address.host = "127.0.0.1";
      o.address.port = port_;
    } else {
      o.address.kind = flow::Address::Kind::local;
      o.address.path = unix_path_;
    }
    o.user = "bench";
    o.password = "bench-password";
    o.timeout_ms = 60000;
    auto c = SyncClient::connect(o);
    if (!c) fail("connect: " + c.error().message);
    return std::move(c).value();
  }

 private:
  std::string unix_path_;
  uint16_t port_ = 0;
  std::unique_ptr<LoopThread> thread_;
  std::unique_ptr<flow::FlowServer> server_;
};

// Pings through the hub until `stop`, keeping each round trip in microseconds.
struct Pinger {
  explicit Pinger(const Hub& hub) : client(hub.client(false)) {
    thread = std::thread([this] {
      while (!stop) {
        const auto t0 = Clock::now();
        if (!client.ping()) fail("ping");
        rtt_us.push_back(seconds(t0, Clock::now()) * 1e6);
      }
    });
  }
  std::pair<double, double> finish() {
    stop = true;
    thread.join();
    std::sort(rtt_us.begin(), rtt_us.end());
    if (rtt_us.empty()) return {0, 0};
    return {rtt_us[rtt_us.size() / 2], rtt_us[rtt_us.size() * 99 / 100]};
  }
  SyncClient client;
  std::atomic<bool> stop{false};
  std::vector<double> rtt_us;
  std::thread thread;
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

// The data of a transfer: pages that differ, so that nothing on the way can shortcut zeros.
std::string payload(size_t bytes) {
  std::string data(bytes, '\0');
  for (size_t i = 0; i < data.size(); i += 4096) data[i] = char(i * 2654435761u >> 24);
  return data;
}

// One run: each size over each socket kind, the hub against its floors; then the ping during the
// largest transfer and during its floor's copy. Ratios go into `ratios` by name.
void run(Hub& hub, const std::filesystem::path& dir, const std::vector<size_t>& sizes_mb,
         std::map<std::string, std::vector<double>>& ratios) {
  std::printf("%-6s %-5s %9s %9s %8s %9s %9s %8s\n", "size", "via", "up MB/s", "floor", "up/fl",
              "down MB/s", "floor", "down/fl");
  for (const size_t mb : sizes_mb) {
    const std::string data = payload(mb << 20);
    for (const bool tcp : {false, true}) {
      SyncClient c = hub.client(tcp);
      auto ch = c.createBlobChannel("bench");
      if (!ch) fail("create: " + ch.error().message);
      ::sync();  // each measurement starts with the disk's write-back done (not the last one's)
      const auto t0 = Clock::now();
      if (auto v = c.blobPut(ch->id, "data.bin", data); !v) fail("put: " + v.error().message);
      const auto t1 = Clock::now();
      // Downloaded into a buffer of the client's, as the floor reads into one.
      uint64_t got = 0;
      auto back = c.blobGetStream(ch->id, "data.bin", [&](std::string_view d) -> Result<void> {
        got += d.size();
        return {};
      });
      const auto t2 = Clock::now();
      if (!back || got != data.size()) fail("get");
      // Removed outside the timing: the next upload makes a new file, as the floor does, rather
      // than replacing (and freeing the blocks of) a file of an earlier size.
      if (!c.blobRemove(ch->id, "data.bin")) fail("remove");
      const double mbytes = double(data.size()) / 1e6;
      const double up = mbytes / seconds(t0, t1), down = mbytes / seconds(t1, t2);
      const auto floor_file = dir / "floor.bin";
      ::sync();
      const double up_floor = mbytes / socketToFile(tcp, floor_file, data);
      const double down_floor = mbytes / fileToSocket(tcp, floor_file, data.size());
      std::filesystem::remove(floor_file);
      const std::string key = std::to_string(mb) + "MB " + (tcp ? "tcp" : "unix");
      std::printf("%-6s %-5s %9.0f %9.0f %8.2f %9.0f %9.0f %8.2f\n",
                  (std::to_string(mb) + "MB").c_str(), tcp ? "tcp" : "unix", up, up_floor,
                  up / up_floor, down, down_floor, down / down_floor);
      ratios[key + " up/floor"].push_back(up / up_floor);
      ratios[key + " down/floor"].push_back(down / down_floor);
    }
  }
  // A ping-pong through the hub during the largest transfer (Unix socket), and during its floor's
  // copy of the same size (the hub idle, the two cores as busy).
  const size_t big = sizes_mb.back() << 20;
  const std::string data = payload(big);
  const auto floor_file = dir / "ping-floor.bin";
  std::pair<double, double> up_floor, up_hub, down_floor, down_hub;
  ::sync();
  {
    Pinger p(hub);
    socketToFile(false, floor_file, data);
    up_floor = p.finish();
  }
  {
    Pinger p(hub);
    fileToSocket(false, floor_file, data.size());
    down_floor = p.finish();
  }
  std::filesystem::remove(floor_file);
  SyncClient c = hub.client(false);
  auto ch = c.createBlobChannel("bench");
  if (!ch) fail("create");
  ::sync();
  {
    Pinger p(hub);
    if (!c.blobPut(ch->id, "ping.bin", data)) fail("put");
    up_hub = p.finish();
  }
  {
    Pinger p(hub);
    if (!c.blobGetStream(ch->id, "ping.bin", [](std::string_view) -> Result<void> { return {}; })) {
      fail("get");
    }
    down_hub = p.finish();
  }
  if (!c.blobRemove(ch->id, "ping.bin")) fail("remove");
  std::printf(
      "ping through the hub, %zu MB: upload p50 %.0f p99 %.0f us (floor's copy %.0f / %.0f); "
      "download p50 %.0f p99 %.0f us (floor's copy %.0f / %.0f)\n",
      sizes_mb.back(), up_hub.first, up_hub.second, up_floor.first, up_floor.second, down_hub.first,
      down_hub.second, down_floor.first, down_floor.second);
  ratios["ping p50 upload/floor"].push_back(up_hub.first / std::max(up_floor.first, 1.0));
  ratios["ping p99 upload/floor"].push_back(up_hub.second / std::max(up_floor.second, 1.0));
  ratios["ping p50 download/floor"].push_back(down_hub.first / std::max(down_floor.first, 1.0));
  ratios["ping p99 download/floor"].push_back(down_hub.second / std::max(down_floor.second, 1.0));
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<size_t> sizes_mb{100, 1024};
  int runs = 3;
  uint32_t io_threads = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--quick") {
      sizes_mb = {1, 16};
      runs = 1;
    } else if (a == "--sizes" && i + 1 < argc) {
      sizes_mb.clear();
      std::stringstream ss(argv[++i]);
      std::string item;
      while (std::getline(ss, item, ',')) sizes_mb.push_back(size_t(std::atol(item.c_str())));
    } else if (a == "--runs" && i + 1 < argc) {
      runs = std::max(1, std::atoi(argv[++i]));
    } else if (a == "--io-threads" && i + 1 < argc) {
      io_threads = uint32_t(std::atoi(argv[++i]));
    } else {
      std::fprintf(stderr,
                   "usage: blob_transfer [--quick] [--sizes MB,MB,...] [--runs N] "
                   "[--io-threads N]\n");
      return 2;
    }
  }
  test::TempDir dir;
  Hub hub(dir.path(), io_threads);
  std::printf("blob_transfer: hub with blobs.io_threads %u, %d run(s)\n", io_threads, runs);
  std::map<std::string, std::vector<double>> ratios;
  for (int r = 0; r < runs; ++r) {
    std::printf("\nrun %d\n", r + 1);
    run(hub, dir.path(), sizes_mb, ratios);
  }
  std::printf(
      "\nmedian of %d run(s) (targets: transfers >= 0.80 of the floor; ping p50 <= 1.2x, "
      "p99 <= 1.5x of the floor's copy)\n",
      runs);
  for (const auto& [name, v] : ratios) {
    std::printf("  %-28s %6.2f   (runs:", name.c_str(), median(v));
    for (double x : v) std::printf(" %.2f", x);
    std::printf(")\n");
  }
  return 0;
}
