// SPDX-License-Identifier: Apache-2.0
// Blob channel transfers against their floors, in one run:
//   - upload and download through the hub (SyncClient, Unix socket and TCP loopback), per size;
//   - a raw socket copy of the same bytes (a socketpair, a TCP loopback pair);
//   - a local file write of the same bytes with its fsync (what an upload must do at least);
//   - the round trip of a ping-pong through the hub during the largest transfer, against the same
//     ping-pong during a raw socket copy of the same size (two cores are shared either way).
//
//   blob_transfer [--quick] [--sizes MB,MB,...]    default sizes 1,100,1024; --quick: 1,16
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

// Seconds to move `data` from one end of a raw pair to the other, 1 MiB per write.
double rawCopy(bool tcp, const std::string& data) {
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
  std::string buf(1 << 20, '\0');
  size_t got = 0;
  while (got < data.size()) {
    const ssize_t n = ::recv(b, buf.data(), buf.size(), 0);
    if (n <= 0) fail("raw recv");
    got += size_t(n);
  }
  writer.join();
  const double s = seconds(t0, Clock::now());
  ::close(a);
  ::close(b);
  return s;
}

// Seconds to write `data` to a new file and fsync it, 1 MiB per write, each started back to the
// disk at once as the hub's store does (without that, a large file waits for the dirty-page
// throttle and the floor is lower than what the store achieves).
double fileWrite(const std::filesystem::path& p, const std::string& data) {
  const auto t0 = Clock::now();
  const int fd = ::open(p.c_str(), O_CREAT | O_TRUNC | O_WRONLY | O_CLOEXEC, 0600);
  if (fd < 0) fail("open " + p.string());
  size_t off = 0;
  while (off < data.size()) {
    const ssize_t n = ::write(fd, data.data() + off, std::min<size_t>(1 << 20, data.size() - off));
    if (n <= 0) fail("write");
    (void)::sync_file_range(fd, off_t(off), off_t(n), SYNC_FILE_RANGE_WRITE);
    off += size_t(n);
  }
  ::fsync(fd);
  ::close(fd);
  const double s = seconds(t0, Clock::now());
  ::unlink(p.c_str());
  return s;
}

// --- the hub ----------------------------------------------------------------------------------

class Hub {
 public:
  explicit Hub(const std::filesystem::path& dir) {
    flow::ServerOptions so;
    so.app_name = "skrobot-blob-bench-" + std::to_string(::getpid());
    so.unix_path = (dir / "hub.sock").string();
    so.data_dir = dir / "data";
    so.users_file = dir / "users.json";
    so.tcp_enabled = true;
    so.tcp_port = 0;
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

}  // namespace

int main(int argc, char** argv) {
  std::vector<size_t> sizes_mb{1, 100, 1024};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--quick") {
      sizes_mb = {1, 16};
    } else if (a == "--sizes" && i + 1 < argc) {
      sizes_mb.clear();
      std::stringstream ss(argv[++i]);
      std::string item;
      while (std::getline(ss, item, ',')) sizes_mb.push_back(size_t(std::atol(item.c_str())));
    } else {
      std::fprintf(stderr, "usage: blob_transfer [--quick] [--sizes MB,MB,...]\n");
      return 2;
    }
  }
  test::TempDir dir;
  Hub hub(dir.path());
  // up/file: an upload ends with the file written and fsynced on the hub's disk, so a local file
  // write of the same bytes is its floor as much as the socket is.
  std::printf("%-6s %-5s %10s %10s %10s %10s %9s %9s %9s\n", "size", "via", "up MB/s", "down MB/s",
              "raw MB/s", "file MB/s", "up/raw", "up/file", "down/raw");
  for (const size_t mb : sizes_mb) {
    std::string data(mb << 20, '\0');
    for (size_t i = 0; i < data.size(); i += 4096) data[i] = char(i * 2654435761u >> 24);
    for (const bool tcp : {false, true}) {
      SyncClient c = hub.client(tcp);
      auto ch = c.createBlobChannel("bench");
      if (!ch) fail("create: " + ch.error().message);
      const auto t0 = Clock::now();
      if (auto v = c.blobPut(ch->id, "data.bin", data); !v) fail("put: " + v.error().message);
      const auto t1 = Clock::now();
      // Downloaded into a buffer of the client's, as the raw copy reads into one.
      uint64_t got = 0;
      auto back = c.blobGetStream(ch->id, "data.bin", [&](std::string_view d) -> Result<void> {
        got += d.size();
        return {};
      });
      const auto t2 = Clock::now();
      if (!back || got != data.size()) fail("get");
      const double mbytes = double(data.size()) / 1e6;
      const double up = mbytes / seconds(t0, t1), down = mbytes / seconds(t1, t2);
      const double raw = mbytes / rawCopy(tcp, data);
      const double file = mbytes / fileWrite(dir.path() / "floor.bin", data);
      std::printf("%-6s %-5s %10.0f %10.0f %10.0f %10.0f %9.2f %9.2f %9.2f\n",
                  (std::to_string(mb) + "MB").c_str(), tcp ? "tcp" : "unix", up, down, raw, file,
                  up / raw, up / file, down / raw);
    }
  }
  // Other traffic during the largest transfer, through the hub and beside a raw copy.
  const size_t big = sizes_mb.back() << 20;
  std::string data(big, 'p');
  double raw_p50 = 0, raw_p99 = 0, hub_p50 = 0, hub_p99 = 0;
  {
    Pinger p(hub);
    rawCopy(false, data);
    rawCopy(false, data);
    std::tie(raw_p50, raw_p99) = p.finish();
  }
  double up_p50 = 0, up_p99 = 0, down_p50 = 0, down_p99 = 0;
  {
    SyncClient c = hub.client(false);
    auto ch = c.createBlobChannel("bench");
    if (!ch) fail("create");
    {
      Pinger p(hub);
      if (!c.blobPut(ch->id, "ping.bin", data)) fail("put");
      std::tie(up_p50, up_p99) = p.finish();
    }
    Pinger p(hub);
    if (!c.blobGetStream(ch->id, "ping.bin", [](std::string_view) -> Result<void> { return {}; })) {
      fail("get");
    }
    std::tie(down_p50, down_p99) = p.finish();
  }
  hub_p50 = std::max(up_p50, down_p50);
  hub_p99 = std::max(up_p99, down_p99);
  std::printf(
      "\nping round trip through the hub during a %zu MB upload:   p50 %.0f us, p99 %.0f us\n"
      "                                          download: p50 %.0f us, p99 %.0f us\n"
      "                          during a raw socket copy:  p50 %.0f us, p99 %.0f us\n"
      "ratio (the worse of upload and download / raw copy): p50 %.2f, p99 %.2f\n",
      sizes_mb.back(), up_p50, up_p99, down_p50, down_p99, raw_p50, raw_p99,
      hub_p50 / std::max(raw_p50, 1.0), hub_p99 / std::max(raw_p99, 1.0));
  return 0;
}
