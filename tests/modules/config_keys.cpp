// SPDX-License-Identifier: Apache-2.0
// A module that declares its config keys (ABI 1.2) and logs what it reads at init
// (CONFIG-KEYS-INIT), so that tests see the host's checks and the declared defaults.
// CASE_BAD_DEFAULT builds a module whose declaration is inconsistent (default out of range).
#include <skrobot/plugin.hpp>
#include <skrobot/support/config.hpp>

#include <string>

namespace {

class ConfigKeys final : public skr::plugin::Module {
 public:
  explicit ConfigKeys(skr::plugin::Host& host) {
    host.log.info("CONFIG-KEYS-INIT", "label=", host.configString("label", "none"),
                  " count=", host.configInt("count", -1), " ratio=", host.configDouble("ratio", -1),
                  " on=", host.configBool("on", false),
                  " input=", host.configString("input", "none"),
                  " has_list=", host.configHas("list"), " json=", host.configJson());
  }
};

namespace cfg = skr::config;
constexpr skr_config_key kConfig[] = {
    cfg::string("label", "arm", "which limb").oneOf("arm|leg"),
#ifdef CASE_BAD_DEFAULT
    cfg::integer("count", "30", "how many").range(1, 10),
#else
    cfg::integer("count", "3", "how many").range(1, 10),
#endif
    cfg::number("ratio", "0.5", "a share").min(0),
    cfg::boolean("on", "true", "switch"),
    cfg::string("input", nullptr, "a channel, <owner>.<name>").required().nonEmpty(),
    cfg::array("list", nullptr, "at most two things").max(2),
    cfg::object("extra", "{}", "free-form"),
};

}  // namespace

SKR_MODULE_WITH_CONFIG(ConfigKeys, "config_keys", "1.0.0", "declares its config keys", 0, kConfig)
