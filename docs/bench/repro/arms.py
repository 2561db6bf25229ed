#!/usr/bin/env python3
"""N soft arms (8 kl sections, 0.35 m, tapered, damped) leaving a fixed hub radially, tilted 30
degrees down, no contacts: the scale study of the README (load time and step time against the
number of rods; from the eighteenth session's outside probe K).

usage: python3 docs/bench/repro/arms.py N > arms.xml
       ./build/cosserat check arms.xml                      # load
       ./build/cosserat run arms.xml --duration 0.2 --json -  # wall_time / steps: the step
"""
import math
import sys


def arms(n, sections=8):
    s = [f'<mujoco model="arms{n}">', '<option timestep="0.001" gravity="0 0 -9.81"/>', '<worldbody>',
         '<body name="hub" pos="0 0 0.6"><geom name="hub" type="sphere" size="0.04" mass="0.3" contype="0" conaffinity="0"/>']
    c30 = math.cos(math.radians(30))
    for i in range(n):
        a = 2 * math.pi * i / n
        ca, sa = math.cos(a), math.sin(a)
        s.append(f'<cosserat name="arm{i}" pos="{0.04 * ca:.6f} {0.04 * sa:.6f} 0" '
                 f'xyaxes="{ca * c30:.12f} {sa * c30:.12f} -0.5 {-sa:.12f} {ca:.12f} 0" length="0.35" '
                 f'sections="{sections}" strain="kl" radius="0.016 0.004" density="1050" young="1.5e5" '
                 f'poisson="0.45" viscosity="2" contype="0" conaffinity="0" capsules="2"/>')
    s += ['</body>', '</worldbody>', '</mujoco>']
    return '\n'.join(s) + '\n'


if __name__ == '__main__':
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    print(arms(int(sys.argv[1])), end='')
