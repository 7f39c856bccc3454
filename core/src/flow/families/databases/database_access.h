// SPDX-License-Identifier: Apache-2.0
// Database access: the PairDatabases as the protocol sees them, and who may write which. One per
// flow ("_flow.<id>", transient), per user (named after the user, persistent), per channel
// (named after the channel, transient: its properties), plus named ones anybody may create.
// A user reads the databases its db_read rule selects; writes go, within its db_write rule, to
// named databases, its own user and flow databases, and (as the channel's owner) its own
// channels' databases; an administrator writes any (flow/access.h). Main loop thread only.
#pragma once

#include "endpoint.h"

#include <skrobot/hub/flow/pair_database.h>
#include <skrobot/runtime/flow/messages.h>
#include <skrobot/runtime/result.h>

#include <filesystem>
#include <functional>
#include <initializer_list>
#include <string>
#include <string_view>
#include <unordered_map>

namespace skr::flow {

class DatabaseAccess {
 public:
  // Persistent databases live in `data_dir` (empty: nothing is saved).
  explicit DatabaseAccess(std::filesystem::path data_dir) : store_(std::move(data_dir)) {}

  [[nodiscard]] DatabaseStore& store() noexcept { return store_; }
  [[nodiscard]] const DatabaseStore& store() const noexcept { return store_; }

  // Told (with the channel's name) whenever a channel's properties change, whichever way they
  // were written: CHAN_SET_PROPS, or a variable set or removed in the channel's database.
  std::function<void(const std::string& channel)> on_props_changed;

  // A logged-in endpoint's databases: its flow database (created) and its user's (created if
  // new, persistent); its current database becomes the user's.
  void attach(Endpoint& e);
  // Removes the flow database of a leaving endpoint.
  void detach(const Endpoint& e);
  // The channel `name`'s database, owned by `owner`, holding `props` (a map or null).
  [[nodiscard]] Result<void> createChannelDb(const std::string& name, const std::string& owner_user,
                                             uint32_t owner_id, const Variant& props);
  // A transient database of the hub's own (a hub link's "_link.<name>"), written by `owner` only.
  [[nodiscard]] Result<PairDatabase*> createOwnedDb(const std::string& name, const Endpoint& owner);
  // Removes a channel's database, or one made by createOwnedDb.
  void removeOwnedDb(const std::string& name);
  // A blob channel's owner connected (its id) or left (0): who writes the channel's database.
  void setChannelDbOwner(const std::string& name, uint32_t owner_id);
  // Sets (or, for null values, removes) the keys of `props` in channel `name`'s database.
  [[nodiscard]] Result<void> setChannelProps(const std::string& name, const Variant::Map& props);
  // Makes channel `name`'s properties `props`: keys set, keys absent from `props` removed, except
  // those in `keep` (a mirror of another channel's properties: hub links, replicas).
  [[nodiscard]] Result<void> replaceChannelProps(const std::string& name, Variant::Map props,
                                                 std::initializer_list<std::string_view> keep = {});
  // The channel `name`'s properties (an empty map when it has none).
  [[nodiscard]] Variant channelProps(const std::string& name) const;

  // `e`'s current database; falls back to its flow database when the current one was removed.
  PairDatabase* current(Endpoint& e);
  // Reading needs the user's db_read rule; writing its db_write rule and ownership (named
  // databases are anybody's), or the administrator role (flow/access.h).
  [[nodiscard]] bool canRead(const Endpoint& e, const std::string& db) const;
  [[nodiscard]] bool canWrite(const Endpoint& e, const std::string& db) const;
  // The database `db_name` names for `e` (its current one when empty), if `e` may write it here:
  // read_only (a linked hub's), not_found, permission_denied.
  [[nodiscard]] Result<PairDatabase*> writable(Endpoint& e, const std::string& db_name);
  [[nodiscard]] bool persistent(const std::string& db) const {
    return store_.kind(db) == DatabaseKind::persistent;
  }

  // "<hub>/<name>" with no database of that name here (a linked channel's properties are kept
  // here): a linked hub's database, read through the link (docs/hub-links.md).
  [[nodiscard]] bool remote(const std::string& db) const {
    return db.find('/') != std::string::npos && store_.find(db) == nullptr;
  }
  // Whether a hub of that name is reachable (set by the server: its links); for select().
  std::function<bool(std::string_view hub)> hub_reachable;
  // A read of a database here (DB_READ): not_found, permission_denied.
  [[nodiscard]] Result<Variant> read(const Endpoint& e, const std::string& db, msg::DbReadWhat what,
                                     const std::string& key) const;
  // The same on a database at hand, named `name` in the error.
  [[nodiscard]] static Result<Variant> readFrom(const PairDatabase& db, msg::DbReadWhat what,
                                                const std::string& key, const std::string& name);

  // The protocol's database commands. Errors: not_found, permission_denied, invalid_argument,
  // already_exists, unsupported (save without a data directory), io_error.
  [[nodiscard]] Result<void> select(Endpoint& e, const std::string& name);
  [[nodiscard]] Result<void> create(const Endpoint& e, const std::string& name);
  // Empty name: the current database. `done` gets the result of writing the snapshot.
  [[nodiscard]] Result<void> save(const Endpoint& e, const std::string& name,
                                  std::function<void(Result<void>)> done);
  [[nodiscard]] Result<void> remove(const Endpoint& e, const std::string& name);
  // In `db` (empty: e's current database).
  [[nodiscard]] Result<void> setVar(Endpoint& e, const std::string& db, const std::string& key,
                                    const Variant& value);
  [[nodiscard]] Result<void> delVar(Endpoint& e, const std::string& db, const std::string& key);

 private:
  // Database name -> who may write it. Named databases (absent here) are writable by anyone.
  struct Owner {
    enum class Kind { user, flow, channel } kind;
    std::string user_name;
    uint32_t endpoint = 0;
  };

  // Calls on_props_changed when `db` is a channel's and its version moved past `before`.
  void propsChanged(const PairDatabase& db, uint64_t before) const;

  DatabaseStore store_;
  std::unordered_map<std::string, Owner> owners_;
  // Named database -> the user who created it since the hub started (the databases limit).
  std::unordered_map<std::string, std::string> creators_;
};

}  // namespace skr::flow
