// SPDX-License-Identifier: Apache-2.0
#include <skrobot/ros2/definitions.h>

#include <dlfcn.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <fstream>
#include <functional>
#include <limits>
#include <set>
#include <sstream>

namespace skr::ros2 {
namespace {

constexpr std::array<std::pair<std::string_view, Primitive>, 15> kPrimitives = {{
    {"bool", Primitive::boolean},
    {"byte", Primitive::byte},
    {"char", Primitive::character},
    {"float32", Primitive::float32},
    {"float64", Primitive::float64},
    {"int8", Primitive::int8},
    {"uint8", Primitive::uint8},
    {"int16", Primitive::int16},
    {"uint16", Primitive::uint16},
    {"int32", Primitive::int32},
    {"uint32", Primitive::uint32},
    {"int64", Primitive::int64},
    {"uint64", Primitive::uint64},
    {"string", Primitive::string},
    {"wstring", Primitive::wstring},
}};

constexpr std::uint32_t kMaxSize = 1u << 24;  // array sizes and string bounds, at most

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) {
    s.remove_prefix(1);
  }
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) {
    s.remove_suffix(1);
  }
  return s;
}

bool identifier(std::string_view s) {
  if (s.empty() || !std::isalpha(static_cast<unsigned char>(s[0]))) return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_';
  });
}

std::optional<std::uint32_t> number(std::string_view s) {
  std::uint32_t v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || end != s.data() + s.size() || v > kMaxSize) return std::nullopt;
  return v;
}

// The text before a comment: '#' outside quotes.
std::string_view uncommented(std::string_view line) {
  char quote = 0;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quote != 0) {
      if (c == '\\')
        ++i;
      else if (c == quote)
        quote = 0;
    } else if (c == '"' || c == '\'') {
      quote = c;
    } else if (c == '#') {
      return line.substr(0, i);
    }
  }
  return line;
}

// A scalar value written in a definition, for a field or constant of type `p`; nullopt when it
// is not one (or out of the type's range).
std::optional<Json::Value> scalar(Primitive p, std::string_view text) {
  text = trim(text);
  if (p == Primitive::string || p == Primitive::wstring) {
    if (text.size() >= 2 && (text.front() == '"' || text.front() == '\'') &&
        text.back() == text.front()) {
      std::string out;
      for (std::size_t i = 1; i + 1 < text.size(); ++i) {
        if (text[i] == '\\' && i + 2 < text.size()) ++i;
        out.push_back(text[i]);
      }
      return Json::Value(out);
    }
    return Json::Value(std::string(text));
  }
  if (text.empty()) return std::nullopt;
  if (p == Primitive::boolean) {
    if (text == "true" || text == "True" || text == "1") return Json::Value(true);
    if (text == "false" || text == "False" || text == "0") return Json::Value(false);
    return std::nullopt;
  }
  if (p == Primitive::float32 || p == Primitive::float64) {
    std::string s(text);
    char* end = nullptr;
    errno = 0;
    const double v = std::strtod(s.c_str(), &end);
    if (end != s.c_str() + s.size() || errno == ERANGE) return std::nullopt;
    return Json::Value(v);
  }
  const bool is_signed = p == Primitive::int8 || p == Primitive::int16 || p == Primitive::int32 ||
                         p == Primitive::int64;
  const int bits = p == Primitive::int16 || p == Primitive::uint16   ? 16
                   : p == Primitive::int32 || p == Primitive::uint32 ? 32
                   : p == Primitive::int64 || p == Primitive::uint64 ? 64
                                                                     : 8;
  if (is_signed) {
    std::int64_t v = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
    if (ec != std::errc() || end != text.data() + text.size()) return std::nullopt;
    const std::int64_t lo =
        bits == 64 ? std::numeric_limits<std::int64_t>::min() : -(std::int64_t{1} << (bits - 1));
    const std::int64_t hi =
        bits == 64 ? std::numeric_limits<std::int64_t>::max() : (std::int64_t{1} << (bits - 1)) - 1;
    if (v < lo || v > hi) return std::nullopt;
    return Json::Value(static_cast<Json::Int64>(v));
  }
  std::uint64_t v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size()) return std::nullopt;
  if (bits < 64 && v >> bits != 0) return std::nullopt;
  return Json::Value(static_cast<Json::UInt64>(v));
}

