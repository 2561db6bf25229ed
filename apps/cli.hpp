// Command-line parsing shared by the cosserat tool's commands (apps/cosserat.cpp and
// apps/render_commands.cpp) and the benchmark programs (bench/*_main.cpp): options "--opt value" /
// "--opt=value", generated --help, strict number parsing, and one failure type reported as a
// one-line reason with exit status 1.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace cosserat::cli {

// A number in messages, "%g" (0.15, not 0.15000000000000002).
inline std::string format_g(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", v);
  return b;
}

// "warning: <msg>" on stderr, once per process whatever the number of calls (render applies the
// start state once to frame the run and again to draw it: outside probe BO saw each twice).
// The warnings warn_once has said, for the JSON reports (outside probe BV: a clamped --ctrl was
// said on stderr only, and the report recorded the control asked for).
inline std::vector<std::string>& said_warnings() {
  static std::vector<std::string> said;
  return said;
}
inline void warn_once(const std::string& msg) {
  std::vector<std::string>& said = said_warnings();
  if (std::find(said.begin(), said.end(), msg) != said.end()) return;
  said.push_back(msg);
  std::cerr << "warning: " << msg << "\n";
}

// -------------------------------------------------------------------------------- failures --

// A bad command line or a failed command: main prints "cosserat: <what>" and exits with 1.
struct Failure : std::runtime_error {
  using std::runtime_error::runtime_error;
};

[[noreturn]] inline void fail(const std::string& msg) { throw Failure(msg); }

// The directories this command created for its outputs, outermost first: a failed command removes
// those still empty (outside probe BL: a render refused for an unknown camera left its --out
// directory behind, empty).
inline std::vector<std::filesystem::path>& created_directories() {
  static std::vector<std::filesystem::path> dirs;
  return dirs;
}

// create_directories(dir), recording the directories it made in created_directories().
inline void create_output_directories(const std::filesystem::path& dir, std::error_code& ec) {
  std::vector<std::filesystem::path> missing;
  std::error_code probe;
  for (std::filesystem::path p = dir; !p.empty() && !std::filesystem::exists(p, probe); p = p.parent_path()) {
    missing.push_back(p);
    if (p == p.parent_path()) break;
  }
  std::filesystem::create_directories(dir, ec);
  for (auto it = missing.rbegin(); it != missing.rend(); ++it)
    if (std::filesystem::is_directory(*it, probe)) created_directories().push_back(*it);
}

// After a failure: removes the directories the command created and left empty, innermost first.
inline void remove_empty_created_directories() {
  auto& dirs = created_directories();
  std::error_code ec;
  for (auto it = dirs.rbegin(); it != dirs.rend(); ++it)
    if (std::filesystem::is_directory(*it, ec) && std::filesystem::is_empty(*it, ec)) std::filesystem::remove(*it, ec);
  dirs.clear();
}

// Fails at once if `path` (an output named by `option`) cannot be written, so that a long run does
// not end to find that out. Creates its directory; leaves an existing file as it is and no new
// file behind.
inline void check_writable(const std::string& option, const std::string& path) {
  if (path.empty() || path == "-") return;
  std::error_code ec;
  const bool existed = std::filesystem::exists(path, ec);
  if (std::filesystem::is_directory(path, ec)) fail(option + ": " + path + " is a directory");
  // a named pipe: opening it blocks until a reader comes, which is what writing it will wait for
  if (std::filesystem::is_fifo(path, ec)) return;
  const std::filesystem::path dir = std::filesystem::path(path).parent_path();
  std::error_code dir_ec;  // why the directory could not be made, if it could not
  if (!dir.empty()) create_output_directories(dir, dir_ec);
  {
    std::ofstream f(path, std::ios::app);
    if (!f) fail(option + ": cannot write " + path + (dir_ec ? " (" + dir_ec.message() + ")" : ""));
  }
  if (!existed) std::filesystem::remove(path, ec);
}

// A program's report of a failure on stderr, "<program>: <reason>" (the prefix once: parse()'s
// messages start with the command's name already); returns the exit status, 1.
inline int report(const std::string& program, const Failure& f) {
  const std::string what = f.what();
  std::cerr << (what.rfind(program + ": ", 0) == 0 ? what : program + ": " + what) << "\n";
  return 1;
}

// ---------------------------------------------------------------------------- option parsing --

struct Option {
  std::string name;     // "--duration"
  std::string metavar;  // "T"; empty for a flag
  std::string help;
  std::function<void(const std::string&)> set;
};

// One command's synopsis, positional arguments and options. parse() accepts "--opt value" and
// "--opt=value" anywhere among the positional arguments.
struct CommandLine {
  std::string name;                     // "run"
  std::string summary;                  // one line
  std::vector<std::string> positional;  // metavars of the required positional arguments
  std::vector<Option> options;
  std::string details = {};             // extra help text
  std::string synopsis = {};            // replaces the generated usage after the name, if given
  std::string program = "cosserat";     // what is typed before the name (empty: the name is the program)

