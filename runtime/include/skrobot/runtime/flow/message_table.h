// SPDX-License-Identifier: Apache-2.0
// Every message struct of the catalogue (catalogue.h), for code that must handle them all (the
// fuzz target, the round-trip tests): forEachMessage(f) calls f(M{}) once per message type, each
// row's body and its reply, each type once.
#pragma once

#include <skrobot/runtime/flow/messages.h>

#include <type_traits>

namespace skr::flow {

namespace msg {
// The reply column of a row that has none.
struct None {};
}  // namespace msg

namespace detail {

template <class... T>
struct TypeList {};

// Appends U unless the list has it (or it is None).
template <class List, class U>
struct AddUnique;
template <class... T, class U>
struct AddUnique<TypeList<T...>, U> {
  using type = std::conditional_t<(std::is_same_v<T, U> || ...) || std::is_same_v<U, msg::None>,
                                  TypeList<T...>, TypeList<T..., U>>;
};

template <class List, class... U>
struct Unique {
  using type = List;
};
template <class List, class U, class... Rest>
struct Unique<List, U, Rest...> {
  using type = typename Unique<typename AddUnique<List, U>::type, Rest...>::type;
};

#define SKR_FLOW_TYPES(code, name, minor, dir, via, family, message, reply) \
  msg::message, msg::reply,
using AllMessages = Unique<TypeList<>, SKR_FLOW_CATALOGUE(SKR_FLOW_TYPES) msg::None>::type;
#undef SKR_FLOW_TYPES

template <class R>
constexpr bool isReplyBody() {
  if constexpr (std::is_same_v<R, msg::None>) {
    return true;
  } else {
    return R::code == Code::reply_ok;
  }
}

// Each row's body is the struct of that code, and its reply a REPLY_OK body.
#define SKR_FLOW_CHECK_ROW(value, name, minor, dir, via, family, message, reply)              \
  static_assert(msg::message::code == Code::name, "catalogue.h: " #message " is not " #name); \
  static_assert(isReplyBody<msg::reply>(),                                                    \
                "catalogue.h: the reply of " #name " is no REPLY_OK body");
SKR_FLOW_CATALOGUE(SKR_FLOW_CHECK_ROW)
#undef SKR_FLOW_CHECK_ROW

template <class F, class... T>
void each(TypeList<T...>, F& f) {
  (f(T{}), ...);
}

}  // namespace detail

template <class F>
void forEachMessage(F&& f) {
  detail::each(detail::AllMessages{}, f);
}

}  // namespace skr::flow