// "[1, 2, 3]" for an array field.
std::optional<Json::Value> arrayValue(Primitive p, std::string_view text) {
  text = trim(text);
  if (text.size() < 2 || text.front() != '[' || text.back() != ']') return std::nullopt;
  text = trim(text.substr(1, text.size() - 2));
  Json::Value out(Json::arrayValue);
  if (text.empty()) return out;
  char quote = 0;
  std::size_t start = 0;
  for (std::size_t i = 0; i <= text.size(); ++i) {
    const char c = i < text.size() ? text[i] : ',';
    if (quote != 0) {
      if (c == '\\')
        ++i;
      else if (c == quote)
        quote = 0;
      continue;
    }
    if (c == '"' || c == '\'') quote = c;
    if (c != ',') continue;
    auto v = scalar(p, text.substr(start, i - start));
    if (!v) return std::nullopt;
    out.append(std::move(*v));
    start = i + 1;
  }
  return out;
}

// "float64[3]", "string<=10[]", "geometry_msgs/Vector3", "Point[<=5]" in package `pkg`.
std::optional<FieldType> typeOf(std::string_view text, std::string_view pkg, std::string& why) {
  FieldType t;
  if (const auto open = text.find('['); open != std::string_view::npos) {
    if (text.back() != ']') {
      why = "an array type must end with ']'";
      return std::nullopt;
    }
    const std::string_view inner = text.substr(open + 1, text.size() - open - 2);
    text = text.substr(0, open);
    if (inner.empty()) {
      t.array = FieldType::Array::unbounded;
    } else if (inner.starts_with("<=")) {
      auto n = number(inner.substr(2));
      if (!n || *n == 0) {
        why = "a bounded array needs a size of 1 to 16777216";
        return std::nullopt;
      }
      t.array = FieldType::Array::bounded;
      t.array_size = *n;
    } else {
      auto n = number(inner);
      if (!n || *n == 0) {
        why = "a fixed array needs a size of 1 to 16777216";
        return std::nullopt;
      }
      t.array = FieldType::Array::fixed;
      t.array_size = *n;
    }
  }
  if (const auto le = text.find("<="); le != std::string_view::npos) {
    const auto base = primitiveOf(text.substr(0, le));
    auto n = number(text.substr(le + 2));
    if (!base || (*base != Primitive::string && *base != Primitive::wstring) || !n || *n == 0) {
      why = "only string and wstring take a bound (string<=N)";
      return std::nullopt;
    }
    t.primitive = base;
    t.string_bound = *n;
    return t;
  }
  if (auto p = primitiveOf(text)) {
    t.primitive = p;
    return t;
  }
  std::string name(text);
  if (name.find('/') == std::string::npos) {
    if (!identifier(name)) {
      why = "\"" + name + "\" is not a type";
      return std::nullopt;
    }
    name = std::string(pkg) + "/" + name;
  }
  auto full = fullName(name);
  if (!full) {
    why = "\"" + std::string(text) + "\" is not a type (pkg/Name or pkg/msg/Name)";
    return std::nullopt;
  }
  if (const char c = (*full)[full->rfind('/') + 1]; c < 'A' || c > 'Z') {
    // ROS 2's message names start with a capital: a misspelt primitive (flaot32) or ROS 1's
    // time and duration are not taken for a message of this package.
    why = "\"" + std::string(text) + "\" is not a type (a message's name starts with a capital)";
    return std::nullopt;
  }
  t.message = *full;
  return t;
}

Error parseError(std::string_view name, std::size_t line, const std::string& why) {
  return makeError(Errc::parse_error, std::string(name) + ":" + std::to_string(line) + ": " + why);
}

