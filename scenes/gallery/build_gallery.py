#!/usr/bin/env python3
"""Write the gallery scenes of the seed notes as binary glTF files next to this script.

The scenes the course notes show, built procedurally (standard library only, deterministic):
the Cornell box with a glass and a mirror sphere, a caustic on a glossy floor, a metal ring's
cardioid caustic, a cognac glass with liquid, a sphereflake, a glass cube caustic, a fractal
Cornell box, an interior lit by the sun through windows with a pool outside (the Mies house idea),
the same room under Blender's Nishita sky at 2 pm and 7 pm, and a translucent bust. The Cornell box with two boxes and the glass-sphere caustic are
`scenes/cornell_box.glb` and `scenes/glass_caustic.glb`.

Usage: python3 scenes/gallery/build_gallery.py
"""

import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import build_scenes as bs  # noqa: E402
from build_scenes import Gltf, axis_angle, cross, cube, floor_quad, normalize, quad, sub, uv_sphere  # noqa: E402,E501

HERE = os.path.dirname(os.path.abspath(__file__))
bs.HERE = HERE  # Gltf.write puts files next to this script


# ----- geometry -------------------------------------------------------------------------------

def lathe(profile, segments, flip=False):
    """A surface of revolution about +Y through the (radius, height) points of `profile`, in
    order; normals from the profile's tangent, pointing to its right (outward for a profile
    going up along the outside), or inward when `flip`."""
    positions, normals, uvs, indices = [], [], [], []
    count = len(profile)
    for i, (r, y) in enumerate(profile):
        a = profile[max(i - 1, 0)]
        b = profile[min(i + 1, count - 1)]
        dr, dy = b[0] - a[0], b[1] - a[1]
        length = math.hypot(dr, dy) or 1.0
        nr, ny = dy / length, -dr / length
        if flip:
            nr, ny = -nr, -ny
        for s in range(segments + 1):
            phi = 2 * math.pi * s / segments
            c, sn = math.cos(phi), -math.sin(phi)
            positions.append([r * c, y, r * sn])
            normals.append([nr * c, ny, nr * sn])
            uvs.append([s / segments, i / (count - 1)])
    row = segments + 1
    for i in range(count - 1):
        for s in range(segments):
            a, b = i * row + s, (i + 1) * row + s
            t1, t2 = (a, a + 1, b), (a + 1, b + 1, b)
            for t in (t1, t2):
                indices += [t[0], t[2], t[1]] if flip else list(t)
    return positions, normals, uvs, indices


def disk(radius, y, segments, up=True):
    """A flat disk at height y facing +Y (or −Y)."""
    positions = [[0.0, y, 0.0]]
    normals = [[0.0, 1.0 if up else -1.0, 0.0]]
    uvs = [[0.5, 0.5]]
    indices = []
    for s in range(segments + 1):
        phi = 2 * math.pi * s / segments
        positions.append([radius * math.cos(phi), y, -radius * math.sin(phi)])
        normals.append(normals[0])
        uvs.append([0.5 + 0.5 * math.cos(phi), 0.5 + 0.5 * math.sin(phi)])
    for s in range(segments):
        t = (0, s + 1, s + 2)
        indices += list(t) if up else [t[0], t[2], t[1]]
    return positions, normals, uvs, indices


def merge(*parts):
    positions, normals, uvs, indices = [], [], [], []
    for p, n, u, i in parts:
        base = len(positions)
        positions += p
        normals += n
        uvs += u
        indices += [base + k for k in i]
    return positions, normals, uvs, indices


def transformed(geometry, scale, offset):
    p, n, u, i = geometry
    return [[scale * x + o for x, o in zip(v, offset)] for v in p], n, u, i


def box(lo, hi):
    """An axis-aligned box from corner `lo` to corner `hi`, outward normals."""
    size = [hi[k] - lo[k] for k in range(3)]
    centre = [(hi[k] + lo[k]) / 2 for k in range(3)]
    p, n, u, i = cube()
    return [[centre[k] + size[k] * v[k] for k in range(3)] for v in p], n, u, i


