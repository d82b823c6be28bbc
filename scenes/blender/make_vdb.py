"""Writes the OpenVDB test files of tests/data/vdb/ (the reader's tests in src/scene/vdb.rs).

Run with the project's bpy: `.venv/bin/python scenes/blender/make_vdb.py [OUT_DIR]`
(default tests/data/vdb). Blender writes them three ways:

- Geometry Nodes "Volume Cube" and "Mesh to Volume" baked to disk by a Bake node (blosc +
  active-mask compression, no grid offsets): `cube_*.vdb`, `mesh_to_volume.vdb`.
- The `openvdb` Python module shipped with bpy: transforms, tiles, vec3 grids, half floats,
  instanced grids and grid types the reader refuses: `pyvdb_*.vdb`.
- OpenVDB's C++ library (Debian's libopenvdb-dev, when installed: the Python module cannot
  choose the compression, and Mantaflow does not run in the bpy module) for zip, no codec,
  a stream without grid offsets and every active-mask code: `cpp_*.vdb`, its expected values
  in `expected_cpp.txt`.

`expected_py.txt` holds values the `openvdb` module reads back from the other files: per grid
its active bounding box and about forty voxels (`file grid x y z value…`).

With `--large N` it bakes only an N³ Volume Cube to OUT_DIR/cube_large.vdb (for timing).
"""

import glob
import os
import shutil
import subprocess
import sys
import tempfile

import bpy
from volume_scenes import bake_volume, openvdb_module

ARGS = [a for a in sys.argv[1:] if not a.startswith("-")]
HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.abspath(ARGS[0]) if ARGS else os.path.join(HERE, "..", "..", "tests", "data", "vdb")
WORK = tempfile.mkdtemp(prefix="make_vdb_")


def bake_geometry(name, build):
    """Bakes the geometry a node group makes (build(ng) returns its output socket) to disk and
    copies the one .vdb it writes to OUT/name."""
    shutil.copy(bake_volume(os.path.join(WORK, name), build), os.path.join(OUT, name))


def ramp_cube(resolution, lo, hi, background=0.0):
    """A Volume Cube whose density is x + 10 y + 100 z of the point it is evaluated at."""

    def build(ng):
        pos = ng.nodes.new("GeometryNodeInputPosition")
        sep = ng.nodes.new("ShaderNodeSeparateXYZ")
        ng.links.new(pos.outputs[0], sep.inputs[0])
        y10 = ng.nodes.new("ShaderNodeMath")
        y10.operation = "MULTIPLY_ADD"
        ng.links.new(sep.outputs[1], y10.inputs[0])
        y10.inputs[1].default_value = 10.0
        ng.links.new(sep.outputs[0], y10.inputs[2])
        z100 = ng.nodes.new("ShaderNodeMath")
        z100.operation = "MULTIPLY_ADD"
        ng.links.new(sep.outputs[2], z100.inputs[0])
        z100.inputs[1].default_value = 100.0
        ng.links.new(y10.outputs[0], z100.inputs[2])
        cube = ng.nodes.new("GeometryNodeVolumeCube")
        ng.links.new(z100.outputs[0], cube.inputs["Density"])
        cube.inputs["Background"].default_value = background
        cube.inputs["Min"].default_value = lo
        cube.inputs["Max"].default_value = hi
        for axis, n in zip("XYZ", resolution):
            cube.inputs["Resolution " + axis].default_value = n
        return cube.outputs[0]

    return build


def noise_cube(n):
    """An n³ Volume Cube of Noise Texture density (for timing: every voxel differs)."""

    def build(ng):
        noise = ng.nodes.new("ShaderNodeTexNoise")
        cube = ng.nodes.new("GeometryNodeVolumeCube")
        ng.links.new(noise.outputs["Fac"], cube.inputs["Density"])
        for axis in "XYZ":
            cube.inputs["Resolution " + axis].default_value = n
        return cube.outputs[0]

    return build


def mesh_to_volume(ng):
    sphere = ng.nodes.new("GeometryNodeMeshUVSphere")
    sphere.inputs["Radius"].default_value = 1.0
    # Away from the origin, so the volume has one root child, not eight (a smaller file).
    move = ng.nodes.new("GeometryNodeTransform")
    move.inputs["Translation"].default_value = (1.5, 1.5, 1.5)
    ng.links.new(sphere.outputs[0], move.inputs[0])
    m2v = ng.nodes.new("GeometryNodeMeshToVolume")
    m2v.resolution_mode = "VOXEL_AMOUNT"
    m2v.inputs["Voxel Amount"].default_value = 12
    m2v.inputs["Density"].default_value = 0.75
    ng.links.new(move.outputs[0], m2v.inputs["Mesh"])
    return m2v.outputs[0]