// The package of "pkg/msg/Name" (or "pkg/srv/Name_Request").
std::string_view packageOf(std::string_view name) {
  return name.substr(0, name.find('/'));
}

}  // namespace

std::string_view primitiveName(Primitive p) noexcept {
  for (const auto& [name, prim] : kPrimitives) {
    if (prim == p) return name;
  }
  return "?";
}

std::optional<Primitive> primitiveOf(std::string_view name) noexcept {
  for (const auto& [n, prim] : kPrimitives) {
    if (n == name) return prim;
  }
  return std::nullopt;
}

std::optional<std::string> fullName(std::string_view name) {
  std::vector<std::string_view> parts;
  std::size_t start = 0;
  while (true) {
    const auto slash = name.find('/', start);
    parts.push_back(name.substr(start, slash == std::string_view::npos ? slash : slash - start));
    if (slash == std::string_view::npos) break;
    start = slash + 1;
  }
  if (parts.size() == 2 && identifier(parts[0]) && identifier(parts[1])) {
    return std::string(parts[0]) + "/msg/" + std::string(parts[1]);
  }
  if (parts.size() == 3 && identifier(parts[0]) && (parts[1] == "msg" || parts[1] == "srv") &&
      identifier(parts[2])) {
    return std::string(name);
  }
  return std::nullopt;
}

std::string ddsTypeName(std::string_view full) {
  std::string out;
  std::size_t start = 0;
  std::vector<std::string_view> parts;
  while (true) {
    const auto slash = full.find('/', start);
    parts.push_back(full.substr(start, slash == std::string_view::npos ? slash : slash - start));
    if (slash == std::string_view::npos) break;
    start = slash + 1;
  }
  for (std::size_t i = 0; i + 1 < parts.size(); ++i) out.append(parts[i]).append("::");
  return out + "dds_::" + std::string(parts.back()) + "_";
}

Result<MessageDefinition> parseMessage(std::string_view name, std::string_view text) {
  MessageDefinition def;
  def.name = std::string(name);
  const std::string_view pkg = packageOf(name);
  std::set<std::string, std::less<>> seen;
  std::size_t line_no = 0;
  std::size_t start = 0;
  while (start <= text.size()) {
    const auto nl = text.find('\n', start);
    const std::string_view raw =
        text.substr(start, nl == std::string_view::npos ? std::string_view::npos : nl - start);
    start = nl == std::string_view::npos ? text.size() + 1 : nl + 1;
    ++line_no;
    const std::string_view line = trim(uncommented(raw));
    if (line.empty()) continue;
    const auto space = line.find_first_of(" \t");
    if (space == std::string_view::npos) {
      return parseError(name, line_no, "a field needs a type and a name");
    }
    std::string why;
    const std::string_view type_text = line.substr(0, space);
    auto type = typeOf(type_text, pkg, why);
    if (!type) return parseError(name, line_no, why);
    std::string_view rest = trim(line.substr(space));
    if (const auto eq = rest.find('='); eq != std::string_view::npos) {
      // A constant: a primitive, not an array.
      const std::string_view cname = trim(rest.substr(0, eq));
      if (!type->primitive || type->array != FieldType::Array::none) {
        return parseError(name, line_no, "a constant must be of a primitive type, not an array");
      }
      if (!identifier(cname)) return parseError(name, line_no, "a constant needs a name");
      auto value = scalar(*type->primitive, rest.substr(eq + 1));
      if (!value) {
        return parseError(name, line_no,
                          "constant " + std::string(cname) + ": not a " +
                              std::string(primitiveName(*type->primitive)));
      }
      if (!seen.insert(std::string(cname)).second) {
        return parseError(name, line_no, std::string(cname) + " is defined twice");
      }
      def.constants.push_back({std::string(cname), *type->primitive, std::move(*value)});
      continue;
    }
    const auto name_end = rest.find_first_of(" \t");
    const std::string_view fname = rest.substr(0, name_end);
    if (!identifier(fname)) {
      return parseError(name, line_no, "\"" + std::string(fname) + "\" is not a field name");
    }
    if (!seen.insert(std::string(fname)).second) {
      return parseError(name, line_no, std::string(fname) + " is defined twice");
    }
    Field f{std::string(fname), *type, std::nullopt};
    if (name_end != std::string_view::npos) {
      const std::string_view dflt = trim(rest.substr(name_end));
      if (!type->primitive) {
        return parseError(name, line_no, "only fields of primitive types have defaults");
      }
      auto value = type->array == FieldType::Array::none ? scalar(*type->primitive, dflt)
                                                         : arrayValue(*type->primitive, dflt);
      if (!value) {
        return parseError(
            name, line_no,
            "the default of " + std::string(fname) + " is not a " + std::string(type_text));
      }
      f.default_value = std::move(*value);
    }
    def.fields.push_back(std::move(f));
  }
  return def;
}

