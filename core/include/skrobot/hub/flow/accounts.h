// SPDX-License-Identifier: Apache-2.0
// User accounts: the users file (argon2id hashes, never passwords) and the Authenticator that the
// hub's server asks at login. docs/accounts.md is the operator's side of this header.
//
// The users file, JSON, mode 0600:
//   {"format": 1,
//    "users": {"alice": {"hash": "$argon2id$v=19$m=65536,t=2,p=1$...",
//                        "created": "2026-01-02T03:04:05Z",
//                        "role": "admin", "rules": {...},   (role and rules: flow/access.h)
//                        "udp_key": "<base64 of 16 bytes>"}}}  (a board's key: server.udp)
//
// User names are 1..64 characters of [A-Za-z0-9_-] (no '.': channel names are "<user>.<short>").
// Passwords are 1..1024 bytes, any content. A password is never logged or stored; the buffers
// this code owns are zeroed after use (best effort: copies the caller made are the caller's).
#pragma once

#include <skrobot/hub/flow/access.h>
#include <skrobot/runtime/result.h>

#include <array>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

namespace skr {
class Loop;
}

namespace skr::flow {

constexpr size_t kMaxUserNameBytes = 64;
constexpr size_t kMinPasswordBytes = 1;
constexpr size_t kMaxPasswordBytes = 1024;
constexpr int kUsersFileFormat = 1;
// A board's key for UDP sessions (SipHash-2-4's 16 bytes; docs/flow-protocol.md, "UDP").
using UdpKey = std::array<uint8_t, 16>;

// Errc::invalid_argument with the reason when `name` is not a valid user name.
[[nodiscard]] Result<void> validateUserName(std::string_view name);
// Errc::invalid_argument with the reason when `password` is empty or longer than 1024 bytes.
[[nodiscard]] Result<void> validatePassword(std::string_view password);

// Initialises libsodium once per process. Thread-safe; cheap after the first call. Every function
// in this header calls it itself; exposed for callers that use libsodium directly.
[[nodiscard]] Result<void> sodiumReady();

// The users file, in memory. Not thread-safe: one thread at a time (the Authenticator locks its
// copy). add() and setPassword() hash with argon2id and block ~0.1 s and 64 MiB; verify() as long.
// Nothing here logs a password; changes reach the disk only through save().
class UsersFile {
 public:
  UsersFile() = default;                                                      // no users, no path
  explicit UsersFile(std::filesystem::path path) : path_(std::move(path)) {}  // no users yet

  // Reads `path`. A missing file gives an empty UsersFile bound to `path`; an unreadable or
  // corrupt one an error naming the path and the reason (io_error, parse_error). Logs
  // ACCOUNTS-PERMS when the file can be read by group or others. Blocking (file I/O).
  [[nodiscard]] static Result<UsersFile> load(const std::filesystem::path& path);

  // Writes path() crash-safely: "<file>.tmp-<pid>" with mode 0600, fsync, rename over the file,
  // fsync of the directory. Creates missing parent directories (mode 0700). Blocking.
  [[nodiscard]] Result<void> save() const;

  // already_exists when present; invalid_argument for a bad name or password.
  [[nodiscard]] Result<void> add(std::string_view user, std::string_view password);
  // not_found when absent.
  [[nodiscard]] Result<void> remove(std::string_view user);
  // not_found when absent; invalid_argument for a bad password. Keeps "created".
  [[nodiscard]] Result<void> setPassword(std::string_view user, std::string_view password);

  // True when `user` exists and `password` matches its hash. An unknown user costs one argon2id
  // verification of a dummy hash too, so the time taken does not tell which names exist.
  [[nodiscard]] bool verify(std::string_view user, std::string_view password) const;

  [[nodiscard]] std::vector<std::string> names() const;  // sorted
  [[nodiscard]] bool contains(std::string_view user) const;
  [[nodiscard]] size_t size() const noexcept { return users_.size(); }
  [[nodiscard]] bool empty() const noexcept { return users_.empty(); }
  // The stored argon2id hash string of `user`; nullopt when unknown.
  [[nodiscard]] std::optional<std::string> hashOf(std::string_view user) const;
  // The creation time of `user` ("YYYY-MM-DDTHH:MM:SSZ"); nullopt when unknown.
  [[nodiscard]] std::optional<std::string> createdOf(std::string_view user) const;
  // The role and rules of `user` (flow/access.h); the defaults for a user without rules or an
  // unknown one.
  [[nodiscard]] std::shared_ptr<const AccessRules> accessOf(std::string_view user) const;
  // not_found when absent.
  [[nodiscard]] Result<void> setAccess(std::string_view user, AccessRules access);
  // The key `user`'s board opens UDP sessions with (server.udp); nullopt when it has none.
  [[nodiscard]] std::optional<UdpKey> udpKeyOf(std::string_view user) const;
  // Sets (or with nullopt removes) that key. not_found when the user is absent.
  [[nodiscard]] Result<void> setUdpKey(std::string_view user, std::optional<UdpKey> key);

