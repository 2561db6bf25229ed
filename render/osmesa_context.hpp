// An off-screen OpenGL context rendered in software by OSMesa: no display, no GPU, no EGL/GLX.
// MuJoCo's GL loader finds OSMesaGetProcAddress in the process, so mjr_makeContext works on it.
#pragma once

#include <vector>

namespace cosserat::render {

class OSMesaGLContext {
 public:
  // Creates an RGBA context with depth and stencil buffers and makes it current on this thread.
  // Throws std::runtime_error when OSMesa cannot.
  OSMesaGLContext(int width, int height);
  ~OSMesaGLContext();
  OSMesaGLContext(const OSMesaGLContext&) = delete;
  OSMesaGLContext& operator=(const OSMesaGLContext&) = delete;

  void make_current();
  // Largest width/height of an off-screen framebuffer (GL_MAX_RENDERBUFFER_SIZE, viewport limit).
  int max_size() const;

 private:
  void* context_ = nullptr;             // OSMesaContext
  std::vector<unsigned char> buffer_;   // the context's own colour buffer (unused: MuJoCo draws to its FBO)
  int width_ = 0, height_ = 0;
};

}  // namespace cosserat::render
