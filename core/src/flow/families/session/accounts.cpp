// SPDX-License-Identifier: Apache-2.0
// The users file: validation, argon2id hashing, JSON load and crash-safe save.
#include "families/databases/file_layer.h"

#include <skrobot/hub/flow/accounts.h>
#include <skrobot/runtime/clock.h>
#include <skrobot/runtime/log.h>

#include <json/reader.h>
#include <json/writer.h>
#include <sodium.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <memory>
#include <sstream>
#include <system_error>

namespace skr::flow {
namespace {

namespace fs = std::filesystem;

constexpr std::string_view kLogSource = "flow.accounts";

// An argon2id hash (INTERACTIVE limits, like every hash we make) of a random password nobody
// knows. Unknown users are verified against it, so that they take as long as known ones.
constexpr const char* kDummyHash =
    "$argon2id$v=19$m=65536,t=2,p=1$AlT+KLbb5GJ6yjH7QF6e0g$"
    "UbWx93kXVNl+0ArFQyKilwRB6LQA2uh5IS3KQCZHGwU";

std::string errnoText(int err) {
  return std::strerror(err);
}

Result<std::string> hashPassword(std::string_view password) {
  if (auto ready = sodiumReady(); !ready) return ready.error();
  if (auto valid = validatePassword(password); !valid) return valid.error();
  char out[crypto_pwhash_STRBYTES];
  if (crypto_pwhash_str_alg(out, password.data(), password.size(),
                            crypto_pwhash_OPSLIMIT_INTERACTIVE, crypto_pwhash_MEMLIMIT_INTERACTIVE,
                            crypto_pwhash_ALG_ARGON2ID13) != 0) {
    return makeError(Errc::limit_exceeded, "argon2id hashing failed (out of memory?)");
  }
  return std::string(out);
}

// A UDP key in the users file: the base64 (original variant, padded) of its 16 bytes.
std::string udpKeyToBase64(const UdpKey& key) {
  char out[sodium_base64_ENCODED_LEN(16, sodium_base64_VARIANT_ORIGINAL)];
  sodium_bin2base64(out, sizeof out, key.data(), key.size(), sodium_base64_VARIANT_ORIGINAL);
  return out;
}

std::optional<UdpKey> udpKeyFromBase64(const std::string& text) {
  UdpKey key{};
  size_t n = 0;
  if (sodium_base642bin(key.data(), key.size(), text.data(), text.size(), nullptr, &n, nullptr,
                        sodium_base64_VARIANT_ORIGINAL) != 0 ||
      n != key.size()) {
    return std::nullopt;
  }
  return key;
}

Error fileError(const fs::path& path, const std::string& what, int err) {
  return makeError(Errc::io_error,
                   "users file " + path.string() + ": " + what + ": " + errnoText(err));
}

}  // namespace

Result<void> validateUserName(std::string_view name) {
  if (name.empty()) return makeError(Errc::invalid_argument, "user name is empty");
  if (name.size() > kMaxUserNameBytes) {
    return makeError(Errc::invalid_argument, "user name is longer than " +
                                                 std::to_string(kMaxUserNameBytes) + " characters");
  }
  for (const char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '-';
    if (!ok) {
      return makeError(Errc::invalid_argument,
                       "user name \"" + std::string(name) +
                           "\" may contain only letters, digits, '_' and '-' (channel names are "
                           "<user>.<name>)");
    }
  }
  return {};
}

Result<void> validatePassword(std::string_view password) {
  if (password.size() < kMinPasswordBytes) {
    return makeError(Errc::invalid_argument, "password is empty");
  }
  if (password.size() > kMaxPasswordBytes) {
    return makeError(Errc::invalid_argument,
                     "password is longer than " + std::to_string(kMaxPasswordBytes) + " bytes");
  }
  return {};
}

Result<void> sodiumReady() {
  // sodium_init() is itself thread-safe and idempotent; the static only saves the call.
  static const bool ready = sodium_init() >= 0;
  if (!ready) return makeError(Errc::io_error, "libsodium could not be initialised");
  return {};
}

bool verifyPasswordHash(const std::string& hash, std::string_view password) {
  if (!sodiumReady()) return false;
  return crypto_pwhash_str_verify(hash.c_str(), password.data(), password.size()) == 0;
}

Result<UsersFile> UsersFile::load(const fs::path& path) {
  if (path.empty()) return makeError(Errc::invalid_argument, "users file path is empty");
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    if (errno == ENOENT) return UsersFile(path);
    return fileError(path, "cannot stat", errno);
  }
  if (!S_ISREG(st.st_mode)) {
    return makeError(Errc::io_error, "users file " + path.string() + " is not a regular file");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) return fileError(path, "cannot open", errno);
  if ((st.st_mode & 077) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    log::warn(
        kLogSource, "ACCOUNTS-PERMS",
        "users file " + path.string() + " has mode " + mode + "; it should be 0600 (chmod 600 it)");
  }

