#!/usr/bin/env python3
"""Writes the scenes of many small things that `sinew bench threads` steps on 1 and 2 workers
(demos/scenes/many-soft-bodies.json, demos/scenes/many-chains.json): work that comes in many independent
pieces, each too small to split, which the step deals to its workers one piece at a time (issue 18).
Run from the repository root: python3 scripts/many_scenes.py
"""
import json
import os

H = 1.0 / 60.0


def write(name, description, settings, bodies, soft_bodies=None, joints=None):
    out = ['{', '  "format": "sinew-scene",', '  "version": 1,', '  "name": %s,' % json.dumps(name),
           '  "description": %s,' % json.dumps(description), '  "settings": %s,' % json.dumps(settings),
           '  "bodies": [', ',\n'.join('    ' + json.dumps(b) for b in bodies)]
    if soft_bodies:
        out += ['  ],', '  "soft_bodies": [', ',\n'.join('    ' + json.dumps(b) for b in soft_bodies)]
    if joints:
        out += ['  ],', '  "joints": [', ',\n'.join('    ' + json.dumps(j) for j in joints)]
    out += ['  ]', '}']
    with open(os.path.join('demos', 'scenes', name + '.json'), 'w') as f:
        f.write('\n'.join(out) + '\n')


def many_soft_bodies():
    bodies = [{"name": "ground", "type": "static", "shape": {"type": "box", "half_extents": [8, 0.5, 8]},
               "position": [0, -0.5, 0], "material": {"friction": 0.5}}]
    soft = []
    k = 0
    for i in range(4):
        for j in range(8):
            x, z = -5.6 + 1.6 * j, -2.4 + 1.6 * i
            if (i + j) % 2 == 0:
                soft.append({"name": "ball-%d" % k, "builder": "icosphere", "center": [x, 1.0 + 0.1 * (j % 3), z],
                             "radius": 0.4, "subdivisions": 2, "mass": 0.5, "method": "implicit",
                             "solver": {"iterations": 50}, "links": {"stretch": 5000},
                             "material": {"pressure": 20, "friction": 0.5, "thickness": 0.02}})
            else:
                bodies.append({"name": "post-%d" % k, "type": "static", "shape": {"type": "sphere", "radius": 0.3},
                               "position": [x, 0.6, z], "material": {"friction": 0.5}})
                soft.append({"name": "cloth-%d" % k, "builder": "cloth", "nodes": [16, 16],
                             "origin": [x - 0.6, 1.3, z - 0.6], "edge_u": [1.2, 0, 0], "edge_v": [0, 0, 1.2],
                             "shear": True, "bend": False, "mass": 0.2, "method": "fast-ms", "solver": {"iterations": 2},
                             "links": {"stretch": 5000, "shear": 5000}, "material": {"friction": 0.5, "thickness": 0.02}})
            k += 1
    write("many-soft-bodies",
          "Issue 18's scene of many small soft bodies: 16 inflated icospheres (162 vertices, radius 0.4 m, 0.5 kg, "
          "implicit Euler, pressure 20 J) dropped on the ground and 16 cloths (16 x 16 nodes, 1.2 m square, 0.2 kg, "
          "fast mass-spring) draped over static spheres, on a 4 x 8 grid 1.6 m apart, none touching another. No body "
          "is large enough to split its own loops: on more than one worker they are stepped one body per worker item. "
          "'sinew bench threads' reads this file.",
          {"time_step": H, "steps": 600, "sleeping": {"enabled": False}}, bodies, soft_bodies=soft)


def many_chains():
    bodies = [{"name": "ground", "type": "static", "shape": {"type": "box", "half_extents": [10, 0.5, 10]},
               "position": [0, -0.5, 0]}]
    joints = []
    for c in range(64):
        x, z = -7 + 2 * (c % 8), -7 + 2 * (c // 8)
        beam = "beam-%d" % c
        bodies.append({"name": beam, "type": "static", "shape": {"type": "box", "half_extents": [0.1, 0.1, 0.1]},
                       "position": [x, 6, z]})
        prev, anchor = beam, [0, -0.1, 0]
        for k in range(8):
            link = "link-%d-%d" % (c, k)
            # Each link 0.1 m further out than the one above: the chains start bent and swing.
            bodies.append({"name": link, "shape": {"type": "box", "half_extents": [0.05, 0.2, 0.05]},
                           "position": [round(x + 0.1 * (k + 1), 3), round(5.7 - 0.4 * k, 3), z], "mass": 1})
            joint = {"type": "ball"} if k % 2 == 0 else {"type": "hinge", "axis": [0, 0, 1]}
            joint.update({"body_a": prev, "body_b": link, "anchor_a": anchor, "anchor_b": [0, 0.2, 0]})
            joints.append(joint)
            prev, anchor = link, [0, -0.2, 0]
    write("many-chains",
          "Issue 18's scene of many small joint groups: 64 chains of 8 links (0.4 m, 1 kg; ball and hinge joints "
          "alternating, 512 joints) hanging from static blocks on an 8 x 8 grid 2 m apart, each link 0.1 m further "
          "out than the one above, so the chains swing. The soft step solves the joints of each chain (a group that "
          "shares no movable body with another) on its own: on more than one worker, one group per worker item. "
          "'sinew bench threads' reads this file.",
          {"time_step": H, "steps": 600, "sleeping": {"enabled": False}}, bodies, joints=joints)


if __name__ == '__main__':
    many_soft_bodies()
    many_chains()
