// SPDX-License-Identifier: Apache-2.0
// The examples in satellite/examples/cpp, run as their users would, against a real hub.
#include <signal.h>

#include "sat_fixture.h"

namespace skr::sat::test {
namespace {

class Examples : public SatTest {
 protected:
  void SetUp() override { startHub(); }
  std::unique_ptr<Child> run(const std::string& name, const std::vector<std::string>& args = {}) {
    std::vector<std::string> argv{std::string(SAT_EXAMPLES_DIR) + "/" + name};
    argv.insert(argv.end(), args.begin(), args.end());
    return std::make_unique<Child>(argv, std::vector<std::string>{"ROBOT_ADDRESS=" + address()},
                                   dir_.path() / (name + std::to_string(++runs_) + ".out"));
  }
  int runs_ = 0;
};

TEST_F(Examples, PublisherProducesOnlyForSubscribers) {
  auto pub = run("publisher", {"50"});
  ASSERT_TRUE(pub->waitOutput("channel guest.counter ready")) << pub->output();
  EXPECT_EQ(pub->output().find("publishing"), std::string::npos) << "nobody subscribed yet";
  auto sub = run("subscriber", {"guest.counter", "5"});
  EXPECT_EQ(sub->wait(), 0) << sub->output();
  const std::string out = sub->output();
  EXPECT_NE(out.find("subscribed to guest.counter"), std::string::npos) << out;
  EXPECT_NE(out.find("\"unit\":\"ticks\""), std::string::npos) << out;
  EXPECT_NE(out.find("\n0\n1\n2\n3\n4\n"), std::string::npos) << out;
  EXPECT_TRUE(pub->waitOutput("first subscriber: publishing")) << pub->output();
  EXPECT_TRUE(pub->waitOutput("no subscriber left")) << pub->output();
  pub->signal(SIGTERM);
  EXPECT_EQ(pub->wait(), 0);
}

TEST_F(Examples, ServiceProviderAndCaller) {
  auto caller_first = run("service_caller");  // waits for the service to appear
  auto provider = run("service_provider");
  ASSERT_TRUE(provider->waitOutput("serving guest.adder")) << provider->output();
  EXPECT_EQ(caller_first->wait(), 0) << caller_first->output();
  auto caller = run("service_caller");
  EXPECT_EQ(caller->wait(), 0) << caller->output();
  for (const auto& c : {caller_first.get(), caller.get()}) {
    EXPECT_NE(c->output().find("blocking: 1 + 2 + 3 = 6"), std::string::npos) << c->output();
    EXPECT_NE(c->output().find("async: 4 + 5 = 9"), std::string::npos) << c->output();
  }
  provider->signal(SIGINT);
  EXPECT_EQ(provider->wait(), 0);
}

}  // namespace
}  // namespace skr::sat::test