Result<std::pair<MessageDefinition, MessageDefinition>> parseService(std::string_view name,
                                                                     std::string_view text) {
  // The separator: a line of three dashes.
  std::size_t sep = std::string_view::npos;
  std::size_t separator_line = 0;
  std::size_t line_no = 0;
  for (std::size_t start = 0; start <= text.size();) {
    const auto nl = text.find('\n', start);
    ++line_no;
    if (trim(text.substr(
            start, nl == std::string_view::npos ? std::string_view::npos : nl - start)) == "---") {
      sep = start;
      separator_line = line_no;
      break;
    }
    if (nl == std::string_view::npos) break;
    start = nl + 1;
  }
  if (sep == std::string_view::npos) {
    return makeError(Errc::parse_error, std::string(name) + ": a service needs a line '---'");
  }
  auto request = parseMessage(std::string(name) + "_Request", text.substr(0, sep));
  if (!request) return request.error();
  const auto after = text.find('\n', sep);
  auto response = parseMessage(std::string(name) + "_Response",
                               after == std::string_view::npos ? "" : text.substr(after + 1));
  if (!response) {
    // Line numbers of the response count from the separator.
    std::string why = response.error().message;
    const auto colon = why.find(':');
    const auto colon2 = why.find(':', colon + 1);
    if (colon != std::string::npos && colon2 != std::string::npos) {
      const std::string n = why.substr(colon + 1, colon2 - colon - 1);
      why = why.substr(0, colon + 1) + std::to_string(std::stoul(n) + separator_line) +
            why.substr(colon2);
    }
    return makeError(Errc::parse_error, why);
  }
  return std::make_pair(std::move(*request), std::move(*response));
}

Result<void> Registry::add(MessageDefinition definition) {
  auto name = definition.name;
  if (auto it = definitions_.find(name); it != definitions_.end()) {
    // The same definition twice is no conflict (a schema carrying a shipped type).
    const auto same = [](const MessageDefinition& a, const MessageDefinition& b) {
      if (a.fields.size() != b.fields.size() || a.constants.size() != b.constants.size()) {
        return false;
      }
      for (std::size_t i = 0; i < a.fields.size(); ++i) {
        const auto& x = a.fields[i];
        const auto& y = b.fields[i];
        if (x.name != y.name || x.type.primitive != y.type.primitive ||
            x.type.message != y.type.message || x.type.string_bound != y.type.string_bound ||
            x.type.array != y.type.array || x.type.array_size != y.type.array_size) {
          return false;
        }
      }
      return true;
    };
    if (same(it->second, definition)) return {};
    return makeError(Errc::already_exists,
                     name + " is defined already, with other fields (two versions of a type)");
  }
  definitions_.emplace(std::move(name), std::move(definition));
  return {};
}

std::filesystem::path shippedFolder(const std::filesystem::path& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  for (const fs::path& candidate :
       {dir / SKROBOT_REL_BIN_TO_ROS2_MSGS, dir / SKROBOT_REL_MODULES_TO_ROS2_MSGS,
        dir / ".." / "ros2" / "msgs"}) {
    if (fs::is_directory(candidate, ec)) return candidate.lexically_normal();
  }
  return {};
}