  const auto corrupt = [&path](const std::string& why) {
    return makeError(Errc::parse_error, "users file " + path.string() + " is corrupt: " + why);
  };
  Json::CharReaderBuilder builder;
  builder["collectComments"] = false;
  builder["rejectDupKeys"] = true;
  Json::Value root;
  std::string errs;
  try {
    if (!Json::parseFromStream(builder, in, &root, &errs)) {
      while (!errs.empty() && (errs.back() == '\n' || errs.back() == ' ')) errs.pop_back();
      return corrupt("not valid JSON: " + errs);
    }
  } catch (const std::exception& e) {  // jsoncpp throws when nesting exceeds its stack limit
    return corrupt(std::string("not valid JSON: ") + e.what());
  }
  if (!root.isObject()) return corrupt("the top level is not an object");
  const Json::Value& format = root["format"];
  if (!format.isInt() || format.asInt() != kUsersFileFormat) {
    return corrupt("\"format\" must be " + std::to_string(kUsersFileFormat) +
                   " (the only format this build reads)");
  }
  const Json::Value& users = root["users"];
  if (!users.isNull() && !users.isObject()) return corrupt("\"users\" is not an object");

  UsersFile file(path);
  for (const auto& name : users.getMemberNames()) {
    const Json::Value& u = users[name];
    const std::string at = "users." + name;
    if (auto valid = validateUserName(name); !valid) return corrupt(valid.error().message);
    if (!u.isObject()) return corrupt(at + " is not an object");
    if (!u["hash"].isString() || u["hash"].asString().rfind("$argon2id$", 0) != 0) {
      return corrupt(at + ".hash is not an argon2id hash string");
    }
    if (!u["created"].isNull() && !u["created"].isString()) {
      return corrupt(at + ".created is not a string");
    }
    auto access = AccessRules::fromJson(u, at);
    if (!access) return corrupt(access.error().message);
    std::optional<UdpKey> udp_key;
    if (!u["udp_key"].isNull()) {
      udp_key = udpKeyFromBase64(u["udp_key"].isString() ? u["udp_key"].asString() : "");
      if (!udp_key) return corrupt(at + ".udp_key is not the base64 of 16 bytes");
    }
    file.users_[name] =
        Entry{u["hash"].asString(), u["created"].asString(),
              std::make_shared<const AccessRules>(std::move(access.value())), udp_key};
  }
  return file;
}

