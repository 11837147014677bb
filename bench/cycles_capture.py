"""Renders a dual-phone capture's frames with Blender Cycles (CPU) from a job
file written by relit-bench-cycles-capture (bench/cycles_capture.cc):

  blender -b --factory-startup -noaudio --python-exit-code 1 \
      --python bench/cycles_capture.py -- --spec DIR/render/spec.json

The C++ side decides everything (cameras, flash positions, eval lights, the
world-frame meshes it also writes as ground truth); this script builds the
scene once and renders every job whose EXR does not exist yet, so an
interrupted run resumes. Conventions:

* World: relit's +Z-up frame, metres. The truth OBJs are in world
  coordinates and imported without axis conversion (forward Y, up Z).
* Camera: OpenCV pinhole (x right, y down, z forward; pixel (0, 0) is the
  centre of the top-left pixel). Blender's camera looks along -Z with +Y up,
  so world_from_blender_camera = world_from_cam * diag(1, -1, -1). The focal
  length goes in as lens = fx * sensor_width / width (sensor fit HORIZONTAL,
  square pixels); the principal point as shift_x = (width / 2 - 0.5 - cx) /
  width and shift_y = (cy + 0.5 - height / 2) / width (Blender's shift is in
  units of the fitted sensor dimension and moves the view, not the image).
* Point light: radiant intensity I [W/sr]; a Cycles point lamp of radius 0
  and power P [W] has I = P / (4 pi). Sun: strength = irradiance [W/m^2].
  Environment: the map is given already in Blender's equirectangular layout
  (the C++ side moves relit's column x to (W/2 - 1 - x) mod W: Cycles has u =
  0.5 - atan2(y, x) / 2pi, relit u = atan2(y, x) / 2pi; rows agree, top =
  zenith; nearest lookup as relit's); background strength = scale.
* Materials: the board uses the truth's own linear albedo texture
  (Non-Color, bilinear); the bunny, the sphere and the table are painted
  here, procedurally (Principled BSDF), which relit never sees.
* Bounces: relit max_depth counts lit path vertices; Cycles max_bounces =
  max_depth - 1 (the caller passes it).

Prints one line per job: RELIT_JOB <index> <total> <seconds> <output> (seconds
= -1 when the file already existed).
"""

import argparse
import json
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
    p = argparse.ArgumentParser(prog="cycles_capture.py", description=__doc__.splitlines()[0])
    p.add_argument("--spec", required=True)
    return p.parse_args(argv)


def clear_scene():
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj, do_unlink=True)
    for collection in (bpy.data.meshes, bpy.data.materials, bpy.data.lights, bpy.data.cameras,
                       bpy.data.images, bpy.data.worlds):
        for block in list(collection):
            collection.remove(block)


def import_obj(path):
    before = set(bpy.data.objects)
    if hasattr(bpy.ops.import_scene, "obj"):  # Blender <= 3.x Python importer
        bpy.ops.import_scene.obj(filepath=path, axis_forward="Y", axis_up="Z",
                                 use_split_objects=False, use_split_groups=False)
    else:  # Blender >= 4.0
        bpy.ops.wm.obj_import(filepath=path, forward_axis="Y", up_axis="Z")
    imported = [o for o in bpy.data.objects if o not in before and o.type == "MESH"]
    if len(imported) != 1:
        raise RuntimeError("expected one mesh object from %s, got %d" % (path, len(imported)))
    obj = imported[0]
    obj.matrix_world = Matrix.Identity(4)
    return obj


def new_material(name):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nodes = mat.node_tree.nodes
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    return mat, nodes, mat.node_tree.links, out


def textured_diffuse(name, texture_path):
    mat, nodes, links, out = new_material(name)
    image = bpy.data.images.load(texture_path)
    image.colorspace_settings.name = "Non-Color"  # linear albedo, no view transform
    tex = nodes.new("ShaderNodeTexImage")
    tex.image = image
    tex.interpolation = "Linear"
    tex.extension = "EXTEND"
    bsdf = nodes.new("ShaderNodeBsdfDiffuse")
    links.new(tex.outputs["Color"], bsdf.inputs["Color"])
    links.new(bsdf.outputs["BSDF"], out.inputs["Surface"])
    return mat


