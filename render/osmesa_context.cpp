#include "osmesa_context.hpp"

#include <GL/osmesa.h>

#include <algorithm>
#include <stdexcept>

namespace cosserat::render {

OSMesaGLContext::OSMesaGLContext(int width, int height) : width_(std::max(width, 1)), height_(std::max(height, 1)) {
  context_ = OSMesaCreateContextExt(OSMESA_RGBA, 24, 8, 0, nullptr);
  if (!context_) throw std::runtime_error("OSMesa could not create an off-screen OpenGL context");
  buffer_.resize(static_cast<size_t>(width_) * height_ * 4);
  make_current();
}

OSMesaGLContext::~OSMesaGLContext() {
  if (context_) OSMesaDestroyContext(static_cast<OSMesaContext>(context_));
}

void OSMesaGLContext::make_current() {
  if (!OSMesaMakeCurrent(static_cast<OSMesaContext>(context_), buffer_.data(), GL_UNSIGNED_BYTE, width_, height_))
    throw std::runtime_error("OSMesa could not make its context current");
}

int OSMesaGLContext::max_size() const {
  GLint renderbuffer = 0, viewport[2] = {0, 0};
  glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &renderbuffer);
  glGetIntegerv(GL_MAX_VIEWPORT_DIMS, viewport);
  return std::min({static_cast<int>(renderbuffer), static_cast<int>(viewport[0]), static_cast<int>(viewport[1])});
}

}  // namespace cosserat::render
