"""Renders an iris scene with Blender Cycles' path tracer: the peer in the benchmark (issue 25).

  blender -b --factory-startup -P scripts/cycles_render.py -- scene.json out.exr \
      (--time SECONDS | --spp N) [--threads 2] [--seed 7] [--stats stats.json] [--filter-width W]

scene.json is `export-scene`'s output: the scene as iris loaded it (world-space triangles after every
toWorld, analytic spheres, the RGB values iris derived from the file's spectra, the camera's prepared
basis), so that Cycles renders the same numbers and nothing here re-reads the Mitsuba XML.

Translation (what Cycles gets for each iris object):
  diffuse        Diffuse BSDF (Lambert, roughness 0), colour = reflectance
  dielectric     Glass BSDF, sharp, IOR = intIOR/extIOR, colour = 1 (iris's default specular reflectance
                 and transmittance; anything else is refused)
  conductor      Glossy BSDF, sharp (its weight is its colour: no Fresnel of its own), colour = specular
                 reflectance x the exact unpolarised conductor Fresnel term for iris's complex IOR eta + i k,
                 evaluated per channel by shader math on cos = N . I (the formula of iris's
                 fresnel_conductor; exact for a mirror, where the incident and reflected angles are equal), and
                 black from behind (Mitsuba's conductors are one-sided; Cycles flips N to face the ray)
  area emitter   Emission (strength 1, colour = radiance in W/(m^2 sr)) added to the surface's BSDF, on
                 the front side only (Mitsuba's area lights are one-sided; Cycles' emission is two-sided,
                 so a Backfacing mix switches it off behind)
  sphere         a fine UV-sphere mesh (256 x 128 segments, smooth normals). Not a point-cloud point: Cycles
                 3.4's points are no solid spheres for refraction (the first run's glass spheres refracted
                 wrongly: a focused image of the light on the floor instead of iris's blurred caustic,
                 +1.5 % red over the whole image, regions 0.5-2x; with meshes the channel means agree
                 to 0.05 %)
  camera         the same origin and basis, horizontal field of view 2 atan(tan_half_x)
  film filter    Gaussian: Cycles 3.4's filter_table() multiplies a Gaussian's width W by 3 and tabulates
                 exp(-2 (6v/3W)^2) = exp(-v^2 / (2 (W/4)^2)) over +-1.5 W, so its standard deviation is
                 W/4 pixels: W = 4 sigma (2 px for Mitsuba's sigma 0.5, cut at +-3 px = 6 sigma; iris cuts
                 at 4 sigma and subtracts the Gaussian's value there, which moves weights by < 4e-4).
                 Measured with `python3 -m scripts.bench filter-profile` (a slanted emitter edge): the
                 fitted sigma agrees with iris's to within 2 %; the earlier mapping W = 12 sigma gave
                 Cycles sigma 1.5 px. Box: width 1 (uniform over the pixel, as iris's box of radius 0.5).
                 --filter-width overrides W (for that measurement).
  depth          Mitsuba maxDepth counts path edges from the camera (2 = direct light); Cycles' bounce
                 limits count bounces after the first hit (0 = direct light): bounces = maxDepth - 2, and
                 Cycles' maximum 1024 for unlimited (-1).
Sampling: CPU, --threads threads, no denoising, no adaptive sampling, no clamping, no light-sampling
threshold (its default 0.01 drops dim lights' samples), reflective and refractive caustics on, glossy
filter 0, a fixed seed. Time budget: Cycles' `time_limit` (seconds of sampling) with the sample count at
its maximum, or a fixed --spp.

Prints one line `cycles: {...}` of JSON with the seconds of each phase (Blender start-up until this
script runs, scene construction, render = sync + sampling, write) and the samples Cycles reported; the
same JSON is written to --stats when given.
"""
import json
import math
import os
import re
import sys
import time

import bpy
import numpy as np

T_SCRIPT = time.time()


def fail(msg):
    print("cycles_render: error: " + msg, file=sys.stderr)
    sys.exit(1)


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    a = dict(time=None, spp=None, threads=2, seed=7, stats=None, filter_width=None)
    pos = []
    i = 0
    while i < len(argv):
        k = argv[i]
        if k in ("--time", "--spp", "--threads", "--seed", "--stats", "--filter-width"):
            if i + 1 >= len(argv):
                fail(k + " wants a value")
            v = argv[i + 1]
            try:
                a[k[2:].replace("-", "_")] = (v if k == "--stats" else
                                              float(v) if k in ("--time", "--filter-width") else int(v))
            except ValueError:
                fail("%s wants a number, got %r" % (k, v))
            i += 2
        else:
            pos.append(k)
            i += 1
    if len(pos) != 2:
        fail("usage: -- scene.json out.exr (--time S | --spp N) [--threads T] [--seed S] [--stats F]")
    if (a["time"] is None) == (a["spp"] is None):
        fail("give exactly one of --time and --spp")
    if a["time"] is not None and not a["time"] > 0:
        fail("--time must be > 0")
    if a["filter_width"] is not None and not a["filter_width"] > 0:
        fail("--filter-width must be > 0")
    if a["spp"] is not None and a["spp"] < 1:
        fail("--spp must be >= 1")
    a["scene"], a["output"] = pos
    if not a["output"].endswith(".exr"):
        fail(a["output"] + ": the output must be an .exr")
    return a