def cornell_walls(g):
    """The Cornell box's room (`build_scenes.cornell_room`) with its camera; returns the white."""
    s = 2.775
    white = bs.cornell_room(g)
    g.camera("Camera", [0, s, s + 8.0], [0, s, 0], 39.3, 1.0)
    bs.render_settings(g, 256, 256)
    return white


def glass(g, name="Glass", ior=1.5, roughness=0.0, attenuation=None, thickness=None):
    ext = {"KHR_materials_transmission": {"transmissionFactor": 1.0},
           "KHR_materials_ior": {"ior": ior}}
    if attenuation is not None:
        colour, distance = attenuation
        ext["KHR_materials_volume"] = {"thicknessFactor": thickness or 1.0,
                                       "attenuationColor": list(colour),
                                       "attenuationDistance": distance}
    return g.material(name, base=(1, 1, 1), roughness=roughness, extensions=ext)


def small_lamp(g, position, size, power, name="Lamp"):
    """A square area light facing down (PHOTON_light), invisible to the camera."""
    g.node(name, translation=position, rotation=axis_angle([1, 0, 0], -90),
           photon_light={"type": "area", "shape": "SQUARE", "size": size, "power": power,
                         "color": [1.0, 1.0, 1.0], "visible_camera": False})


# ----- scenes ---------------------------------------------------------------------------------

def cornell_spheres():
    """The Cornell box with a mirror sphere (back left) and a glass sphere (front right)."""
    g = Gltf()
    cornell_walls(g)
    mirror = g.material("Mirror", base=(0.95, 0.95, 0.95), metallic=1.0, roughness=0.0)
    sphere = uv_sphere(1.0, 64, 32)
    g.node("MirrorSphere", mesh=g.mesh("MirrorSphere", sphere, mirror),
           translation=[-1.0, 1.0, -0.9])
    g.node("GlassSphere", mesh=g.mesh("GlassSphere", sphere, glass(g)),
           translation=[1.05, 1.0, 0.8])
    g.write("cornell_spheres.glb")


def glossy_caustic():
    """A glass sphere focusing a small light onto a glossy (roughness 0.3) floor."""
    g = Gltf()
    floor = g.material("GlossyFloor", base=(0.5, 0.55, 0.6), roughness=0.3)
    g.node("Floor", mesh=g.mesh("Floor", floor_quad(4.0), floor))
    g.node("GlassSphere", mesh=g.mesh("GlassSphere", uv_sphere(0.8, 64, 32), glass(g)),
           translation=[0, 0.8, 0])
    small_lamp(g, [-1.2, 4.5, -0.6], 0.25, 400.0)
    g.scene_extension("PHOTON_world", {"color": [0.05, 0.06, 0.08], "strength": 1.0})
    g.camera("Camera", [0, 2.6, 5.0], [0, 0.4, 0], 40.0, 1.0)
    bs.render_settings(g, 256, 256)
    g.write("glossy_caustic.glb")


def metal_ring():
    """A polished metal ring on a floor, lit from a low angle: the cardioid caustic inside."""
    g = Gltf()
    floor = g.material("Floor", base=(0.8, 0.8, 0.8), roughness=1.0, lambert=True)
    metal = g.material("Gold", base=(1.0, 0.78, 0.34), metallic=1.0, roughness=0.0)
    g.node("Floor", mesh=g.mesh("Floor", floor_quad(4.0), floor))
    r, t, h = 1.0, 0.04, 0.5
    ring = merge(lathe([(r, 0.0), (r, h)], 128, flip=True),  # inside wall, facing the axis
                 lathe([(r + t, h), (r + t, 0.0)], 128, flip=True),  # outside wall
                 lathe([(r, h), (r + t, h)], 128, flip=True))  # rim
    g.node("Ring", mesh=g.mesh("Ring", ring, metal))
    # A small lamp low on the left (18° above the floor), pointed at the ring: the ring's inner
    # wall focuses it into a cardioid on the floor inside, its shadow falls to the right.
    lamp = [-5.0, 1.6, 0.0]
    small_lamp(g, lamp, 0.2, 3000.0)
    g.doc["nodes"][-1]["rotation"] = bs.clean(bs.look_at(lamp, [0.0, 0.0, 0.0]))
    g.camera("Camera", [0.5, 3.4, 2.6], [0.2, 0.0, 0.0], 45.0, 1.0)
    bs.render_settings(g, 256, 256)
    g.write("metal_ring.glb")


