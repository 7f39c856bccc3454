// SPDX-License-Identifier: Apache-2.0
// Its constructor (init) throws: the C++ helper must turn that into a status and a message.
#include <skrobot/plugin.hpp>

#include <stdexcept>

namespace {

class Throws final : public skr::plugin::Module {
 public:
  explicit Throws(skr::plugin::Host& host) : tick_(host.onTick(skr::plugin::Tick::fast, [] {})) {
    throw std::runtime_error("boom in the constructor");
  }

 private:
  skr::plugin::TickHandle tick_;
};

}  // namespace

SKR_MODULE(Throws, "init_throws", "0.1.0", "init throws", 0)
