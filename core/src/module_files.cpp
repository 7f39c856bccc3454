// SPDX-License-Identifier: Apache-2.0
// Finding module files and reading their descriptors.
#include "module_record.h"

#include <skrobot/hub/install_layout.h>

#include <unistd.h>

#include <algorithm>
#include <cstddef>
#include <cstdlib>
#include <string>
#include <string_view>
#include <system_error>

namespace skr {
namespace fs = std::filesystem;

namespace {

// The 1.0 descriptor: what every module of major 1 provides at least (1.1 added nothing to it).
constexpr uint32_t kDescriptorHeader = 8;  // struct_size, abi_major, abi_minor
constexpr uint32_t kDescriptorSize10 = offsetof(skr_module_descriptor, config_keys);
// 1.2 appended the declared config keys.
constexpr uint32_t kDescriptorSize12 =
    offsetof(skr_module_descriptor, config_key_count) + sizeof(size_t);

std::string abiText(unsigned major, unsigned minor) {
  return std::to_string(major) + "." + std::to_string(minor);
}

}  // namespace

std::string_view moduleStateName(ModuleState state) noexcept {
  switch (state) {
    case ModuleState::loaded:
      return "loaded";
    case ModuleState::inited:
      return "inited";
    case ModuleState::started:
      return "started";
    case ModuleState::stopped:
      return "stopped";
    case ModuleState::unloaded:
      return "unloaded";
  }
  return "?";
}

std::vector<fs::path> moduleSearchPath(const std::vector<fs::path>& config_paths) {
  std::vector<fs::path> dirs = config_paths;
  if (const char* env = std::getenv("SKROBOT_MODULE_PATH"); env != nullptr) {
    std::string_view rest(env);
    while (!rest.empty()) {
      const auto colon = rest.find(':');
      const std::string_view dir = rest.substr(0, colon);
      if (!dir.empty()) dirs.emplace_back(dir);
      rest = colon == std::string_view::npos ? std::string_view() : rest.substr(colon + 1);
    }
  }
  if (const fs::path exe_dir = executableDir(); !exe_dir.empty()) {
    dirs.push_back((exe_dir / ".." / "modules").lexically_normal());
    dirs.push_back(installedModuleDir());
  }
  std::vector<fs::path> unique;
  for (auto& d : dirs) {
    if (std::find(unique.begin(), unique.end(), d) == unique.end()) unique.push_back(d);
  }
  return unique;
}

Result<fs::path> resolveModule(const ModuleEntry& entry, const std::vector<fs::path>& search_path) {
  std::error_code ec;
  if (!entry.path.empty()) {
    if (!fs::is_regular_file(entry.path, ec)) {
      return makeError(Errc::not_found, "no such file: " + entry.path.string());
    }
    return fs::absolute(entry.path, ec);
  }
  if (entry.name.empty() || entry.name.find('/') != std::string::npos) {
    return makeError(Errc::not_found, "invalid module name '" + entry.name + "'");
  }
  const std::string file = entry.name + ".so";
  std::string looked;
  for (const auto& dir : search_path) {
    const fs::path candidate = dir / file;
    if (fs::is_regular_file(candidate, ec)) return fs::absolute(candidate, ec);
    looked += (looked.empty() ? "" : ", ") + dir.string();
  }
  return makeError(Errc::not_found,
                   "no " + file + " in " + (looked.empty() ? "an empty search path" : looked));
}

Result<OpenedModule> openModule(const fs::path& file) {
  auto lib = SharedLibrary::open(file);
  if (!lib) return lib.error();
  OpenedModule m;
  m.library = std::move(lib).value();
  m.info.file = file;
  auto entry = reinterpret_cast<skr_module_entry_fn>(m.library.symbol(SKR_MODULE_ENTRY_SYMBOL));
  if (entry == nullptr) {
    return makeError(Errc::not_found, std::string("no ") + SKR_MODULE_ENTRY_SYMBOL + " symbol");
  }
  const skr_module_descriptor* d = entry();
  if (d == nullptr) return makeError(Errc::parse_error, "the entry symbol returned no descriptor");
  if (d->struct_size < kDescriptorHeader) {
    return makeError(Errc::parse_error,
                     "descriptor of " + std::to_string(d->struct_size) + " bytes is too short");
  }
  m.info.abi_major = d->abi_major;
  m.info.abi_minor = d->abi_minor;
  const std::string versions = "built for ABI " + abiText(d->abi_major, d->abi_minor) +
                               ", this hub has ABI " +
                               abiText(SKR_PLUGIN_ABI_MAJOR, SKR_PLUGIN_ABI_MINOR);
  // Another major may lay the rest of the struct out differently, and a newer minor may give
  // its fields a meaning this hub does not know: refuse both on the header alone, reading nothing
  // more (tests/modules/abi/abi_compat_test.sh gives them nothing readable after it).
  if (d->abi_major != SKR_PLUGIN_ABI_MAJOR) {
    return makeError(Errc::abi_mismatch, versions + " (another major)");
  }
  if (d->abi_minor > SKR_PLUGIN_ABI_MINOR) {
    return makeError(Errc::abi_mismatch, versions + " (a newer minor); upgrade the hub");
  }
  if (d->struct_size < kDescriptorSize10) {
    return makeError(Errc::parse_error, "descriptor of " + std::to_string(d->struct_size) +
                                            " bytes is shorter than ABI 1.0's " +
                                            std::to_string(kDescriptorSize10));
  }
  if (d->name == nullptr || d->name[0] == '\0') {
    return makeError(Errc::parse_error, "the descriptor has no name");
  }
  m.info.name = d->name;
  m.info.version = d->version != nullptr ? d->version : "";
  m.info.description = d->description != nullptr ? d->description : "";
  m.info.flags = d->flags;
  if (d->init == nullptr) return makeError(Errc::parse_error, "the descriptor has no init");
  if (d->struct_size >= kDescriptorSize12 && d->config_keys != nullptr) {
    auto keys = readConfigKeys(d->config_keys, d->config_key_count);
    if (!keys) return keys.error();
    m.info.declares_config = true;
    m.info.config_keys = std::move(keys).value();
  }
  m.descriptor = d;
  return m;
}

ModuleCheck prepareModule(const ModuleEntry& entry, const std::string& json_path,
                          const std::vector<fs::path>& search_path, OpenedModule* opened_out,
                          Json::Value* config_out) {
  ModuleCheck c;
  c.name = !entry.name.empty() ? entry.name : entry.path.stem().string();
  c.json_path = json_path;
  c.enabled = entry.enabled;
  if (!entry.enabled) return c;
  auto file = resolveModule(entry, search_path);
  if (!file) {
    c.tag = "MODULE-NOT-FOUND";
    c.reason = file.error().message;
    return c;
  }
  c.file = file.value();
  auto opened = openModule(c.file);
  if (!opened) {
    switch (opened.error().code) {
      case Errc::io_error:
        c.tag = "MODULE-LOAD";
        break;
      case Errc::not_found:
        c.tag = "MODULE-NO-ENTRY";
        break;
      case Errc::abi_mismatch:
        c.tag = "MODULE-ABI";
        break;
      default:
        c.tag = "MODULE-DESCRIPTOR";
        break;
    }
    c.reason = opened.error().message;
    return c;
  }
  c.info = opened->info;
  Json::Value filled;
  c.config_problems = checkModuleConfig(c.info, entry.config, json_path + ".config", filled);
  if (!c.config_problems.empty()) {
    c.tag = "MODULE-CONFIG";
    for (const auto& p : c.config_problems) {
      c.reason += (c.reason.empty() ? "" : "; ") + p.path + ": " + p.reason;
    }
    return c;
  }
  if (opened_out != nullptr) *opened_out = std::move(opened).value();
  if (config_out != nullptr) *config_out = std::move(filled);
  return c;
}

std::vector<ModuleCheck> checkModules(const std::vector<ModuleEntry>& entries,
                                      const std::vector<fs::path>& search_path) {
  std::vector<ModuleCheck> out;
  out.reserve(entries.size());
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const ModuleEntry& e = entries[i];
    const std::string path =
        !e.json_path.empty() ? e.json_path : "$.modules[" + std::to_string(i) + "]";
    out.push_back(prepareModule(e, path, search_path, nullptr, nullptr));
  }
  return out;
}

Result<ModuleFileInfo> readModuleDescriptor(const fs::path& file) {
  auto m = openModule(file);
  if (!m) return m.error();
  return m->info;  // the library closes here
}

std::vector<ModuleListing> listModuleFiles(const std::vector<fs::path>& search_path) {
  std::vector<ModuleListing> out;
  for (const auto& dir : search_path) {
    std::error_code ec;
    std::vector<fs::path> files;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
      if (it->path().extension() == ".so" && it->is_regular_file(ec)) files.push_back(it->path());
    }
    std::sort(files.begin(), files.end());
    for (auto& f : files) out.push_back(ModuleListing{f, readModuleDescriptor(f)});
  }
  return out;
}

}  // namespace skr