def cognac_glass():
    """A lathed cognac glass (solid glass walls, stem and foot) holding amber liquid."""
    g = Gltf()
    floor = g.material("Table", base=(0.35, 0.25, 0.18), roughness=0.6)
    g.node("Table", mesh=g.mesh("Table", floor_quad(3.0), floor))
    # Outer profile from the foot's rim up to the lip, then the inner surface back down.
    bowl = lambda k, n: [(0.42 * math.sin(math.pi * (0.15 + 0.75 * i / n)) * k,
                          0.35 + 0.6 * i / n) for i in range(n + 1)]
    outer = [(0.0, 0.0), (0.3, 0.0), (0.3, 0.015), (0.04, 0.03), (0.03, 0.3)] + \
        [(r, y) for r, y in bowl(1.0, 24)][1:]
    inner = [(r - 0.012, y) for r, y in reversed(bowl(1.0, 24)[2:])] + [(0.0, 0.37)]
    lip = [outer[-1], (outer[-1][0] - 0.012, outer[-1][1])]
    glass_solid = merge(lathe(outer, 96), lathe(lip, 96), lathe(inner, 96, flip=False))
    amber = glass(g, "Cognac", ior=1.36, attenuation=((0.75, 0.35, 0.08), 0.15))
    g.node("Glass", mesh=g.mesh("Glass", glass_solid, glass(g)))
    # The liquid fills the bowl to 0.55 m, 1 mm inside the glass.
    level = 0.55
    liquid_profile = [(0.0, 0.372)] + [(r - 0.013, y) for r, y in bowl(1.0, 24)[2:] if y < level]
    top_r = liquid_profile[-1][0]
    liquid = merge(lathe(liquid_profile, 96), disk(top_r, liquid_profile[-1][1], 96))
    g.node("Cognac", mesh=g.mesh("Cognac", liquid, amber))
    small_lamp(g, [1.0, 3.0, 0.5], 0.3, 300.0)
    g.scene_extension("PHOTON_world", {"color": [0.1, 0.1, 0.12], "strength": 1.0})
    g.camera("Camera", [0, 1.1, 2.2], [0, 0.45, 0], 35.0, 1.0)
    bs.render_settings(g, 256, 256)
    g.write("cognac_glass.glb")


def sphereflake():
    """Haines' sphereflake (three levels, 91 spheres) of polished metal on a floor."""
    g = Gltf()
    floor = g.material("Floor", base=(0.6, 0.6, 0.6), roughness=1.0, lambert=True)
    metal = g.material("Chrome", base=(0.9, 0.9, 0.92), metallic=1.0, roughness=0.05)
    g.node("Floor", mesh=g.mesh("Floor", floor_quad(6.0), floor))
    sphere = g.mesh("Sphere", uv_sphere(1.0, 24, 12), metal)

    def children(centre, radius, up, level):
        g.node("Flake%d" % len(g.doc["nodes"]), mesh=sphere, translation=centre,
               scale=[radius] * 3)
        if level == 0:
            return
        # Nine children: six around the equator, three above, each a third the size.
        ref = [1, 0, 0] if abs(up[0]) < 0.9 else [0, 0, 1]
        a = normalize(cross(up, ref))
        b = cross(up, a)
        r = radius / 3
        for k in range(9):
            if k < 6:
                phi, lift = 2 * math.pi * k / 6, 0.0
            else:
                phi, lift = 2 * math.pi * (k - 6) / 3 + math.pi / 6, 0.9
            d = [math.cos(phi) * a[i] + math.sin(phi) * b[i] + lift * up[i] for i in range(3)]
            d = normalize(d)
            c = [centre[i] + (radius + r) * d[i] for i in range(3)]
            children(c, r, d, level - 1)

    children([0, 1.0, 0], 1.0, [0, 1, 0], 2)
    g.punctual("Sun", "directional", [1, 0.95, 0.9], 3.0 * bs.LUMENS_PER_WATT, [0, 10, 0],
               target=[-2, 0, -3], photon={"angle": 0.02})
    g.scene_extension("PHOTON_world", {"color": [0.35, 0.45, 0.65], "strength": 0.6})
    g.camera("Camera", [2.5, 2.6, 4.5], [0, 0.9, 0], 40.0, 1.0)
    bs.render_settings(g, 256, 256)
    g.write("sphereflake.glb")