std::filesystem::path shippedFolder() {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::path self;
  Dl_info info{};
  using Fn = fs::path (*)();
  if (::dladdr(reinterpret_cast<void*>(static_cast<Fn>(&shippedFolder)), &info) != 0 &&
      info.dli_fname != nullptr &&
      std::string_view(info.dli_fname).find('/') != std::string_view::npos) {
    self = fs::absolute(info.dli_fname, ec);
  }
  // A program's own name may come without its directory: the kernel knows where it is.
  if (self.empty() || !fs::exists(self, ec)) self = fs::read_symlink("/proc/self/exe", ec);
  return self.empty() ? fs::path() : shippedFolder(self.parent_path());
}

Result<void> Registry::addFolder(const std::filesystem::path& root) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(root, ec)) {
    return makeError(Errc::not_found, root.string() + ": not a folder of interface packages");
  }
  std::vector<fs::path> files;
  for (const auto& pkg : fs::directory_iterator(root, ec)) {
    if (!pkg.is_directory()) continue;
    for (const char* kind : {"msg", "srv"}) {
      const fs::path dir = pkg.path() / kind;
      if (!fs::is_directory(dir, ec)) continue;
      for (const auto& f : fs::directory_iterator(dir, ec)) {
        if (f.path().extension() == std::string(".") + kind) files.push_back(f.path());
      }
    }
  }
  std::sort(files.begin(), files.end());
  for (const auto& file : files) {
    std::ifstream in(file, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    if (!in && !in.eof()) return makeError(Errc::io_error, "cannot read " + file.string());
    const std::string pkg = file.parent_path().parent_path().filename().string();
    const std::string kind = file.extension().string().substr(1);
    const std::string name = pkg + "/" + kind + "/" + file.stem().string();
    if (kind == "msg") {
      auto def = parseMessage(name, text.str());
      if (!def) return makeError(def.error().code, file.string() + ": " + def.error().message);
      texts_[name] = text.str();
      if (auto r = add(std::move(*def)); !r) return r;
    } else {
      auto defs = parseService(name, text.str());
      if (!defs) return makeError(defs.error().code, file.string() + ": " + defs.error().message);
      const std::string t = text.str();
      const auto dashes = t.find("\n---");
      texts_[defs->first.name] = t.substr(0, dashes == std::string::npos ? 0 : dashes + 1);
      const auto after = t.find('\n', dashes + 1);
      texts_[defs->second.name] = after == std::string::npos ? "" : t.substr(after + 1);
      if (auto r = add(std::move(defs->first)); !r) return r;
      if (auto r = add(std::move(defs->second)); !r) return r;
    }
  }
  return {};
}

Result<void> Registry::addSchema(std::string_view name, std::string_view text) {
  auto full = fullName(name);
  if (!full) return makeError(Errc::invalid_argument, std::string(name) + " is not a type name");
  // Sections: the main one, then after each line of '=' one "MSG: pkg/Type" definition.
  std::string current = *full;
  std::string body;
  auto flush = [&]() -> Result<void> {
    auto def = parseMessage(current, body);
    if (!def) return def.error();
    if (!texts_.count(current)) texts_[current] = body;
    return add(std::move(*def));
  };
  std::size_t start = 0;
  while (start <= text.size()) {
    const auto nl = text.find('\n', start);
    const std::string_view line =
        text.substr(start, nl == std::string_view::npos ? std::string_view::npos : nl - start);
    start = nl == std::string_view::npos ? text.size() + 1 : nl + 1;
    if (nl == std::string_view::npos && line.empty()) break;  // after the last newline
    const std::string_view t = trim(line);
    if (t.size() >= 3 && t.find_first_not_of('=') == std::string_view::npos) {
      if (auto r = flush(); !r) return r;
      body.clear();
      current.clear();
      continue;
    }
    if (current.empty()) {
      if (!t.starts_with("MSG:")) {
        if (t.empty()) continue;
        return makeError(
            Errc::parse_error,
            std::string(name) + ": a section after '====' starts with \"MSG: pkg/Type\"");
      }
      auto sub = fullName(trim(t.substr(4)));
      if (!sub) {
        return makeError(Errc::parse_error,
                         std::string(name) + ": \"" + std::string(t) + "\" names no type");
      }
      current = *sub;
      continue;
    }
    body.append(line).push_back('\n');
  }
  if (current.empty()) return {};
  return flush();
}

