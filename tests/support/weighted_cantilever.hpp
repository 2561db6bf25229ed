// An undamped kl cantilever with a tip weight (0.05 kg sphere), released straight under gravity
// (large deflection): the scene of the Newton and Rosenbrock tests.
#pragma once

#include <cstdio>
#include <string>

namespace cosserat::testing {

inline std::string weighted_cantilever_xml(double young, double radius, int sections, double timestep) {
  char buf[1024];
  std::snprintf(buf, sizeof buf, R"(<mujoco>
  <option timestep="%g" gravity="0 0 -9.81"/>
  <worldbody>
    <cosserat name="rod" pos="0 0 1" length="0.5" sections="%d" strain="kl" radius="%g" density="1000"
              young="%g" poisson="0.5" viscosity="0">
      <body name="weight" pos="0.02 0 0"><geom type="sphere" size="0.02" mass="0.05" contype="0" conaffinity="0"/></body>
    </cosserat>
  </worldbody>
</mujoco>)", timestep, sections, radius, young);
  return buf;
}

}  // namespace cosserat::testing