def glass_cube():
    """A glass cube turned on a diffuse floor under a small light: a sharp-edged caustic."""
    g = Gltf()
    floor = g.material("Floor", base=(0.8, 0.8, 0.8), roughness=1.0, lambert=True)
    g.node("Floor", mesh=g.mesh("Floor", floor_quad(4.0), floor))
    g.node("GlassCube", mesh=g.mesh("GlassCube", cube(), glass(g)),
           translation=[0, 0.6, 0], rotation=axis_angle([0.3, 1, 0.2], 35), scale=[1.1] * 3)
    small_lamp(g, [1.0, 4.5, 0.8], 0.3, 400.0)
    g.camera("Camera", [0, 3.0, 5.5], [0, 0.5, 0], 40.0, 1.0)
    bs.render_settings(g, 256, 256)
    g.write("glass_cube.glb")


def fractal_cornell():
    """The Cornell box with a fractal (midpoint-displacement) terrain filling its floor."""
    g = Gltf()
    white = cornell_walls(g)
    n = 64
    heights = [[0.0] * (n + 1) for _ in range(n + 1)]
    seed = [12345]

    def rnd():
        seed[0] = (seed[0] * 1103515245 + 12345) % (1 << 31)
        return seed[0] / float(1 << 31) - 0.5

    step, amp = n, 1.2
    while step > 1:
        half = step // 2
        for y in range(0, n, step):  # diamond step
            for x in range(0, n, step):
                avg = (heights[y][x] + heights[y][x + step] + heights[y + step][x]
                       + heights[y + step][x + step]) / 4
                heights[y + half][x + half] = avg + amp * rnd()
        for y in range(0, n + 1, half):  # square step
            for x in range((y + half) % step, n + 1, step):
                total, count = 0.0, 0
                for dx, dy in ((-half, 0), (half, 0), (0, -half), (0, half)):
                    if 0 <= x + dx <= n and 0 <= y + dy <= n:
                        total += heights[y + dy][x + dx]
                        count += 1
                heights[y][x] = total / count + amp * rnd()
        step, amp = half, amp * 0.55
    s = 2.6
    positions, uvs, indices = [], [], []
    lo = min(min(r) for r in heights)
    for j in range(n + 1):
        for i in range(n + 1):
            positions.append([-s + 2 * s * i / n, 0.05 + heights[j][i] - lo, -s + 2 * s * j / n])
            uvs.append([i / n, j / n])
    normals = []
    for j in range(n + 1):
        for i in range(n + 1):
            p = lambda a, b: positions[min(max(b, 0), n) * (n + 1) + min(max(a, 0), n)]
            dx, dz = sub(p(i + 1, j), p(i - 1, j)), sub(p(i, j + 1), p(i, j - 1))
            normals.append(normalize(cross(dz, dx)))
    row = n + 1
    for j in range(n):
        for i in range(n):
            a = j * row + i
            indices += [a, a + row, a + 1, a + 1, a + row, a + row + 1]
    g.node("Terrain", mesh=g.mesh("Terrain", (positions, normals, uvs, indices), white))
    g.write("fractal_cornell.glb")


def interior():
    """A room lit by the sun through two windows, a pool of water outside (the Mies house)."""
    g = interior_room()
    g.punctual("Sun", "directional", [1.0, 0.93, 0.85], 5.0 * bs.LUMENS_PER_WATT, [0, 10, 10],
               target=[0.6, 0, -2.0], photon={"angle": 0.0092})
    g.scene_extension("PHOTON_world", {"color": [0.45, 0.6, 0.9], "strength": 0.8})
    g.camera("Camera", [2.4, 1.4, -2.6], [-0.3, 0.9, 2.0], 60.0, 1.0)
    bs.render_settings(g, 256, 256)
    g.write("interior.glb")


