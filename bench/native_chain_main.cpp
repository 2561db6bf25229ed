// Prints the MuJoCo-native equivalent of a scene with <cosserat> rods (native_chain.hpp).
// Usage: bench_native_chain MODEL.xml [--segments N] [--ball] [--base-spring F] [--armature A] [--out FILE]
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <string>

#include "cli.hpp"
#include "common.hpp"
#include "native_chain.hpp"

int main(int argc, char** argv) {
  namespace cli = cosserat::cli;
  cosserat::bench::NativeChainOptions opt;
  std::string out;
  cli::CommandLine cl{"bench_native_chain",
                      "prints the MuJoCo-native equivalent of a scene with <cosserat> rods (native_chain.hpp)",
                      {"MODEL.xml"},
                      {cli::int_option("--segments", "N", "capsule bodies per rod (default 8)", opt.segments, 1),
                       cli::flag_option("--ball", "ball joints instead of hinge triples", opt.ball),
                       {"--base-spring", "F", "the clamp's bending spring: F times EI/ds (default 1)",
                        [&opt](const std::string& v) { opt.base_spring_factor = cli::parse_positive("--base-spring", v); }},
                       {"--armature", "A", "armature of every hinge: A times its segment's rho A ds^3 / 12 (default 0)",
                        [&opt](const std::string& v) { opt.armature_factor = cli::parse_positive("--armature", v); }},
                       cli::text_option("--out", "FILE", "write the XML there (default: stdout)", out)}};
  cl.program.clear();
  std::string in;
  try {
    const auto pos = cl.parse(argc - 1, argv + 1);
    if (!pos) return 0;
    in = pos->at(0);
  } catch (const cli::Failure& f) {
    return cli::report("bench_native_chain", f);
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