class Math:
    """Scalar shader arithmetic on node sockets or constants (Cycles' Math node), for expressions per channel."""

    def __init__(self, nt):
        self.nt = nt

    def op(self, operation, a, b=None):
        n = self.nt.nodes.new("ShaderNodeMath")
        n.operation = operation
        for i, v in enumerate((a, b)):
            if v is None:
                continue
            if isinstance(v, (int, float)):
                n.inputs[i].default_value = float(v)
            else:
                self.nt.links.new(v, n.inputs[i])
        return n.outputs[0]

    def add(self, a, b): return self.op("ADD", a, b)
    def sub(self, a, b): return self.op("SUBTRACT", a, b)
    def mul(self, a, b): return self.op("MULTIPLY", a, b)
    def div(self, a, b): return self.op("DIVIDE", a, b)
    def sqrt(self, a): return self.op("SQRT", a)
    def max(self, a, b): return self.op("MAXIMUM", a, b)


def conductor_fresnel(m, c, eta, k):
    """Unpolarised Fresnel reflectance of a conductor (eta + i k) at cosine c (a socket in [0, 1]), as iris's
    fresnel_conductor: a^2+b^2 = |n^2 - sin^2|, Rs and Rp in real arithmetic; eta <= 0 is a perfect mirror."""
    if not eta > 0:
        return 1.0
    c2 = m.mul(c, c)
    s2 = m.sub(1.0, c2)
    s4 = m.mul(s2, s2)
    t0 = m.sub(eta * eta - k * k, s2)
    a2b2 = m.sqrt(m.add(m.mul(t0, t0), 4.0 * eta * eta * k * k))
    a = m.sqrt(m.max(0.0, m.mul(0.5, m.add(a2b2, t0))))
    t1 = m.add(a2b2, c2)
    t2 = m.mul(m.mul(2.0, a), c)
    # t1 + t2 > 0 unless eta = 1, k = 0 at grazing (no interface); the floor keeps the division finite there.
    rs = m.div(m.sub(t1, t2), m.max(m.add(t1, t2), 1e-30))
    t3 = m.add(m.mul(a2b2, c2), s4)
    t4 = m.mul(t2, s2)
    rp = m.mul(rs, m.div(m.sub(t3, t4), m.max(m.add(t3, t4), 1e-30)))
    return m.op("MINIMUM", m.max(m.mul(0.5, m.add(rs, rp)), 0.0), 1.0)


def material(name, bsdf, radiance):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    out.target = "CYCLES"
    t = bsdf["type"]
    if t == "diffuse":
        s = nt.nodes.new("ShaderNodeBsdfDiffuse")
        s.inputs["Color"].default_value = list(bsdf["diffuse"]) + [1.0]
        s.inputs["Roughness"].default_value = 0.0
    elif t == "dielectric":
        if any(abs(c - 1.0) > 1e-6 for c in bsdf["specular"] + bsdf["transmittance"]):
            fail("%s: a dielectric with specular reflectance or transmittance other than 1 (Cycles' Glass tints "
                 "both alike)" % name)
        s = nt.nodes.new("ShaderNodeBsdfGlass")
        s.distribution = "SHARP"
        s.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
        s.inputs["IOR"].default_value = bsdf["ior"]
    elif t == "conductor":
        s = nt.nodes.new("ShaderNodeBsdfGlossy")
        s.distribution = "SHARP"
        mm = Math(nt)
        geo = nt.nodes.new("ShaderNodeNewGeometry")
        dot = nt.nodes.new("ShaderNodeVectorMath")
        dot.operation = "DOT_PRODUCT"
        nt.links.new(geo.outputs["Normal"], dot.inputs[0])
        nt.links.new(geo.outputs["Incoming"], dot.inputs[1])
        c = mm.op("MINIMUM", mm.max(dot.outputs["Value"], 0.0), 1.0)
        front = mm.sub(1.0, geo.outputs["Backfacing"])
        comb = nt.nodes.new("ShaderNodeCombineColor")
        for ch in range(3):
            f = conductor_fresnel(mm, c, bsdf["eta"][ch], bsdf["k"][ch])
            v = mm.mul(mm.mul(f, bsdf["specular"][ch]), front)
            nt.links.new(v, comb.inputs[ch])
        nt.links.new(comb.outputs[0], s.inputs["Color"])
    else:
        fail("%s: BSDF type %s has no Cycles equivalent set up" % (name, t))
    if bsdf.get("two_sided") and t != "diffuse":
        fail(name + ": a two-sided non-diffuse BSDF")
    shader = s
    if radiance is not None:
        e = nt.nodes.new("ShaderNodeEmission")
        e.inputs["Color"].default_value = list(radiance) + [1.0]
        e.inputs["Strength"].default_value = 1.0
        add = nt.nodes.new("ShaderNodeAddShader")
        nt.links.new(s.outputs[0], add.inputs[0])
        nt.links.new(e.outputs[0], add.inputs[1])
        # Front side only: Backfacing = 1 selects the BSDF alone.
        geo = nt.nodes.new("ShaderNodeNewGeometry")
        mix = nt.nodes.new("ShaderNodeMixShader")
        nt.links.new(geo.outputs["Backfacing"], mix.inputs["Fac"])
        nt.links.new(add.outputs[0], mix.inputs[1])
        nt.links.new(s.outputs[0], mix.inputs[2])
        shader = mix
    nt.links.new(shader.outputs[0], out.inputs["Surface"])
    return m


