// SPDX-License-Identifier: Apache-2.0
#include "qi_value.h"

#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>

namespace skr::nao::qi {

Value Value::boolean(bool b) {
  Value v;
  v.kind_ = Kind::boolean;
  v.sig_ = 'b';
  v.b_ = b;
  v.i_ = b ? 1 : 0;
  return v;
}
Value Value::integer(std::int64_t i, char sig) {
  Value v;
  v.kind_ = Kind::integer;
  v.sig_ = sig;
  v.i_ = i;
  return v;
}
Value Value::real(double d, char sig) {
  Value v;
  v.kind_ = Kind::real;
  v.sig_ = sig;
  v.d_ = d;
  return v;
}
Value Value::string(std::string s, char sig) {
  Value v;
  v.kind_ = Kind::string;
  v.sig_ = sig;
  v.s_ = std::move(s);
  return v;
}
Value Value::list(std::vector<Value> items) {
  Value v;
  v.kind_ = Kind::list;
  v.sig_ = '[';
  v.items_ = std::move(items);
  return v;
}
Value Value::map(std::vector<std::pair<Value, Value>> entries) {
  Value v;
  v.kind_ = Kind::map;
  v.sig_ = '{';
  v.entries_ = std::move(entries);
  return v;
}
Value Value::tuple(std::vector<Value> items, std::string name, std::vector<std::string> fields) {
  Value v;
  v.kind_ = Kind::tuple;
  v.sig_ = '(';
  v.items_ = std::move(items);
  v.name_ = std::move(name);
  v.fields_ = std::move(fields);
  return v;
}
Value Value::strings(const std::vector<std::string>& v) {
  std::vector<Value> items;
  for (const auto& s : v) items.push_back(string(s));
  return list(std::move(items));
}
Value Value::reals(const std::vector<double>& v) {
  std::vector<Value> items;
  for (double d : v) items.push_back(real(d));
  return list(std::move(items));
}

double Value::asDouble() const noexcept {
  if (kind_ == Kind::real) return d_;
  if (kind_ == Kind::integer && sig_ == 'L') return static_cast<double>(static_cast<uint64_t>(i_));
  return static_cast<double>(i_);
}

const Value* Value::find(std::string_view key) const {
  for (const auto& [k, v] : entries_) {
    if (k.kind_ == Kind::string && k.s_ == key) return &v;
  }
  return nullptr;
}

Type Value::naturalType() const {
  Type t;
  t.kind = sig_;
  auto common = [](const std::vector<Type>& types) {
    Type m;
    m.kind = 'm';
    if (types.empty()) return m;
    for (const Type& x : types) {
      if (!(x == types.front())) return m;
    }
    return types.front();
  };
  if (kind_ == Kind::list) {
    std::vector<Type> types;
    for (const Value& i : items_) types.push_back(i.naturalType());
    t.items = {common(types)};
  } else if (kind_ == Kind::map) {
    std::vector<Type> keys, vals;
    for (const auto& [k, v] : entries_) {
      keys.push_back(k.naturalType());
      vals.push_back(v.naturalType());
    }
    t.items = {common(keys), common(vals)};
  } else if (kind_ == Kind::tuple) {
    for (const Value& i : items_) t.items.push_back(i.naturalType());
    t.name = name_;
    t.fields = fields_;
  }
  return t;
}

std::string Value::text() const {
  std::ostringstream o;
  switch (kind_) {
    case Kind::none:
      return "null";
    case Kind::boolean:
      return b_ ? "true" : "false";
    case Kind::integer:
      return sig_ == 'L' ? std::to_string(static_cast<uint64_t>(i_)) : std::to_string(i_);
    case Kind::real:
      o << d_;
      return o.str();
    case Kind::string:
      return "\"" + s_ + "\"";
    case Kind::list:
    case Kind::tuple: {
      o << (kind_ == Kind::list ? "[" : "(");
      for (std::size_t i = 0; i < items_.size(); ++i) o << (i ? "," : "") << items_[i].text();
      o << (kind_ == Kind::list ? "]" : ")");
      return o.str();
    }
    case Kind::map: {
      o << "{";
      for (std::size_t i = 0; i < entries_.size(); ++i) {
        o << (i ? "," : "") << entries_[i].first.text() << ":" << entries_[i].second.text();
      }
      o << "}";
      return o.str();
    }
  }
  return {};
}

bool Value::operator==(const Value& o) const {
  if (kind_ != o.kind_) return false;
  switch (kind_) {
    case Kind::none:
      return true;
    case Kind::boolean:
      return b_ == o.b_;
    case Kind::integer:
      return i_ == o.i_;
    case Kind::real:
      return d_ == o.d_;
    case Kind::string:
      return s_ == o.s_;
    case Kind::list:
    case Kind::tuple:
      return items_ == o.items_;
    case Kind::map:
      return entries_ == o.entries_;
  }
  return false;
}

namespace {

class Reader {
 public:
  explicit Reader(std::string_view b) : b_(b) {}
  [[nodiscard]] std::size_t left() const { return b_.size() - pos_; }
  [[nodiscard]] std::size_t pos() const { return pos_; }
  // Counts decoded values: a Value takes ~200 bytes of memory, so a payload of one-byte elements
  // would otherwise grow 200-fold in memory.
  bool spend() { return ++values_ <= kMaxDecodedValues; }
  bool bytes(void* out, std::size_t n) {
    if (left() < n) return false;
    std::memcpy(out, b_.data() + pos_, n);
    pos_ += n;
    return true;
  }
  bool view(std::size_t n, std::string_view& out) {
    if (left() < n) return false;
    out = b_.substr(pos_, n);
    pos_ += n;
    return true;
  }

