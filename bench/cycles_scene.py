"""Renders relit's path tracer benchmark scene with Blender Cycles (CPU).

Run by relit-bench-pathtracer, or by hand:

  blender -b --factory-startup -noaudio --python-exit-code 1 \
      --python bench/cycles_scene.py -- --mesh bench/assets/spot.obj \
      --output-dir /tmp/cycles [scene options, see --help]

The scene mirrors bench/bench_scene.cc; every number comes from the command
line so the C++ side stays the single source of truth. Conventions:

* World: relit's +Z-up frame, metres. The OBJ is imported without axis
  conversion (axis_forward='Y', axis_up='Z' is the identity) and placed with
  --object-matrix (relit's world_from_object, row-major 4x4).
* Camera: relit's OpenCV pinhole with the principal point at the image centre
  and a horizontal field of view; Blender gets the eye, a look-at target (up
  = +Z, as relit's LookAt) and the same horizontal FoV (sensor fit HORIZONTAL).
* Point light: relit's radiant intensity I [W/sr]. A Cycles point lamp of
  power P [W] and radius 0 has I = P / (4 pi), so P = 4 pi I.
* Materials: Lambert = Diffuse BSDF (roughness 0). GGX = Glossy BSDF with the
  GGX distribution; Cycles squares the roughness (alpha = r^2), so
  r = sqrt(relit alpha). relit's GGX variant uses Fresnel f0 = 1 to match
  the Fresnel-free Glossy BSDF.
* Generic materials (the radiance-cue benchmark, relit-bench-cues):
  --materials also takes tokens NAME=diffuse:ALBEDO and
  NAME=glossy:ALBEDO:ALPHA (ALPHA = relit's GGX alpha; the script sets the
  Glossy BSDF roughness to sqrt(ALPHA)), rendered to cycles_NAME.exr.
  --ground-half-size 0 leaves the ground out (the cue scene is the object
  alone, as relit's cue stage renders the proxy alone).
* Bounces: relit max_depth counts path vertices that get direct lighting
  (1 = direct only); Cycles max_bounces = 0 is direct only, so the caller
  passes max_depth - 1.

For each material prints one parseable line
  RELIT_CYCLES material=<name> seconds=<s> cpu_seconds=<s> output=<exr path>
where seconds is the best wall time of bpy.ops.render.render over --repeats
and cpu_seconds the best process CPU time (all threads) of the same call.
"""

import argparse
import math
import os
import sys
import time

import bpy
from mathutils import Matrix, Vector

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cycles_settings import configure_cycles  # noqa: E402 (beside this script)


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="cycles_scene.py", description=__doc__.splitlines()[0])
    p.add_argument("--mesh", required=True)
    p.add_argument("--output-dir", required=True)
    p.add_argument("--materials", default="lambert,ggx")
    p.add_argument("--width", type=int, default=320)
    p.add_argument("--height", type=int, default=240)
    p.add_argument("--spp", type=int, default=16)
    p.add_argument("--max-bounces", type=int, default=7)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--repeats", type=int, default=1)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--object-matrix", type=float, nargs=16, required=True)
    p.add_argument("--camera-eye", type=float, nargs=3, required=True)
    p.add_argument("--camera-target", type=float, nargs=3, required=True)
    p.add_argument("--hfov-deg", type=float, required=True)
    p.add_argument("--light-position", type=float, nargs=3, required=True)
    p.add_argument("--light-intensity", type=float, required=True, help="W/sr")
    p.add_argument("--ground-half-size", type=float, required=True, help="0 = no ground")
    p.add_argument("--ground-albedo", type=float, required=True)
    p.add_argument("--lambert-albedo", type=float, required=True)
    p.add_argument("--ggx-albedo", type=float, required=True)
    p.add_argument("--ggx-alpha", type=float, required=True)
    return p.parse_args(argv)


def clear_scene():
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj, do_unlink=True)
    for collection in (bpy.data.meshes, bpy.data.materials, bpy.data.lights, bpy.data.cameras):
        for block in list(collection):
            collection.remove(block)


def import_mesh(path, matrix):
    before = set(bpy.data.objects)
    if hasattr(bpy.ops.import_scene, "obj"):  # Blender <= 3.x Python importer
        bpy.ops.import_scene.obj(filepath=path, axis_forward="Y", axis_up="Z",
                                 use_split_objects=False, use_split_groups=False)
    else:  # Blender >= 4.0: C++ importer
        bpy.ops.wm.obj_import(filepath=path, forward_axis="Y", up_axis="Z")
    imported = [o for o in bpy.data.objects if o not in before and o.type == "MESH"]
    if len(imported) != 1:
        raise RuntimeError("expected one mesh object from %s, got %d" % (path, len(imported)))
    obj = imported[0]
    obj.matrix_world = Matrix([matrix[0:4], matrix[4:8], matrix[8:12], matrix[12:16]])
    # Smooth shading with Blender's (angle-weighted) vertex normals; relit's
    # bench computes the same normals.
    obj.data.polygons.foreach_set("use_smooth", [True] * len(obj.data.polygons))
    obj.data.update()
    return obj