def interior_sky(name, elevation_deg, rotation_deg):
    """The Mies house room lit by Blender's sky (a Nishita Sky Texture at Background strength
    0.05, as the add-on exports it) with the sun at `elevation_deg` and turned `rotation_deg`
    from Blender's +Y (the windows face Blender's −Y, glTF's +Z)."""
    g = interior_room()
    g.scene_extension("PHOTON_world", {"strength": 0.05, "sky": {
        "type": "NISHITA", "sun_elevation": math.radians(elevation_deg),
        "sun_rotation": math.radians(rotation_deg)}})
    g.camera("Camera", [2.4, 1.4, -2.6], [-0.3, 0.9, 2.0], 60.0, 1.0)
    bs.render_settings(g, 256, 256)
    g.write(name)


def interior_2pm():
    interior_sky("interior_2pm.glb", 50.0, 200.0)


def interior_7pm():
    interior_sky("interior_7pm.glb", 9.0, 235.0)


def interior_room():
    """The room, its windows, the terrace and the pool, without lights or camera."""
    g = Gltf()
    wall = g.material("Wall", base=(0.8, 0.78, 0.74), roughness=1.0, lambert=True)
    wood = g.material("Floor", base=(0.45, 0.3, 0.18), roughness=0.5)
    stone = g.material("Terrace", base=(0.6, 0.6, 0.58), roughness=1.0, lambert=True)
    water = glass(g, "Water", ior=1.33, attenuation=((0.6, 0.85, 0.9), 1.5), thickness=0.3)
    w, d, h = 3.0, 3.0, 2.6  # half width, half depth, height
    parts = []
    # Floor, ceiling and three closed walls, as boxes 0.1 m thick.
    parts.append(("Floor", wood, box([-w, -0.1, -d], [w, 0.0, d])))
    parts.append(("Ceiling", wall, box([-w, h, -d], [w, h + 0.1, d])))
    parts.append(("Back", wall, box([-w, 0.0, -d - 0.1], [w, h, -d])))
    parts.append(("Left", wall, box([-w - 0.1, 0.0, -d], [-w, h, d])))
    parts.append(("Right", wall, box([w, 0.0, -d], [w + 0.1, h, d])))
    # The front wall (+Z) with two window openings 1.6 m wide, from 0.6 m to 2.2 m high.
    z0, z1 = d, d + 0.1
    for name, x0, x1, y0, y1 in (("FrontBelow", -w, w, 0.0, 0.6), ("FrontAbove", -w, w, 2.2, h),
                                 ("FrontLeft", -w, -2.4, 0.6, 2.2),
                                 ("FrontMiddle", -0.8, 0.8, 0.6, 2.2),
                                 ("FrontRight", 2.4, w, 0.6, 2.2)):
        parts.append((name, wall, box([x0, y0, z0], [x1, y1, z1])))
    # Outside: a terrace and a pool of water 0.3 m deep set into it.
    # The terrace around the pool's opening (x in ±2.5, z from 4.5 to 7.5).
    def ground(x0, x1, z0, z1):
        return quad([[x0, -0.1, z1], [x1, -0.1, z1], [x1, -0.1, z0], [x0, -0.1, z0]], [0, 1, 0])
    for k, (x0, x1, z0, z1) in enumerate(((-8, 8, d + 0.1, 4.5), (-8, 8, 7.5, 12),
                                          (-8, -2.5, 4.5, 7.5), (2.5, 8, 4.5, 7.5))):
        parts.append(("Terrace%d" % k, stone, ground(x0, x1, z0, z1)))
    parts.append(("Pool", water, box([-2.5, -0.4, 4.5], [2.5, -0.12, 7.5])))
    parts.append(("PoolBed", stone, quad([[-2.5, -0.42, 7.5], [2.5, -0.42, 7.5],
                                          [2.5, -0.42, 4.5], [-2.5, -0.42, 4.5]], [0, 1, 0])))
    for name, material, geometry in parts:
        g.node(name, mesh=g.mesh(name, geometry, material))
    g.node("Sofa", mesh=g.mesh("Sofa", cube(), wall), translation=[-1.2, 0.3, -1.8],
           scale=[1.8, 0.6, 0.8])
    return g