 private:
  std::string_view b_;
  std::size_t pos_ = 0;
  std::size_t values_ = 0;
};

// Little-endian host assumed (x86, ARM as used by Nao and the hub); checked at compile time.
static_assert(std::endian::native == std::endian::little, "the qi codec assumes little-endian");

template <class T>
bool readLe(Reader& r, T& out) {
  return r.bytes(&out, sizeof(T));
}

Error shortPayload() {
  return makeError(Errc::protocol_error, "payload ends early");
}

Result<Value> decodeAt(const Type& t, Reader& r, int depth);

Result<std::uint32_t> readCount(Reader& r, const Type& elem, std::size_t per) {
  std::uint32_t n = 0;
  if (!readLe(r, n)) return shortPayload();
  if (n > 0 && per == 0) return makeError(Errc::protocol_error, "container of zero-size elements");
  if (per != 0 && n > r.left() / per) {
    return makeError(Errc::protocol_error, "count " + std::to_string(n) + " exceeds the payload (" +
                                               toString(elem) + ")");
  }
  return n;
}

Result<Value> decodeAt(const Type& t, Reader& r, int depth) {
  if (depth > kMaxValueDepth) return makeError(Errc::protocol_error, "value nested too deeply");
  if (!r.spend()) {
    return makeError(Errc::protocol_error,
                     "more than " + std::to_string(kMaxDecodedValues) + " values");
  }
  switch (t.kind) {
    case 'v':
      return Value();
    case 'b': {
      std::uint8_t b = 0;
      if (!readLe(r, b)) return shortPayload();
      return Value::boolean(b != 0);
    }
    case 'c': {
      std::int8_t x = 0;
      if (!readLe(r, x)) return shortPayload();
      return Value::integer(x, 'c');
    }
    case 'C': {
      std::uint8_t x = 0;
      if (!readLe(r, x)) return shortPayload();
      return Value::integer(x, 'C');
    }
    case 'w': {
      std::int16_t x = 0;
      if (!readLe(r, x)) return shortPayload();
      return Value::integer(x, 'w');
    }
    case 'W': {
      std::uint16_t x = 0;
      if (!readLe(r, x)) return shortPayload();
      return Value::integer(x, 'W');
    }
    case 'i': {
      std::int32_t x = 0;
      if (!readLe(r, x)) return shortPayload();
      return Value::integer(x, 'i');
    }
    case 'I': {
      std::uint32_t x = 0;
      if (!readLe(r, x)) return shortPayload();
      return Value::integer(x, 'I');
    }
    case 'l':
    case 'L': {
      std::int64_t x = 0;
      if (!readLe(r, x)) return shortPayload();
      return Value::integer(x, t.kind);
    }
    case 'f': {
      float x = 0;
      if (!readLe(r, x)) return shortPayload();
      return Value::real(x, 'f');
    }
    case 'd': {
      double x = 0;
      if (!readLe(r, x)) return shortPayload();
      return Value::real(x, 'd');
    }
    case 's':
    case 'r': {
      std::uint32_t n = 0;
      std::string_view s;
      if (!readLe(r, n) || !r.view(n, s)) return shortPayload();
      return Value::string(std::string(s), t.kind);
    }
    case 'm': {
      std::uint32_t n = 0;
      std::string_view sig;
      if (!readLe(r, n) || !r.view(n, sig)) return shortPayload();
      auto inner = parseSignature(sig);
      if (!inner) return inner.error();
      return decodeAt(inner.value(), r, depth + 1);
    }
    case '[': {
      auto n = readCount(r, t.items[0], minWireSize(t.items[0]));
      if (!n) return n.error();
      std::vector<Value> items;
      items.reserve(n.value());
      for (std::uint32_t i = 0; i < n.value(); ++i) {
        auto v = decodeAt(t.items[0], r, depth + 1);
        if (!v) return v;
        items.push_back(std::move(v.value()));
      }
      return Value::list(std::move(items));
    }
    case '{': {
      auto n = readCount(r, t.items[0], minWireSize(t.items[0]) + minWireSize(t.items[1]));
      if (!n) return n.error();
      std::vector<std::pair<Value, Value>> entries;
      entries.reserve(n.value());
      for (std::uint32_t i = 0; i < n.value(); ++i) {
        auto k = decodeAt(t.items[0], r, depth + 1);
        if (!k) return k;
        auto v = decodeAt(t.items[1], r, depth + 1);
        if (!v) return v;
        entries.emplace_back(std::move(k.value()), std::move(v.value()));
      }
      return Value::map(std::move(entries));
    }
    case '(': {
      std::vector<Value> items;
      for (const Type& m : t.items) {
        auto v = decodeAt(m, r, depth + 1);
        if (!v) return v;
        items.push_back(std::move(v.value()));
      }
      return Value::tuple(std::move(items), t.name, t.fields);
    }
    default:
      return makeError(Errc::unsupported, std::string("cannot decode type '") + t.kind + "'");
  }
}

template <class T>
void writeLe(std::string& out, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out.append(b, sizeof(T));
}

Error mismatch(const Type& t, const Value& v) {
  return makeError(Errc::protocol_error, "cannot send " + v.text() + " as '" + toString(t) + "'");
}

Result<void> writeInt(const Type& t, const Value& v, std::string& out) {
  if (v.kind() != Value::Kind::integer && v.kind() != Value::Kind::boolean) return mismatch(t, v);
  const std::int64_t i = v.asInt();
  auto in = [&](std::int64_t lo, std::int64_t hi) { return i >= lo && i <= hi; };
  switch (t.kind) {
    case 'c':
      if (!in(INT8_MIN, INT8_MAX)) return mismatch(t, v);
      writeLe(out, static_cast<std::int8_t>(i));
      return {};
    case 'C':
      if (!in(0, UINT8_MAX)) return mismatch(t, v);
      writeLe(out, static_cast<std::uint8_t>(i));
      return {};
    case 'w':
      if (!in(INT16_MIN, INT16_MAX)) return mismatch(t, v);
      writeLe(out, static_cast<std::int16_t>(i));
      return {};
    case 'W':
      if (!in(0, UINT16_MAX)) return mismatch(t, v);
      writeLe(out, static_cast<std::uint16_t>(i));
      return {};
    case 'i':
      if (!in(INT32_MIN, INT32_MAX)) return mismatch(t, v);
      writeLe(out, static_cast<std::int32_t>(i));
      return {};
    case 'I':
      if (!in(0, UINT32_MAX)) return mismatch(t, v);
      writeLe(out, static_cast<std::uint32_t>(i));
      return {};
    default:  // l, L: the 64-bit pattern as stored
      writeLe(out, i);
      return {};
  }
}

Result<void> encodeAt(const Type& t, const Value& v, std::string& out, int depth) {
  if (depth > kMaxValueDepth) return makeError(Errc::protocol_error, "value nested too deeply");
  switch (t.kind) {
    case 'v':
      return {};
    case 'b':
      if (v.kind() != Value::Kind::boolean) return mismatch(t, v);
      out.push_back(v.asBool() ? 1 : 0);
      return {};
    case 'c':
    case 'C':
    case 'w':
    case 'W':
    case 'i':
    case 'I':
    case 'l':
    case 'L':
      return writeInt(t, v, out);
    case 'f':
    case 'd': {
      if (v.kind() != Value::Kind::real && v.kind() != Value::Kind::integer) return mismatch(t, v);
      if (t.kind == 'f') {
        writeLe(out, static_cast<float>(v.asDouble()));
      } else {
        writeLe(out, v.asDouble());
      }
      return {};
    }
    case 's':
    case 'r':
      if (v.kind() != Value::Kind::string || v.asString().size() > UINT32_MAX) {
        return mismatch(t, v);
      }
      writeLe(out, static_cast<std::uint32_t>(v.asString().size()));
      out += v.asString();
      return {};
    case 'm': {
      const Type inner = v.naturalType();
      const std::string sig = toString(inner);
      writeLe(out, static_cast<std::uint32_t>(sig.size()));
      out += sig;
      return encodeAt(inner, v, out, depth + 1);
    }
    case '[':
      if (v.kind() != Value::Kind::list) return mismatch(t, v);
      writeLe(out, static_cast<std::uint32_t>(v.items().size()));
      for (const Value& i : v.items()) {
        auto r = encodeAt(t.items[0], i, out, depth + 1);
        if (!r) return r;
      }
      return {};
    case '{':
      if (v.kind() != Value::Kind::map) return mismatch(t, v);
      writeLe(out, static_cast<std::uint32_t>(v.entries().size()));
      for (const auto& [k, x] : v.entries()) {
        auto r = encodeAt(t.items[0], k, out, depth + 1);
        if (!r) return r;
        r = encodeAt(t.items[1], x, out, depth + 1);
        if (!r) return r;
      }
      return {};
    case '(':
      if (v.kind() != Value::Kind::tuple || v.items().size() != t.items.size()) {
        return mismatch(t, v);
      }
      for (std::size_t i = 0; i < t.items.size(); ++i) {
        auto r = encodeAt(t.items[i], v.items()[i], out, depth + 1);
        if (!r) return r;
      }
      return {};
    default:
      return makeError(Errc::unsupported, std::string("cannot encode type '") + t.kind + "'");
  }
}

}  // namespace

Result<Value> decode(const Type& t, std::string_view bytes, std::size_t* used) {
  Reader r(bytes);
  auto v = decodeAt(t, r, 0);
  if (!v) return v;
  if (used != nullptr) {
    *used = r.pos();
  } else if (r.pos() != bytes.size()) {
    // A message read only in part was not understood: its type is not the one assumed.
    return makeError(Errc::protocol_error, std::to_string(bytes.size() - r.pos()) +
                                               " bytes left after the value (" + toString(t) + ")");
  }
  return v;
}

Result<Value> decode(std::string_view sig, std::string_view bytes, std::size_t* used) {
  auto t = parseSignature(sig);
  if (!t) return t.error();
  return decode(t.value(), bytes, used);
}

Result<void> encode(const Type& t, const Value& v, std::string& out) {
  return encodeAt(t, v, out, 0);
}

Result<std::string> encode(std::string_view sig, const Value& v) {
  auto t = parseSignature(sig);
  if (!t) return t.error();
  std::string out;
  auto r = encode(t.value(), v, out);
  if (!r) return r.error();
  return out;
}

}  // namespace skr::nao::qi