def python_files():
    vdb = openvdb_module()

    def ramp(grid, lo, hi, f):
        acc = grid.getAccessor()
        for x in range(lo[0], hi[0] + 1):
            for y in range(lo[1], hi[1] + 1):
                for z in range(lo[2], hi[2] + 1):
                    acc.setValueOn((x, y, z), f(x, y, z))

    # Tiles at every level, an inactive voxel with a value, a negative origin; scale map.
    g = vdb.FloatGrid(background=0.25)
    g.name = "tiles"
    g.fill((-8, 0, 0), (-1, 7, 7), 2.0, True)  # one whole leaf: a tile of the lower internal node
    g.fill((128, 0, 0), (255, 127, 127), 3.0, True)  # a tile of the upper internal node
    ramp(g, (-3, 9, 1), (2, 11, 3), lambda x, y, z: x + 10 * y + 100 * z)
    g.getAccessor().setValueOff((5, 5, 20), -7.0)
    g.transform = vdb.createLinearTransform([[0.5, 0, 0, 0], [0, 0.25, 0, 0], [0, 0, 2, 0],
                                             [1, 2, 3, 1]])
    vel = vdb.Vec3SGrid(background=(0.0, 0.0, 1.0))
    vel.name = "velocity"
    ramp(vel, (0, 0, 0), (9, 3, 2), lambda x, y, z: (x, -y, 0.5 * z))
    vel.transform = vdb.createLinearTransform(voxelSize=0.1)
    vdb.write(os.path.join(OUT, "pyvdb_tiles.vdb"), grids=[g, vel])

    # An affine map (rotation, non-uniform scale, translation) and a translation-only map.
    a = vdb.FloatGrid()
    a.name = "affine"
    ramp(a, (0, 0, 0), (3, 2, 1), lambda x, y, z: x + 10 * y + 100 * z)
    a.transform = vdb.createLinearTransform([[0, 2, 0, 0], [-1, 0, 0, 0], [0, 0, 3, 0],
                                             [4, 5, 6, 1]])
    t = vdb.FloatGrid()
    t.name = "translated"
    ramp(t, (0, 0, 0), (1, 1, 1), lambda x, y, z: 1.0)
    t.transform = vdb.createLinearTransform([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0],
                                             [-1, -2, -3, 1]])
    inst = a.copy()  # shares the tree: written as an instance of "affine"
    inst.name = "instance"
    inst.transform = vdb.createLinearTransform(voxelSize=2.0)
    vdb.write(os.path.join(OUT, "pyvdb_maps.vdb"), grids=[a, t, inst])

    # Half floats, float and vec3.
    h = vdb.FloatGrid()
    h.name = "half"
    ramp(h, (0, 0, 0), (9, 9, 9), lambda x, y, z: 0.125 * x + 0.5 * y + z)
    h.saveFloatAsHalf = True
    hv = vdb.Vec3SGrid()
    hv.name = "half_vec"
    ramp(hv, (0, 0, 0), (4, 4, 4), lambda x, y, z: (x, y + 0.5, -z))
    hv.saveFloatAsHalf = True
    vdb.write(os.path.join(OUT, "pyvdb_half.vdb"), grids=[h, hv])

    # Types the reader refuses (and steps over in a file without offsets), before one it reads.
    d = vdb.DoubleGrid()
    d.name = "double"
    d.getAccessor().setValueOn((1, 2, 3), 1.5)
    b = vdb.BoolGrid()
    b.name = "bool"
    b.getAccessor().setValueOn((1, 2, 3), True)
    i = vdb.Int32Grid()
    i.name = "int"
    i.getAccessor().setValueOn((1, 2, 3), 7)
    f = vdb.FloatGrid()
    f.name = "float"
    f.getAccessor().setValueOn((1, 2, 3), 0.5)
    vdb.write(os.path.join(OUT, "pyvdb_types.vdb"), grids=[d, b, i, f])
    return vdb


