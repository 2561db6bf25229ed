// Prints the MuJoCo-native equivalent of a scene with <cosserat> rods (native_chain.hpp).
// Usage: bench_native_chain MODEL.xml [--segments N] [--ball] [--base-spring F] [--out FILE]
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <string>

#include "common.hpp"
#include "native_chain.hpp"

int main(int argc, char** argv) {
  cosserat::bench::NativeChainOptions opt;
  std::string in, out;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--segments" && i + 1 < argc) opt.segments = std::atoi(argv[++i]);
    else if (a == "--ball") opt.ball = true;
    else if (a == "--base-spring" && i + 1 < argc) opt.base_spring_factor = std::atof(argv[++i]);
    else if (a == "--out" && i + 1 < argc) out = argv[++i];
    else if (in.empty() && a[0] != '-') in = a;
    else {
      std::fprintf(stderr, "usage: bench_native_chain MODEL.xml [--segments N] [--ball] [--base-spring F] [--out FILE]\n");
      return 1;
    }
  }
  if (in.empty()) {
    std::fprintf(stderr, "usage: bench_native_chain MODEL.xml [--segments N] [--ball] [--base-spring F] [--out FILE]\n");
    return 1;
  }
  try {
    const std::string xml = cosserat::bench::native_chain_xml(cosserat::bench::read_file(in), in, opt);
    mjModel* m = cosserat::bench::load_mujoco_string(xml, in);  // check that MuJoCo compiles it
    std::fprintf(stderr, "native chain: nbody %d, nv %d, ngeom %d\n", m->nbody, m->nv, m->ngeom);
    mj_deleteModel(m);
    if (out.empty()) std::cout << xml;
    else std::ofstream(out) << xml;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_native_chain: %s\n", e.what());
    return 1;
  }
  return 0;
}
