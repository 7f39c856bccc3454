// SPDX-License-Identifier: Apache-2.0
// flowctl: an operator's tool for a running hub, as handy as redis-cli. main reads the global
// options and hands the command to its row's handler (commands.h: the table of commands).
#include <skrobot/runtime/flow/udp.h>
#include <skrobot/runtime/log.h>

#include <cstdlib>
#include <cstring>

#include "commands.h"

int main(int argc, char** argv) {
  using namespace flowctl;
  skr::log::setLevel(skr::log::Level::error);  // flowctl speaks for itself
  Cli cli;
  std::string env_error;  // a bad ROBOT_ADDRESS matters only without --address
  if (auto env = skr::sat::ConnectOptions::fromEnvironment("flowctl")) {
    cli.connect = std::move(env).value();
  } else {
    env_error = env.error().message;
    cli.connect.client_name = "flowctl";
    if (const char* u = std::getenv("ROBOT_USER"); u != nullptr && *u != '\0') cli.connect.user = u;
    if (const char* p = std::getenv("ROBOT_PASSWORD"); p != nullptr && *p != '\0') {
      cli.connect.password = p;
    }
    if (const char* v = std::getenv("ROBOT_TLS_CA"); v != nullptr) cli.connect.tls.ca_file = v;
    if (const char* v = std::getenv("ROBOT_TLS_CERT"); v != nullptr) cli.connect.tls.cert_file = v;
    if (const char* v = std::getenv("ROBOT_TLS_KEY"); v != nullptr) cli.connect.tls.key_file = v;
  }
  bool help = false;
  bool positional_only = false;
  bool address_given = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (!positional_only) {
      std::string* target = nullptr;
      std::string address;
      std::string udp_key_file;
      std::string name = a.substr(0, a.find('='));
      if (name == "--address") target = &address;
      if (name == "--udp-key-file") target = &udp_key_file;
      if (name == "--user") target = &cli.connect.user;
      if (name == "--password") target = &cli.connect.password;
      if (name == "--ca") target = &cli.connect.tls.ca_file;
      if (name == "--cert") target = &cli.connect.tls.cert_file;
      if (name == "--key") target = &cli.connect.tls.key_file;
      if (target != nullptr) {
        if (name.size() < a.size()) {
          *target = a.substr(name.size() + 1);
        } else if (i + 1 < argc) {
          *target = argv[++i];
        } else {
          return fail(kUsage, name + " needs a value");
        }
        if (target == &address) {
          auto parsed = skr::sat::Address::parse(address);
          if (!parsed) return fail(kUsage, parsed.error().message);
          cli.connect.address = std::move(parsed).value();
          address_given = true;
        }
        if (target == &udp_key_file) {
          auto key = skr::flow::transport::readUdpKeyFile(udp_key_file);
          if (!key) return fail(kUsage, "--udp-key-file: " + key.error().message);
          cli.connect.udp_key = *key;
        }
        continue;
      }
      if (a == "--json") {
        cli.json = true;
        continue;
      }
      if (a == "--help" || a == "-h") {
        help = true;
        continue;
      }
      if (a == "--") positional_only = true;
    }
    if (cli.command.empty() && !a.starts_with("-")) {
      cli.command = a;
    } else {
      cli.args.push_back(a);
    }
  }
  const Command* command = findCommand(cli.command);
  if (command != nullptr && command->run == nullptr) {  // help [COMMAND]
    help = true;
    cli.command = cli.args.empty() ? "" : cli.args[0];
  }
  if (help || cli.command.empty()) {
    const std::string text = cli.command.empty()           ? overview()
                             : cli.command == "--markdown" ? commandsMarkdown()
                                                           : std::string(commandHelp(cli.command));
    if (text.empty()) return unknownCommand(cli.command);
    std::fputs(text.c_str(), help ? stdout : stderr);
    return help ? kOk : kUsage;
  }
  if (!env_error.empty() && !address_given) return fail(kUsage, env_error);
  if (command == nullptr) return unknownCommand(cli.command);
  return command->run(cli);
}
