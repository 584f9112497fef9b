#include "src/core/config_json.hpp"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "src/core/fs_util.hpp"

namespace atacom {

std::string printable_text(std::string_view s, size_t max_bytes) {
  std::string out;
  const size_t n = std::min(s.size(), max_bytes);
  out.reserve(n + 8);
  for (size_t i = 0; i < n; ++i) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    if (c >= 0x20 && c < 0x7f) {
      out += static_cast<char>(c);
    } else {
      char b[8];
      std::snprintf(b, sizeof(b), "\\x%02x", c);
      out += b;
    }
  }
  if (s.size() > max_bytes) out += "...";
  return out;
}

std::string value_text(const nlohmann::json& v, size_t max_bytes) {
  // Numbers and short values print whole; the replace handler keeps a dump of
  // any string from throwing (parsed strings are valid UTF-8 anyway).
  if (v.is_array() || v.is_object()) return v.is_array() ? "a list" : "an object";
  return printable_text(v.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace), max_bytes);
}

std::string unknown_key_message(const std::string& key_path, const std::string& section,
                                const std::vector<std::string>& valid) {
  std::string list;
  for (const std::string& k : valid) list += (list.empty() ? "" : ", ") + printable_text(k);
  return "unknown config key '" + printable_text(key_path) + "' (valid keys of '" + printable_text(section) +
         "': " + (list.empty() ? "none" : list) + ")";
}

nlohmann::json parse_json_strict(std::string_view text, const std::string& what) {
  using json = nlohmann::json;
  // One frame per open object or array: the keys seen so far (objects only)
  // and the key being read, for "duplicate key 'a.b'" messages.
  struct Frame {
    bool object = false;
    std::set<std::string> keys;
    std::string key;
  };
  std::vector<Frame> stack;
  auto key_path = [&](const std::string& last) {
    std::string p;
    for (size_t i = 0; i + 1 < stack.size(); ++i)
      if (stack[i].object) p += stack[i].key + ".";
    return p + last;
  };
  std::string problem;
  const json::parser_callback_t cb = [&](int depth, json::parse_event_t ev, json& parsed) -> bool {
    switch (ev) {
      case json::parse_event_t::object_start:
      case json::parse_event_t::array_start:
        if (depth >= kMaxJsonDepth) {
          problem = "nested deeper than " + std::to_string(kMaxJsonDepth) + " levels";
          throw std::invalid_argument(problem);
        }
        stack.push_back(Frame{ev == json::parse_event_t::object_start, {}, {}});
        break;
      case json::parse_event_t::key: {
        Frame& f = stack.back();
        f.key = parsed.get<std::string>();
        if (!f.keys.insert(f.key).second) {
          problem = "duplicate key '" + printable_text(key_path(f.key)) + "'";
          throw std::invalid_argument(problem);
        }
        break;
      }
      case json::parse_event_t::object_end:
      case json::parse_event_t::array_end:
        if (!stack.empty()) stack.pop_back();
        break;
      default: break;
    }
    return true;
  };
  // The parser takes a NUL byte for the end of its input ("{...}\0garbage" would
  // read as valid); a NUL is never valid JSON text, so it is refused where it is.
  if (const size_t nul = text.find('\0'); nul != std::string_view::npos)
    throw std::invalid_argument(what + " is not valid JSON: a NUL byte at offset " + std::to_string(nul));
  try {
    return json::parse(text.begin(), text.end(), cb);
  } catch (const json::exception& e) {
    throw std::invalid_argument(what + " is not valid JSON: " + printable_text(e.what()));
  } catch (const std::invalid_argument&) {
    if (problem.empty()) throw;
    throw std::invalid_argument(what + ": " + problem);
  }
}

nlohmann::json read_json_file(const std::string& path, const std::string& what) {
  namespace fs = std::filesystem;
  const std::string name = what + " '" + printable_text(path) + "'";
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (ec || !fs::exists(st)) throw std::invalid_argument("cannot read " + name + ": no such file");
  if (fs::is_directory(st))
    throw std::invalid_argument(name + " is a directory; give the path of a JSON file (for a run: DIR/config.json)");
  const auto size = fs::file_size(path, ec);
  if (!ec && size > kMaxConfigFileBytes)
    throw std::invalid_argument(name + " is " + std::to_string(size) + " bytes, more than the limit of " +
                                std::to_string(kMaxConfigFileBytes >> 20) + " MiB");
  std::ifstream f(path, std::ios::binary);
  if (!f) throw std::invalid_argument("cannot read " + name + ": " + std::strerror(errno));
  std::string text;
  char buf[1 << 16];
  while (f.read(buf, sizeof(buf)) || f.gcount() > 0) {
    text.append(buf, size_t(f.gcount()));
    if (text.size() > kMaxConfigFileBytes)
      throw std::invalid_argument(name + " is larger than the limit of " + std::to_string(kMaxConfigFileBytes >> 20) +
                                  " MiB");
  }
  if (f.bad()) throw std::invalid_argument("cannot read " + name + ": read error");
  return parse_json_strict(text, name);
}

}  // namespace atacom

namespace atacom {

nlohmann::json read_json_below(const std::string& base, const std::string& rel, const std::string& what,
                               size_t max_bytes) {
  std::string why;
  const std::optional<std::string> text = read_below(base, rel, max_bytes, &why);
  const std::string name = what + " '" + printable_text(base + "/" + rel) + "'";
  if (!text) throw std::invalid_argument("cannot read " + name + ": it " + why);
  return parse_json_strict(*text, name);
}

}  // namespace atacom
