// SPDX-License-Identifier: Apache-2.0
// Type-safe signals and slots.
//
//   struct Sensor : skr::Object { skr::Signal<double> reading{*this}; ... };
//   struct Logger : skr::Object { void onReading(double v); ... };
//   sensor.reading.connect(&logger, &Logger::onReading, skr::ConnectionType::queued);
//   sensor.reading.emit(21.5);
//
// Modes:
// - direct: the slot runs in the emitting thread, inside emit().
// - queued: the arguments are copied and the slot runs at the next pulse of the receiver's loop;
//   emit() never blocks and works across threads.
// - one_shot_direct / one_shot_queued: as above, and the connection is gone after one call.
// Rules:
// - A signal never connects the same (receiver, member function) or function pointer twice:
//   connecting again returns the existing connection.
// - connect() and disconnect() take effect at the next pulse of the signal owner's loop: an emit()
//   before that pulse does not see the change.
// - A receiver that is destroyed is detached at once; its queued calls not yet run are dropped.
// - A slot whose parameters do not match the signal's does not compile.
// - Signal arguments are values or const references (queued calls must copy them).
#pragma once

#include <skrobot/runtime/object.h>

#include <array>
#include <atomic>
#include <concepts>
#include <cstring>
#include <functional>
#include <memory>
#include <mutex>
#include <tuple>
#include <type_traits>
#include <vector>

namespace skr {

enum class ConnectionType { direct, queued, one_shot_direct, one_shot_queued };

namespace detail {

// Identity of a slot, to refuse duplicates: a member function pointer or function pointer,
// stored as bytes; all zero for lambdas (never equal to another).
using SlotKey = std::array<unsigned char, 2 * sizeof(void*)>;

struct ConnectionBase {
  Loop* sender_loop = nullptr;  // whose pulse applies attach/detach
  Loop* target_loop = nullptr;  // where queued calls run
  Object* receiver = nullptr;   // null for function pointers
  SlotKey key{};
  bool keyed = false;
  ConnectionType type = ConnectionType::direct;
  std::atomic<bool> attached{false};  // from the pulse after connect until detached
  std::atomic<bool> detach_requested{false};
  std::atomic<bool> receiver_gone{false};  // set by the receiver's destructor
  std::atomic<bool> fired{false};          // one-shot: the single call was taken
  virtual ~ConnectionBase() = default;
};

template <typename... Args>
struct Connection : ConnectionBase {
  std::function<void(const std::decay_t<Args>&...)> call;
};

}  // namespace detail

// A handle to one connection. Copyable; does not keep the connection alive.
class Connection {
 public:
  Connection() = default;
  explicit Connection(std::weak_ptr<detail::ConnectionBase> c) : c_(std::move(c)) {}

  // True from connect() until disconnect() was asked, the receiver died or a one-shot fired.
  [[nodiscard]] bool connected() const noexcept {
    auto c = c_.lock();
    return c && !c->detach_requested.load() && !c->receiver_gone.load() &&
           !(c->fired.load() && (c->type == ConnectionType::one_shot_direct ||
                                 c->type == ConnectionType::one_shot_queued));
  }
  // Detaches at the next pulse of the signal owner's loop. Any thread; idempotent.
  void disconnect() const {
    auto c = c_.lock();
    if (!c || c->detach_requested.exchange(true)) return;
    c->sender_loop->post([c] { c->attached.store(false); });
  }

 private:
  std::weak_ptr<detail::ConnectionBase> c_;
};

template <typename... Args>
class Signal {
  static_assert(((!std::is_lvalue_reference_v<Args> ||
                  std::is_const_v<std::remove_reference_t<Args>>)&&...),
                "signal arguments are values or const references");
  using Conn = detail::Connection<Args...>;
  using List = std::vector<std::shared_ptr<Conn>>;

 public:
  explicit Signal(Object& owner) : owner_loop_(&owner.loop()) {}
  ~Signal() { disconnectAll(); }
  Signal(const Signal&) = delete;
  Signal& operator=(const Signal&) = delete;
  Signal(Signal&&) = delete;
  Signal& operator=(Signal&&) = delete;

  // Connects a member function of a receiver Object. Any thread.
  template <typename R>
  requires std::derived_from<R, Object> Connection
  connect(R* receiver, void (R::*slot)(Args...), ConnectionType type = ConnectionType::direct) {
    detail::SlotKey key{};
    static_assert(sizeof(slot) <= sizeof(key));
    std::memcpy(key.data(), &slot, sizeof(slot));
    return add(receiver, key, true, type,
               [receiver, slot](const std::decay_t<Args>&... a) { (receiver->*slot)(a...); });
  }

  // Connects a callable; `context` is the receiver: its loop runs queued calls and its
  // destruction detaches the callable.
  template <typename F>
  requires std::invocable < F&, const std::decay_t<Args>
  &... > Connection connect(Object* context, F&& fn, ConnectionType type = ConnectionType::direct) {
    return add(context, {}, false, type,
               std::function<void(const std::decay_t<Args>&...)>(std::forward<F>(fn)));
  }

