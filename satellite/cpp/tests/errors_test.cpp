// The hub's failures reach a C++ satellite as Errc values of the one mapping in
// skrobot/flow/protocol.h. tests/flow/error_mapping_test.cpp causes the same failures from a
// module (LocalClient) and expects the same codes.
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

}  // namespace
}  // namespace skr::sat::test
