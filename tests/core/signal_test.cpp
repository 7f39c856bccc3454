// SPDX-License-Identifier: Apache-2.0
#include "test_support.h"

#include <skrobot/runtime/signal.h>

#include <gtest/gtest.h>

#include <atomic>
#include <string>
#include <thread>
#include <vector>

namespace skr {
namespace {

struct Sender : Object {
  explicit Sender(Loop& loop) : Object(loop) {}
  Signal<int> value{*this};
  Signal<const std::string&> text{*this};
};

struct Receiver : Object {
  explicit Receiver(Loop& loop, std::vector<std::string>* destroyed = nullptr,
                    std::string name = {})
      : Object(loop), destroyed_(destroyed), name_(std::move(name)) {}
  ~Receiver() override {
    if (destroyed_ != nullptr) destroyed_->push_back(name_);
  }
  Receiver(const Receiver&) = delete;
  Receiver& operator=(const Receiver&) = delete;
  Receiver(Receiver&&) = delete;
  Receiver& operator=(Receiver&&) = delete;

  void onValue(int v) {
    values.push_back(v);
    thread = std::this_thread::get_id();
  }
  void onText(const std::string& s) { texts.push_back(s); }
  void onOther(int v) { others.push_back(v); }
  void wrongType(const std::string&) {}

  std::vector<int> values;
  std::vector<int> others;
  std::vector<std::string> texts;
  std::thread::id thread;
  std::vector<std::string>* destroyed_;
  std::string name_;
};

// Type safety: a slot with other parameters is not accepted by connect().
template <typename S, typename R, typename M>
concept CanConnect = requires(S& s, R* r, M m) {
  s.connect(r, m);
};
static_assert(CanConnect<Signal<int>, Receiver, void (Receiver::*)(int)>);
static_assert(!CanConnect<Signal<int>, Receiver, void (Receiver::*)(const std::string&)>);
static_assert(!CanConnect<Signal<const std::string&>, Receiver, void (Receiver::*)(int)>);
static_assert(!CanConnect<Signal<int>, Receiver, int (Receiver::*)(int, int)>);

TEST(Signal, DirectSlotRunsInEmitterAfterTheAttachPulse) {
  Loop loop;
  Sender s(loop);
  Receiver r(loop);
  auto c = s.value.connect(&r, &Receiver::onValue);
  EXPECT_TRUE(c.connected());
  s.value.emit(1);  // attach takes effect at the next pulse
  EXPECT_TRUE(r.values.empty());
  test::pump(loop);
  s.value.emit(2);
  ASSERT_EQ(r.values, std::vector<int>{2});
  EXPECT_EQ(r.thread, std::this_thread::get_id());
  EXPECT_EQ(s.value.connectionCount(), 1u);
}

TEST(Signal, SameSlotNeverConnectedTwice) {
  Loop loop;
  Sender s(loop);
  Receiver r(loop);
  s.value.connect(&r, &Receiver::onValue);
  s.value.connect(&r, &Receiver::onValue, ConnectionType::queued);
  s.value.connect(&r, &Receiver::onOther);  // another slot of the same receiver is fine
  test::pump(loop);
  s.value.emit(7);
  EXPECT_EQ(r.values, std::vector<int>{7});
  EXPECT_EQ(r.others, std::vector<int>{7});
  EXPECT_EQ(s.value.connectionCount(), 2u);
}

TEST(Signal, DisconnectTakesEffectAtNextPulse) {
  Loop loop;
  Sender s(loop);
  Receiver r(loop);
  s.value.connect(&r, &Receiver::onValue);
  test::pump(loop);
  EXPECT_TRUE(s.value.disconnect(&r, &Receiver::onValue));
  s.value.emit(1);  // still attached until the pulse
  test::pump(loop);
  s.value.emit(2);
  EXPECT_EQ(r.values, std::vector<int>{1});
  EXPECT_EQ(s.value.connectionCount(), 0u);
  EXPECT_FALSE(s.value.disconnect(&r, &Receiver::onValue));
}

TEST(Signal, QueuedRunsOnReceiverLoopThreadWithCopies) {
  Loop sender_loop;
  LoopThread receiver_thread(LoopOptions{});
  receiver_thread.start();
  Sender s(sender_loop);
  std::unique_ptr<Receiver> r;
  receiver_thread.loop().invoke([&] { r = std::make_unique<Receiver>(receiver_thread.loop()); });
  std::atomic<int> delivered{0};
  s.text.connect(
      r.get(), [&](const std::string&) { ++delivered; }, ConnectionType::queued);
  s.text.connect(r.get(), &Receiver::onText, ConnectionType::queued);
  s.value.connect(r.get(), &Receiver::onValue, ConnectionType::queued);
  test::pump(sender_loop);
  {
    std::string payload = "hello";
    s.text.emit(payload);
    payload = "changed";  // the queued call holds its own copy
  }
  s.value.emit(42);
  while (delivered == 0) std::this_thread::yield();
  std::vector<std::string> texts;
  std::vector<int> values;
  std::thread::id thread;
  // Queued calls run in posting order; read the results on the receiver's thread.
  for (;;) {
    receiver_thread.loop().invoke([&] {
      texts = r->texts;
      values = r->values;
      thread = r->thread;
    });
    if (!values.empty()) break;
  }
  EXPECT_EQ(texts, std::vector<std::string>{"hello"});
  EXPECT_EQ(values, std::vector<int>{42});
  EXPECT_NE(thread, std::this_thread::get_id());
  receiver_thread.loop().invoke([&] { r.reset(); });
}

TEST(Signal, QueuedDoesNotRunInsideEmit) {
  Loop loop;
  Sender s(loop);
  Receiver r(loop);
  s.value.connect(&r, &Receiver::onValue, ConnectionType::queued);
  test::pump(loop);
  s.value.emit(5);
  EXPECT_TRUE(r.values.empty());
  test::pump(loop);
  EXPECT_EQ(r.values, std::vector<int>{5});
}

TEST(Signal, OneShotDirectAndQueuedFireOnce) {
  Loop loop;
  Sender s(loop);
  Receiver r(loop);
  auto direct = s.value.connect(&r, &Receiver::onValue, ConnectionType::one_shot_direct);
  auto queued = s.value.connect(&r, &Receiver::onOther, ConnectionType::one_shot_queued);
  test::pump(loop);
  s.value.emit(1);
  s.value.emit(2);
  test::pump(loop);
  s.value.emit(3);
  test::pump(loop);
  EXPECT_EQ(r.values, std::vector<int>{1});
  EXPECT_EQ(r.others, std::vector<int>{1});
  EXPECT_FALSE(direct.connected());
  EXPECT_FALSE(queued.connected());
  EXPECT_EQ(s.value.connectionCount(), 0u);
}

TEST(Signal, DestroyedReceiverIsDetachedAndItsQueuedCallsDropped) {
  Loop loop;
  Sender s(loop);
  auto r = std::make_unique<Receiver>(loop);
  int lambda_calls = 0;
  auto c = s.value.connect(r.get(), &Receiver::onValue, ConnectionType::queued);
  s.value.connect(r.get(), [&](int) { ++lambda_calls; });
  test::pump(loop);
  s.value.emit(1);  // queued call posted, not yet run
  r.reset();
  test::pump(loop);  // must not touch the dead receiver (ASan would tell)
  s.value.emit(2);
  EXPECT_EQ(lambda_calls, 1);
  EXPECT_FALSE(c.connected());
  EXPECT_EQ(s.value.connectionCount(), 0u);
}

void freeSlot(int v);
std::vector<int> g_free_values;
void freeSlot(int v) {
  g_free_values.push_back(v);
}

TEST(Signal, FunctionPointerSlotsAndDisconnectAll) {
  Loop loop;
  Sender s(loop);
  g_free_values.clear();
  s.value.connect(&freeSlot);
  s.value.connect(&freeSlot);  // duplicate refused
  test::pump(loop);
  s.value.emit(3);
  s.value.disconnectAll();
  test::pump(loop);
  s.value.emit(4);
  EXPECT_EQ(g_free_values, std::vector<int>{3});
}

TEST(Signal, EmitFromManyThreadsWithQueuedReceiver) {
  Loop loop;
  Sender s(loop);
  Receiver r(loop);
  s.value.connect(&r, &Receiver::onValue, ConnectionType::queued);
  test::pump(loop);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&] {
      for (int i = 0; i < 1000; ++i) s.value.emit(i);
    });
  }
  for (auto& t : threads) t.join();
  ASSERT_TRUE(loop.runUntil([&] { return r.values.size() == 4000; }, 20 * kNsPerSec));
}

