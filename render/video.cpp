#include "video.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <regex>
#include <sstream>
#include <stdexcept>

namespace cosserat::render {

namespace fs = std::filesystem;

namespace {

std::string quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// Runs a shell command; returns its exit status and its combined output.
int run(const std::string& command, std::string& output) {
  FILE* p = popen((command + " 2>&1").c_str(), "r");
  if (!p) return -1;
  char buf[4096];
  for (size_t n; (n = std::fread(buf, 1, sizeof buf, p)) > 0;) output.append(buf, n);
  const int status = pclose(p);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string last_line(const std::string& text) {
  std::istringstream in(text);
  std::string line, last;
  while (std::getline(in, line))
    if (!line.empty()) last = line;
  return last;
}

}  // namespace

std::string frame_path(const std::string& dir, int frame) {
  char name[32];
  std::snprintf(name, sizeof name, "frame_%05d.png", frame);
  return (fs::path(dir) / name).string();
}

int remove_frames(const std::string& dir) {
  static const std::regex pattern(R"(frame_\d{5,}\.png)");
  std::error_code ec;
  int removed = 0;
  for (const auto& entry : fs::directory_iterator(dir, ec))
    if (entry.is_regular_file() && std::regex_match(entry.path().filename().string(), pattern))
      removed += fs::remove(entry.path(), ec) ? 1 : 0;
  return removed;
}

std::string find_program(const std::string& program) {
  const char* path = std::getenv("PATH");
  std::istringstream dirs(path ? path : "");
  for (std::string dir; std::getline(dirs, dir, ':');) {
    const fs::path candidate = fs::path(dir.empty() ? "." : dir) / program;
    if (access(candidate.c_str(), X_OK) == 0 && fs::is_regular_file(candidate)) return candidate.string();
  }
  return "";
}

namespace {
// ffmpeg's encoder options for the container `output`'s extension names, from the encoders this
// ffmpeg has; throws when it has none for that container.
std::string encoder_options(const std::string& ffmpeg, const std::string& output) {
  std::string ext = fs::path(output).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  std::string encoders;
  run(quote(ffmpeg) + " -hide_banner -encoders", encoders);
  auto has = [&](const char* name) { return encoders.find(std::string(" ") + name + " ") != std::string::npos; };
  const std::string even = " -vf " + quote("pad=ceil(iw/2)*2:ceil(ih/2)*2") + " -pix_fmt yuv420p";  // yuv420p: even sizes
  if (ext == ".gif") {  // one palette for the whole clip, from its frames
    if (!has("gif")) throw std::runtime_error("this ffmpeg has no gif encoder: use --video with .mp4 or .mkv");
    return " -vf " + quote("split[a][b];[a]palettegen[p];[b][p]paletteuse") + " -c:v gif";
  }
  if (ext == ".webm") {  // WebM holds VP8, VP9 or AV1 only
    if (has("libvpx-vp9")) return even + " -c:v libvpx-vp9 -crf 30 -b:v 0";
    if (has("libvpx")) return even + " -c:v libvpx -crf 10 -b:v 4M";
    throw std::runtime_error("this ffmpeg has no VP8 or VP9 encoder (libvpx) for .webm: use --video with .mp4 or .mkv");
  }
  return even + (has("libx264") ? " -c:v libx264 -crf 18" : " -c:v mpeg4 -q:v 2");
}
}  // namespace

void check_video_encoder(const std::string& output) {
  const std::string ffmpeg = find_program("ffmpeg");
  if (ffmpeg.empty()) throw std::runtime_error("ffmpeg is not installed (apt-get install ffmpeg): no video written");
  encoder_options(ffmpeg, output);
}

void encode_video(const std::string& dir, double fps, const std::string& output) {
  const std::string ffmpeg = find_program("ffmpeg");
  if (ffmpeg.empty()) throw std::runtime_error("ffmpeg is not installed (apt-get install ffmpeg): no video written");
  std::ostringstream cmd;
  cmd.precision(17);
  cmd << quote(ffmpeg) << " -y -hide_banner -loglevel error -framerate " << fps << " -i "
      << quote((fs::path(dir) / "frame_%05d.png").string()) << encoder_options(ffmpeg, output) << " -r " << fps << " "
      << quote(output) << " </dev/null";
  std::string log;
  if (run(cmd.str(), log) != 0) {
    std::error_code ec;
    fs::remove(output, ec);  // not a partial, unplayable file
    throw std::runtime_error("ffmpeg could not encode " + output + ": " + last_line(log));
  }
}

}  // namespace cosserat::render
