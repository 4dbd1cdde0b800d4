// What follows from a key's declaration (case_schema.hpp): its bounds message, and the default and
// choices read from the document's text.
#include "config/case_schema.hpp"

#include <cstdlib>
#include <regex>

#include "config/case_parser_detail.hpp"

namespace mlcg::config::schema {

using detail::num;

std::string Bounds::text() const {
  return std::string(lo_open ? "(" : "[") + num(lo) + ", " + num(hi) + (hi_open ? ")" : "]");
}

std::vector<std::string> names(Keys keys) {
  std::vector<std::string> out;
  for (const KeySpec& k : keys) out.emplace_back(k.name);
  return out;
}

std::string bounds_message(const KeySpec& k, double v) {
  const Bounds& b = k.bounds;
  const std::string unit(k.unit), in_unit = unit.empty() ? "" : " in " + unit;
  std::string s = num(v);
  if (b.hi == kInf && b.lo == 0.0 && b.lo_open) s += " is not > 0; give a positive value" + in_unit;
  else if (b.hi == kInf && b.lo == 0.0) s += " is negative; give a value >= 0" + in_unit;
  else if (b.hi == kInf)
    s += (b.lo_open ? " is not above " : " is below ") + num(b.lo) + (unit.empty() ? "" : " " + unit) + "; give " +
         std::string(k.name) + (b.lo_open ? " > " : " >= ") + num(b.lo);
  else s += " is outside " + b.text() + (unit.empty() ? "" : " " + unit);
  if (!k.why.empty()) s += "; " + std::string(k.why);
  return s;
}

namespace {

// The text between the backticks when default_text is one `code` span, else nullopt.
std::optional<std::string> code(std::string_view text) {
  if (text.size() < 2 || text.front() != '`' || text.back() != '`') return std::nullopt;
  const std::string_view inner = text.substr(1, text.size() - 2);
  if (inner.find('`') != std::string_view::npos) return std::nullopt;
  return std::string(inner);
}

std::optional<double> parse_number(const std::string& s) {
  if (s.empty()) return std::nullopt;
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (end != s.c_str() + s.size()) return std::nullopt;
  return v;
}

}  // namespace

std::optional<double> default_number(const KeySpec& k) {
  const auto c = code(k.default_text);
  return c ? parse_number(*c) : std::nullopt;
}

std::optional<std::string> default_string(const KeySpec& k) {
  const auto c = code(k.default_text);
  if (!c || c->size() < 2 || c->front() != '"' || c->back() != '"') return std::nullopt;
  return c->substr(1, c->size() - 2);
}

std::optional<bool> default_boolean(const KeySpec& k) {
  const auto c = code(k.default_text);
  if (c == "true") return true;
  if (c == "false") return false;
  return std::nullopt;
}

std::optional<std::vector<double>> default_numbers(const KeySpec& k) {
  const auto c = code(k.default_text);
  if (!c || c->size() < 2 || c->front() != '[' || c->back() != ']') return std::nullopt;
  std::vector<double> out;
  size_t at = 1;
  while (at < c->size() - 1) {
    const size_t comma = std::min(c->find(',', at), c->size() - 1);
    std::string item = c->substr(at, comma - at);
    item.erase(0, item.find_first_not_of(' '));
    item.erase(item.find_last_not_of(' ') + 1);
    const auto v = parse_number(item);
    if (!v) return std::nullopt;
    out.push_back(*v);
    at = comma + 1;
  }
  return out;
}

std::vector<std::string> choices(const KeySpec& k) {
  static const std::regex quoted("`\"([^\"`]*)\"`");
  const std::string allowed(k.allowed);
  std::vector<std::string> out;
  for (std::sregex_iterator it(allowed.begin(), allowed.end(), quoted), end; it != end; ++it) out.push_back((*it)[1]);
  return out;
}

}  // namespace mlcg::config::schema