def sphere_mesh(name, center, radius, mat, u=256, v=128):
    """A UV sphere of U x V segments (triangles, smooth-shaded, built with NumPy: bmesh's create_uvsphere
    took 4 s). Its facets deviate from the true sphere by at most R (1 - cos(pi/U)) = 7.5e-5 R radially."""
    lat = np.pi * np.arange(1, v) / v                      # ring polar angles, poles excluded
    lon = 2 * np.pi * np.arange(u) / u
    st, ct = np.sin(lat)[:, None], np.cos(lat)[:, None]
    ring = np.stack([st * np.cos(lon), st * np.sin(lon), np.broadcast_to(ct, (v - 1, u))], axis=2).reshape(-1, 3)
    co = np.concatenate([[[0, 0, 1]], ring, [[0, 0, -1]]]) * radius
    top, bottom = 0, len(co) - 1
    r = lambda i, j: 1 + i * u + (j % u)                   # vertex of ring i, meridian j
    tris = []
    j = np.arange(u)
    tris.append(np.stack([np.full(u, top), r(0, j), r(0, j + 1)], axis=1))
    for i in range(v - 2):
        a, b, c, d = r(i, j), r(i, j + 1), r(i + 1, j), r(i + 1, j + 1)
        tris.append(np.stack([a, c, d], axis=1))
        tris.append(np.stack([a, d, b], axis=1))
    tris.append(np.stack([r(v - 2, j), np.full(u, bottom), r(v - 2, j + 1)], axis=1))
    tris = np.concatenate(tris).astype(np.int32)
    me = bpy.data.meshes.new(name)
    me.vertices.add(len(co))
    me.vertices.foreach_set("co", co.astype(np.float32).ravel())
    me.loops.add(tris.size)
    me.loops.foreach_set("vertex_index", tris.ravel())
    me.polygons.add(len(tris))
    me.polygons.foreach_set("loop_start", np.arange(0, tris.size, 3, dtype=np.int32))
    me.polygons.foreach_set("loop_total", np.full(len(tris), 3, dtype=np.int32))
    me.polygons.foreach_set("use_smooth", np.ones(len(tris), dtype=bool))
    me.update(calc_edges=True)
    me.materials.append(mat)
    ob = bpy.data.objects.new(name, me)
    ob.location = center
    return ob


