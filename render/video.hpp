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

// Encodes DIR/frame_00000.png ... at `fps` into `output`, the container from its extension: .gif
// with ffmpeg's gif encoder (one palette for the clip), .webm with VP9 (else VP8), any other with
// H.264 (libx264 when ffmpeg has it, else MPEG-4 part 2), yuv420p. Throws std::runtime_error when
// ffmpeg is not installed, has no encoder for the container, or fails (with its last message; no
// partial file is left).
void encode_video(const std::string& dir, double fps, const std::string& output);
// The checks of encode_video that need no frames: ffmpeg installed, an encoder for the container.
void check_video_encoder(const std::string& output);

}  // namespace cosserat::render
