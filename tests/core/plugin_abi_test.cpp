// SPDX-License-Identifier: Apache-2.0
// The binary layout of the seam: a module built against an older header must find every host
// function where it was. Slots are spent from `reserved` without moving what follows
// (docs/plugins.md, "Plan for the ABI changes"); 1.8 spent the last one, so a later minor grows
// the table at its end. A change that fails here breaks modules built before it: add at the end
// instead, or raise the major version.
#include <skrobot/plugin.h>

#include <gtest/gtest.h>

#include <cstddef>

namespace {

constexpr size_t kHeader = 8;  // struct_size, abi_major, abi_minor
constexpr size_t kPtr = sizeof(void (*)(void));
// 1.0, 1.1 and 1.3 to 1.8 named functions: the 49 function pointers of 1.0's table, every
// reserved slot spent.
constexpr size_t kFunctionSlots = 49;
// What later minors added at the end: 1.9 two, 1.10 one.
constexpr size_t kGrownSlots = 3;

TEST(PluginAbi, HostTableKeptItsSizeUntilTheReservedSlotsRanOutThenGrewAtItsEnd) {
  EXPECT_EQ(sizeof(skr_host_api), kHeader + (kFunctionSlots + kGrownSlots) * kPtr);
  EXPECT_EQ(offsetof(skr_host_api, ws_close), kHeader + (kFunctionSlots - 1) * kPtr);
}

TEST(PluginAbi, FunctionsOfReleasedMinorsStayWhereTheyWere) {
  // 1.0
  EXPECT_EQ(offsetof(skr_host_api, log), kHeader + 0 * kPtr);
  EXPECT_EQ(offsetof(skr_host_api, config_string), kHeader + 2 * kPtr);
  EXPECT_EQ(offsetof(skr_host_api, tick_add), kHeader + 9 * kPtr);
  EXPECT_EQ(offsetof(skr_host_api, post), kHeader + 11 * kPtr);
  EXPECT_EQ(offsetof(skr_host_api, module_name), kHeader + 16 * kPtr);
  // 1.1: channels and databases, in the first reserved slots of 1.0.
  EXPECT_EQ(offsetof(skr_host_api, channel_create), kHeader + 17 * kPtr);
  EXPECT_EQ(offsetof(skr_host_api, publish), kHeader + 20 * kPtr);
  EXPECT_EQ(offsetof(skr_host_api, db_set), kHeader + 26 * kPtr);
  // 1.3: the database barrier, in the first reserved slot of 1.2.
  EXPECT_EQ(offsetof(skr_host_api, db_sync), kHeader + 27 * kPtr);
  // 1.4: blob channels; 1.5: the sync pulse, each in the next free slots.
  EXPECT_EQ(offsetof(skr_host_api, blob_get), kHeader + 28 * kPtr);
  EXPECT_EQ(offsetof(skr_host_api, blob_do), kHeader + 31 * kPtr);
  EXPECT_EQ(offsetof(skr_host_api, sync_pulse), kHeader + 32 * kPtr);
  EXPECT_EQ(offsetof(skr_host_api, sync_done), kHeader + 35 * kPtr);
  // 1.6: watching and the hub's name.
  EXPECT_EQ(offsetof(skr_host_api, hub_name), kHeader + 36 * kPtr);
  EXPECT_EQ(offsetof(skr_host_api, db_remove), kHeader + 41 * kPtr);
  // 1.7: physical paths.
  EXPECT_EQ(offsetof(skr_host_api, channel_paths), kHeader + 42 * kPtr);
  EXPECT_EQ(offsetof(skr_host_api, publish_commit), kHeader + 44 * kPtr);
  // 1.8: modules' WebSocket endpoints on the web port, in the last four slots.
  EXPECT_EQ(offsetof(skr_host_api, ws_serve), kHeader + 45 * kPtr);
  EXPECT_EQ(offsetof(skr_host_api, ws_close), kHeader + 48 * kPtr);
  // 1.9: retained messages, the first members past the reserved slots.
  EXPECT_EQ(offsetof(skr_host_api, publish_retained), kHeader + 49 * kPtr);
  EXPECT_EQ(offsetof(skr_host_api, retain_clear), kHeader + 50 * kPtr);
  // 1.10: a module that cannot go on.
  EXPECT_EQ(offsetof(skr_host_api, fail), kHeader + 51 * kPtr);
}

TEST(PluginAbi, DescriptorStartsWithItsVersionedHeader) {
  EXPECT_EQ(offsetof(skr_module_descriptor, struct_size), 0u);
  EXPECT_EQ(offsetof(skr_module_descriptor, abi_major), 4u);
  EXPECT_EQ(offsetof(skr_module_descriptor, abi_minor), 6u);
  EXPECT_EQ(offsetof(skr_module_descriptor, name), 8u);
  EXPECT_EQ(offsetof(skr_module_descriptor, init), 8u + 3 * kPtr + 8u);  // after flags (u64)
}

}  // namespace
