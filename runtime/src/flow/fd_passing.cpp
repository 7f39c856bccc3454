// SPDX-License-Identifier: Apache-2.0
#include <skrobot/runtime/flow/fd_passing.h>

#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace skr::flow {

Result<void> sendWithFds(int socket, std::string_view bytes, std::span<const int> fds) {
  if (bytes.empty() || fds.size() > kMaxPassedFds) {
    return makeError(Errc::invalid_argument, "sendWithFds: 1+ bytes and at most 8 descriptors");
  }
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(int) * kMaxPassedFds)] = {};
  iovec iov{const_cast<char*>(bytes.data()), bytes.size()};
  msghdr msg{};
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  if (!fds.empty()) {
    msg.msg_control = control;
    msg.msg_controllen = CMSG_SPACE(sizeof(int) * fds.size());
    cmsghdr* c = CMSG_FIRSTHDR(&msg);
    c->cmsg_level = SOL_SOCKET;
    c->cmsg_type = SCM_RIGHTS;
    c->cmsg_len = CMSG_LEN(sizeof(int) * fds.size());
    std::memcpy(CMSG_DATA(c), fds.data(), sizeof(int) * fds.size());
  }
  ssize_t n;
  do {
    n = ::sendmsg(socket, &msg, MSG_NOSIGNAL);
  } while (n < 0 && errno == EINTR);
  if (n < 0) return makeError(Errc::io_error, std::string("sendmsg: ") + std::strerror(errno));
  if (static_cast<std::size_t>(n) != bytes.size()) {
    return makeError(Errc::io_error, "sendmsg sent part of the message");
  }
  return {};
}

Result<Received> receiveWithFds(int socket, std::size_t max_bytes) {
  Received r;
  r.bytes.resize(max_bytes);
  // Room for one more than allowed: more than kMaxPassedFds is seen, then refused.
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(int) * (kMaxPassedFds + 1))] = {};
  iovec iov{r.bytes.data(), r.bytes.size()};
  msghdr msg{};
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  msg.msg_control = control;
  msg.msg_controllen = sizeof control;
  ssize_t n;
  do {
    n = ::recvmsg(socket, &msg, MSG_CMSG_CLOEXEC);
  } while (n < 0 && errno == EINTR);
  if (n < 0) return makeError(Errc::io_error, std::string("recvmsg: ") + std::strerror(errno));
  r.bytes.resize(static_cast<std::size_t>(n));
  for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
    if (c->cmsg_level != SOL_SOCKET || c->cmsg_type != SCM_RIGHTS) continue;
    const std::size_t count = (c->cmsg_len - CMSG_LEN(0)) / sizeof(int);
    for (std::size_t i = 0; i < count; ++i) {
      int fd;
      std::memcpy(&fd, CMSG_DATA(c) + i * sizeof(int), sizeof fd);
      r.fds.push_back(fd);
    }
  }
  if ((msg.msg_flags & MSG_CTRUNC) != 0 || r.fds.size() > kMaxPassedFds) {
    for (int fd : r.fds) ::close(fd);
    return makeError(Errc::protocol_error, "more descriptors than allowed came with a message");
  }
  return r;
}

}  // namespace skr::flow
