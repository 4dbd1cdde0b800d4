// A look at the raw case text before the TOML reader sees it. toml++ nests a
// table per part of a dotted key or table header without a depth limit, so a
// key of 100,000 parts overflows the stack while it is built or destroyed (a
// segfault, naming nothing). Such text is refused here with its file:line.
#include <string>

#include "config/case_parser_detail.hpp"

namespace mlcg::config::detail {

namespace {

bool bare_key_char(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
}

// Walks the text once, tracking strings and comments, and counts the parts of
// every dotted name (a.b.c or "a".'b'.c; a float such as 1.5 counts 2).
class Scanner {
 public:
  Scanner(const Doc& doc, std::string_view text) : doc_(doc), s_(text) {}

  void run() {
    while (i_ < s_.size()) {
      const char c = s_[i_];
      if (c == '\n') {
        end_line();
      } else if (c == '#') {
        skip_comment();
        continue;
      } else if (c == '"' || c == '\'') {
        skip_string(c);
        part();
        continue;
      } else if (bare_key_char(c)) {
        while (i_ < s_.size() && bare_key_char(s_[i_])) ++i_;
        part();
        continue;
      } else if (c == '.') {
        after_dot_ = parts_ > 0;
        if (!after_dot_) parts_ = 0;
      } else if (c != ' ' && c != '\t' && c != '\r') {
        parts_ = 0;
        after_dot_ = false;
      }
      ++i_;
    }
    check_line_length();
  }

 private:
  void part() {
    parts_ = after_dot_ ? parts_ + 1 : 1;
    after_dot_ = false;
    if (parts_ > kMaxKeyParts)
      fail(doc_, line_, "", "a dotted key or table header of more than " + std::to_string(kMaxKeyParts) +
                                " parts; MLCG's files nest tables at most a few deep (e.g. [[coupling.regions]])");
  }

  void end_line() {
    check_line_length();
    ++line_;
    line_start_ = i_ + 1;
    parts_ = 0;
    after_dot_ = false;
  }

  void check_line_length() const {
    const size_t length = i_ - line_start_;
    if (length > kMaxLineChars)
      fail(doc_, line_, "", "line of more than " + std::to_string(kMaxLineChars) +
                                " characters; split long arrays over several lines");
  }

  void skip_comment() {
    while (i_ < s_.size() && s_[i_] != '\n') ++i_;
  }

  // A string from its opening quote to past its closing one; multi-line
  // strings ("""...""" and '''...''') may span lines. An unterminated string
  // ends the scan: the TOML reader reports it.
  void skip_string(char q) {
    const bool multi = s_.compare(i_, 3, std::string(3, q)) == 0;
    i_ += multi ? 3 : 1;
    while (i_ < s_.size()) {
      const char c = s_[i_];
      if (c == '\\' && q == '"' && i_ + 1 < s_.size() && s_[i_ + 1] != '\n') {
        i_ += 2;  // an escaped character (a line-ending backslash leaves the newline to be counted)
        continue;
      }
      if (c == '\n') {
        if (!multi) return;
        end_line();
      } else if (c == q && (!multi || s_.compare(i_, 3, std::string(3, q)) == 0)) {
        i_ += multi ? 3 : 1;
        return;
      }
      ++i_;
    }
  }

  static constexpr int kMaxKeyParts = 64;
  static constexpr size_t kMaxLineChars = 65536;
  const Doc& doc_;
  std::string_view s_;
  size_t i_ = 0, line_start_ = 0;
  int line_ = 1;
  int parts_ = 0;
  bool after_dot_ = false;
};

}  // namespace

void scan_text(const Doc& doc, std::string_view text) { Scanner(doc, text).run(); }

}  // namespace mlcg::config::detail