def principled(name, spec):
    """spec: {"kind": "paint"|"wood"|"uniform", colours, roughness, specular}."""
    mat, nodes, links, out = new_material(name)
    bsdf = nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.inputs["Roughness"].default_value = spec["roughness"]
    bsdf.inputs["Specular"].default_value = spec["specular"]
    kind = spec["kind"]
    if kind == "uniform":
        bsdf.inputs["Base Color"].default_value = tuple(spec["color_a"]) + (1.0,)
    else:
        coords = nodes.new("ShaderNodeTexCoord")
        if kind == "paint":  # blotches of two paints, in object space (no UVs needed)
            pattern = nodes.new("ShaderNodeTexNoise")
            pattern.inputs["Scale"].default_value = spec["scale"]
            pattern.inputs["Detail"].default_value = 3.0
            links.new(coords.outputs["Object"], pattern.inputs["Vector"])
            factor = pattern.outputs["Fac"]
        else:  # wood: rings along x
            pattern = nodes.new("ShaderNodeTexWave")
            pattern.wave_type = "BANDS"
            pattern.inputs["Scale"].default_value = spec["scale"]
            pattern.inputs["Distortion"].default_value = 4.0
            links.new(coords.outputs["Object"], pattern.inputs["Vector"])
            factor = pattern.outputs["Fac"]
        ramp = nodes.new("ShaderNodeValToRGB")
        ramp.color_ramp.elements[0].position = spec.get("ramp", [0.45, 0.55])[0]
        ramp.color_ramp.elements[0].color = tuple(spec["color_a"]) + (1.0,)
        ramp.color_ramp.elements[1].position = spec.get("ramp", [0.45, 0.55])[1]
        ramp.color_ramp.elements[1].color = tuple(spec["color_b"]) + (1.0,)
        links.new(factor, ramp.inputs["Fac"])
        links.new(ramp.outputs["Color"], bsdf.inputs["Base Color"])
    links.new(bsdf.outputs["BSDF"], out.inputs["Surface"])
    return mat


def build_scene(spec):
    clear_scene()
    scene = bpy.context.scene
    objects = {}
    for o in spec["objects"]:
        obj = import_obj(o["mesh"])
        material = o["material"]
        if material["kind"] == "texture":
            mat = textured_diffuse(o["name"], material["texture"])
        else:
            mat = principled(o["name"], material)
        obj.data.materials.clear()
        obj.data.materials.append(mat)
        if o.get("smooth", False):
            obj.data.polygons.foreach_set("use_smooth", [True] * len(obj.data.polygons))
            obj.data.update()
        objects[o["name"]] = (obj, o.get("foreground", True))

    cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    scene.collection.objects.link(cam)
    scene.camera = cam

    world = bpy.data.worlds.new("world")
    world.use_nodes = True
    nodes = world.node_tree.nodes
    background = nodes["Background"]
    env = nodes.new("ShaderNodeTexEnvironment")
    env.interpolation = "Closest"  # relit's maps are piecewise constant
    env.projection = "EQUIRECTANGULAR"
    scene.world = world
    envmaps = {}
    for name, path in spec.get("envmaps", {}).items():
        image = bpy.data.images.load(path)
        image.colorspace_settings.name = "Non-Color"
        envmaps[name] = image

    configure_cycles(scene, spec["max_bounces"], spec["threads"], transparent_max_bounces=8)
    scene.render.use_persistent_data = True  # keep the BVH between jobs
    return scene, cam, world, background, env, envmaps, objects


