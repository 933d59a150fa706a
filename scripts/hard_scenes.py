#!/usr/bin/env python3
"""Writes the hard scenes of `sinew bench robustness` (demos/scenes/hard-*.json).

The scenes are where rigid solvers are known to fail (Catto's Solver2D collects the kind): mass ratios,
heavy impacts, long chains with heavy ends, fast and tumbling bodies, deep overlaps, an arch, a stack
sliding down a ramp and a body spun about its intermediate axis; and where soft bodies are known to fail
under contact (hard-soft-*): a cloth draped over a sphere, a pressure ball landing, two soft balls thrown
at each other, a cloth folded onto itself and a cloth thrown at a thin wall. What the benchmark checks in
each is in tools/bench/bench_robustness.cpp. Run from the repository root: python3 scripts/hard_scenes.py
"""
import json
import math
import os

H = 1.0 / 60.0


def settings(steps, gravity=(0, -9.81, 0)):
    return {"time_step": H, "steps": steps, "gravity": list(gravity),
            "solver": {"kind": "soft_step", "velocity_iterations": 10},
            "sleeping": {"enabled": False}}


def scene(name, description, steps, bodies, generators=None, joints=None, gravity=(0, -9.81, 0)):
    s = {"format": "sinew-scene", "version": 1, "name": name, "description": description,
         "settings": settings(steps, gravity),
         "materials": {"box": {"density": 1000, "friction": 0.6, "restitution": 0}},
         "bodies": bodies}
    if generators:
        s["generators"] = generators
    if joints:
        s["joints"] = joints
    return s


GROUND = {"name": "ground", "type": "static", "shape": {"type": "box", "half_extents": [50, 0.5, 50]},
          "position": [0, -0.5, 0], "material": "box"}


def box(name, pos, half, mass, **kw):
    b = {"name": name, "shape": {"type": "box", "half_extents": list(half)}, "position": list(pos),
         "mass": mass, "material": "box"}
    b.update(kw)
    return b


def heavy_on_pyramid():
    return scene(
        "hard-heavy-on-pyramid",
        "A 1000 kg unit box dropped from 1 m onto the top of a 10-row pyramid of 1 kg unit boxes (1000:1, "
        "4.4 m/s at impact). Rigid boxes dropped square on the top box hold: checked that the heavy box "
        "comes to rest on the pyramid (centre within 5 cm of y = 10.5) and no light box moves 5 cm.",
        300, [GROUND, box("heavy", (0, 11.5, 0), (0.5, 0.5, 0.5), 1000)],
        generators=[{"type": "pyramid", "rows": 10, "mass": 1, "material": "box"}])


def heavy_on_light():
    return scene(
        "hard-heavy-on-light",
        "Heavy unit boxes resting on 1 kg unit boxes: 100 kg (100:1) at x = -2, 1000 kg (1000:1) at x = 2, "
        "10 s. Checked: no box moves 1 cm (a rigid answer sinks nothing) and the stacks end at rest.",
        600, [GROUND,
              box("light-100", (-2, 0.5, 0), (0.5, 0.5, 0.5), 1), box("heavy-100", (-2, 1.5, 0), (0.5, 0.5, 0.5), 100),
              box("light-1000", (2, 0.5, 0), (0.5, 0.5, 0.5), 1), box("heavy-1000", (2, 1.5, 0), (0.5, 0.5, 0.5), 1000)])


