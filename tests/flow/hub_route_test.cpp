// SPDX-License-Identifier: Apache-2.0
// A hub link's naming and routing rules (core/src/flow/families/links/hub_route.cpp,
// docs/hub-links.md).
#include "families/links/hub_route.h"

#include <gtest/gtest.h>

namespace skr::flow {
namespace {

TEST(HubRoute, FarChannelsArePrefixedWithTheLinksHubAndThirdHubsKeepTheirName) {
  EXPECT_EQ(linkedName("guest.camera", "arm", "head"), "arm/guest.camera");
  EXPECT_EQ(linkedName("guest.a/b", "arm", "head"), "arm/guest.a/b");  // '/' after the user
  EXPECT_EQ(linkedName("base/guest.camera", "arm", "head"), "base/guest.camera");
  EXPECT_EQ(linkedName("head/guest.camera", "arm", "head"), "");  // ours, coming back
  EXPECT_EQ(linkedName("nodot", "arm", "head"), "");
  EXPECT_EQ(linkedName(".x", "arm", "head"), "");
  EXPECT_EQ(linkedName("/guest.x", "arm", "head"), "");
  EXPECT_EQ(linkedName("base/.x", "arm", "head"), "");
}

TEST(HubRoute, TheRouteEndsWithTheLinkAndRefusesLoopsAndLongPaths) {
  EXPECT_EQ(hubRoute(Variant::Map{}, "arm"), std::vector<std::string>{"arm"});
  const Variant props(Variant::Map{{"hub_route", Variant::List{"base", 3, "mid"}}});
  EXPECT_EQ(hubRoute(props, "arm"), (std::vector<std::string>{"base", "mid", "arm"}));
  EXPECT_EQ(hubRoute(Variant::Map{{"hub_route", "base"}}, "arm"),
            std::vector<std::string>{"arm"});  // not a list: ignored
  EXPECT_TRUE(routeAccepted({"base", "arm"}, "head", 8));
  EXPECT_FALSE(routeAccepted({"head", "arm"}, "head", 8));
  EXPECT_FALSE(routeAccepted({"a", "b", "c"}, "head", 2));
  EXPECT_TRUE(routeAccepted({"a", "b"}, "head", 2));
  // The length routes compare: a channel of this hub has none.
  EXPECT_EQ(routeLength(Variant::Map{}), 0u);
  EXPECT_EQ(routeLength(props), 3u);
  EXPECT_EQ(routeLength(routedProps(Variant(), {"base", "arm"})), 2u);
  EXPECT_EQ(*routedProps(Variant::Map{{"unit", "m"}}, {"arm"}).find("unit"), Variant("m"));
}

}  // namespace
}  // namespace skr::flow
