// SPDX-License-Identifier: Apache-2.0
#include "families/session/login_throttle.h"

#include <algorithm>
#include <vector>

namespace skr::flow {

namespace {

std::string userKey(std::string_view user) {
  return "user:" + std::string(user);
}
std::string sourceKey(std::string_view source) {
  return "from:" + std::string(source);
}

}  // namespace

Nanos LoginThrottle::wait(std::string_view user, std::string_view source, Nanos now) const {
  Nanos until = 0;
  for (const std::string& key : {userKey(user), sourceKey(source)}) {
    if (auto it = entries_.find(key); it != entries_.end())
      until = std::max(until, it->second.until);
  }
  return until > now ? until - now : 0;
}

void LoginThrottle::failed(std::string_view user, std::string_view source, Nanos now) {
  if (entries_.size() >= kMaxEntries) prune(now);
  fail(userKey(user), now);
  if (!source.empty()) fail(sourceKey(source), now);
}

void LoginThrottle::succeeded(std::string_view user, std::string_view source) {
  entries_.erase(userKey(user));
  entries_.erase(sourceKey(source));
}

void LoginThrottle::fail(const std::string& key, Nanos now) {
  Entry& e = entries_[key];
  if (e.last != 0 && now - e.last > kForgetAfter) e = Entry{};
  ++e.failures;
  const Nanos delay =
      e.failures >= 6 ? kMaxDelay : std::min(kMaxDelay, kFirstDelay << (e.failures - 1));
  e.until = now + delay;
  e.last = now;
}

void LoginThrottle::prune(Nanos now) {
  std::erase_if(entries_, [now](const auto& kv) { return now - kv.second.last > kForgetAfter; });
  // Still full (a flood of names): forget the oldest half rather than grow without bound.
  if (entries_.size() >= kMaxEntries) {
    std::vector<Nanos> lasts;
    lasts.reserve(entries_.size());
    for (const auto& [k, e] : entries_) lasts.push_back(e.last);
    std::nth_element(lasts.begin(), lasts.begin() + lasts.size() / 2, lasts.end());
    const Nanos median = lasts[lasts.size() / 2];
    std::erase_if(entries_, [median](const auto& kv) { return kv.second.last <= median; });
  }
}

}  // namespace skr::flow