Result<void> UsersFile::save() const {
  if (path_.empty()) return makeError(Errc::invalid_argument, "users file has no path");
  Json::Value root(Json::objectValue);
  root["format"] = kUsersFileFormat;
  Json::Value& users = root["users"] = Json::Value(Json::objectValue);
  for (const auto& [name, e] : users_) {
    users[name]["hash"] = e.hash;
    users[name]["created"] = e.created;
    if (e.access) e.access->toJson(users[name]);
    if (e.udp_key) users[name]["udp_key"] = udpKeyToBase64(*e.udp_key);
  }
  Json::StreamWriterBuilder writer;
  writer["indentation"] = "  ";
  const std::string text = Json::writeString(writer, root) + "\n";

  // Crash-safe, as the database snapshots: temporary file, fsync, rename, fsync of the directory.
  const fs::path dir = path_.has_parent_path() ? path_.parent_path() : fs::path(".");
  FileLayer& files = *posixFiles();
  Result<void> r = files.makeDir(dir);
  if (r) r = replaceFile(files, dir, path_.filename().string(), text);
  if (!r)
    return makeError(Errc::io_error, "users file " + path_.string() + ": " + r.error().message);
  return {};
}

Result<void> UsersFile::add(std::string_view user, std::string_view password) {
  if (auto valid = validateUserName(user); !valid) return valid.error();
  if (contains(user)) {
    return makeError(Errc::already_exists, "user " + std::string(user) + " already exists");
  }
  auto hash = hashPassword(password);
  if (!hash) return hash.error();
  users_.emplace(std::string(user), Entry{std::move(hash.value()), utcNowText(), nullptr});
  return {};
}

Result<void> UsersFile::remove(std::string_view user) {
  const auto it = users_.find(user);
  if (it == users_.end()) {
    return makeError(Errc::not_found, "no user " + std::string(user));
  }
  users_.erase(it);
  return {};
}

Result<void> UsersFile::setPassword(std::string_view user, std::string_view password) {
  const auto it = users_.find(user);
  if (it == users_.end()) {
    return makeError(Errc::not_found, "no user " + std::string(user));
  }
  auto hash = hashPassword(password);
  if (!hash) return hash.error();
  it->second.hash = std::move(hash.value());
  return {};
}

bool UsersFile::verify(std::string_view user, std::string_view password) const {
  const auto it = users_.find(user);
  const bool known = it != users_.end();
  const bool match = verifyPasswordHash(known ? it->second.hash : kDummyHash, password);
  return known && match;
}

std::vector<std::string> UsersFile::names() const {
  std::vector<std::string> out;
  out.reserve(users_.size());
  for (const auto& [name, e] : users_) out.push_back(name);  // std::map: already sorted
  return out;
}

bool UsersFile::contains(std::string_view user) const {
  return users_.find(user) != users_.end();
}

std::optional<std::string> UsersFile::hashOf(std::string_view user) const {
  const auto it = users_.find(user);
  if (it == users_.end()) return std::nullopt;
  return it->second.hash;
}

std::optional<std::string> UsersFile::createdOf(std::string_view user) const {
  const auto it = users_.find(user);
  if (it == users_.end()) return std::nullopt;
  return it->second.created;
}

std::shared_ptr<const AccessRules> UsersFile::accessOf(std::string_view user) const {
  const auto it = users_.find(user);
  if (it == users_.end() || !it->second.access) return AccessRules::defaults();
  return it->second.access;
}

Result<void> UsersFile::setAccess(std::string_view user, AccessRules access) {
  const auto it = users_.find(user);
  if (it == users_.end()) return makeError(Errc::not_found, "no user " + std::string(user));
  it->second.access = std::make_shared<const AccessRules>(std::move(access));
  return {};
}

std::optional<UdpKey> UsersFile::udpKeyOf(std::string_view user) const {
  const auto it = users_.find(user);
  if (it == users_.end()) return std::nullopt;
  return it->second.udp_key;
}

Result<void> UsersFile::setUdpKey(std::string_view user, std::optional<UdpKey> key) {
  const auto it = users_.find(user);
  if (it == users_.end()) return makeError(Errc::not_found, "no user " + std::string(user));
  it->second.udp_key = key;
  return {};
}

std::string_view dummyPasswordHash() noexcept {
  return kDummyHash;
}

}  // namespace skr::flow
