// flowctl: an operator's tool for a running hub, as handy as redis-cli.
//   flowctl ls | echo CHANNEL | pub CHANNEL [PAYLOAD] | call SERVICE CMD [VALUE] | db ...
//           | flows | kick ID | chan rm CHANNEL
#include <skrobot/core/log.h>

#include <cstdlib>
#include <cstring>

#include "cli.h"

namespace flowctl {

std::string_view usage() {
  return R"(usage: flowctl [--address ADDR] [--user NAME] [--password PW] [--ca FILE] [--json] COMMAND ...

Commands:
  ls                          list the hub's channels: id, kind, name, owner, subscribers, mime,
                              properties
  echo CHANNEL                print the data published on a streaming channel
  poll CHANNEL                print a streaming channel's latest payload when it changes
  pub CHANNEL [PAYLOAD]       publish on one of your channels (<user>.<name>), creating it
  call SERVICE CMD [VALUE]    call a service channel; VALUE is JSON; prints the answer
  db get|set|del|ls|save|databases [--db NAME] [KEY [VALUE]]
                              read and write PairDatabases
  flows                       the hub's connections: id, user, client, source (administrators)
  kick ID                     disconnect connection ID (administrators)
  chan rm CHANNEL             remove any channel (administrators)
  blob ls|get|put|mkdir|rmdir|rm CHANNEL ...
                              the files of a blob channel (flowctl help blob)
  sync source NAME --hz N | sync follow NAME
                              emit sync pulses, or follow them and measure their period
  link ls                     this hub's links to other hubs: state, channels, round trip,
                              clock offset, traffic (docs/hub-links.md)
  top                         channels by rate and bandwidth, and slow flows, refreshed each
                              second from hub.stats (docs/observability.md)
  hz CHANNEL | bw CHANNEL     a streaming channel's rate (interval min/max/std dev) or
                              bandwidth (message sizes), measured here once a second
  info CHANNEL                owner, subscribers, rate, totals, properties
  graph                       who publishes and who subscribes, as Graphviz DOT
  record -o FILE.mcap (CHANNEL... | --all)
                              record streaming channels to an MCAP file (docs/recording.md)
  play FILE.mcap              publish a recording again, with its timing, on your channels
  mcap info|cat FILE.mcap     what an MCAP file holds; its messages as JSON lines
  users                       the accounts of the users file (administrators)
  user add|del|passwd|role|rule NAME ...
                              change an account; a password is one line on stdin
                              (administrators; flowctl help user)
  help [COMMAND]              this text, or a command's options

Global options:
  --address ADDR    local:/path, tcp:host[:port] or tls:host[:port]
                    (default: $ROBOT_ADDRESS, else local:/tmp/Robot)
  --user NAME       (default: $ROBOT_USER, else guest)
  --password PW     (default: $ROBOT_PASSWORD, else password)
  --ca FILE         tls: the CA certificate that signed the hub's (default: $ROBOT_TLS_CA, else
                    the system's CA store); the hub's certificate must name the address's host
  --cert FILE, --key FILE
                    tls: a client certificate and its key, for a hub that asks for one
                    (default: $ROBOT_TLS_CERT, $ROBOT_TLS_KEY)
  --json            machine-readable output (one JSON document, or one JSON line per message)

Exit codes: 0 ok, 1 refused or failed, 2 usage, 3 no hub (or hub lost), 4 login refused,
            5 no such channel/variable/database, 6 timeout, 7 permission denied,
            8 call: the service answered that it failed ({"ok": false} or {"error": ...}).

Accounts are managed on the hub's machine with `skrobot user add|del|passwd|list`
(docs/accounts.md). More: docs/cpp-satellites.md, section flowctl.
)";
}

