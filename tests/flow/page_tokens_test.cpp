// SPDX-License-Identifier: Apache-2.0
// Page tokens (families/session/page_tokens.h): a token logs in as the page account until it
// expires, from the address that fetched it only; issuance is throttled per address and bounded.
#include "families/session/page_tokens.h"

#include <gtest/gtest.h>

#include <set>

namespace skr::flow {
namespace {

constexpr Nanos kSec = kNsPerSec;

TEST(PageTokens, ALiveTokenLogsInFromItsAddressUntilItExpires) {
  PageTokens t("web-page", 1 * kSec);
  auto issued = t.issue("127.0.0.1", 0);
  ASSERT_TRUE(issued.ok()) << issued.error().message;
  EXPECT_EQ(issued->token.size(), 43u);
  EXPECT_EQ(issued->token.find_first_of("+/="), std::string::npos);  // base64url, no padding
  EXPECT_EQ(issued->account, "web-page");
  // Any number of logins while it lives.
  EXPECT_EQ(t.redeem(issued->token, "127.0.0.1", kSec / 2), "web-page");
  EXPECT_EQ(t.redeem(issued->token, "127.0.0.1", kSec / 2), "web-page");
  std::string why;
  EXPECT_FALSE(t.redeem(issued->token, "192.168.1.9", kSec / 2, &why));
  EXPECT_EQ(why, "page token fetched from another address");
  EXPECT_FALSE(t.redeem(issued->token, "127.0.0.1", kSec, &why));
  EXPECT_EQ(why, "expired page token");
  EXPECT_EQ(t.live(), 0u);
  std::string forged = issued->token;
  forged[0] = forged[0] == 'A' ? 'B' : 'A';
  EXPECT_FALSE(t.redeem(forged, "127.0.0.1", 0, &why));
  EXPECT_FALSE(t.redeem("short", "127.0.0.1", 0, &why));
  EXPECT_EQ(why, "not a page token");
}

TEST(PageTokens, EachTokenIsNewAndIssuanceIsThrottledPerAddress) {
  PageTokens t("web-page", 60 * kSec);
  std::set<std::string> seen;
  for (size_t i = 0; i < PageTokens::kBurst; ++i) {
    auto r = t.issue("10.0.0.1", 0);
    ASSERT_TRUE(r.ok()) << i;
    EXPECT_TRUE(seen.insert(r->token).second);
  }
  auto refused = t.issue("10.0.0.1", 0);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, Errc::limit_exceeded);
  EXPECT_TRUE(t.issue("10.0.0.2", 0).ok());  // another address has its own allowance
  EXPECT_TRUE(t.issue("10.0.0.1", PageTokens::kRefillInterval).ok());  // one more after a while
  EXPECT_FALSE(t.issue("10.0.0.1", PageTokens::kRefillInterval).ok());
}

TEST(PageTokens, AtMostKMaxLiveTokensLive) {
  PageTokens t("web-page", 60 * kSec);
  for (size_t i = 0; i < PageTokens::kMaxLive; ++i) {
    ASSERT_TRUE(t.issue("10.1." + std::to_string(i / 256) + "." + std::to_string(i % 256), 0).ok())
        << i;
  }
  auto full = t.issue("10.9.9.9", 0);
  ASSERT_FALSE(full.ok());
  EXPECT_EQ(full.error().code, Errc::limit_exceeded);
  EXPECT_TRUE(t.issue("10.9.9.9", 61 * kSec).ok());  // the old ones expired
}

}  // namespace
}  // namespace skr::flow
