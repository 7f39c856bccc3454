// SPDX-License-Identifier: Apache-2.0
// flowctl's table of commands (commands.h) and the texts made from it.
#include "commands.h"

#include <iterator>

namespace flowctl {

namespace {

constexpr std::string_view kHzBwHelp = R"(usage: flowctl hz|bw CHANNEL [--window N] [--count N]
  Subscribes to a streaming channel and prints, once a second, over its last N messages (100):
  hz the rate and the interval's min, max and standard deviation; bw the bytes per second and
  the message sizes. --count N stops after N lines.
)";

// One row per command, in the overview's order. The texts are printed as they are written.
constexpr Command kCommands[] = {
    {.name = "ls",
     .synopsis = "ls",
     .summary = "list the hub's channels: id, kind, hub, name, owner, subscribers,\n"
                "mime, properties",
     .help = R"(usage: flowctl ls [PATTERN...]
  Lists the channels whose names match a PATTERN (all without one). In a pattern '*' is any run
  within one part of the name (parts are separated by '.'), '**' any run across parts, '?' one
  character; a PATTERN starting with '!' excludes what it matches. Examples:
    flowctl ls 'guest.*'            guest's channels
    flowctl ls '*.faces'            every user's "faces" channel
    flowctl ls '**' '!**.debug'     everything but debug channels
)",
     .run = cmdLs},
    {.name = "echo",
     .synopsis = "echo CHANNEL",
     .summary = "print the data published on a streaming channel",
     .usage = "usage: flowctl echo CHANNEL [options]",
     .help =
         R"(usage: flowctl echo CHANNEL [--format auto|text|hex|json] [--count N] [--rate] [--wait]
                    [--queue BYTES] [--max-hz N]
  Subscribes to a streaming channel and prints each message.
  --format    auto (text when printable, else hex; the default), text, hex, or json (a
              binary Variant payload or JSON text, shown as JSON); auto and json show a
              ROS 2 channel (cdr with a ros2msg schema, or a shipped type) as JSON
  --count N   stop after N messages
  --rate      print messages/s and bytes/s once a second instead of the data
  --wait      wait for the channel to appear instead of failing (exit 5) when it is absent
  --queue N   ask the hub to hold up to N bytes for this subscription before it drops the
              oldest (FlowProtocol 1.13; clamped to server.subscriber_queue_max_bytes)
  --max-hz N  at most N messages a second, newest wins: the hub holds back the newest and
              sends it when the interval ends (FlowProtocol 1.14; a preview of a fast channel)
)",
     .run = cmdEcho},
    {.name = "poll",
     .synopsis = "poll CHANNEL",
     .summary = "print a streaming channel's latest payload when it changes",
     .usage = "usage: flowctl poll CHANNEL [options]",
     .help =
         R"(usage: flowctl poll CHANNEL [--interval MS] [--count N] [--format auto|text|hex|json]
  Polls a streaming channel instead of subscribing: the hub keeps its latest payload, which is
  fetched every --interval ms (default 500) and printed when it changed (--count: after N, stop).
  Payloads published between two fetches are not seen: that is polling. --json adds "seq".
)",
     .run = cmdPoll},
    {.name = "pub",
     .synopsis = "pub CHANNEL [PAYLOAD]",
     .summary = "publish on one of your channels (<user>.<name>), creating it",
     .usage = "usage: flowctl pub CHANNEL [PAYLOAD | --file PATH] [options]",
     .help =
         R"(usage: flowctl pub CHANNEL [PAYLOAD | --file PATH] [--repeat N] [--rate HZ] [options]
  Publishes on CHANNEL, which must be yours: <user>.<name> (or just <name>). It is created for
  the time flowctl runs, unless it exists already (then its owner alone may publish on it).
  The payload is PAYLOAD, the bytes of --file, or else standard input.
  --repeat N     publish N times (default 1; with --rate and no --repeat: until Ctrl-C)
  --rate HZ      publish HZ times a second
  --variant      PAYLOAD is JSON: publish its binary Variant encoding
  --mime TYPE    the channel's mime type when flowctl creates it (default text/plain)
  --props JSON   the channel's properties when flowctl creates it (an object: its database,
                 e.g. '{"encoding":"bgr8","width":640,"height":480}', docs/channels.md)
  --encoding ENC the message_encoding of its type when flowctl creates it (json, cdr, ...), with
                 --schema-name NAME, --schema-encoding ENC and --schema-file PATH where the
                 encoding has schemas (docs/channels.md, "Typed channels"; checked first)
  --ros2-type T  PAYLOAD is JSON: publish it as the CDR of the ROS 2 type T (sensor_msgs/msg/
                 Image, ...; fields left out are their defaults), the channel typed cdr with T's
                 ros2msg schema (docs/ros2.md); T is shipped with flowctl or in --definitions DIR
                 (interface packages: DIR/<package>/msg/<Type>.msg)
  --wait-ms MS   when flowctl created the channel, wait up to MS for a first subscriber before
                 publishing (default 1000; 0: do not wait)
)",
     .run = cmdPub},
    {.name = "call",
     .synopsis = "call SERVICE CMD [VALUE]",
     .summary = "call a service channel; VALUE is JSON; prints the answer",
     .usage = "usage: flowctl call SERVICE CMD [VALUE]",
     .help = R"(usage: flowctl call SERVICE CMD [VALUE] [--timeout-ms MS]
  Calls a service channel and prints its answer as JSON. VALUE is JSON (default null); quote
  strings: '"text"'. Exit 6 when no answer came within MS milliseconds (default 5000).
)",
     .run = cmdCall},
    {.name = "db",
     .synopsis = "db get|set|del|ls|watch|save|sync|databases [--db NAME] [KEY [VALUE]]",
     .summary = "read and write PairDatabases",
     .help =
         R"(usage: flowctl db get KEY | set KEY VALUE | del KEY | ls | watch | save | sync | databases
                  [--db NAME] [--count N]
  get KEY          print a variable as JSON (exit 5 when absent)
  set KEY VALUE    set a variable; VALUE is JSON (quote strings: '"text"')
  del KEY          remove a variable
  ls               every variable of the database
  watch            every variable, then each change as it is made: KEY = VALUE, KEY removed,
                   or (cleared) when every key went (--json: one object a line); --count N:
                   stop after N changes. Ends with the database (exit 5) (FlowProtocol 1.14)
  save             write the database's snapshot now (compacts its log)
  sync             wait until every change the hub made so far is on disk (any policy)
  databases        the names of all databases
  --db NAME        the database (default: your user's); a channel's is named after it
)",
     .run = cmdDb},
    {.name = "flows",
     .synopsis = "flows",
     .summary = "the hub's connections: id, user, client, source (administrators)",
     .usage = "usage: flowctl flows",
     .help = R"(usage: flowctl flows
  The hub's connections (administrators only; docs/security.md): id, user, client name,
  transport, source address, channels owned and subscriptions.
)",
     .run = cmdFlows},
    {.name = "kick",
     .synopsis = "kick ID",
     .summary = "disconnect connection ID (administrators)",
     .usage = "usage: flowctl kick ID",
     .help = R"(usage: flowctl kick ID
  Disconnects connection ID, as flowctl flows lists it (administrators only).
)",
     .run = cmdKick},
    {.name = "chan",
     .synopsis = "chan rm CHANNEL",
     .summary = "remove any channel (administrators)",
     .usage = "usage: flowctl chan rm CHANNEL",
     .help = R"(usage: flowctl chan rm CHANNEL
  Removes the channel CHANNEL, whoever owns it (administrators only).
)",
     .run = cmdChan},
    {.name = "blob",
     .synopsis = "blob ls|get|put|mkdir|rmdir|rm CHANNEL ...",
     .summary = "the files of a blob channel (flowctl help blob)",
     .usage = "flowctl blob ls|get|put|mkdir|rmdir|rm CHANNEL ...",
     .help =
         R"(usage: flowctl blob ls CHANNEL [DIR] | get CHANNEL PATH [LOCAL|-] | put CHANNEL LOCAL PATH
                   | mkdir CHANNEL PATH | rmdir CHANNEL PATH | rm CHANNEL PATH
  The files of a blob channel (docs/blob-channels.md). CHANNEL is <user>.<name>, or <name> for
  one of yours. Everyone may list and get; only the channel's owner writes.
  ls      the entries of DIR (default: the root): size, time, name (a '/' after directories)
  get     downloads one whole version of PATH to LOCAL (default: its last component; '-' is
          standard output)
  put     uploads LOCAL as PATH (missing directories are made); creates your blob channel
          <user>.<name> when it does not exist
  mkdir, rmdir (empty directories), rm (files)
  A progress bar is shown on a terminal for files of 4 MB and more.
)",
     .run = cmdBlob},
    {.name = "sync",
     .synopsis = "sync source NAME --hz N | sync follow NAME",
     .summary = "emit sync pulses, or follow them and measure their period",
     .usage =
         "usage: flowctl sync source NAME --hz N [--count N] | follow NAME [--every N] [--count N]",
     .help =
         R"(usage: flowctl sync source NAME --hz N [--count N] | follow NAME [--every N] [--count N]
  The sync pulse (docs/sync-pulse.md).
  source  creates your sync source <user>.NAME and pulses N times a second (--count: then
          stops); at the end prints its own period error p50/p99/max
  follow  follows the source NAME (every Nth pulse), printing each pulse's arrival: the period
          since the previous one, the delay from the source (one machine's clock), and the
          pulses the hub dropped while this follower was busy; at the end (Ctrl-C, or --count
          pulses) the period error p50/p99/max, the delay's, and the pulses dropped and missed
          (--json: one object per pulse, then the summary)
)",
     .run = cmdSync},
    {.name = "link",
     .synopsis = "link ls",
     .summary = "this hub's links to other hubs: state, channels, round trip,\n"
                "clock offset, traffic (docs/hub-links.md)",
     .usage = "usage: flowctl link ls",
     .help = R"(usage: flowctl link ls
  This hub's links to other hubs (docs/hub-links.md), from their databases _link.<name>: the
  far hub, state, channels, round trip and clock offset (microseconds), messages in, requests,
  drops and address.
)",
     .run = cmdLink},
    {.name = "top",
     .synopsis = "top",
     .summary = "channels by rate and bandwidth, and slow flows, refreshed each\n"
                "second from hub.stats (docs/observability.md)",
     .usage = "usage: flowctl top [--sort hz|bw|drops|name] [--rows N] [--once]",
     .help = R"(usage: flowctl top [--sort hz|bw|drops|name] [--rows N] [--once]
  The hub's channels by rate (or bandwidth, drops, name) with their subscribers, drops and owner,
  and the flows that drop or whose output queue is filling, refreshed each second from the
  hub's statistics channel hub.stats. --once prints one second's table and exits; with --json,
  the statistics themselves, one JSON line a second (docs/observability.md).
)",
     .run = cmdTop},
    {.name = "hz",
     .synopsis = "hz CHANNEL | bw CHANNEL",
     .summary = "a streaming channel's rate (interval min/max/std dev) or\n"
                "bandwidth (message sizes), measured here once a second",
     .usage = "usage: flowctl hz CHANNEL [--window N] [--count N]",
     .help = kHzBwHelp,
     .run = cmdHz},
    {.name = "bw",
     .usage = "usage: flowctl bw CHANNEL [--window N] [--count N]",
     .help = kHzBwHelp,
     .run = cmdBw},
    {.name = "info",
     .synopsis = "info CHANNEL",
     .summary = "owner, subscribers, rate, totals, properties",
     .usage = "usage: flowctl info CHANNEL",
     .help = R"(usage: flowctl info CHANNEL
  A channel's kind, mime type, owner, subscribers (their flows), rates (over the hub's last
  second and last ten), totals (messages, bytes, drops), pending requests and properties.
)",
     .run = cmdInfo},
    {.name = "graph",
     .synopsis = "graph",
     .summary = "who publishes and who subscribes, as Graphviz DOT",
     .usage = "usage: flowctl graph [--all]",
     .help = R"(usage: flowctl graph [--all]
  Graphviz DOT of the hub's flows (boxes) and channels (ellipses, services dashed) with an edge
  from each owner to its channel and from each channel to its subscribers; what drops is red.
  --all includes the hub's own statistics channels. flowctl graph | dot -Tsvg > hub.svg
)",
     .run = cmdGraph},
    {.name = "record",
     .synopsis = "record -o FILE.mcap (CHANNEL... | --all)",
     .summary = "record streaming channels to an MCAP file (docs/recording.md)",
     .usage = "usage: flowctl record -o FILE.mcap (CHANNEL... | --all) [options]",
     .help = R"(usage: flowctl record -o FILE.mcap (CHANNEL... | --all) [options]
  Subscribes to streaming channels (names or patterns, as for ls; --all: every one, and those
  that appear later) and writes them to an MCAP file until Ctrl-C or SIGTERM, which finish the
  file (summary and index). A recorder killed otherwise leaves a file readable up to its last
  chunk (written at least every --flush-ms). Prints what was recorded, dropped and lost.
  --compression zstd|lz4|none   chunk compression (default zstd)
  --chunk-kb N     a chunk is written when it holds N KiB (default 4096)
  --flush-ms MS    ... or when it is MS old (default 1000)
  --queue-mb N     memory for messages waiting for the disk; past it they are dropped and
                   counted (default 256)
  --duration S     stop after S seconds
)",
     .run = cmdRecord},
    {.name = "play",
     .synopsis = "play FILE.mcap",
     .summary = "publish a recording again, with its timing, on your channels",
     .usage = "usage: flowctl play FILE.mcap [options]",
     .help = R"(usage: flowctl play FILE.mcap [--rate X] [--loop] [--start S] [--remap FROM=TO]...
                    [--channels PATTERN,...] [--wait-ms MS]
  Creates your channel <you>.<name> for each recorded channel <user>.<name> (with its mime type
  and properties, changed when they changed) and publishes the messages at their recorded times.
  --rate X        X times as fast (0.5: half speed)
  --loop          start again at the end, until Ctrl-C
  --start S       begin S seconds into the recording
  --remap FROM=TO the recorded channel FROM becomes <you>.TO (TO may be <you>.<name>)
  --channels P,.. only the recorded channels matching these patterns
  --wait-ms MS    wait up to MS for every channel to have a subscriber before starting
                  (default 1000; 0: start at once)
  --sync NAME --sync-hz HZ
                  also a sync source <you>.NAME pulsing HZ times per second of the
                  recording (scaled by --rate), for followers that step with the replay
)",
     .run = cmdPlay},
    {.name = "mcap",
     .synopsis = "mcap info|cat FILE.mcap",
     .summary = "what an MCAP file holds; its messages as JSON lines",
     .usage = "usage: flowctl mcap info|cat FILE.mcap",
     .help = R"(usage: flowctl mcap info FILE.mcap | cat FILE.mcap
  info  reads the whole file (checking its CRCs and index) and prints its channels, message
        counts, time range, chunks and compression; a file cut short is read up to its last
        complete chunk. --json: one JSON document.
  cat   one JSON line per message: topic, sequence, log_time, publish_time, data (text, or
        {"$base64": ...} for binary).
)",
     .run = cmdMcap},
    {.name = "reload",
     .synopsis = "reload",
     .summary = "read the hub's config again and apply what changed (administrators)",
     .usage = "usage: flowctl reload",
     .help = R"(usage: flowctl reload
  The hub reads its config file again (as SIGHUP does) and applies the difference: modules added
  are loaded, removed ones stopped and unloaded, changed ones restarted (and those that failed
  tried again); satellites likewise; the log level. Other sections take a restart of the hub:
  their changes are listed, not applied. A config with a problem changes nothing: its problems
  are printed with their JSON paths (exit 1). Prints one line per change. docs/robot.md.
)",
     .run = cmdReload},
    {.name = "module",
     .synopsis = "module load|unload|config NAME",
     .summary = "load a module dropped into module_paths, unload one, or show and\n"
                "change a running one's config (administrators)",
     .usage = "usage: flowctl module load NAME [--config JSON] | unload NAME |\n"
              "                     config NAME [KEY=VALUE...] [--save]",
     .help = R"(usage: flowctl module load NAME [--config JSON]
       flowctl module unload NAME
       flowctl module config NAME [KEY=VALUE...] [--save]
  load: the hub loads and starts the module NAME, found on its module search path (module_paths,
  then its own modules) by name, never by a path, with --config checked against the keys it
  declares, as at start (problems are printed). For a new .so dropped into a directory of
  module_paths: install it by renaming a complete file into place, never by copying over a
  loaded one. It is not written into the config: a restart forgets it (add it to "modules").
  unload: stops and unloads a running module.
  config: without KEY=VALUE, the keys a running module declares (type, default, range, choices,
  description) and their values now; with them (VALUE is JSON, else a string), its config
  changed at run time: checked against its keys, given in place when the module can (plugin ABI
  1.11 reconfigure) or by a restart. --save also writes those values into the config file (only
  them: its comments and the rest stay as they are); unsaved, a reload or restart goes back to
  the file's. docs/robot.md.
)",
     .run = cmdModule},
    {.name = "ps",
     .synopsis = "ps",
     .summary = "the hub's supervised satellites: state, pid, uptime, restarts,\n"
                "last exit, flows, channels (administrators)",
     .usage = "usage: flowctl ps",
     .help = R"(usage: flowctl ps
  The satellites the hub supervises ("satellites" in its config, docs/robot.md; administrators
  only): state (waiting, with what it waits for; starting; running; stopping; backoff, until its
  next start; stopped; failed), pid, uptime, restarts, how its last run ended, the flows it
  logged in with and their channels. --json prints the whole answer.
)",
     .run = cmdPs},
    {.name = "start",
     .synopsis = "start NAME | stop NAME | restart NAME",
     .summary = "start, stop or restart a supervised satellite (administrators)",
     .usage = "usage: flowctl start NAME",
     .help = R"(usage: flowctl start NAME
  Starts a supervised satellite that is stopped or failed (its restart count and delay start
  afresh), once what its "after" names is up. docs/robot.md.
)",
     .run = cmdStart},
    {.name = "stop",
     .usage = "usage: flowctl stop NAME",
     .help = R"(usage: flowctl stop NAME
  Stops a supervised satellite: its stop signal, then SIGKILL to it and everything it started
  after its grace period. It is not restarted until flowctl start. docs/robot.md.
)",
     .run = cmdStop},
    {.name = "restart",
     .usage = "usage: flowctl restart NAME",
     .help = R"(usage: flowctl restart NAME
  Stops a supervised satellite as flowctl stop does, then starts it again. docs/robot.md.
)",
     .run = cmdRestart},
    {.name = "logs",
     .synopsis = "logs NAME [-f]",
     .summary = "a supervised satellite's last lines of output (administrators)",
     .usage = "usage: flowctl logs NAME [-f] [--lines N]",
     .help = R"(usage: flowctl logs NAME [-f] [--lines N]
  Prints the last N lines (100; the hub keeps up to 2000) that a supervised satellite wrote to its
  standard output and error (the latter marked "! "), then, with -f, each new one as it comes
  until interrupted. The hub's log has them too, at most log_lines_per_second a second.
)",
     .run = cmdLogs},
    {.name = "users",
     .synopsis = "users",
     .summary = "the accounts of the users file (administrators)",
     .usage = "usage: flowctl users",
     .help = R"(usage: flowctl users
  The accounts of the hub's users file: name, role, when it was made (administrators only;
  docs/accounts.md).
)",
     .run = cmdUsers},
    {.name = "user",
     .synopsis = "user add|del|passwd|role|rule NAME ...",
     .summary = "change an account; a password is one line on stdin\n"
                "(administrators; flowctl help user)",
     .usage =
         "usage: flowctl user add NAME [--admin] | del NAME | passwd NAME | "
         "role NAME admin|user |\n"
         "                    rule NAME ACTION [PATTERN...]   (the password: one line on stdin)",
     .help =
         R"(usage: flowctl user add NAME [--admin] | del NAME | passwd NAME | role NAME admin|user
                   | rule NAME ACTION [PATTERN...]
  Changes an account of the hub's users file (administrators only; docs/security.md). add and
  passwd read the password as one line from stdin. ACTION: publish, subscribe, call, db_read,
  db_write; no PATTERN: back to '**'. The account's connections keep their old rules until they
  reconnect.
)",
     .run = cmdUser},
    {.name = "help",
     .synopsis = "help [COMMAND]",
     .summary = "this text, or a command's options",
     .help = R"(usage: flowctl help [COMMAND | --markdown]
  The commands and the global options, or COMMAND's usage and options (as flowctl COMMAND
  --help). --markdown: the commands as a Markdown list (README.md's).
)",
     .run = nullptr},  // main answers help
};