std::string_view commandHelp(std::string_view command) {
  if (command == "ls") {
    return R"(usage: flowctl ls [PATTERN...]
  Lists the channels whose names match a PATTERN (all without one). In a pattern '*' is any run
  within one part of the name (parts are separated by '.'), '**' any run across parts, '?' one
  character; a PATTERN starting with '!' excludes what it matches. Examples:
    flowctl ls 'guest.*'            guest's channels
    flowctl ls '*.faces'            every user's "faces" channel
    flowctl ls '**' '!**.debug'     everything but debug channels
)";
  }
  if (command == "echo") {
    return R"(usage: flowctl echo CHANNEL [--format auto|text|hex|json] [--count N] [--rate] [--wait]
  Subscribes to a streaming channel and prints each message.
  --format    auto (text when printable, else hex; the default), text, hex, or json (a
              binary Variant payload or JSON text, shown as JSON)
  --count N   stop after N messages
  --rate      print messages/s and bytes/s once a second instead of the data
  --wait      wait for the channel to appear instead of failing (exit 5) when it is absent
)";
  }
  if (command == "pub") {
    return R"(usage: flowctl pub CHANNEL [PAYLOAD | --file PATH] [--repeat N] [--rate HZ] [options]
  Publishes on CHANNEL, which must be yours: <user>.<name> (or just <name>). It is created for
  the time flowctl runs, unless it exists already (then its owner alone may publish on it).
  The payload is PAYLOAD, the bytes of --file, or else standard input.
  --repeat N     publish N times (default 1; with --rate and no --repeat: until Ctrl-C)
  --rate HZ      publish HZ times a second
  --variant      PAYLOAD is JSON: publish its binary Variant encoding
  --mime TYPE    the channel's mime type when flowctl creates it (default text/plain)
  --wait-ms MS   when flowctl created the channel, wait up to MS for a first subscriber before
                 publishing (default 1000; 0: do not wait)
)";
  }
  if (command == "top") {
    return R"(usage: flowctl top [--sort hz|bw|drops|name] [--rows N] [--once]
  The hub's channels by rate (or bandwidth, drops, name) with their subscribers, drops and owner,
  and the flows that drop or whose output queue is filling, refreshed each second from the
  hub's statistics channel hub.stats. --once prints one second's table and exits; with --json,
  the statistics themselves, one JSON line a second (docs/observability.md).
)";
  }
  if (command == "hz" || command == "bw") {
    return R"(usage: flowctl hz|bw CHANNEL [--window N] [--count N]
  Subscribes to a streaming channel and prints, once a second, over its last N messages (100):
  hz the rate and the interval's min, max and standard deviation; bw the bytes per second and
  the message sizes. --count N stops after N lines.
)";
  }
  if (command == "info") {
    return R"(usage: flowctl info CHANNEL
  A channel's kind, mime type, owner, subscribers (their flows), rate (since the hub's figures
  were last taken), totals (messages, bytes, drops), pending requests and properties.
)";
  }
  if (command == "graph") {
    return R"(usage: flowctl graph [--all]
  Graphviz DOT of the hub's flows (boxes) and channels (ellipses, services dashed) with an edge
  from each owner to its channel and from each channel to its subscribers; what drops is red.
  --all includes the hub's own statistics channels. flowctl graph | dot -Tsvg > hub.svg
)";
  }
  if (command == "record") {
    return R"(usage: flowctl record -o FILE.mcap (CHANNEL... | --all) [options]
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
)";
  }
  if (command == "play") {
    return R"(usage: flowctl play FILE.mcap [--rate X] [--loop] [--start S] [--remap FROM=TO]...
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
)";
  }
  if (command == "mcap") {
    return R"(usage: flowctl mcap info FILE.mcap | cat FILE.mcap
  info  reads the whole file (checking its CRCs and index) and prints its channels, message
        counts, time range, chunks and compression; a file cut short is read up to its last
        complete chunk. --json: one JSON document.
  cat   one JSON line per message: topic, sequence, log_time, publish_time, data (text, or
        {"$base64": ...} for binary).
)";
  }
  if (command == "call") {
    return R"(usage: flowctl call SERVICE CMD [VALUE] [--timeout-ms MS]
  Calls a service channel and prints its answer as JSON. VALUE is JSON (default null); quote
  strings: '"text"'. Exit 6 when no answer came within MS milliseconds (default 5000).
)";
  }
  if (command == "user") {
    return R"(usage: flowctl user add NAME [--admin] | del NAME | passwd NAME | role NAME admin|user
                   | rule NAME ACTION [PATTERN...]
  Changes an account of the hub's users file (administrators only; docs/security.md). add and
  passwd read the password as one line from stdin. ACTION: publish, subscribe, call, db_read,
  db_write; no PATTERN: back to '**'. The account's connections keep their old rules until they
  reconnect.
)";
  }
  if (command == "poll") {
    return R"(usage: flowctl poll CHANNEL [--interval MS] [--count N] [--format auto|text|hex|json]
  Polls a streaming channel instead of subscribing: the hub keeps its latest payload, which is
  fetched every --interval ms (default 500) and printed when it changed (--count: after N, stop).
  Payloads published between two fetches are not seen: that is polling. --json adds "seq".
)";
  }
  if (command == "sync") {
    return R"(usage: flowctl sync source NAME --hz N [--count N] | follow NAME [--every N] [--count N]
  The sync pulse (docs/sync-pulse.md).
  source  creates your sync source <user>.NAME and pulses N times a second (--count: then
          stops); at the end prints its own period error p50/p99/max
  follow  follows the source NAME (every Nth pulse), printing each pulse's arrival: the period
          since the previous one, the delay from the source (one machine's clock), and the
          pulses the hub dropped while this follower was busy; at the end (Ctrl-C, or --count
          pulses) the period error p50/p99/max, the delay's, and the pulses dropped and missed
          (--json: one object per pulse, then the summary)
)";
  }
  if (command == "blob") {
    return R"(usage: flowctl blob ls CHANNEL [DIR] | get CHANNEL PATH [LOCAL|-] | put CHANNEL LOCAL PATH
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
)";
  }
  if (command == "db") {
    return R"(usage: flowctl db get KEY | set KEY VALUE | del KEY | ls | save | sync | databases [--db NAME]
  get KEY          print a variable as JSON (exit 5 when absent)
  set KEY VALUE    set a variable; VALUE is JSON (quote strings: '"text"')
  del KEY          remove a variable
  ls               every variable of the database
  save             write the database's snapshot now (compacts its log)
  sync             wait until every change the hub made so far is on disk (any policy)
  databases        the names of all databases
  --db NAME        the database (default: your user's); a channel's is named after it
)";
  }
  return {};
}

}  // namespace flowctl

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
      std::string name = a.substr(0, a.find('='));
      if (name == "--address") target = &address;
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
  if (cli.command == "help") {
    help = true;
    cli.command = cli.args.empty() ? "" : cli.args[0];
  }
  if (help || cli.command.empty()) {
    const auto text = cli.command.empty() ? usage() : commandHelp(cli.command);
    if (text.empty()) {
      return fail(kUsage, "unknown command '" + cli.command + "' (see flowctl --help)");
    }
    std::fputs(std::string(text).c_str(), help ? stdout : stderr);
    return help ? kOk : kUsage;
  }
  if (!env_error.empty() && !address_given) return fail(kUsage, env_error);
  if (cli.command == "mcap") return cmdMcap(cli);  // reads a file: no hub
  if (cli.command == "ls") return cmdLs(cli);
  if (cli.command == "echo") return cmdEcho(cli);
  if (cli.command == "pub") return cmdPub(cli);
  if (cli.command == "call") return cmdCall(cli);
  if (cli.command == "top") return cmdTop(cli);
  if (cli.command == "hz") return cmdHz(cli);
  if (cli.command == "bw") return cmdBw(cli);
  if (cli.command == "info") return cmdInfo(cli);
  if (cli.command == "graph") return cmdGraph(cli);
  if (cli.command == "db") return cmdDb(cli);
  if (cli.command == "flows") return cmdFlows(cli);
  if (cli.command == "kick") return cmdKick(cli);
  if (cli.command == "chan") return cmdChan(cli);
  if (cli.command == "users") return cmdUsers(cli);
  if (cli.command == "user") return cmdUser(cli);
  if (cli.command == "blob") return cmdBlob(cli);
  if (cli.command == "sync") return cmdSync(cli);
  if (cli.command == "poll") return cmdPoll(cli);
  if (cli.command == "link") return cmdLink(cli);
  if (cli.command == "record") return cmdRecord(cli);
  if (cli.command == "play") return cmdPlay(cli);
  return fail(kUsage, "unknown command '" + cli.command + "' (see flowctl --help)");
}