  std::string command() const { return program.empty() ? name : program + " " + name; }

  std::string usage() const {
    if (!synopsis.empty()) return command() + " " + synopsis;
    std::string u = command();
    for (const auto& p : positional) u += " " + p;
    for (const auto& o : options) u += " [" + o.name + (o.metavar.empty() ? "" : " " + o.metavar) + "]";
    return u;
  }

  std::string help() const {
    std::ostringstream h;
    h << "usage: " << usage() << "\n  " << summary << "\noptions:\n";
    auto row = [&h](std::string left, const std::string& text) {
      left.resize(std::max<size_t>(left.size() + 2, 22), ' ');
      h << "  " << left << text << "\n";
    };
    for (const auto& o : options) row(o.name + (o.metavar.empty() ? "" : " " + o.metavar), o.help);
    row("--help", "this text");
    h << details;
    return h.str();
  }

  // The positional arguments, or nullopt after printing --help. Throws Failure on bad input.
  std::optional<std::vector<std::string>> parse(int argc, char** argv) const {
    std::vector<std::string> pos;
    const std::string hint = " (see '" + command() + " --help')";
    for (int i = 0; i < argc; ++i) {
      std::string a = argv[i];
      if (a == "--help" || a == "-h") {
        std::cout << help();
        return std::nullopt;
      }
      if (a.size() < 2 || a[0] != '-') {
        pos.push_back(a);
        continue;
      }
      std::optional<std::string> inline_value;
      if (const size_t eq = a.find('='); eq != std::string::npos) {
        inline_value = a.substr(eq + 1);
        a.resize(eq);
      }
      const auto o = std::find_if(options.begin(), options.end(), [&](const Option& x) { return x.name == a; });
      if (o == options.end()) fail(name + ": unknown option '" + a + "'" + hint);
      if (o->metavar.empty()) {
        if (inline_value) fail(name + ": " + a + " takes no value");
        o->set("");
      } else if (inline_value) {
        o->set(*inline_value);
      } else {
        if (i + 1 >= argc) fail(name + ": " + a + " needs a value " + o->metavar + hint);
        o->set(argv[++i]);
      }
    }
    if (pos.size() != positional.size()) {
      std::string want;
      for (const auto& p : positional) want += (want.empty() ? "" : " ") + p;
      fail(name + ": expected " + (want.empty() ? "no arguments" : want) + ", got " + std::to_string(pos.size()) +
           " argument" + (pos.size() == 1 ? "" : "s") + hint);
    }
    return pos;
  }
};

inline double parse_number(const std::string& flag, const std::string& text) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  // (strtod also reads hexadecimal, which no option means)
  if (text.empty() || *end || !std::isfinite(v) || text.find_first_of("xX") != std::string::npos)
    fail(flag + ": '" + text + "' is not a number");
  return v;
}

inline double parse_positive(const std::string& flag, const std::string& text) {
  const double v = parse_number(flag, text);
  if (!(v > 0)) fail(flag + ": must be positive, got '" + text + "'");
  return v;
}

inline int parse_int(const std::string& flag, const std::string& text, int min) {
  char* end = nullptr;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end) fail(flag + ": '" + text + "' is not an integer");
  if (v < min) fail(flag + ": must be an integer >= " + std::to_string(min) + ", got '" + text + "'");
  if (v > 1000000000L) fail(flag + ": " + text + " is too large (at most 1000000000)");
  return static_cast<int>(v);
}

inline Option positive_option(const std::string& name, const std::string& metavar, const std::string& help, double& target) {
  return {name, metavar, help, [&target, name](const std::string& v) { target = parse_positive(name, v); }};
}
inline Option optional_positive_option(const std::string& name, const std::string& metavar, const std::string& help,
                                std::optional<double>& target) {
  return {name, metavar, help, [&target, name](const std::string& v) { target = parse_positive(name, v); }};
}
inline Option int_option(const std::string& name, const std::string& metavar, const std::string& help, int& target, int min) {
  return {name, metavar, help, [&target, name, min](const std::string& v) { target = parse_int(name, v, min); }};
}
inline Option text_option(const std::string& name, const std::string& metavar, const std::string& help, std::string& target) {
  return {name, metavar, help, [&target, name](const std::string& v) {
            if (v.empty()) fail(name + ": empty value");
            target = v;
          }};
}
inline Option flag_option(const std::string& name, const std::string& help, bool& target) {
  return {name, "", help, [&target](const std::string&) { target = true; }};
}
}  // namespace cosserat::cli