def add_ground(half, material):
    mesh = bpy.data.meshes.new("ground")
    h = half
    mesh.from_pydata([(-h, -h, 0), (h, -h, 0), (h, h, 0), (-h, h, 0)], [], [(0, 1, 2, 3)])
    mesh.materials.append(material)
    obj = bpy.data.objects.new("ground", mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def node_material(name, kind, color, roughness=0.0):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nodes = mat.node_tree.nodes
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    if kind == "diffuse":
        bsdf = nodes.new("ShaderNodeBsdfDiffuse")
    else:
        bsdf = nodes.new("ShaderNodeBsdfGlossy")
        bsdf.distribution = "GGX"
    bsdf.inputs["Color"].default_value = (color, color, color, 1.0)
    bsdf.inputs["Roughness"].default_value = roughness
    mat.node_tree.links.new(bsdf.outputs["BSDF"], out.inputs["Surface"])
    return mat


def add_camera(scene, eye, target, hfov_deg):
    cam_data = bpy.data.cameras.new("camera")
    cam_data.type = "PERSP"
    cam_data.sensor_fit = "HORIZONTAL"
    cam_data.sensor_width = 36.0
    cam_data.lens = 0.5 * cam_data.sensor_width / math.tan(0.5 * math.radians(hfov_deg))
    cam_data.shift_x = cam_data.shift_y = 0.0
    cam_data.clip_start = 1e-3
    cam_data.clip_end = 1e4
    cam = bpy.data.objects.new("camera", cam_data)
    scene.collection.objects.link(cam)
    eye, target = Vector(eye), Vector(target)
    cam.location = eye
    # Blender cameras look along -Z with +Y up; keep image up near world +Z.
    cam.rotation_mode = "QUATERNION"
    cam.rotation_quaternion = (target - eye).to_track_quat("-Z", "Y")
    scene.camera = cam


def add_point_light(scene, position, intensity):
    light = bpy.data.lights.new("point", type="POINT")
    light.energy = 4.0 * math.pi * intensity  # W; Cycles: I = P / (4 pi)
    light.color = (1.0, 1.0, 1.0)
    light.shadow_soft_size = 0.0  # a true point light, as relit's
    obj = bpy.data.objects.new("point", light)
    obj.location = Vector(position)
    scene.collection.objects.link(obj)


def configure_render(scene, args):
    configure_cycles(scene, args.max_bounces, args.threads, transparent_max_bounces=0)
    scene.cycles.samples = args.spp
    scene.cycles.seed = args.seed
    scene.render.resolution_x = args.width
    scene.render.resolution_y = args.height
    scene.render.film_transparent = False
    scene.render.use_persistent_data = False
    scene.render.image_settings.color_mode = "RGBA"
    # Black world: relit's benchmark scene has no environment light.
    world = bpy.data.worlds.new("black")
    world.use_nodes = False
    world.color = (0.0, 0.0, 0.0)
    scene.world = world


def parse_material(token, predefined):
    """Returns (name, factory) for "lambert", "ggx", "NAME=diffuse:ALBEDO" or
    "NAME=glossy:ALBEDO:ALPHA" (ALPHA: GGX alpha; Cycles roughness = sqrt)."""
    if "=" not in token:
        if token not in predefined:
            raise ValueError("unknown material %r (lambert, ggx, NAME=diffuse:A, NAME=glossy:A:ALPHA)" % token)
        return token, predefined[token]
    name, spec = token.split("=", 1)
    fields = spec.split(":")
    if fields[0] == "diffuse" and len(fields) == 2:
        return name, lambda: node_material(name, "diffuse", float(fields[1]))
    if fields[0] == "glossy" and len(fields) == 3:
        return name, lambda: node_material(name, "glossy", float(fields[1]), math.sqrt(float(fields[2])))
    raise ValueError("bad material token %r" % token)


def main():
    args = parse_args()
    os.makedirs(args.output_dir, exist_ok=True)
    clear_scene()
    scene = bpy.context.scene
    configure_render(scene, args)
    cow = import_mesh(os.path.abspath(args.mesh), args.object_matrix)
    if args.ground_half_size > 0:
        add_ground(args.ground_half_size, node_material("ground", "diffuse", args.ground_albedo))
    add_camera(scene, args.camera_eye, args.camera_target, args.hfov_deg)
    add_point_light(scene, args.light_position, args.light_intensity)

    materials = {
        "lambert": lambda: node_material("lambert", "diffuse", args.lambert_albedo),
        "ggx": lambda: node_material("ggx", "glossy", args.ggx_albedo, math.sqrt(args.ggx_alpha)),
    }
    for token in [m for m in args.materials.split(",") if m]:
        name, make = parse_material(token, materials)
        cow.data.materials.clear()
        cow.data.materials.append(make())
        output = os.path.abspath(os.path.join(args.output_dir, "cycles_%s.exr" % name))
        scene.render.filepath = output
        best = best_cpu = None
        for _ in range(max(1, args.repeats)):
            cpu_start = time.process_time()  # all threads of the process
            start = time.perf_counter()
            bpy.ops.render.render(write_still=True)
            seconds = time.perf_counter() - start
            cpu_seconds = time.process_time() - cpu_start
            best = seconds if best is None else min(best, seconds)
            best_cpu = cpu_seconds if best_cpu is None else min(best_cpu, cpu_seconds)
        print("RELIT_CYCLES material=%s seconds=%.6f cpu_seconds=%.6f output=%s"
              % (name, best, best_cpu, output), flush=True)


if __name__ == "__main__":
    main()