def chains():
    # Written out with anchors in each body's own frame; the loader's default anchor_b is the same point.
    bodies, joints = [], []
    for prefix, z, horizontal in (("hanging", -1.0, False), ("released", 1.0, True)):
        n = 20
        top = (0.0, 12.0)
        bodies.append({"name": prefix + "/post", "type": "static",
                       "shape": {"type": "box", "half_extents": [0.05, 0.05, 0.05]}, "position": [top[0], top[1], z]})
        prev, prev_pos, prev_rot = prefix + "/post", (top[0], top[1]), None
        for i in range(n):
            if horizontal:
                c = (top[0] + 0.25 + 0.5 * i, top[1])
                jp = (top[0] + 0.5 * i, top[1])
            else:
                c = (top[0], top[1] - 0.25 - 0.5 * i)
                jp = (top[0], top[1] - 0.5 * i)
            name = f"{prefix}/l{i}"
            bodies.append({"name": name, "shape": {"type": "box", "half_extents": [0.25, 0.05, 0.05]},
                           "position": [c[0], c[1], z], "rotation_deg": [0, 0, 0 if horizontal else 90],
                           "mass": 1, "material": "box"})
            joints.append({"type": "ball", "body_a": prev, "body_b": name,
                           "anchor_a": local_anchor(prev_pos, prev_rot, jp)})
            prev, prev_pos, prev_rot = name, c, (0 if horizontal else 90)
        end = (top[0] + 0.5 * n + 0.25, top[1]) if horizontal else (top[0], top[1] - 0.5 * n - 0.25)
        jp = (top[0] + 0.5 * n, top[1]) if horizontal else (top[0], top[1] - 0.5 * n)
        bodies.append({"name": prefix + "/end", "shape": {"type": "box", "half_extents": [0.25, 0.25, 0.25]},
                       "position": [end[0], end[1], z], "mass": 100, "material": "box"})
        joints.append({"type": "ball", "body_a": prev, "body_b": prefix + "/end",
                       "anchor_a": local_anchor(prev_pos, prev_rot, jp)})
    return scene(
        "hard-chain",
        "Two 20-link ball-joint chains of 1 kg links (0.5 m boxes) with a 100 kg end cube (100:1), pinned "
        "to static posts at y = 12: one hanging at rest (z = -1), one released from horizontal (z = 1), 5 s, "
        "no ground. Checked: the largest joint error (distance between a joint's two anchor points) stays "
        "under 1 cm.", 300, bodies, joints=joints)


def local_anchor(body_pos, rot_deg, world_point):
    dx, dy = world_point[0] - body_pos[0], world_point[1] - body_pos[1]
    if not rot_deg:
        return [dx, dy, 0]
    # body turned +90 degrees about z: world = R local, local = R^T world
    return [dy, -dx, 0]


def fast():
    wall = {"type": "static", "shape": {"type": "box", "half_extents": [0.05, 2, 1]}, "material": "box"}
    return scene(
        "hard-fast",
        "Bodies at 100 m/s against 0.1 m walls 5 m away (6 cm of travel per step is more than the wall is "
        "thick): a 0.1 m sphere (z = -3), a 0.2 m cube tumbling at 20 rad/s (z = 0), a 0.05 m sphere at "
        "300 m/s (z = 3); no gravity, 1 s. Checked: no centre passes its wall's near face, and each body "
        "reaches it (comes within 2 cm of touching).",
        60, [dict(wall, name="wall-sphere", position=[5.05, 0, -3]),
             dict(wall, name="wall-cube", position=[5.05, 0, 0]),
             dict(wall, name="wall-small", position=[5.05, 0, 3]),
             {"name": "sphere", "shape": {"type": "sphere", "radius": 0.1}, "position": [0, 0, -3],
              "linear_velocity": [100, 0, 0], "material": "box"},
             {"name": "cube", "shape": {"type": "box", "half_extents": [0.1, 0.1, 0.1]}, "position": [0, 0, 0],
              "linear_velocity": [100, 0, 0], "angular_velocity": [3, 20, 7], "material": "box"},
             {"name": "small", "shape": {"type": "sphere", "radius": 0.05}, "position": [0, 0, 3],
              "linear_velocity": [300, 0, 0], "material": "box"}],
        gravity=(0, 0, 0))