TEST(Object, ChildrenDestroyedWithParentInReverseOrder) {
  Loop loop;
  std::vector<std::string> destroyed;
  {
    Receiver parent(loop, &destroyed, "parent");
    parent.makeChild<Receiver>(&destroyed, "a");
    auto& b = parent.makeChild<Receiver>(&destroyed, "b");
    b.makeChild<Receiver>(&destroyed, "b1");
    EXPECT_EQ(parent.childCount(), 2u);
    EXPECT_EQ(b.parent(), &parent);
  }
  EXPECT_EQ(destroyed, (std::vector<std::string>{"parent", "b", "b1", "a"}));
}

TEST(Object, DeleteLaterDestroysAtNextPulse) {
  Loop loop;
  std::vector<std::string> destroyed;
  Receiver parent(loop, &destroyed, "parent");
  auto& child = parent.makeChild<Receiver>(&destroyed, "child");
  child.deleteLater();
  EXPECT_TRUE(destroyed.empty());
  test::pump(loop);
  EXPECT_EQ(destroyed, std::vector<std::string>{"child"});
  EXPECT_EQ(parent.childCount(), 0u);

  deleteLater(std::make_unique<Receiver>(loop, &destroyed, "top"));
  EXPECT_EQ(destroyed.size(), 1u);
  test::pump(loop);
  EXPECT_EQ(destroyed.back(), "top");
}

TEST(Object, DeleteLaterAfterParentIsGoneIsHarmless) {
  Loop loop;
  std::vector<std::string> destroyed;
  auto parent = std::make_unique<Receiver>(loop, &destroyed, "parent");
  parent->makeChild<Receiver>(&destroyed, "child").deleteLater();
  parent.reset();
  test::pump(loop);
  EXPECT_EQ(destroyed, (std::vector<std::string>{"parent", "child"}));
}

TEST(Object, TickHandlersEndWithTheObject) {
  LoopOptions o;
  o.fast_interval_ns = kNsPerMs;
  Loop loop(o);
  int ticks = 0;
  auto r = std::make_unique<Receiver>(loop);
  r->onTick(Tick::fast, [&] { ++ticks; });
  ASSERT_TRUE(loop.runUntil([&] { return ticks >= 2; }, 10 * kNsPerSec));
  r.reset();
  const int before = ticks;
  const auto fast = loop.stats().fast_ticks;
  loop.runUntil([&] { return loop.stats().fast_ticks >= fast + 3; }, 10 * kNsPerSec);
  EXPECT_EQ(ticks, before);
}

}  // namespace
}  // namespace skr