def main():
    a = parse_args()
    try:
        with open(a["scene"]) as f:
            sc = json.load(f)
    except (OSError, ValueError) as e:
        fail("%s: %s" % (a["scene"], e))
    t_build = time.time()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    col = scene.collection

    radiance = [l["radiance"] for l in sc["lights"]]
    mats = {}

    def mat_for(bsdf, light):
        key = (bsdf, light)
        if key not in mats:
            mats[key] = material("bsdf%d_light%d" % key, sc["bsdfs"][bsdf], radiance[light] if light >= 0 else None)
        return mats[key]

    for i, m in enumerate(sc["meshes"]):
        me = bpy.data.meshes.new("mesh%d" % i)
        idx = m["indices"]
        faces = [(idx[k], idx[k + 1], idx[k + 2]) for k in range(0, len(idx), 3)]
        if m["flip_normals"]:
            faces = [(f[0], f[2], f[1]) for f in faces]
        me.from_pydata([tuple(p) for p in m["positions"]], [], faces)
        if m["normals"]:
            if m["flip_normals"]:
                fail("mesh %d: flipped normals with shading normals" % i)
            me.use_auto_smooth = True
            me.polygons.foreach_set("use_smooth", [True] * len(faces))
            me.normals_split_custom_set_from_vertices([tuple(n) for n in m["normals"]])
        me.materials.append(mat_for(m["bsdf"], m["light"]))
        col.objects.link(bpy.data.objects.new("mesh%d" % i, me))
    for i, s in enumerate(sc["spheres"]):
        col.objects.link(sphere_mesh("sphere%d" % i, s["center"], s["radius"], mat_for(s["bsdf"], s["light"])))

    # Camera: Blender's camera looks along its local -Z with +Y up and +X right.
    c = sc["camera"]
    from mathutils import Matrix, Vector
    r, u, fw = Vector(c["right"]), Vector(c["up"]), Vector(c["forward"])
    rot = Matrix((r, u, -fw)).transposed()
    if rot.determinant() < 0:
        fail("the camera's right, up, -forward basis is left-handed (det %.3f)" % rot.determinant())
    cam = bpy.data.cameras.new("camera")
    cam.type = "PERSP"
    cam.sensor_fit = "HORIZONTAL"
    cam.lens_unit = "FOV"
    cam.angle = 2.0 * math.atan(c["tan_half_x"])
    cam.clip_start = c["near"]
    cam.clip_end = c["far"]
    cob = bpy.data.objects.new("camera", cam)
    cob.matrix_world = Matrix.Translation(Vector(c["origin"])) @ rot.to_4x4()
    col.objects.link(cob)
    scene.camera = cob
    want_tan_y = c["tan_half_x"] * sc["height"] / sc["width"]
    if abs(want_tan_y - c["tan_half_y"]) > 1e-5 * c["tan_half_y"]:
        fail("non-square pixels (tan_half_y %g, expected %g)" % (c["tan_half_y"], want_tan_y))

    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.world = world

    rd = scene.render
    rd.engine = "CYCLES"
    rd.resolution_x, rd.resolution_y, rd.resolution_percentage = sc["width"], sc["height"], 100
    rd.threads_mode = "FIXED"
    rd.threads = a["threads"]
    rd.use_persistent_data = False
    cy = scene.cycles
    cy.device = "CPU"
    cy.feature_set = "SUPPORTED"
    cy.use_denoising = False
    cy.use_preview_denoising = False
    cy.use_adaptive_sampling = False
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = 0.0
    cy.light_sampling_threshold = 0.0
    cy.caustics_reflective = True
    cy.caustics_refractive = True
    cy.blur_glossy = 0.0
    cy.seed = a["seed"]
    cy.use_animated_seed = False
    bounces = 1024 if sc["max_depth"] < 0 else max(0, sc["max_depth"] - 2)
    for k in ("max_bounces", "diffuse_bounces", "glossy_bounces", "transmission_bounces", "volume_bounces",
              "transparent_max_bounces"):
        setattr(cy, k, bounces)
    f = sc["filter"]
    if f["type"] == "gaussian":
        cy.pixel_filter_type = "GAUSSIAN"
        cy.filter_width = 4.0 * f["stddev"]
    else:
        cy.pixel_filter_type = "BOX"
        cy.filter_width = 1.0
    if a["filter_width"] is not None:
        cy.filter_width = a["filter_width"]
    if a["time"] is not None:
        cy.samples = 16777216  # Cycles' maximum: the time limit ends the render
        cy.time_limit = a["time"]
    else:
        cy.samples = a["spp"]
        cy.time_limit = 0.0
    cy.use_auto_tile = False
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    scene.display_settings.display_device = "sRGB"
    im = rd.image_settings
    im.file_format = "OPEN_EXR"
    im.color_mode = "RGB"
    im.color_depth = "32"
    im.exr_codec = "ZIP"
    rd.use_file_extension = False
    rd.filepath = a["output"]

    t_render = time.time()
    bpy.ops.render.render(write_still=False)
    t_write = time.time()
    img = bpy.data.images["Render Result"]
    tmp = a["output"] + ".tmp.exr"
    img.save_render(tmp, scene=scene)
    os.replace(tmp, a["output"])
    t_end = time.time()
    # Cycles records its own sync and sampling times and the samples taken in the EXR's metadata
    # (cycles.ViewLayer.synchronization_time / render_time / samples).
    import _cycles
    out = dict(blender=bpy.app.version_string, path_guiding_built=bool(_cycles.with_path_guiding),
               embree=bool(_cycles.with_embree), startup=T_SCRIPT - float(os.environ.get("CYCLES_T0", T_SCRIPT)),
               build=t_render - t_build, render=t_write - t_render, write=t_end - t_write,
               bounces=bounces, filter=cy.pixel_filter_type, filter_width=cy.filter_width)
    print("cycles: " + json.dumps(out))
    if a["stats"]:
        with open(a["stats"], "w") as f:
            json.dump(out, f)


main()