// Every row has a name of its own and a help text (flowctl help NAME).
constexpr bool wellFormed() {
  for (size_t i = 0; i < std::size(kCommands); ++i) {
    if (kCommands[i].name.empty() || kCommands[i].help.empty()) return false;
    for (size_t j = 0; j < i; ++j) {
      if (kCommands[i].name == kCommands[j].name) return false;
    }
  }
  return true;
}
static_assert(wellFormed(), "each command needs a name of its own and a help text");

// The overview around the rows' lines.
constexpr std::string_view kOverviewHead =
    R"(usage: flowctl [--address ADDR] [--user NAME] [--password PW] [--ca FILE] [--json] COMMAND ...

Commands:
)";
constexpr std::string_view kOverviewTail = R"(Global options:
  --address ADDR    local:/path, tcp:host[:port], tls:host[:port], serial:/dev/path[@baud]
                    or udp:host[:port] (default: $ROBOT_ADDRESS, else local:/tmp/Robot);
                    serial: and udp: carry the flow only: commands that ask the hub
                    synchronously need one of the first three
  --user NAME       (default: $ROBOT_USER, else guest)
  --password PW     (default: $ROBOT_PASSWORD, else password)
  --ca FILE         tls: the CA certificate that signed the hub's (default: $ROBOT_TLS_CA, else
                    the system's CA store); the hub's certificate must name the address's host
  --cert FILE, --key FILE
                    tls: a client certificate and its key, for a hub that asks for one
                    (default: $ROBOT_TLS_CERT, $ROBOT_TLS_KEY)
  --udp-key-file FILE
                    udp: a file holding the account's key in hex, as `skrobot user key NAME`
                    printed it (default: $ROBOT_UDP_KEY, the hex itself, else the file
                    $ROBOT_UDP_KEY_FILE)
  --json            machine-readable output (one JSON document, or one JSON line per message)