def overlap():
    s = scene(
        "hard-overlap",
        "Deep overlaps at the start: two unit boxes on the ground 0.2 m apart (0.8 m overlap), a 0.5 m "
        "sphere half inside a unit box, and a box buried 0.4 m in the ground; 3 s; every solver's push-out "
        "speed capped at 3 m/s. Checked: no body moves faster than 3.5 m/s (the cap, and 0.5 m/s for what "
        "gravity and friction add while bodies are pushed), and the two boxes end separated (centres at least "
        "0.98 m apart).",
        180, [GROUND,
              box("box-a", (-0.1, 0.5, -3), (0.5, 0.5, 0.5), 1), box("box-b", (0.1, 0.5, -3), (0.5, 0.5, 0.5), 1),
              box("box-c", (0, 0.5, 0), (0.5, 0.5, 0.5), 1),
              {"name": "sphere", "shape": {"type": "sphere", "radius": 0.5}, "position": [0.5, 0.5, 0], "mass": 1,
               "material": "box"},
              box("buried", (0, 0.1, 3), (0.5, 0.5, 0.5), 1)])
    # Every solver's push-out cap at 3 m/s: the soft step's contact_push_velocity, the others'
    # max_correction_velocity.
    s["settings"]["solver"]["contact_push_velocity"] = 3
    s["settings"]["solver"]["max_correction_velocity"] = 3
    return s


def arch():
    # A semicircular arch of 9 voussoirs (convex hulls), inner radius 2.5 m, outer 3.5 m, 1 m deep.
    n, r0, r1 = 9, 2.5, 3.5
    bodies = [GROUND]
    for i in range(n):
        a0, a1 = math.pi * i / n, math.pi * (i + 1) / n
        pts = []
        for a in (a0, a1):
            for r in (r0, r1):
                for z in (-0.5, 0.5):
                    pts.append([r * math.cos(a), r * math.sin(a), z])
        cx = sum(p[0] for p in pts) / 8
        cy = sum(p[1] for p in pts) / 8
        local = [[round(p[0] - cx, 9), round(p[1] - cy, 9), p[2]] for p in pts]
        bodies.append({"name": f"stone{i}", "shape": {"type": "convex_hull", "points": local},
                       "position": [round(cx, 9), round(cy, 9), 0],
                       "material": {"density": 2000, "friction": 0.6, "restitution": 0}})
    return scene(
        "hard-arch",
        "A semicircular arch of 9 convex-hull voussoirs (inner radius 2.5 m, outer 3.5 m, friction 0.6) "
        "standing on the ground, 5 s. A real arch of these proportions stands: checked that no stone moves 5 cm.",
        300, bodies)


def ramp_stack():
    theta = math.radians(30)
    # Friction mixes as sqrt(mu_a mu_b): box on ramp sqrt(0.8 * 0.05) = 0.2, box on box 0.8, so the
    # boxes hold together (they need only 0.2 between them) while the stack slides.
    # ramp: a long static box turned by -30 degrees about z, top face through the origin
    n = (math.sin(theta), math.cos(theta))  # up-slope normal for a ramp falling towards +x: (sin, cos)
    t = (math.cos(theta), -math.sin(theta))  # down-slope direction
    ramp_c = (-0.5 * n[0], -0.5 * n[1])
    bodies = [{"name": "ramp", "type": "static", "shape": {"type": "box", "half_extents": [20, 0.5, 2]},
               "position": [ramp_c[0], ramp_c[1], 0], "rotation_deg": [0, 0, -30],
               "material": {"friction": 0.05, "restitution": 0}}]
    for k in range(3):
        c = (-8 * t[0] + (0.5 + k) * n[0], -8 * t[1] + (0.5 + k) * n[1])
        bodies.append({"name": f"box{k}", "shape": {"type": "box", "half_extents": [0.5, 0.5, 0.5]},
                       "position": [round(c[0], 9), round(c[1], 9), 0], "rotation_deg": [0, 0, -30], "mass": 1,
                       "material": {"friction": 0.8, "restitution": 0}})
    return scene(
        "hard-ramp-stack",
        "Three unit boxes stacked on a 30 degree ramp, friction 0.2 against the ramp and 0.8 between boxes: the stack slides as one "
        "body with a = g (sin 30 - 0.2 cos 30) = 3.206 m/s^2. Checked: after 1.5 s every box has slid "
        "0.5 a t^2 = 3.607 m within 3%.", 90, bodies)