  // Connects a plain function; queued calls run on the signal owner's loop.
  Connection connect(void (*fn)(Args...), ConnectionType type = ConnectionType::direct) {
    detail::SlotKey key{};
    std::memcpy(key.data(), &fn, sizeof(fn));
    return add(nullptr, key, true, type, [fn](const std::decay_t<Args>&... a) { fn(a...); });
  }

  template <typename R>
  requires std::derived_from<R, Object>
  bool disconnect(R* receiver, void (R::*slot)(Args...)) {
    detail::SlotKey key{};
    std::memcpy(key.data(), &slot, sizeof(slot));
    return disconnectKey(receiver, key);
  }
  bool disconnect(void (*fn)(Args...)) {
    detail::SlotKey key{};
    std::memcpy(key.data(), &fn, sizeof(fn));
    return disconnectKey(nullptr, key);
  }
  // Detaches every connection at the next pulse.
  void disconnectAll() {
    auto list = snapshot();
    for (auto& c : *list) Connection(c).disconnect();
  }

  // Calls every attached slot. Any thread.
  void emit(const std::decay_t<Args>&... args) const {
    auto list = snapshot();
    bool prune = false;
    for (const auto& c : *list) {
      if (!c->attached.load() || c->receiver_gone.load()) {
        prune = prune || c->detach_requested.load() || c->receiver_gone.load();
        continue;
      }
      const bool one_shot =
          c->type == ConnectionType::one_shot_direct || c->type == ConnectionType::one_shot_queued;
      if (one_shot) {
        if (c->fired.exchange(true)) continue;
        c->attached.store(false);
        prune = true;
      }
      if (c->type == ConnectionType::direct || c->type == ConnectionType::one_shot_direct) {
        c->call(args...);
      } else {
        c->target_loop->post([c, copy = std::make_tuple(std::decay_t<Args>(args)...)] {
          if (!c->receiver_gone.load()) std::apply(c->call, copy);
        });
      }
    }
    if (prune) const_cast<Signal*>(this)->pruneDetached();
  }

  // Attached connections (attach/detach pending at the next pulse are not counted).
  [[nodiscard]] size_t connectionCount() const {
    auto list = snapshot();
    size_t n = 0;
    for (const auto& c : *list) n += c->attached.load() && !c->receiver_gone.load() ? 1 : 0;
    return n;
  }

 private:
  std::shared_ptr<const List> snapshot() const {
    std::lock_guard lock(mutex_);
    return list_;
  }

  Connection add(Object* receiver, const detail::SlotKey& key, bool keyed, ConnectionType type,
                 std::function<void(const std::decay_t<Args>&...)> call) {
    std::lock_guard lock(mutex_);
    if (keyed) {
      for (const auto& c : *list_) {
        if (c->keyed && c->receiver == receiver && c->key == key && !c->detach_requested.load() &&
            !c->receiver_gone.load() && !c->fired.load()) {
          return Connection(c);  // never the same slot twice
        }
      }
    }
    auto c = std::make_shared<Conn>();
    c->sender_loop = owner_loop_;
    c->target_loop = receiver != nullptr ? &receiver->loop() : owner_loop_;
    c->receiver = receiver;
    c->key = key;
    c->keyed = keyed;
    c->type = type;
    c->call = std::move(call);
    auto next = std::make_shared<List>();
    next->reserve(list_->size() + 1);
    for (const auto& old : *list_) {
      if (!old->detach_requested.load() && !old->receiver_gone.load()) next->push_back(old);
    }
    next->push_back(c);
    list_ = std::move(next);
    if (receiver != nullptr) receiver->addInbound(c);
    owner_loop_->post([c] {
      if (!c->detach_requested.load()) c->attached.store(true);
    });
    return Connection(std::static_pointer_cast<detail::ConnectionBase>(c));
  }

  bool disconnectKey(Object* receiver, const detail::SlotKey& key) {
    auto list = snapshot();
    for (const auto& c : *list) {
      if (c->keyed && c->receiver == receiver && c->key == key && !c->detach_requested.load()) {
        Connection(c).disconnect();
        return true;
      }
    }
    return false;
  }

  void pruneDetached() {
    std::lock_guard lock(mutex_);
    auto next = std::make_shared<List>();
    for (const auto& c : *list_) {
      const bool spent = c->fired.load() && (c->type == ConnectionType::one_shot_direct ||
                                             c->type == ConnectionType::one_shot_queued);
      const bool gone = c->receiver_gone.load() || (c->detach_requested.load() && !c->attached);
      if (!spent && !gone) next->push_back(c);
    }
    list_ = std::move(next);
  }

  Loop* owner_loop_;
  mutable std::mutex mutex_;
  std::shared_ptr<const List> list_ = std::make_shared<List>();
};

}  // namespace skr
