// Frame sequences and their encoding into a video by the ffmpeg program (when installed).
#pragma once

#include <string>

namespace cosserat::render {

// "DIR/frame_00042.png" for frame 42.
std::string frame_path(const std::string& dir, int frame);
// Removes DIR/frame_NNNNN.png files (left by an earlier render). Returns how many.
int remove_frames(const std::string& dir);

// Full path of `program` found in $PATH (as `command -v` does), or "" when it is not there.
std::string find_program(const std::string& program);

// Encodes DIR/frame_00000.png ... at `fps` into `output` (H.264 in MP4, yuv420p, with libx264 when
// ffmpeg has it, else MPEG-4 part 2). Throws std::runtime_error when ffmpeg is not installed or
// fails (with its last message).
void encode_video(const std::string& dir, double fps, const std::string& output);

}  // namespace cosserat::render
