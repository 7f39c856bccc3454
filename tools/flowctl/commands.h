// SPDX-License-Identifier: Apache-2.0
// flowctl's commands: one row each (commands.cpp) with the word the operator types, the texts
// that explain it and the handler that runs it. The overview (flowctl --help), a command's help
// (flowctl help NAME), its usage error, the unknown-command error, the dispatch and the docs'
// list of commands (flowctl help --markdown) are all read from these rows. Adding a command: one
// row in commands.cpp and one handler (declared in cli.h).
#pragma once

#include <string>
#include <string_view>

#include "cli.h"

namespace flowctl {

struct Command {
  std::string_view name;  // what the operator types after the global options; the row's key
  // The overview's line: its left column (empty: the row has no line of its own, another row's
  // synopsis lists it, as hz's lists bw) and its right column ('\n' starts a new line there).
  std::string_view synopsis = {};
  std::string_view summary = {};
  // Printed on a usage error (usageError); empty: the help is printed instead.
  std::string_view usage = {};
  std::string_view help = {};            // flowctl help NAME, or NAME --help (every row has one)
  int (*run)(const Cli& cli) = nullptr;  // the handler; null for help, which main answers
};

// The row named `name`, or null.
const Command* findCommand(std::string_view name);

// flowctl --help: the global options, every row's line, the exit codes.
std::string overview();
// flowctl help --markdown: the commands as a Markdown list, one item per line of the overview
// (help aside); README.md and docs/cpp-satellites.md hold it (tests/commands_markdown.py).
std::string commandsMarkdown();
// flowctl help NAME: the row's help, or "" when there is no such command.
std::string_view commandHelp(std::string_view name);
// "unknown command 'NAME' (see flowctl --help)"; returns kUsage.
int unknownCommand(const std::string& name);

}  // namespace flowctl