Exit codes: 0 ok, 1 refused or failed, 2 usage, 3 no hub (or hub lost), 4 login refused,
            5 no such channel/variable/database, 6 timeout, 7 permission denied,
            8 call: the service answered that it failed ({"ok": false} or {"error": ...}).

Accounts are managed on the hub's machine with `skrobot user add|del|passwd|list`
(docs/accounts.md). More: docs/cpp-satellites.md, section flowctl.
)";

// The overview's right column: a synopsis longer than this is on a line of its own.
constexpr size_t kSummaryColumn = 30;

}  // namespace

const Command* findCommand(std::string_view name) {
  for (const Command& c : kCommands) {
    if (c.name == name) return &c;
  }
  return nullptr;
}

std::string overview() {
  std::string out(kOverviewHead);
  for (const Command& c : kCommands) {
    if (c.synopsis.empty()) continue;
    out += "  ";
    out += c.synopsis;
    if (2 + c.synopsis.size() + 2 <= kSummaryColumn) {
      out.append(kSummaryColumn - 2 - c.synopsis.size(), ' ');
    } else {
      out += '\n';
      out.append(kSummaryColumn, ' ');
    }
    for (const char ch : c.summary) {
      out += ch;
      if (ch == '\n') out.append(kSummaryColumn, ' ');
    }
    out += '\n';
  }
  out += '\n';
  out += kOverviewTail;
  return out;
}

std::string commandsMarkdown() {
  std::string out;
  for (const Command& c : kCommands) {
    if (c.synopsis.empty() || c.run == nullptr) continue;  // listed on another row's line; help
    out += "- `flowctl ";
    out += c.synopsis;
    out += "`: ";
    for (const char ch : c.summary) {
      if (ch == '<') out += '\\';  // "<user>" is text, not HTML
      out += ch == '\n' ? ' ' : ch;
    }
    out += '\n';
  }
  return out;
}

std::string_view commandHelp(std::string_view name) {
  const Command* c = findCommand(name);
  return c != nullptr ? c->help : std::string_view();
}

int unknownCommand(const std::string& name) {
  return fail(kUsage, "unknown command '" + name + "' (see flowctl --help)");
}

int usageError(const Cli& cli) {
  const Command* c = findCommand(cli.command);
  if (c == nullptr) return unknownCommand(cli.command);
  return fail(kUsage, std::string(c->usage.empty() ? c->help : c->usage));
}

}  // namespace flowctl