def set_camera(scene, cam, job):
    w, h = job["width"], job["height"]
    scene.render.resolution_x = w
    scene.render.resolution_y = h
    data = cam.data
    data.type = "PERSP"
    data.sensor_fit = "HORIZONTAL"
    data.sensor_width = 36.0
    data.lens = job["fx"] * data.sensor_width / w
    data.shift_x = (0.5 * w - 0.5 - job["cx"]) / w
    data.shift_y = (job["cy"] + 0.5 - 0.5 * h) / w
    data.clip_start = 1e-3
    data.clip_end = 100.0
    m = job["cam_from_world"]  # row-major 4x4
    cam_from_world = Matrix([m[0:4], m[4:8], m[8:12], m[12:16]])
    flip = Matrix.Diagonal((1.0, -1.0, -1.0, 1.0))
    cam.matrix_world = cam_from_world.inverted() @ flip


def set_lights(scene, world, background, env, envmaps, job):
    for obj in [o for o in bpy.data.objects if o.type == "LIGHT"]:
        data = obj.data
        bpy.data.objects.remove(obj, do_unlink=True)
        bpy.data.lights.remove(data)
    links = world.node_tree.links
    for link in list(background.inputs["Color"].links):
        links.remove(link)
    background.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    background.inputs["Strength"].default_value = 0.0
    for light in job.get("lights", []):
        if light["type"] == "point":
            data = bpy.data.lights.new("point", type="POINT")
            i = light["intensity_w_per_sr"]
            peak = max(i)
            data.energy = 4.0 * math.pi * peak  # W; Cycles: I = P / (4 pi)
            data.color = tuple(v / peak for v in i)
            data.shadow_soft_size = 0.0
            obj = bpy.data.objects.new("point", data)
            obj.location = light["position_world_m"]
        elif light["type"] == "directional":
            data = bpy.data.lights.new("sun", type="SUN")
            e = light["irradiance"]
            peak = max(e)
            data.energy = peak  # W/m^2 on a surface facing the sun
            data.color = tuple(v / peak for v in e)
            data.angle = 0.0
            obj = bpy.data.objects.new("sun", data)
            # A sun shines along its local -Z: point -Z away from the light.
            d = light["direction_to_light_world"]
            obj.rotation_mode = "QUATERNION"
            obj.rotation_quaternion = Vector(d).to_track_quat("Z", "Y")
        else:
            env.image = envmaps[light["envmap"]]
            links.new(env.outputs["Color"], background.inputs["Color"])
            background.inputs["Strength"].default_value = light["scale"]
            continue
        scene.collection.objects.link(obj)


def render_job(scene, objects, job):
    alpha_only = job.get("alpha_only", False)
    for obj, foreground in objects.values():
        obj.visible_camera = foreground or not alpha_only
    scene.render.film_transparent = alpha_only
    scene.render.image_settings.color_mode = "RGBA" if alpha_only else "RGB"
    scene.cycles.samples = job["spp"]
    scene.cycles.seed = job["seed"]
    tmp = job["output"] + ".part.exr"
    scene.render.filepath = tmp
    start = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    os.replace(tmp, job["output"])
    return time.perf_counter() - start


def main():
    args = parse_args()
    with open(args.spec) as f:
        spec = json.load(f)
    jobs = spec["jobs"]
    for job in jobs:  # outputs are relative to the cache folder
        job["output"] = os.path.join(spec["output_root"], job["output"])
    todo = [j for j in jobs if not os.path.exists(j["output"])]
    for index, job in enumerate(jobs):
        if os.path.exists(job["output"]):
            print("RELIT_JOB %d %d -1 %s" % (index, len(jobs), job["output"]), flush=True)
    if not todo:
        return
    scene, cam, world, background, env, envmaps, objects = build_scene(spec)
    for index, job in enumerate(jobs):
        if os.path.exists(job["output"]):
            continue
        os.makedirs(os.path.dirname(job["output"]), exist_ok=True)
        set_camera(scene, cam, job)
        set_lights(scene, world, background, env, envmaps, job)
        seconds = render_job(scene, objects, job)
        print("RELIT_JOB %d %d %.3f %s" % (index, len(jobs), seconds, job["output"]), flush=True)


if __name__ == "__main__":
    main()