def spin():
    return scene(
        "hard-spin",
        "A 0.6 x 0.3 x 0.1 m box spun at 10 rad/s about its intermediate (y) axis with 0.01 rad/s about x, "
        "no gravity, 3 s (Dzhanibekov). Checked: the box flips (its y axis turns to within 0.9 of the "
        "opposite of where it started).", 180,
        [{"name": "spinner", "shape": {"type": "box", "half_extents": [0.3, 0.15, 0.05]}, "position": [0, 2, 0],
          "angular_velocity": [0.01, 10, 0], "material": "box"}],
        gravity=(0, 0, 0))


# Soft bodies under contact (issue 14 items 7 and 8). The benchmark runs each under every soft method, replacing
# the scene's method and iterations (tools/bench/bench_robustness.cpp); the links' stiffness is the
# spring methods'.
def soft_scene(name, description, steps, bodies, soft_bodies, gravity=(0, -9.81, 0)):
    s = scene(name, description, steps, bodies, gravity=gravity)
    del s["materials"]
    s["soft_bodies"] = soft_bodies
    return s


SOFT_GROUND = {"name": "ground", "type": "static", "shape": {"type": "box", "half_extents": [5, 0.5, 5]},
               "position": [0, -0.5, 0], "material": {"friction": 0.5}}


def soft_drape():
    return soft_scene(
        "hard-soft-drape",
        "Issue 5's cloth-drop with springs: a free 2 m x 2 m cloth (32 x 32 nodes, 1 kg, stretch and shear "
        "links of 1e4 N/m) falls from y = 2 onto a sphere (radius 0.5, top at 1.5) and drapes over it to the "
        "ground, 10 s. Contacts are where fast mass-spring lost its stiffness (stretch 1.78 against 1.04 "
        "hanging free). Checked: the largest link stretch at the end, at most 1.10.", 600,
        [SOFT_GROUND, {"name": "ball", "type": "static", "shape": {"type": "sphere", "radius": 0.5},
                       "position": [0, 1, 0], "material": {"friction": 0.5}}],
        [{"name": "cloth", "builder": "cloth", "nodes": [32, 32], "origin": [-1, 2, -1], "edge_u": [2, 0, 0],
          "edge_v": [0, 0, 2], "shear": True, "bend": False, "mass": 1, "method": "fast-ms",
          "solver": {"iterations": 3}, "links": {"stretch": 10000, "shear": 10000},
          "material": {"friction": 0.5, "thickness": 0.02}}])


def soft_pressure():
    return soft_scene(
        "hard-soft-pressure",
        "Issue 5's pressure-ball: an inflated icosphere (642 vertices, radius 0.5 m, 1 kg, links of 1e4 N/m, "
        "Matyka pressure constant 50 J) dropped from y = 1.5 onto the ground, 5 s. A fast mass-spring ball "
        "crumpled to a quarter of its volume. Checked: its volume at the end within 10% of the rest volume, "
        "and never below 0.80 of it on the way (the isothermal gas's energy bound is exp(-m g H / P) = 0.82).",
        300, [SOFT_GROUND],
        [{"name": "ball", "builder": "icosphere", "center": [0, 1.5, 0], "radius": 0.5, "subdivisions": 3,
          "mass": 1, "method": "fast-ms", "solver": {"iterations": 3}, "links": {"stretch": 10000},
          "material": {"pressure": 50, "friction": 0.5, "thickness": 0.02}}])


def soft_collide():
    ball = {"builder": "icosphere", "radius": 0.3, "subdivisions": 2, "mass": 0.5, "method": "fast-ms",
            "solver": {"iterations": 3}, "links": {"stretch": 10000},
            "material": {"pressure": 20, "friction": 0.3, "thickness": 0.01}}
    return soft_scene(
        "hard-soft-collide",
        "Two inflated soft balls (162 vertices, radius 0.3 m, 0.5 kg, links of 1e4 N/m, pressure 20 J) "
        "thrown at each other at 3 m/s each along x, no gravity, 1.5 s. They passed through each other "
        "before soft-soft contacts. Checked: no particle of either ball ends a step inside the other's "
        "surface (its generalised winding number below one half).", 90, [],
        [dict(ball, name="left", center=[-0.5, 1, 0], velocity=[3, 0, 0]),
         dict(ball, name="right", center=[0.5, 1, 0], velocity=[-3, 0, 0])],
        gravity=(0, 0, 0))


