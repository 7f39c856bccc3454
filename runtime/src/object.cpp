// SPDX-License-Identifier: Apache-2.0
#include <skrobot/runtime/log.h>
#include <skrobot/runtime/signal.h>

#include <algorithm>

namespace skr {

Object::~Object() {
  *alive_ = false;
  {
    std::lock_guard lock(inbound_mutex_);
    for (auto& weak : inbound_) {
      if (auto c = weak.lock()) {
        c->receiver_gone.store(true);
        c->attached.store(false);
      }
    }
    inbound_.clear();
  }
  for (TickId id : ticks_) loop_->removeTickHandler(id);
  while (!children_.empty()) children_.pop_back();  // reverse order of creation
}

void Object::addInbound(const std::shared_ptr<detail::ConnectionBase>& c) {
  std::lock_guard lock(inbound_mutex_);
  std::erase_if(inbound_, [](const auto& w) { return w.expired(); });
  inbound_.push_back(c);
}

void Object::destroyChild(Object* child) {
  auto it = std::find_if(children_.begin(), children_.end(),
                         [child](const auto& p) { return p.get() == child; });
  if (it != children_.end()) children_.erase(it);
}

void Object::deleteLater() {
  if (parent_ == nullptr) {
    log::error("core.object", "OBJECT-DELETE-LATER",
               "deleteLater() on a top-level object; use skr::deleteLater(std::unique_ptr)");
    return;
  }
  std::weak_ptr<bool> alive = alive_;
  Object* parent = parent_;
  loop_->post([alive, parent, self = this] {
    if (alive.lock() && *alive.lock()) parent->destroyChild(self);
  });
}

TickId Object::onTick(Tick which, std::function<void()> handler) {
  const TickId id = loop_->addTickHandler(which, std::move(handler));
  ticks_.push_back(id);
  return id;
}

void deleteLater(std::unique_ptr<Object> object) {
  if (!object) return;
  Loop& loop = object->loop();
  // std::function needs a copyable callable: hand the pointer over through a shared_ptr.
  auto holder = std::make_shared<std::unique_ptr<Object>>(std::move(object));
  loop.post([holder] { holder->reset(); });
}

}  // namespace skr