  [[nodiscard]] const std::filesystem::path& path() const noexcept { return path_; }

 private:
  struct Entry {
    std::string hash;                           // crypto_pwhash_str format, "$argon2id$..."
    std::string created;                        // ISO-8601 UTC
    std::shared_ptr<const AccessRules> access;  // null: the defaults
    std::optional<UdpKey> udp_key{};
  };
  std::filesystem::path path_;
  std::map<std::string, Entry, std::less<>> users_;
};

// One argon2id verification of `password` against `hash` (crypto_pwhash_str_verify). Blocking
// ~0.1 s. False for a malformed hash.
[[nodiscard]] bool verifyPasswordHash(const std::string& hash, std::string_view password);
// The argon2id hash (of a password nobody knows) that unknown users are verified against.
[[nodiscard]] std::string_view dummyPasswordHash() noexcept;

// Where a login comes from. The development account is accepted on the Unix socket, and on
// WebSocket from loopback when DevAccount::websocket_loopback says so (server.web.dev_account).
// Every network transport but WebSocket (TLS, serial, UDP) counts as tcp.
enum class Transport { unix_socket, tcp, in_process, websocket, websocket_loopback };
[[nodiscard]] std::string_view transportName(Transport transport) noexcept;

// An account held in memory only (e.g. guest/password for development), see docs/accounts.md.
struct DevAccount {
  std::string user;
  std::string password;
  bool websocket_loopback = false;  // also on WebSocket connections from this machine
};

struct LoginResult {
  bool ok = false;
  // For the operator's log ("unknown user", "wrong password", "cached verification", ...), never
  // the password. Do not send it to the client: telling unknown names from wrong passwords
  // there would reveal which names exist.
  std::string reason;
  // A supervised satellite's name when it logged in with the password made for its run.
  std::string satellite{};
};

// Verifies logins for the hub's server without blocking its loop.
//
// Threads: every public member is thread-safe (verify() is meant for the loop thread, but any will
// do). argon2id runs on one worker thread the Authenticator owns, in the order logins arrived;
// `done` always runs on the loop thread, through loop.post(), never inside verify().
//
// Cache: a successful verification is remembered as a keyed BLAKE2b digest of (user, password)
// (the key is random per process) together with the user's hash at that time, so that many
// satellites logging in with the same account cost one argon2id. An entry is dropped when reload()
// finds that user's hash changed or the user gone; an entry whose hash no longer matches is never
// used. Failed verifications are not cached.
//
// Lifetime: the Loop must outlive the Authenticator. The destructor (any thread, including inside
// a `done`) drops the logins still queued without calling their `done`, waits for the one being
// verified, and joins the worker. No `done` runs after the destructor returned, including those
// already posted to the loop.
class Authenticator {
 public:
  // Logins waiting for the worker beyond this are refused at once ("too many logins waiting").
  static constexpr size_t kMaxQueued = 256;
  static constexpr size_t kMaxCacheEntries = 256;

  // `users` normally comes from UsersFile::load; its path() is what reload() reads.
  Authenticator(UsersFile users, std::optional<DevAccount> dev, Loop& loop);
  // Loads `users_path` (missing = no users) and constructs. Error when the file is corrupt, or
  // when the development account's name or password is invalid.
  [[nodiscard]] static Result<std::unique_ptr<Authenticator>> create(
      const std::filesystem::path& users_path, std::optional<DevAccount> dev, Loop& loop);
  ~Authenticator();
  Authenticator(const Authenticator&) = delete;
  Authenticator& operator=(const Authenticator&) = delete;
  Authenticator(Authenticator&&) = delete;
  Authenticator& operator=(Authenticator&&) = delete;

  using Done = std::function<void(LoginResult)>;
  // Checks (user, password) for a connection on `transport`; `done` gets the answer on the loop
  // thread. Never blocks: the development account, a cache hit and malformed input are answered
  // without the worker (still through loop.post()); everything else queues one argon2id.
  void verify(std::string user, std::string password, Transport transport, Done done);

