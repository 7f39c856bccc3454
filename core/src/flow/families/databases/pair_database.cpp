// SPDX-License-Identifier: Apache-2.0
// PairDatabase: the pairs, their validation and their JSON form. The store and its files are in
// database_store.cpp.
#include <skrobot/hub/flow/pair_database.h>

#include <algorithm>
#include <cstdio>
#include <limits>

namespace skr::flow {
namespace {

// Why `key` cannot be a key, or empty.
std::string keyProblem(std::string_view key) {
  if (key.size() > std::numeric_limits<uint16_t>::max()) {
    return "key of " + std::to_string(key.size()) + " bytes exceeds 65535";
  }
  if (!isValidUtf8(key)) return "key is not valid UTF-8";
  return {};
}

// A key for messages: at most 64 bytes of it.
std::string shownKey(std::string_view key) {
  return "\"" + std::string(key.substr(0, 64)) + (key.size() > 64 ? "...\"" : "\"");
}

}  // namespace

const Variant* PairDatabase::get(std::string_view key) const noexcept {
  const auto it = pairs_.find(key);
  return it == pairs_.end() ? nullptr : &it->second;
}

bool PairDatabase::contains(std::string_view key) const noexcept {
  return pairs_.contains(key);
}

Result<void> PairDatabase::set(std::string key, Variant value) {
  if (std::string why = keyProblem(key); !why.empty()) {
    return makeError(Errc::invalid_argument, "database \"" + name_ + "\": " + why);
  }
  DecodeLimits limits;
  limits.max_depth = kDatabaseMaxDepth;
  if (Result<void> r = checkEncodable(value, limits); !r) {
    return makeError(r.error().code,
                     "database \"" + name_ + "\" key " + shownKey(key) + ": " + r.error().message);
  }
  auto it = pairs_.find(key);
  if (it == pairs_.end()) {
    it = pairs_.emplace(std::move(key), std::move(value)).first;
  } else if (it->second == value) {
    return {};
  } else {
    it->second = std::move(value);
  }
  changed();
  if (listener_ != nullptr) listener_->onSet(*this, it->first, it->second);
  return {};
}

bool PairDatabase::remove(std::string_view key) {
  const auto it = pairs_.find(key);
  if (it == pairs_.end()) return false;
  pairs_.erase(it);
  changed();
  if (listener_ != nullptr) listener_->onRemove(*this, key);
  return true;
}

void PairDatabase::clear() {
  if (pairs_.empty()) return;
  pairs_.clear();
  changed();
  if (listener_ != nullptr) listener_->onClear(*this);
}

std::vector<std::string> PairDatabase::keys() const {
  std::vector<std::string> out;
  out.reserve(pairs_.size());
  for (const auto& [key, value] : pairs_) out.push_back(key);
  return out;
}

Json::Value PairDatabase::toJson() const {
  Json::Value out(Json::objectValue);
  for (const auto& [key, value] : pairs_) out[key] = value.toJson();
  return out;
}

Result<PairDatabase> PairDatabase::fromJson(std::string name, const Json::Value& pairs) {
  if (!pairs.isObject()) return makeError(Errc::parse_error, "pairs must be a JSON object");
  PairDatabase db(std::move(name));
  for (auto it = pairs.begin(); it != pairs.end(); ++it) {
    std::string key = it.name();
    if (std::string why = keyProblem(key); !why.empty()) {
      return makeError(Errc::parse_error, "pairs: " + why);
    }
    Result<Variant> value = Variant::fromJson(*it, kDatabaseMaxDepth);
    if (!value) {
      return makeError(Errc::parse_error,
                       "pairs key " + shownKey(key) + ": " + value.error().message);
    }
    if (Result<void> r = db.set(std::move(key), std::move(value).value()); !r) {
      return makeError(Errc::parse_error, r.error().message);
    }
  }
  return db;
}

Result<void> validateDatabaseName(std::string_view name) {
  if (name.empty()) return makeError(Errc::invalid_argument, "database name is empty");
  if (name.size() > 128) {
    return makeError(Errc::invalid_argument,
                     "database name of " + std::to_string(name.size()) + " characters exceeds 128");
  }
  if (name.front() == '.') {
    return makeError(Errc::invalid_argument,
                     "database name \"" + std::string(name) + "\" must not start with '.'");
  }
  for (size_t i = 0; i < name.size(); ++i) {
    const char c = name[i];
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '.' || c == '-';
    if (!ok) {
      char code[8];
      std::snprintf(code, sizeof code, "0x%02x", static_cast<unsigned char>(c));
      return makeError(Errc::invalid_argument,
                       "database name has character " + std::string(code) + " at position " +
                           std::to_string(i) +
                           "; only letters, digits, '_', '.' and '-' may be used");
    }
  }
  return {};
}

bool validHubName(std::string_view name) noexcept {
  if (name.empty() || name.size() > 64) return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-';
  });
}

}  // namespace skr::flow