BUST_PARTS = ("dome", "neck", "egg", "nose")


def bust_scene(parts=BUST_PARTS, scale=0.08, ior=1.4):
    """The translucent bust's scene with only `parts` of its marble mesh (the shoulders' lathed
    `dome`, the `neck` column, the `egg` of the head, the `nose`: overlapping solids merged into
    one mesh, so it has faces inside the marble) and the given Subsurface Scale and IOR;
    docs/bench/bust_256px/variants.py builds subsets to study them."""
    g = Gltf()
    plinth = g.material("Plinth", base=(0.08, 0.08, 0.09), roughness=0.4)
    marble = g.material("Marble", base=(0.9, 0.88, 0.84), roughness=0.35, extensions={
        "PHOTON_material_subsurface": {"weight": 1.0, "radius": [1.0, 0.7, 0.5], "scale": scale,
                                       "ior": ior, "anisotropy": 0.0}})
    floor = g.material("Floor", base=(0.5, 0.5, 0.5), roughness=1.0, lambert=True)
    g.node("Floor", mesh=g.mesh("Floor", floor_quad(6.0), floor))
    g.node("Plinth", mesh=g.mesh("Plinth", box([-0.5, 0.0, -0.4], [0.5, 0.6, 0.4]), plinth))
    # Shoulders: a squashed lathed dome; neck: a waisted column; head: an egg with a nose.
    shoulders = [(0.0, 0.6), (0.42, 0.6)] + [
        (0.42 * math.cos(a), 0.6 + 0.28 * math.sin(a))
        for a in [math.pi / 2 * k / 12 for k in range(1, 13)]]
    neck = [(0.13 - 0.02 * math.sin(math.pi * k / 8), 0.8 + 0.22 * k / 8) for k in range(9)]
    egg = [(0.24 * math.sin(math.pi * k / 24) * (1.0 - 0.15 * k / 24),
            1.2 + 0.32 * (-math.cos(math.pi * k / 24))) for k in range(25)]
    dome = lathe(shoulders, 64)
    dome = ([[1.3 * x, y, z] for x, y, z in dome[0]],) + dome[1:]  # broad shoulders
    meshes = {"dome": dome, "neck": lathe(neck, 48), "egg": lathe(egg, 64),
              "nose": transformed(uv_sphere(0.05, 16, 8), 1.0, [0.0, 1.22, 0.225])}
    g.node("Bust", mesh=g.mesh("Bust", merge(*[meshes[p] for p in parts]), marble))
    small_lamp(g, [-1.5, 2.5, -1.5], 0.5, 150.0, name="KeyLight")
    g.doc["nodes"][-1]["rotation"] = bs.clean(bs.look_at([-1.5, 2.5, -1.5], [0, 1.0, 0]))
    small_lamp(g, [2.0, 1.8, 2.0], 0.6, 40.0, name="FillLight")
    g.doc["nodes"][-1]["rotation"] = bs.clean(bs.look_at([2.0, 1.8, 2.0], [0, 1.0, 0]))
    g.scene_extension("PHOTON_world", {"color": [0.02, 0.02, 0.025], "strength": 1.0})
    g.camera("Camera", [0.6, 1.35, 3.2], [0, 0.95, 0], 35.0, 1.0)
    bs.render_settings(g, 256, 256)
    return g


def translucent_bust():
    """A sculpted bust (head, neck and shoulders as lathed and scaled solids) of translucent
    marble on a dark plinth, lit from behind and the side so light shows through thin parts."""
    bust_scene().write("translucent_bust.glb")


SCENES = [cornell_spheres, glossy_caustic, metal_ring, cognac_glass, sphereflake, glass_cube,
          fractal_cornell, interior, interior_2pm, interior_7pm, translucent_bust]

if __name__ == "__main__":
    for build in SCENES:
        build()
