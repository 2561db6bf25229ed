// The `render` and `snapshot` commands of the cosserat tool (DESIGN.md section 8): headless
// pictures of a simulated scene through cosserat_render (OSMesa; no display needed).
//   render MODEL.xml --out DIR [--duration T] [--fps F] [--width W] [--height H] [--camera NAME] [--video F.mp4]
//   snapshot MODEL.xml --out F.png [--time t] [--width W] [--height H] [--camera NAME]
// plus the options listed by --help. argv[0] is the command name. Return 0 on success; on failure
// print a one-line reason on stderr and return 1.
#pragma once

int render_command(int argc, char** argv);
int snapshot_command(int argc, char** argv);