def folded_cloth_obj(path):
    # 2 m x 1 m, 21 x 11 nodes 10 cm apart, folded in half along x = 1 m: the lower layer at y = 1 cm,
    # the upper laid back over it at 5 cm (the fold is its rest shape). Node (i, k) is vertex i * 11 + k.
    nx, nz = 21, 11
    with open(path, "w") as f:
        f.write("# folded cloth for hard-soft-fold (scripts/hard_scenes.py)\n")
        for i in range(nx):
            for k in range(nz):
                upper = i > 10
                x = 0.1 * (20 - i if upper else i)
                f.write("v %.2f %.2f %.2f\n" % (x, 0.05 if upper else 0.01, 0.1 * k))
        for i in range(nx - 1):
            for k in range(nz - 1):
                a = i * nz + k + 1
                b, d = a + nz, a + 1
                c = b + 1
                f.write("f %d %d %d\nf %d %d %d\n" % (a, d, c, a, c, b))


def soft_fold():
    return soft_scene(
        "hard-soft-fold",
        "Self-collision: a 2 m x 1 m cloth (21 x 11 nodes, 0.5 kg, demos/meshes/folded-cloth.obj) lying on the "
        "ground folded in half, its upper layer 4 cm above the lower, with self_collision on; gravity brings "
        "the upper layer down, 2 s. Without self-collision it falls through the lower layer onto the ground. "
        "Checked: the least height of the upper layer's inner nodes above the nodes under them, at least "
        "17 mm (the two thicknesses, 20 mm, less 3 mm).", 120, [SOFT_GROUND],
        [{"name": "cloth", "builder": "mesh", "obj": "../meshes/folded-cloth.obj", "link_distance": 1, "mass": 0.5,
          "method": "implicit", "solver": {"iterations": 100},
          "material": {"thickness": 0.01, "self_collision": True, "friction": 0.5}}])


def soft_tunnel():
    return soft_scene(
        "hard-soft-tunnel",
        "A 0.5 m cloth (11 x 11 nodes, 0.1 kg, links of 1e4 N/m) thrown at 50 m/s along x at a 0.1 m wall "
        "1 m away (0.83 m of travel per step, eight times the wall's thickness), no gravity, 0.5 s. Checked: "
        "no particle passes the wall's near face less its thickness (m beyond it, at most 5 mm).", 30,
        [{"name": "wall", "type": "static", "shape": {"type": "box", "half_extents": [0.05, 1, 1]},
          "position": [1, 0, 0], "material": {"friction": 0.5}}],
        [{"name": "cloth", "builder": "cloth", "nodes": [11, 11], "origin": [-0.25, -0.25, 0], "edge_u": [0, 0.5, 0],
          "edge_v": [0, 0, 0.5], "shear": True, "bend": False, "mass": 0.1, "method": "fast-ms",
          "solver": {"iterations": 3}, "links": {"stretch": 10000, "shear": 10000}, "velocity": [50, 0, 0],
          "material": {"friction": 0.5, "thickness": 0.01}}],
        gravity=(0, 0, 0))


def main():
    out = os.path.join(os.path.dirname(__file__), "..", "demos", "scenes")
    folded_cloth_obj(os.path.join(os.path.dirname(__file__), "..", "demos", "meshes", "folded-cloth.obj"))
    for s in (heavy_on_pyramid(), heavy_on_light(), chains(), fast(), overlap(), arch(), ramp_stack(), spin(),
              soft_drape(), soft_pressure(), soft_collide(), soft_fold(), soft_tunnel()):
        with open(os.path.join(out, s["name"] + ".json"), "w") as f:
            json.dump(s, f, indent=1)
            f.write("\n")


if __name__ == "__main__":
    main()
