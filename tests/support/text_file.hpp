// The whole text of a file (empty if it cannot be read): the tests' fixtures and tool outputs;
// and text replacement for model variants.
#pragma once

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace cosserat::testing {

inline std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// s with every occurrence of a replaced by b: the tests' model variants.
inline std::string replace_all(std::string s, const std::string& a, const std::string& b) {
  for (size_t p = s.find(a); p != std::string::npos; p = s.find(a, p + b.size())) s.replace(p, a.size(), b);
  return s;
}

// x with all its digits, for numbers written into a model's text (std::to_string keeps 6
// decimals: outside probe AU found a 1e-6 kg load written as 0.000006, 5% light)
inline std::string full_precision(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%.17g", x);
  return b;
}

}  // namespace cosserat::testing
