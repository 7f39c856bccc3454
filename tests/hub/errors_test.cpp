// SPDX-License-Identifier: Apache-2.0
// The hub's failures reach a C++ satellite as Errc values of the one mapping in
// skrobot/runtime/flow/protocol.h. tests/flow/error_mapping_test.cpp causes the same failures from
// a module (LocalClient) and expects the same codes.
#include <algorithm>
#include <string>

#include "log_capture.h"
#include "sat_fixture.h"

namespace skr::sat::test {
namespace {

using flow::ErrorCode;

class SatErrors : public SatTest {
 protected:
  void SetUp() override { startHub(); }
};

TEST_F(SatErrors, TimeoutOwnerGoneAndAlreadyExistsKeepTheirNames) {
  auto provider = satellite("provider");
  auto requests = std::make_shared<Events>();
  provider->on([&](Satellite& s) {
    ASSERT_TRUE(s.addChannel({.name = "quiet", .kind = flow::ChannelKind::service}));
    s.serviceRequest.connect(&s, [requests](const Request& r) { requests->add(r.command); });
  });  // never answers
  ASSERT_TRUE(eventually([&] { return provider->events.count("ready:guest.quiet") == 1; }));
  auto caller = satellite("caller");
  ASSERT_TRUE(eventually([&] {
    return caller->on([](Satellite& s) { return s.channel("guest.quiet") != nullptr; });
  }));

  // A blocking call that nobody answers in time.
  auto slow = caller->on([](Satellite& s) { return s.call("guest.quiet", "x", 1, 200); });
  ASSERT_FALSE(slow);
  EXPECT_EQ(slow.error().code, Errc::timeout) << slow.error().describe();

  // An asynchronous request whose owner removes the channel before answering.
  auto answers = std::make_shared<Events>();
  auto tag = caller->on([&](Satellite& s) {
    return s.request("guest.quiet", "async", 1, [answers](const Response& r) {
      answers->add(std::string(errcName(r.errc())));
    });
  });
  ASSERT_TRUE(tag) << tag.error().message;
  // The request reached the owner (else the removal could overtake it: not_found).
  ASSERT_TRUE(eventually([&] { return requests->count("async") == 1; }));
  ASSERT_TRUE(provider->on([](Satellite& s) { return s.removeChannel("quiet"); }));
  ASSERT_TRUE(eventually([&] { return answers->count("") == 1; })) << answers->dump();
  EXPECT_EQ(answers->with(""), std::vector<std::string>{"owner_gone"});

  // A channel that exists already (another satellite of the same user holds "guest.twin").
  ASSERT_TRUE(provider->on([](Satellite& s) { return s.addChannel({.name = "twin"}); }));
  ASSERT_TRUE(eventually([&] { return provider->events.count("ready:guest.twin") == 1; }));
  auto refusals = std::make_shared<Events>();
  caller->on([&](Satellite& s) {
    s.error.connect(&s, [refusals](const FlowError& e) {
      refusals->add(std::string(errcName(flow::toErrc(static_cast<ErrorCode>(e.error)))));
    });
    ASSERT_TRUE(s.addChannel({.name = "twin"}));  // accepted here, refused by the hub
  });
  ASSERT_TRUE(eventually([&] { return refusals->count("") >= 1; })) << caller->events.dump();
  EXPECT_EQ(refusals->with("").front(), "already_exists");
}

// A second publisher of a channel (another satellite of the same user): addChannel() accepts it
// here, the hub refuses it later, and the library reports that: the `error` signal (CHAN_ADD,
// already_exists, a message naming the channel) and a SAT-HUB-ERROR line naming it; no
// `channelReady`. It asks again once a second, ten times at most (docs/cpp-satellites.md): when
// the owner goes meanwhile, the channel becomes this satellite's.
TEST_F(SatErrors, ASecondPublisherOfAChannelHearsTheRefusal) {
  const skr::test::LogCapture logs;
  auto first = satellite("first");
  ASSERT_TRUE(first->on([](Satellite& s) { return s.addChannel({.name = "camera"}); }));
  ASSERT_TRUE(eventually([&] { return first->events.count("ready:guest.camera") == 1; }));
  auto second = satellite("second");
  auto refusals = std::make_shared<Events>();
  second->on([&](Satellite& s) {
    s.error.connect(&s, [refusals](const FlowError& e) {
      refusals->add(std::string(flow::codeName(e.command)) + " " +
                    std::string(errcName(flow::toErrc(static_cast<ErrorCode>(e.error)))) + " " +
                    e.message);
    });
    ASSERT_TRUE(s.addChannel({.name = "camera"}));  // accepted here: the hub answers later
  });
  ASSERT_TRUE(eventually([&] { return refusals->count("") >= 1; })) << second->events.dump();
  const std::string refusal = refusals->with("").front();
  EXPECT_EQ(refusal.rfind("CHAN_ADD already_exists ", 0), 0U) << refusal;
  EXPECT_NE(refusal.find("guest.camera"), std::string::npos) << refusal;
  const auto lines = logs.lines();
  EXPECT_TRUE(std::any_of(lines.begin(), lines.end(), [](const std::string& l) {
    return l.rfind("SAT-HUB-ERROR the hub refused CHAN_ADD camera: already_exists", 0) == 0;
  })) << "no SAT-HUB-ERROR line naming the channel";
  EXPECT_EQ(second->events.count("ready:guest.camera"), 0U) << second->events.dump();

  first.reset();  // the owner goes: one of the next attempts gets the channel
  EXPECT_TRUE(eventually([&] { return second->events.count("ready:guest.camera") == 1; }))
      << second->events.dump();
}

}  // namespace
}  // namespace skr::sat::test
