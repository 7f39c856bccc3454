// SPDX-License-Identifier: Apache-2.0
// SERVICE_CALL (a synchronous connection waits for the answer), SERVICE_REQUEST and
// SERVICE_REQUEST_TIMED (the answer comes as an event on the flow), SERVICE_RESPONSE.
#include "families/services/services_room.h"

#include "connection.h"
#include "hub.h"

namespace skr::flow {

ServicesRoom::ServicesRoom(Hub& hub)
    : Room(hub),
      RequestTable(hub.endpoints, hub.channels, hub.opt.max_pending_requests,
                   hub.opt.request_timeout_ms) {}

void ServicesRoom::handle(Connection& c, msg::ServiceCall& m) {
  // Block first: the reply is the owner's response (an in-hub module may answer inside
  // request()), or a timeout.
  c.block();
  auto r = request(c, m.chan_id, 0, true, m.timeout_ms, m.command, m.value);
  if (!r) c.answerDone(r);
}

void ServicesRoom::handle(Connection& c, msg::ServiceRequest& m) {
  msg::ServiceRequestTimed timed{m.tag, m.chan_id, 0, std::move(m.command), std::move(m.value)};
  handle(c, timed);
}

void ServicesRoom::handle(Connection& c, msg::ServiceRequestTimed& m) {
  auto r = request(c, m.chan_id, m.tag, false, m.timeout_ms, m.command, m.value);
  // Failures of a request come back as its response, where the caller waits for them.
  if (!r) {
    c.send(msg::EvServiceResponse{m.chan_id, m.tag, uint16_t(toErrorCode(r.error().code)),
                                  Variant(r.error().message)});
  }
}

void ServicesRoom::handle(Connection& c, msg::ServiceResponse& m) {
  c.refused(Code::service_response, 0, m.chan_id, respond(c, m.chan_id, m.request, m.value));
}

void ServicesRoom::endpointLeft(Endpoint& e) {
  dropRequester(e.id);
}

void ServicesRoom::channelRemoved(const Channel& ch) {
  failChannel(ch.id, ErrorCode::owner_gone, "channel " + ch.name + " was removed");
}

void ServicesRoom::sweep(Nanos now) {
  expire(now);
}

}  // namespace skr::flow
