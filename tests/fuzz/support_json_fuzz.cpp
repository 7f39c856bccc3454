// SPDX-License-Identifier: Apache-2.0
// Fuzz target: the module-support library's JSON parser (skrobot/support/json.hpp), which modules
// run on messages from any publisher. It must never throw or crash; whatever it accepts must
// write out as JSON that parses back (to the same text once written again: invalid UTF-8 in a
// string becomes U+FFFD on the first write), and every string must quote to JSON.
#include <skrobot/support/json.hpp>

#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view in(reinterpret_cast<const char*>(data), size);
  if (!skr::support::parseJson(skr::support::jsonQuote(in)).ok()) std::abort();
  auto parsed = skr::support::parseJson(in, skr::support::JsonLimits{16, 1u << 16});
  if (!parsed) return 0;
  const std::string text = skr::support::writeJson(*parsed);
  auto again = skr::support::parseJson(text);
  if (!again || skr::support::writeJson(*again) != text) std::abort();
  return 0;
}