  // Re-reads the users file (path of the UsersFile given at construction). On error the users in
  // memory are kept. Drops cache entries of changed or removed users. Blocking (file I/O); waits
  // for no argon2id.
  [[nodiscard]] Result<void> reload();
  // Changes the users file off the loop, on the worker thread (argon2id and disk I/O): `change`
  // edits a copy of the file as last loaded; the copy is saved, then becomes the current one
  // (cached logins of changed passwords are forgotten). `done` runs on the loop thread with the
  // result, never inside this call.
  using Change = std::function<Result<void>(UsersFile&)>;
  void changeUsers(Change change, std::function<void(Result<void>)> done);
  // A copy of the users file as last loaded.
  [[nodiscard]] UsersFile snapshot() const;

  // A password for one run of a supervised satellite (docs/robot.md): random, accepted for
  // `user` on any transport until removed, and never written anywhere but the satellite's
  // environment. `user` is an account (users file or development account; else
  // Errc::not_found) or, with `own_name`, the satellite's own name, which must be no account
  // (Errc::already_exists): it then has the default rules, as a module without an account.
  [[nodiscard]] Result<std::string> addSatellitePassword(const std::string& user,
                                                         const std::string& satellite,
                                                         bool own_name);
  void removeSatellitePassword(const std::string& user, const std::string& password);

  // True when the users file (as last loaded) has `user`.
  [[nodiscard]] bool hasUser(std::string_view user) const;
  // The UDP key of `user` in the users file as last loaded; nullopt when none. Never blocks on
  // file I/O (the UDP port asks on the loop thread).
  [[nodiscard]] std::optional<UdpKey> udpKeyOf(std::string_view user) const;
  // The role and rules of `user` in the users file as last loaded (the defaults when unknown).
  [[nodiscard]] std::shared_ptr<const AccessRules> accessOf(std::string_view user) const;

  // The users file has at least one user. The server refuses TCP without real accounts.
  [[nodiscard]] bool hasRealAccounts() const;
  [[nodiscard]] bool hasDevAccount() const noexcept { return dev_.has_value(); }

  // argon2id verifications run so far (dummy hashes for unknown users included). For tests.
  [[nodiscard]] uint64_t argon2Verifications() const noexcept { return argon2_runs_.load(); }
  // The thread the last argon2id verification ran on (the worker). For tests.
  [[nodiscard]] std::thread::id lastArgon2Thread() const noexcept { return argon2_thread_.load(); }
  [[nodiscard]] size_t cacheSize() const;

 private:
  using Digest = std::array<unsigned char, 32>;
  struct Job {
    std::string user;
    std::string password;
    Done done;
    std::function<void()> task;  // set: a change of the users file instead of a login
  };
  struct CacheEntry {
    std::string user;
    std::string hash;  // the user's hash when the entry was made
    uint64_t seq = 0;  // insertion order, for eviction
  };
  struct DevDigest {
    std::string user;
    Digest password{};  // keyed BLAKE2b of the password; the password itself is not kept
    bool websocket_loopback = false;
  };
  // Shared with the closures posted to the loop, so that they can tell whether we still exist.
  struct Liveness {
    std::recursive_mutex mutex;
    bool alive = true;
  };

  [[nodiscard]] Digest credentialDigest(std::string_view user, std::string_view password) const;
  [[nodiscard]] Digest passwordDigest(std::string_view password) const;
  // The supervised satellite whose password this is (compared in constant time), if any.
  [[nodiscard]] std::optional<std::string> satelliteOf(const Digest& credential) const;
  // The answer if the cache knows (user, password) with the user's current hash.
  [[nodiscard]] bool cacheHit(const Digest& key, std::string_view user) const;
  void remember(const Digest& key, std::string_view user, std::string hash);
  void answer(Done done, LoginResult result);
  void work();
  [[nodiscard]] LoginResult verifySlow(Job& job);

  Loop& loop_;
  std::shared_ptr<Liveness> live_ = std::make_shared<Liveness>();
  std::array<unsigned char, 32> key_{};  // BLAKE2b key, random per process
  std::optional<DevDigest> dev_;

  mutable std::mutex users_mutex_;  // guards users_, cache_, cache_seq_, satellites_
  // Supervised satellites' passwords: the digest of (user, password) -> the satellite's name.
  std::map<Digest, std::string> satellites_;
  UsersFile users_;
  std::map<Digest, CacheEntry> cache_;
  uint64_t cache_seq_ = 0;

  std::mutex queue_mutex_;
  std::condition_variable queue_cv_;
  std::deque<Job> queue_;
  bool stopping_ = false;
  std::atomic<uint64_t> argon2_runs_{0};
  std::atomic<std::thread::id> argon2_thread_{};
  std::thread worker_;  // last: started once everything above exists
};

}  // namespace skr::flow
