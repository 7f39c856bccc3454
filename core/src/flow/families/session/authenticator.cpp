// SPDX-License-Identifier: Apache-2.0
// Authenticator: logins verified on one worker thread, answered on the loop thread.
#include <skrobot/hub/flow/accounts.h>
#include <skrobot/runtime/log.h>
#include <skrobot/runtime/loop.h>

#include <sodium.h>

#include <cstdint>
#include <utility>

namespace skr::flow {
namespace {

constexpr std::string_view kLogSource = "flow.accounts";

// Domain separation between the two digests made with the same key.
constexpr unsigned char kCredentialTag = 'C';
constexpr unsigned char kPasswordTag = 'P';

void wipe(std::string& secret) noexcept {
  if (!secret.empty()) sodium_memzero(secret.data(), secret.size());
}

class SecretWiper {
 public:
  explicit SecretWiper(std::string& secret) noexcept : secret_(secret) {}
  ~SecretWiper() { wipe(secret_); }
  SecretWiper(const SecretWiper&) = delete;
  SecretWiper& operator=(const SecretWiper&) = delete;
  SecretWiper(SecretWiper&&) = delete;
  SecretWiper& operator=(SecretWiper&&) = delete;

 private:
  std::string& secret_;
};

}  // namespace

std::string_view transportName(Transport transport) noexcept {
  switch (transport) {
    case Transport::unix_socket:
      return "unix socket";
    case Transport::tcp:
      return "tcp";
    case Transport::in_process:
      return "in-process";
    case Transport::websocket:
      return "websocket";
    case Transport::websocket_loopback:
      return "websocket (loopback)";
  }
  return "unknown";
}

Authenticator::Authenticator(UsersFile users, std::optional<DevAccount> dev, Loop& loop)
    : loop_(loop), users_(std::move(users)) {
  if (auto ready = sodiumReady(); !ready) {
    log::error(kLogSource, "ACCOUNTS-SODIUM", ready.error().message);
  }
  crypto_generichash_keygen(key_.data());
  if (dev) {
    auto name_ok = validateUserName(dev->user);
    auto password_ok = validatePassword(dev->password);
    if (!name_ok || !password_ok) {
      log::error(kLogSource, "ACCOUNTS-DEV-INVALID",
                 "development account ignored: " +
                     (!name_ok ? name_ok.error().message : password_ok.error().message));
    } else {
      dev_ = DevDigest{dev->user, passwordDigest(dev->password), dev->websocket_loopback};
    }
    wipe(dev->password);
  }
  worker_ = std::thread([this] { work(); });
}

Result<std::unique_ptr<Authenticator>> Authenticator::create(
    const std::filesystem::path& users_path, std::optional<DevAccount> dev, Loop& loop) {
  if (dev) {
    if (auto n = validateUserName(dev->user); !n) {
      return makeError(Errc::invalid_argument, "development account: " + n.error().message);
    }
    if (auto p = validatePassword(dev->password); !p) {
      return makeError(Errc::invalid_argument, "development account: " + p.error().message);
    }
  }
  auto users = UsersFile::load(users_path);
  if (!users) return users.error();
  return std::make_unique<Authenticator>(std::move(users.value()), std::move(dev), loop);
}

Authenticator::~Authenticator() {
  {
    // Waits for a `done` running right now on the loop thread (or is inside it: recursive).
    std::lock_guard lock(live_->mutex);
    live_->alive = false;
  }
  {
    std::lock_guard lock(queue_mutex_);
    stopping_ = true;
    for (auto& job : queue_) wipe(job.password);
    queue_.clear();
  }
  queue_cv_.notify_all();
  if (worker_.joinable()) worker_.join();
}

void Authenticator::verify(std::string user, std::string password, Transport transport, Done done) {
  // Zeroes the password on every return, best effort (a moved-from one is empty).
  const SecretWiper wiper(password);

  if (!validateUserName(user)) {
    answer(std::move(done), {false, "malformed user name"});
    return;
  }
  if (!validatePassword(password)) {
    answer(std::move(done), {false, "password empty or longer than 1024 bytes"});
    return;
  }
  if (auto satellite = satelliteOf(credentialDigest(user, password))) {
    answer(std::move(done), {true, "supervised satellite " + *satellite, *satellite});
    return;
  }
  if (dev_ && user == dev_->user) {
    const bool real = [&] {
      std::lock_guard lock(users_mutex_);
      return users_.contains(user);
    }();
    const bool websocket = transport == Transport::websocket_loopback && dev_->websocket_loopback;
    if (transport == Transport::unix_socket || websocket) {
      const Digest d = passwordDigest(password);
      if (sodium_memcmp(d.data(), dev_->password.data(), d.size()) == 0) {
        answer(std::move(done), {true, websocket ? "development account on WebSocket (loopback)"
                                                 : "development account on the Unix socket"});
        return;
      }
      if (!real) {
        answer(std::move(done), {false, "wrong password for the development account"});
        return;
      }
    } else if (!real) {
      answer(std::move(done),
             {false, "development account refused on " + std::string(transportName(transport)) +
                         (dev_->websocket_loopback
                              ? ": accepted on the Unix socket and on WebSocket from loopback only"
                              : ": accepted on the Unix socket only")});
      return;
    }
    // A real account of the same name: verified like any other below.
  }
  if (cacheHit(credentialDigest(user, password), user)) {
    answer(std::move(done), {true, "cached verification"});
    return;
  }

  std::unique_lock lock(queue_mutex_);
  if (stopping_) return;
  if (queue_.size() >= kMaxQueued) {
    lock.unlock();
    log::warn(kLogSource, "ACCOUNTS-BUSY", "login refused: too many logins waiting");
    answer(std::move(done), {false, "too many logins waiting"});
    return;
  }
  queue_.push_back(Job{std::move(user), std::move(password), std::move(done), {}});
  lock.unlock();
  queue_cv_.notify_one();
}

Result<std::string> Authenticator::addSatellitePassword(const std::string& user,
                                                        const std::string& satellite,
                                                        bool own_name) {
  const bool known = (dev_ && dev_->user == user) || hasUser(user);
  if (own_name && known) {
    return makeError(
        Errc::already_exists,
        "its name " + user + " is an account: say which account it logs in as (\"account\")");
  }
  if (!own_name && !known) {
    return makeError(Errc::not_found, "no account " + user + " (users file or dev_account)");
  }
  unsigned char raw[32];
  randombytes_buf(raw, sizeof raw);
  char hex[sizeof raw * 2 + 1];
  sodium_bin2hex(hex, sizeof hex, raw, sizeof raw);
  sodium_memzero(raw, sizeof raw);
  std::string password(hex);
  sodium_memzero(hex, sizeof hex);
  std::lock_guard lock(users_mutex_);
  satellites_[credentialDigest(user, password)] = satellite;
  return password;
}

void Authenticator::removeSatellitePassword(const std::string& user, const std::string& password) {
  std::lock_guard lock(users_mutex_);
  satellites_.erase(credentialDigest(user, password));
}

std::optional<std::string> Authenticator::satelliteOf(const Digest& credential) const {
  std::lock_guard lock(users_mutex_);
  if (satellites_.empty()) return std::nullopt;
  for (const auto& [digest, name] : satellites_) {
    if (sodium_memcmp(digest.data(), credential.data(), digest.size()) == 0) return name;
  }
  return std::nullopt;
}

void Authenticator::changeUsers(Change change, std::function<void(Result<void>)> done) {
  Job job;
  job.task = [this, change = std::move(change), done = std::move(done)]() mutable {
    UsersFile copy = snapshot();
    Result<void> r = change(copy);
    if (r) r = copy.save();
    if (r) {
      std::lock_guard lock(users_mutex_);
      users_ = std::move(copy);
      std::erase_if(cache_, [this](const auto& kv) {
        return users_.hashOf(kv.second.user) != kv.second.hash;
      });
    }
    loop_.post([live = live_, done = std::move(done), r = std::move(r)]() mutable {
      std::lock_guard lock(live->mutex);
      if (live->alive && done) done(std::move(r));
    });
  };
  std::unique_lock lock(queue_mutex_);
  if (stopping_) return;
  queue_.push_back(std::move(job));
  lock.unlock();
  queue_cv_.notify_one();
}

UsersFile Authenticator::snapshot() const {
  std::lock_guard lock(users_mutex_);
  return users_;
}

bool Authenticator::hasUser(std::string_view user) const {
  std::lock_guard lock(users_mutex_);
  return users_.contains(user);
}

std::optional<UdpKey> Authenticator::udpKeyOf(std::string_view user) const {
  std::lock_guard lock(users_mutex_);
  return users_.udpKeyOf(user);
}

std::shared_ptr<const AccessRules> Authenticator::accessOf(std::string_view user) const {
  std::lock_guard lock(users_mutex_);
  return users_.accessOf(user);
}

Result<void> Authenticator::reload() {
  std::filesystem::path path;
  {
    std::lock_guard lock(users_mutex_);
    path = users_.path();
  }
  if (path.empty()) return makeError(Errc::invalid_argument, "no users file to reload");
  auto loaded = UsersFile::load(path);
  if (!loaded) return loaded.error();

  std::lock_guard lock(users_mutex_);
  users_ = std::move(loaded.value());
  for (auto it = cache_.begin(); it != cache_.end();) {
    if (users_.hashOf(it->second.user) != it->second.hash) {
      it = cache_.erase(it);
    } else {
      ++it;
    }
  }
  log::info(kLogSource, "ACCOUNTS-RELOAD",
            "users file " + path.string() + " reloaded, users: " + std::to_string(users_.size()));
  return {};
}

bool Authenticator::hasRealAccounts() const {
  std::lock_guard lock(users_mutex_);
  return !users_.empty();
}

size_t Authenticator::cacheSize() const {
  std::lock_guard lock(users_mutex_);
  return cache_.size();
}

Authenticator::Digest Authenticator::credentialDigest(std::string_view user,
                                                      std::string_view password) const {
  // The user's length first, so that ("ab", "c...") and ("a", "bc...") differ.
  const auto len = static_cast<uint32_t>(user.size());
  const unsigned char len_le[4] = {
      static_cast<unsigned char>(len), static_cast<unsigned char>(len >> 8),
      static_cast<unsigned char>(len >> 16), static_cast<unsigned char>(len >> 24)};
  crypto_generichash_state st;
  Digest out{};
  crypto_generichash_init(&st, key_.data(), key_.size(), out.size());
  crypto_generichash_update(&st, &kCredentialTag, 1);
  crypto_generichash_update(&st, len_le, sizeof len_le);
  crypto_generichash_update(&st, reinterpret_cast<const unsigned char*>(user.data()), user.size());
  crypto_generichash_update(&st, reinterpret_cast<const unsigned char*>(password.data()),
                            password.size());
  crypto_generichash_final(&st, out.data(), out.size());
  sodium_memzero(&st, sizeof st);
  return out;
}

Authenticator::Digest Authenticator::passwordDigest(std::string_view password) const {
  crypto_generichash_state st;
  Digest out{};
  crypto_generichash_init(&st, key_.data(), key_.size(), out.size());
  crypto_generichash_update(&st, &kPasswordTag, 1);
  crypto_generichash_update(&st, reinterpret_cast<const unsigned char*>(password.data()),
                            password.size());
  crypto_generichash_final(&st, out.data(), out.size());
  sodium_memzero(&st, sizeof st);
  return out;
}

bool Authenticator::cacheHit(const Digest& key, std::string_view user) const {
  std::lock_guard lock(users_mutex_);
  const auto it = cache_.find(key);
  return it != cache_.end() && it->second.user == user && users_.hashOf(user) == it->second.hash;
}

void Authenticator::remember(const Digest& key, std::string_view user, std::string hash) {
  std::lock_guard lock(users_mutex_);
  // The password may have changed (reload) while argon2id ran: remember only the current hash.
  if (users_.hashOf(user) != hash) return;
  cache_[key] = CacheEntry{std::string(user), std::move(hash), ++cache_seq_};
  if (cache_.size() > kMaxCacheEntries) {
    auto oldest = cache_.begin();
    for (auto it = cache_.begin(); it != cache_.end(); ++it) {
      if (it->second.seq < oldest->second.seq) oldest = it;
    }
    cache_.erase(oldest);
  }
}

void Authenticator::answer(Done done, LoginResult result) {
  loop_.post([live = live_, done = std::move(done), result = std::move(result)]() mutable {
    std::lock_guard lock(live->mutex);
    if (live->alive && done) done(std::move(result));
  });
}

void Authenticator::work() {
  for (;;) {
    Job job;
    {
      std::unique_lock lock(queue_mutex_);
      queue_cv_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;
      job = std::move(queue_.front());
      queue_.pop_front();
    }
    if (job.task) {
      job.task();
      continue;
    }
    LoginResult result = verifySlow(job);
    wipe(job.password);
    answer(std::move(job.done), std::move(result));
  }
}

LoginResult Authenticator::verifySlow(Job& job) {
  // Logins queued together with the same credentials: the first one filled the cache.
  const Digest key = credentialDigest(job.user, job.password);
  if (cacheHit(key, job.user)) return {true, "cached verification"};
  std::optional<std::string> hash;
  {
    std::lock_guard lock(users_mutex_);
    hash = users_.hashOf(job.user);
  }
  ++argon2_runs_;
  argon2_thread_ = std::this_thread::get_id();
  // Unknown users cost one argon2id too, so timing does not tell which names exist.
  const bool match =
      verifyPasswordHash(hash ? *hash : std::string(dummyPasswordHash()), job.password);
  if (!hash) return {false, "unknown user"};
  if (!match) return {false, "wrong password"};
  remember(key, job.user, std::move(*hash));
  return {true, "password verified"};
}

}  // namespace skr::flow