def write_expected(vdb):
    """About forty voxels of each float and vec3 grid, as the openvdb module reads them."""
    lines = []
    for name in sorted(os.listdir(OUT)):
        if not name.endswith(".vdb") or name.startswith("cpp_"):
            continue
        grids, _ = vdb.readAll(os.path.join(OUT, name))
        for g in grids:
            if g.valueTypeName not in ("float", "vec3s"):
                continue
            lo, hi = g.evalActiveVoxelBoundingBox()
            lines.append("%s %s bbox %d %d %d %d %d %d" % ((name, g.name) + tuple(lo) + tuple(hi)))
            size = [h - l + 1 for l, h in zip(lo, hi)]
            volume = size[0] * size[1] * size[2]
            step = max(1, volume // 40) | 1
            acc = g.getConstAccessor()
            for n in range(0, volume, step):
                x, y, z = lo[0] + n // (size[1] * size[2]), lo[1] + n // size[2] % size[1], lo[2] + n % size[2]
                v = acc.getValue((x, y, z))
                v = tuple(v) if isinstance(v, tuple) else (v,)
                lines.append("%s %s %d %d %d " % (name, g.name, x, y, z) + " ".join(repr(float(c)) for c in v))
    with open(os.path.join(OUT, "expected_py.txt"), "w") as f:
        f.write("\n".join(lines) + "\n")


CPP_WRITER = r"""
// Writes OpenVDB files with each compression (none, zip, blosc), seekable or not, half floats,
// and leaves whose inactive values need every active-mask code.
#include <openvdb/openvdb.h>
#include <openvdb/io/Stream.h>
#include <openvdb/tools/LevelSetSphere.h>
#include <fstream>
#include <iostream>
using namespace openvdb;

static GridPtrVec grids() {
    GridPtrVec out;
    // A ramp with inactive voxels of other values than the background: codes 2, 4 and 5.
    FloatGrid::Ptr ramp = FloatGrid::create(0.5f);
    ramp->setName("ramp");
    auto acc = ramp->getAccessor();
    for (int x = 0; x < 13; ++x)
        for (int y = 0; y < 10; ++y)
            for (int z = 2; z < 7; ++z) acc.setValueOn(Coord(x, y, z), x + 10.f * y + 100.f * z);
    // Leaves whose inactive values are: the background and one other (code 4); three values
    // (code 6, all stored); one value (code 2); two other values (code 5); minus the
    // background (code 1); both signs of the background (code 3, a selection mask).
    acc.setValueOff(Coord(1, 1, 1), 7.f);
    acc.setValueOff(Coord(9, 1, 1), 7.f);
    acc.setValueOff(Coord(9, 1, 0), -3.f);
    auto leafOf = [&](int x, float inactive) {
        ramp->fill(CoordBBox(Coord(x, 0, 0), Coord(x + 7, 7, 7)), inactive, false);
        for (int y = 2; y < 6; ++y) acc.setValueOn(Coord(x + 1, y, 3), x + 10.f * y + 300.f);
    };
    leafOf(16, 7.f);
    leafOf(24, 7.f);
    acc.setValueOff(Coord(26, 4, 4), -3.f);
    leafOf(32, -0.5f);
    leafOf(40, -0.5f);
    acc.setValueOff(Coord(40, 4, 4), 0.5f);
    ramp->setTransform(math::Transform::createLinearTransform(0.25));
    ramp->transform().postTranslate(Vec3d(1, 2, 3));
    out.push_back(ramp);
    // A level set: inactive values of both signs, selection masks (code 3).
    FloatGrid::Ptr sphere = tools::createLevelSetSphere<FloatGrid>(2.5f, Vec3f(6, 6, 6), 0.5f, 2.0f);
    sphere->setName("sphere");
    out.push_back(sphere);
    // A vec3 grid with an active tile of a lower internal node.
    Vec3SGrid::Ptr vel = Vec3SGrid::create(Vec3s(0, 0, 1));
    vel->setName("velocity");
    auto vacc = vel->getAccessor();
    for (int x = 0; x < 6; ++x)
        for (int y = 0; y < 3; ++y) vacc.setValueOn(Coord(x, y, 1), Vec3s(x, -y, 0.5f));
    vel->tree().addTile(1, Coord(16, 0, 0), Vec3s(1, 2, 3), true);
    out.push_back(vel);
    return out;
}

static void samples(std::ofstream& txt, const std::string& file, const GridPtrVec& gs) {
    for (auto& base : gs) {
        CoordBBox box = base->evalActiveVoxelBoundingBox();
        txt << file << " " << base->getName() << " bbox " << box.min() << " " << box.max() << "\n";
        const Index64 step = std::max<Index64>(1, box.volume() / 40) | 1;
        Index64 n = 0;
        for (auto it = box.begin(); it; ++it, ++n) {
            const Coord c0 = *it;
            const bool chosen = c0 == Coord(1, 1, 1) || c0 == Coord(9, 1, 0) || c0 == Coord(26, 4, 4)
                || c0 == Coord(17, 2, 3) || c0 == Coord(16, 0, 0) || c0 == Coord(33, 7, 7) || c0 == Coord(20, 8, 8)
                || c0 == Coord(40, 4, 4) || c0 == Coord(41, 4, 4);
            if (n % step != 0 && !chosen) continue;
            Coord c = *it;
            if (auto g = GridBase::grid<FloatGrid>(base)) {
                txt << file << " " << base->getName() << " " << c.x() << " " << c.y() << " " << c.z()
                    << " " << g->getConstAccessor().getValue(c) << "\n";
            } else if (auto g = GridBase::grid<Vec3SGrid>(base)) {
                Vec3s v = g->getConstAccessor().getValue(c);
                txt << file << " " << base->getName() << " " << c.x() << " " << c.y() << " " << c.z()
                    << " " << v[0] << " " << v[1] << " " << v[2] << "\n";
            }
        }
    }
}

int main(int argc, char** argv) {
    openvdb::initialize();
    std::string dir = argv[1];
    std::ofstream txt(dir + "/expected_cpp.txt");
    txt.precision(9);
    GridPtrVec gs = grids();
    struct Variant { const char* file; uint32_t compression; bool half; bool stream; };
    Variant variants[] = {
        {"cpp_none.vdb", io::COMPRESS_ACTIVE_MASK, false, true},
        {"cpp_zip.vdb", io::COMPRESS_ZIP | io::COMPRESS_ACTIVE_MASK, false, false},
        {"cpp_blosc.vdb", io::COMPRESS_BLOSC | io::COMPRESS_ACTIVE_MASK, false, true},
        {"cpp_zip_half.vdb", io::COMPRESS_ZIP | io::COMPRESS_ACTIVE_MASK, true, false},
    };
    for (auto& v : variants) {
        for (auto& g : gs) g->setSaveFloatAsHalf(v.half);
        std::string path = dir + "/" + v.file;
        if (v.stream) {
            std::ofstream os(path, std::ios::binary);
            io::Stream stream(os);
            stream.setCompression(v.compression);
            stream.write(gs);
        } else {
            io::File file(path);
            file.setCompression(v.compression);
            file.write(gs);
            file.close();
        }
        // Expected values as OpenVDB reads the file back (half floats rounded).
        io::File in(path);
        in.open();
        GridPtrVec back = *in.getGrids();
        samples(txt, v.file, back);
    }
    return 0;
}
"""


def cpp_files():
    """Builds and runs CPP_WRITER against Debian's OpenVDB, if it is installed."""
    if not os.path.exists("/usr/include/openvdb/openvdb.h"):
        print("no /usr/include/openvdb (apt-get install libopenvdb-dev libboost-dev g++): "
              "cpp_*.vdb left as they are")
        return
    source = os.path.join(WORK, "make_vdb.cpp")
    with open(source, "w") as f:
        f.write(CPP_WRITER)
    binary = os.path.join(WORK, "make_vdb")
    libs = ["-lopenvdb", "-ltbb"] + ["-l" + os.path.basename(p)[3:].split(".so")[0]
                                     for p in glob.glob("/usr/lib/x86_64-linux-gnu/libImath-*.so")]
    subprocess.run(["g++", "-O1", "-std=c++17", source, "-o", binary] + libs, check=True)
    subprocess.run([binary, OUT], check=True)


def main():
    if "--large" in sys.argv:
        n = int(ARGS[-1]) if len(ARGS) > 1 else 256
        os.makedirs(OUT, exist_ok=True)
        bake_geometry("cube_large.vdb", noise_cube(n))
        return
    os.makedirs(OUT, exist_ok=True)
    bake_geometry("cube_ramp_8.vdb", ramp_cube((8, 8, 8), (-1, -1, -1), (1, 1, 1)))
    bake_geometry("cube_ramp_20x12x9.vdb", ramp_cube((20, 12, 9), (-1, -2, 0.5), (3, 1, 2.5), 0.5))
    bake_geometry("mesh_to_volume.vdb", mesh_to_volume)
    vdb = python_files()
    write_expected(vdb)
    cpp_files()
    for f in sorted(os.listdir(OUT)):
        print(f, os.path.getsize(os.path.join(OUT, f)))
    shutil.rmtree(WORK)


main()