const MessageDefinition* Registry::find(std::string_view name) const {
  auto it = definitions_.find(name);
  if (it != definitions_.end()) return &it->second;
  if (auto full = fullName(name); full && *full != name) {
    it = definitions_.find(*full);
    if (it != definitions_.end()) return &it->second;
  }
  return nullptr;
}

Result<void> Registry::resolve(std::string_view name) const {
  // Depth first, so that a type met again while its own fields are visited is a cycle.
  std::set<std::string, std::less<>> visiting, done;
  std::function<Result<void>(const std::string&, const std::string&)> visit =
      [&](const std::string& n, const std::string& user) -> Result<void> {
    if (done.contains(n)) return {};
    if (visiting.contains(n)) {
      return makeError(Errc::invalid_argument, n + " uses itself (" + user + ")");
    }
    const MessageDefinition* def = find(n);
    if (def == nullptr) {
      return makeError(Errc::not_found,
                       "no definition of " + n + (user.empty() ? "" : ", used by " + user));
    }
    visiting.insert(n);
    for (const auto& f : def->fields) {
      if (f.type.primitive) continue;
      if (auto r = visit(f.type.message, def->name + "." + f.name); !r) return r;
    }
    visiting.erase(n);
    done.insert(n);
    return {};
  };
  return visit(std::string(name), "");
}

std::vector<std::string> Registry::names() const {
  std::vector<std::string> out;
  out.reserve(definitions_.size());
  for (const auto& [name, def] : definitions_) out.push_back(name);
  return out;
}

std::string Registry::schemaText(std::string_view name) const {
  const MessageDefinition* root = find(name);
  if (root == nullptr) return {};
  auto textOf = [&](const MessageDefinition& d) {
    if (auto t = texts_.find(d.name); t != texts_.end()) return t->second;
    // Written from the definition (a type added without its text).
    std::string out;
    for (const auto& c : d.constants) {
      out += std::string(primitiveName(c.type)) + " " + c.name + "=" + c.value.asString() + "\n";
    }
    for (const auto& f : d.fields) {
      std::string type =
          f.type.primitive ? std::string(primitiveName(*f.type.primitive)) : f.type.message;
      if (f.type.string_bound != 0) type += "<=" + std::to_string(f.type.string_bound);
      if (f.type.array == FieldType::Array::unbounded) type += "[]";
      if (f.type.array == FieldType::Array::fixed)
        type += "[" + std::to_string(f.type.array_size) + "]";
      if (f.type.array == FieldType::Array::bounded)
        type += "[<=" + std::to_string(f.type.array_size) + "]";
      out += type + " " + f.name + "\n";
    }
    return out;
  };
  std::string out = textOf(*root);
  std::set<std::string, std::less<>> written{root->name};
  std::vector<const MessageDefinition*> todo{root};
  while (!todo.empty()) {
    const MessageDefinition* d = todo.front();
    todo.erase(todo.begin());
    for (const auto& f : d->fields) {
      if (f.type.primitive || !written.insert(f.type.message).second) continue;
      const MessageDefinition* sub = find(f.type.message);
      if (sub == nullptr) continue;
      // "MSG: pkg/Type", as rosbag2 and MCAP's ROS 2 profile write it.
      std::string short_name = sub->name;
      if (const auto m = short_name.find("/msg/"); m != std::string::npos) short_name.erase(m, 4);
      if (!out.empty() && out.back() != '\n') out += '\n';
      out += std::string(80, '=') + "\nMSG: " + short_name + "\n" + textOf(*sub);
      todo.push_back(sub);
    }
  }
  return out;
}

}  // namespace skr::ros2
