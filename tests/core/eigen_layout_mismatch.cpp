// Compiled for the baseline instruction set against libraries built for x86-64-v3 (see
// tests/CMakeLists.txt): the layout check of lie.hpp must stop it at start-up, before it builds a
// model whose structs it would read with the wrong layout (outside probe AB: a double free).
#include <cstdio>

#include "model.hpp"

int main() {
  cosserat::Model m;
  cosserat::Data d(m);
  std::printf("not stopped: sizeof(Data) = %zu\n", sizeof(d));
  return 0;
}
