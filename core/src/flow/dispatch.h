// SPDX-License-Identifier: Apache-2.0
// The dispatch of a received frame to its room, generated from the catalogue (catalogue.h): the
// row of the code names the family, whose room (a member of Hub named as the family) has a
// handle(Connection&, msg::X&) overload for the row's message. Connection::handleFrame has
// checked the code's direction, connection and minor before.
#pragma once

#include <skrobot/runtime/flow/protocol.h>

#include <string_view>

namespace skr::flow {

class Connection;
struct Hub;

// Decodes `body` as the message of `code` (a code the catalogue has, sent to the hub) and calls
// its room's handler; a body that does not decode closes the connection (FLOW-PROTOCOL).
void dispatch(Hub& hub, Connection& c, uint8_t code, std::string_view body);

}  // namespace skr::flow
