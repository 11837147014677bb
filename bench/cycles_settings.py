"""The Cycles settings under which Blender renders what relit's path tracer
does, shared by bench/cycles_scene.py and bench/cycles_capture.py (each
imports this file from its own folder):

* CPU, no adaptive sampling, no denoising, a fixed seed per render;
* no clamping, no light-sample skipping, no glossy blur, caustics on: an
  unbiased estimate, as relit's;
* bounces: max_bounces for every kind relit has (diffuse, glossy), none for
  transmission and volumes (relit has neither);
* a one-pixel box filter (relit averages samples over the pixel square);
* linear output: the Standard view transform, no look, exposure 0, gamma 1,
  32-bit float OpenEXR with ZIP compression.
"""


def configure_cycles(scene, max_bounces, threads, transparent_max_bounces):
    """Sets the scene's engine, integrator, threads and output as above; the
    caller sets the samples, seed, image size and anything else."""
    render = scene.render
    render.engine = "CYCLES"
    cycles = scene.cycles
    cycles.device = "CPU"
    cycles.use_adaptive_sampling = False
    cycles.use_denoising = False
    cycles.use_animated_seed = False
    cycles.max_bounces = max_bounces
    cycles.diffuse_bounces = max_bounces
    cycles.glossy_bounces = max_bounces
    cycles.transmission_bounces = 0
    cycles.volume_bounces = 0
    cycles.transparent_max_bounces = transparent_max_bounces
    cycles.min_light_bounces = 0
    cycles.blur_glossy = 0.0
    cycles.light_sampling_threshold = 0.0  # no probabilistic skipping of dim light samples
    cycles.sample_clamp_direct = 0.0
    cycles.sample_clamp_indirect = 0.0
    cycles.caustics_reflective = True
    cycles.caustics_refractive = True
    cycles.pixel_filter_type = "BOX"
    cycles.filter_width = 1.0
    render.threads_mode = "FIXED"
    render.threads = threads
    render.resolution_percentage = 100
    render.pixel_aspect_x = render.pixel_aspect_y = 1.0
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    image = render.image_settings
    image.file_format = "OPEN_EXR"
    image.color_depth = "32"
    image.exr_codec = "ZIP"
