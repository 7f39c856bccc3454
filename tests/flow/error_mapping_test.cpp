// SPDX-License-Identifier: Apache-2.0
// One mapping between wire errors and Errc (skrobot/runtime/flow/protocol.h): every code
// round-trips, and a module (LocalClient) gets the Errc a socket satellite gets for the same
// failure. tests/hub/errors_test.cpp expects the same codes from the C++ satellite library.
#include "flow_fixture.h"

#include <skrobot/runtime/flow/protocol.h>

namespace skr::test {
namespace {

using flow::Code;
using flow::ErrorCode;
using flow::Variant;
namespace msg = flow::msg;

TEST(ErrorMapping, EveryWireErrorRoundTripsUnderItsOwnName) {
  for (uint16_t n = 0; n <= static_cast<uint16_t>(ErrorCode::internal); ++n) {
    const auto wire = static_cast<ErrorCode>(n);
    const Errc code = flow::toErrc(wire);
    EXPECT_EQ(flow::toErrorCode(code), wire) << flow::errorCodeName(wire);
    EXPECT_EQ(errcName(code), flow::errorCodeName(wire));
  }
  // Local-only codes travel as the nearest wire error, never as ok.
  for (Errc local : {Errc::config_error, Errc::parse_error, Errc::closed, Errc::abi_mismatch,
                     Errc::module_failed, Errc::exception, Errc::remote}) {
    EXPECT_NE(flow::toErrorCode(local), ErrorCode::ok) << errcName(local);
  }
  EXPECT_EQ(flow::toErrorCode(Errc::config_error), ErrorCode::invalid_argument);
  EXPECT_EQ(flow::toErrorCode(Errc::closed), ErrorCode::io_error);
  EXPECT_EQ(flow::toErrorCode(Errc::exception), ErrorCode::internal);
}

// Modules (in-process LocalClients, made on the hub thread) next to socket satellites.
class SameFailureSameCode : public FlowFixture {
 protected:
  flow::LocalClient& module(const std::string& user, flow::LocalHandlers h = {}) {
    onHub([&] { modules_.push_back(server_->attachLocal(user, user, std::move(h))); });
    return *modules_.back();
  }
  void TearDown() override {
    if (hub_) onHub([&] { modules_.clear(); });
    FlowFixture::TearDown();
  }
  std::vector<std::unique_ptr<flow::LocalClient>> modules_;
};

TEST_F(SameFailureSameCode, CreatingAChannelThatExists) {
  startHub();
  flow::LocalClient& m = module("guest");
  Errc module_code = Errc::ok;
  onHub([&] {
    ASSERT_TRUE(m.createChannel("dup", flow::ChannelKind::streaming, "", Variant()));
    auto again = m.createChannel("dup", flow::ChannelKind::streaming, "", Variant());
    ASSERT_FALSE(again);
    module_code = again.error().code;
  });
  EXPECT_EQ(module_code, Errc::already_exists);

  TestClient sat = flowClient();  // also "guest": its guest.dup exists
  ASSERT_TRUE(sat.send(msg::ChanAdd{7, uint8_t(flow::ChannelKind::streaming), "dup", "", {}}));
  auto err = as<msg::EvError>(sat.waitFor(Code::ev_error));
  ASSERT_TRUE(err);
  EXPECT_EQ(err->tag, 7u);
  EXPECT_EQ(flow::toErrc(static_cast<ErrorCode>(err->error)), module_code);
}

TEST_F(SameFailureSameCode, ARequestWhoseOwnerLeaves) {
  startHub();
  size_t requests_seen = 0;  // hub thread
  flow::LocalHandlers quiet;
  quiet.on_request = [&](uint16_t, uint64_t, const std::string&, const std::string&,
                         const Variant&) { ++requests_seen; };  // never answers
  flow::LocalClient& owner = module("owner", std::move(quiet));
  std::vector<Errc> module_answers;
  flow::LocalHandlers h;
  h.on_response = [&](uint16_t, uint32_t, Errc error, const Variant&) {
    module_answers.push_back(error);
  };
  flow::LocalClient& requester = module("requester", std::move(h));
  uint16_t svc = 0;
  onHub([&] {
    auto id = owner.createChannel("quiet", flow::ChannelKind::service, "", Variant());
    ASSERT_TRUE(id);
    svc = *id;
    ASSERT_TRUE(requester.request(svc, 1, "x", Variant()));
  });
  TestClient sat = flowClient();
  ASSERT_TRUE(sat.send(msg::ServiceRequest{5, svc, "x", Variant()}));
  size_t seen = 0;
  for (int i = 0; i < 500 && seen < 2; ++i) {
    onHub([&] { seen = requests_seen; });
    if (seen < 2) usleep(10 * 1000);
  }
  ASSERT_EQ(seen, 2u) << "both requests reach the owner";
  onHub([&] { ASSERT_TRUE(owner.removeChannel(svc)); });

  auto answer = as<msg::EvServiceResponse>(sat.waitFor(Code::ev_service_response));
  ASSERT_TRUE(answer);
  EXPECT_EQ(answer->tag, 5u);
  ASSERT_EQ(module_answers.size(), 1u);
  EXPECT_EQ(module_answers[0], Errc::owner_gone);
  EXPECT_EQ(flow::toErrc(static_cast<ErrorCode>(answer->error)), module_answers[0]);
}

}  // namespace
}  // namespace skr::test
