// SPDX-License-Identifier: Apache-2.0
// Objects live on one loop, own their children and are the receivers of signals.
//
// - An Object belongs to the loop it was created with; destroy it on that loop's thread.
// - Children made with makeChild() are owned by their parent and destroyed with it, in reverse
//   order of creation.
// - Destroying an Object first detaches every signal connection whose receiver it is, so no slot
//   of it runs afterwards (queued calls already posted are dropped), then removes its tick
//   handlers, then destroys its children.
// - deleteLater() destroys a child at the next pulse of its loop; top-level objects use the free
//   function skr::deleteLater(std::unique_ptr<T>).
#pragma once

#include <skrobot/runtime/loop.h>

#include <functional>
#include <memory>
#include <mutex>
#include <vector>

namespace skr {

namespace detail {
struct ConnectionBase;
}

class Object {
 public:
  explicit Object(Loop& loop) : loop_(&loop), alive_(std::make_shared<bool>(true)) {}
  virtual ~Object();
  Object(const Object&) = delete;
  Object& operator=(const Object&) = delete;
  Object(Object&&) = delete;
  Object& operator=(Object&&) = delete;

  [[nodiscard]] Loop& loop() const noexcept { return *loop_; }
  [[nodiscard]] Object* parent() const noexcept { return parent_; }

  // Creates a child owned by this object: T's constructor takes (Loop&, args...).
  template <typename T, typename... A>
  T& makeChild(A&&... args) {
    auto child = std::make_unique<T>(*loop_, std::forward<A>(args)...);
    T& ref = *child;
    child->parent_ = this;
    children_.push_back(std::move(child));
    return ref;
  }
  [[nodiscard]] size_t childCount() const noexcept { return children_.size(); }

  // Destroys this child at the next pulse of its loop (no-op if already destroyed by then).
  // Loop thread only. A top-level object logs an error and is left alone: use the free function.
  void deleteLater();

  // A tick handler that lives as long as this object. Loop thread only.
  TickId onTick(Tick which, std::function<void()> handler);

 private:
  template <typename... Args>
  friend class Signal;
  friend void deleteLater(std::unique_ptr<Object> object);

  void addInbound(const std::shared_ptr<detail::ConnectionBase>& c);
  void destroyChild(Object* child);

  Loop* loop_;
  Object* parent_ = nullptr;
  std::shared_ptr<bool> alive_;  // a weak_ptr to it tells deferred work the object is gone
  std::vector<std::unique_ptr<Object>> children_;
  std::vector<TickId> ticks_;
  std::mutex inbound_mutex_;  // connect() may run on another thread than the receiver's
  std::vector<std::weak_ptr<detail::ConnectionBase>> inbound_;
};

// Destroys a top-level object at the next pulse of its loop.
void deleteLater(std::unique_ptr<Object> object);

}  // namespace skr
