"""Loads a vdbscatter lit VDB into Blender and renders it with Cycles (docs/handoff.md).

    blender -b -P scripts/blender/load_lit_vdb.py -- LIT.vdb --mode full|ms --out OUT.exr
        [--camera PX,PY,PZ:TX,TY,TZ:FOV] [--size WxH] [--spp N] [--seed S]
        [--background scene|black] [--step-rate R] [--threads N] [--save-blend FILE.blend]

Modes:
  full  the whole lighting from the lit VDB's grids: emission sigma_s * S(x, wo) with
        S = sum over the stored lights (vdbscatter_lights: light_depth_*, sky_depth_*) of
        c_e F_e exp(-tau_e) f_hg(t_e . wo, g) + Sms(x, wo), and absorption sigma_t. No lamps,
        and no scattering closures, so nothing lights the volume but its emission. Needs a
        format 2 lit VDB (vdbscatter_format >= 2).
  ms    emission sigma_s * Sms(x, wo) only (the multiple scattering), plus sun and point
        lamps and the world recreated from the baked scene, a Volume Scatter with sigma_s
        and HG g and a Volume Absorption, with Cycles' volume bounces = 1: Cycles computes
        the single scattering itself, the lit VDB adds the higher orders.

The file's metadata (vdbscatter_density_scale, vdbscatter_albedo, vdbscatter_g,
vdbscatter_scene, vdbscatter_lights, vdbscatter_format) is read by the small pure-Python
parser below (read_vdb_metadata): Blender's Python API exposes a volume's grids but not
their metadata, and the file-level metadata block sits at the start of every .vdb file,
uncompressed. The parser also runs without Blender:

    python3 scripts/blender/load_lit_vdb.py --print-meta LIT.vdb

Coordinates are the VDB's world coordinates unchanged (vdbscatter's +Y up is not rotated to
Blender's +Z up): the camera is built with +Y as up, as vdbscatter's is.
"""
import argparse
import json
import math
import os
import struct
import sys

FOUR_PI = 4.0 * math.pi

# Blender's point lamp: radiant intensity I (W/sr) = power (W) / (4 pi) in Cycles, so a
# vdbscatter point light of intensity I becomes a lamp of I * 4 pi watts (measured: see
# docs/handoff.md, "Lamps").
POINT_WATTS_PER_INTENSITY = 4.0 * math.pi


# --------------------------------------------------------------------------- metadata


def _read_string(blob, pos):
    (n,) = struct.unpack_from("<I", blob, pos)
    return blob[pos + 4:pos + 4 + n], pos + 4 + n


def read_vdb_metadata(path):
    """{name: value} of an OpenVDB file's file-level metadata. Strings are decoded; int32,
    int64, float, double and bool are unpacked; other types are returned as raw bytes."""
    with open(path, "rb") as f:
        blob = f.read(1 << 20)
    if len(blob) < 8 or struct.unpack_from("<q", blob, 0)[0] != 0x56444220:
        raise ValueError(f"{path}: not an OpenVDB file")
    (version,) = struct.unpack_from("<I", blob, 8)
    pos = 8 + 4 + 8 + 1  # file version, library major and minor, hasGridOffsets
    if version >= 220:   # the file's UUID as 36 ASCII characters
        pos += 36
    else:
        pos += 16
    (count,) = struct.unpack_from("<i", blob, pos)
    pos += 4
    meta = {}
    for _ in range(count):
        if pos > len(blob) - 12:  # a metadata block larger than the first MiB
            with open(path, "rb") as f:
                blob = f.read()
        name, pos = _read_string(blob, pos)
        kind, pos = _read_string(blob, pos)
        value, pos = _read_string(blob, pos)
        kind = kind.decode()
        if kind == "string":
            value = value.decode("utf-8", "replace")
        elif kind in ("int32", "int64", "float", "double", "bool") and value:
            code = {"int32": "<i", "int64": "<q", "float": "<f", "double": "<d", "bool": "<?"}[kind]
            value = struct.unpack(code, value)[0]
        meta[name.decode()] = value
    return meta


def _floats(text, n=3):
    vals = [float(v) for v in str(text).split(",")]
    return vals * n if len(vals) == 1 else vals


def _rgb(value):
    if isinstance(value, (int, float)):
        return [float(value)] * 3
    return [float(v) for v in value]


class LitInfo:
    """What the script needs from a lit VDB's metadata."""

    def __init__(self, meta):
        self.meta = meta
        if "vdbscatter_density_scale" not in meta:
            raise ValueError("no vdbscatter_density_scale metadata: not a lit VDB written by vdbscatter bake")
        self.density_scale = float(meta["vdbscatter_density_scale"])
        self.albedo = _floats(meta.get("vdbscatter_albedo", "0.5"))
        self.g = float(meta.get("vdbscatter_g", "0"))
        self.scene = json.loads(meta.get("vdbscatter_scene", "{}") or "{}")
        self.format = int(meta.get("vdbscatter_format", "1") or 1)
        self.lights = json.loads(meta["vdbscatter_lights"]) if meta.get("vdbscatter_lights") else []


# --------------------------------------------------------------------------- arguments


def parse_args(argv):
    p = argparse.ArgumentParser(prog="load_lit_vdb.py", description=__doc__.split("\n\n")[0])
    p.add_argument("vdb")
    p.add_argument("--mode", choices=("full", "ms", "single"), default="full",
                   help="single: ms without the emission (Cycles' single scattering alone; a check)")
    p.add_argument("--out", help="output OpenEXR (linear float RGB)")
    p.add_argument("--camera", help="PX,PY,PZ:TX,TY,TZ:FOV (default: the baked scene's camera)")
    p.add_argument("--size", help="WxH (default: the baked scene camera's, else 640x480)")
    p.add_argument("--spp", type=int, default=64)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--background", choices=("scene", "black"), default="scene",
                   help="full mode: what camera rays see behind the volume (default: the "
                        "scene's sky, as vdbscatter render shows it; it lights nothing)")
    p.add_argument("--env-file", help="the scene's env map (default: its stored path, from the "
                   "current folder or beside the lit VDB)")
    p.add_argument("--step-rate", type=float, default=1.0,
                   help="Cycles' volume step rate (ray-marching step in voxels; default 1)")
    p.add_argument("--volume-bounces", type=int, default=0,
                   help="ms and single modes: Cycles' volume bounces (default 0: single scattering)")
    p.add_argument("--no-half-voxel-shift", dest="half_voxel_shift", action="store_false",
                   help="keep the object at the file's transform (Cycles then shows the volume "
                        "half a voxel off; for checking the shift)")
    p.add_argument("--threads", type=int, default=0, help="render threads (0: all)")
    p.add_argument("--save-blend", help="also save the built scene as a .blend file")
    p.add_argument("--print-meta", action="store_true", help="print the metadata and exit")
    return p.parse_args(argv)


def camera_setup(args, info):
    cam = info.scene.get("camera") or {}
    if args.camera:
        pos, tgt, fov = args.camera.split(":")
        pos, tgt, fov = _floats(pos), _floats(tgt), float(fov)
    elif cam:
        pos, tgt = _rgb(cam["position"]), _rgb(cam.get("target", [0, 0, 0]))
        fov = float(cam.get("fov_deg", 40.0))
    else:
        raise SystemExit("load_lit_vdb: the lit VDB's scene has no camera: give --camera")
    if args.size:
        w, h = (int(v) for v in args.size.lower().split("x"))
    elif cam.get("width"):
        w, h = int(cam["width"]), int(cam.get("height", cam["width"] * 3 // 4))
    else:
        w, h = 640, 480
    return pos, tgt, fov, w, h


# --------------------------------------------------------------------------- node building


class Nodes:
    """A node tree with arithmetic helpers; Python floats are folded before nodes are made."""

    def __init__(self, tree):
        self.tree = tree
        self.nodes = tree.nodes
        self.links = tree.links
        self.count = 0

    def new(self, kind, **props):
        node = self.nodes.new(kind)
        node.location = (200 * (self.count // 30), -120 * (self.count % 30))
        self.count += 1
        for k, v in props.items():
            setattr(node, k, v)
        return node

    def feed(self, socket, value):
        if isinstance(value, (int, float)):
            socket.default_value = float(value)
        elif isinstance(value, (tuple, list)):
            socket.default_value = tuple(float(v) for v in value)[:len(socket.default_value)]
        else:
            self.links.new(value, socket)

    def math(self, op, a, b=0.0):
        if isinstance(a, (int, float)) and isinstance(b, (int, float)):
            return {"ADD": a + b, "SUBTRACT": a - b, "MULTIPLY": a * b,
                    "DIVIDE": a / b if b else 0.0, "POWER": a ** b,
                    "MINIMUM": min(a, b), "MAXIMUM": max(a, b),
                    "EXPONENT": math.exp(a)}[op]
        n = self.new("ShaderNodeMath", operation=op)
        self.feed(n.inputs[0], a)
        self.feed(n.inputs[1], b)
        return n.outputs[0]

    def vmath(self, op, a, b=None, scale=None):
        n = self.new("ShaderNodeVectorMath", operation=op)
        self.feed(n.inputs[0], a)
        if b is not None:
            self.feed(n.inputs[1], b)
        if scale is not None:
            self.feed(n.inputs["Scale"], scale)
        out = "Value" if op in ("DOT_PRODUCT", "LENGTH", "DISTANCE") else "Vector"
        return n.outputs[out]

    def attr(self, name, output):
        return self.new("ShaderNodeAttribute", attribute_type="GEOMETRY",
                        attribute_name=name).outputs[output]

    def separate(self, vec):
        n = self.new("ShaderNodeSeparateXYZ")
        self.feed(n.inputs[0], vec)
        return n.outputs[0], n.outputs[1], n.outputs[2]

    def combine(self, x, y, z):
        n = self.new("ShaderNodeCombineXYZ")
        for i, v in enumerate((x, y, z)):
            self.feed(n.inputs[i], v)
        return n.outputs[0]

    def hg(self, mu, g):
        """f_hg(mu, g) = (1 - g^2) / (4 pi (1 + g^2 - 2 g mu)^1.5)."""
        g2 = self.math("MULTIPLY", g, g)
        t = self.math("ADD", self.math("ADD", g2, 1.0),
                      self.math("MULTIPLY", mu, self.math("MULTIPLY", g, -2.0)))
        den = self.math("MULTIPLY", self.math("POWER", t, 1.5), FOUR_PI)
        return self.math("DIVIDE", self.math("SUBTRACT", 1.0, g2), den)


def sms_nodes(nb, wo):
    """Sms(x, wo) per channel from ms and ms_l1x/y/z (vs_ms_channel): n = L1 / |L1|,
    b = clamp(|L1| / (3 ms), 0, 0.999), Sms = 4 pi ms f_hg(wo . n, b); Cycles' divide and
    normalize return 0 for a zero denominator, so ms = 0 or L1 = 0 give Sms = ms."""
    ms = nb.separate(nb.attr("ms", "Vector"))
    lx = nb.separate(nb.attr("ms_l1x", "Vector"))
    ly = nb.separate(nb.attr("ms_l1y", "Vector"))
    lz = nb.separate(nb.attr("ms_l1z", "Vector"))
    out = []
    for c in range(3):
        l1 = nb.combine(lx[c], ly[c], lz[c])
        length = nb.vmath("LENGTH", l1)
        b = nb.math("DIVIDE", length, nb.math("MULTIPLY", ms[c], 3.0))
        b = nb.math("MAXIMUM", nb.math("MINIMUM", b, 0.999), 0.0)
        mu = nb.vmath("DOT_PRODUCT", nb.vmath("NORMALIZE", l1), wo)
        out.append(nb.math("MULTIPLY", nb.math("MULTIPLY", ms[c], FOUR_PI), nb.hg(mu, b)))
    return nb.combine(*out)


def direct_nodes(nb, info, wo, position):
    """sum over the stored lights of c_e F_e exp(-tau_e) f_hg(t_e . wo, g) (format 2)."""
    total = None
    for e in info.lights:
        tau = nb.attr(e["grid"], "Fac")
        trans = nb.math("EXPONENT", nb.math("MULTIPLY", tau, -1.0))
        if e["type"] in ("sun", "sky"):
            colour = _rgb(e["radiance"])
            mu = nb.vmath("DOT_PRODUCT", _rgb(e["travel"]), wo)
            weight = trans
        elif e["type"] == "point":
            raise SystemExit("load_lit_vdb: a point light's depth grid is radial (octahedral texels x "
                             "shells), which Cycles' shader nodes cannot sample: use --mode ms")
        else:
            raise SystemExit(f"load_lit_vdb: unknown light entry type {e['type']!r}")
        scalar = nb.math("MULTIPLY", weight, nb.hg(mu, info.g))
        term = nb.vmath("SCALE", colour, scale=scalar)
        total = term if total is None else nb.vmath("ADD", total, term)
    return total


def build_material(bpy, info, mode):
    mat = bpy.data.materials.new("lit_vdb_" + mode)
    mat.use_nodes = True
    mat.cycles.volume_interpolation = "LINEAR"
    mat.cycles.homogeneous_volume = False
    nt = mat.node_tree
    nt.nodes.clear()
    nb = Nodes(nt)
    geo = nb.new("ShaderNodeNewGeometry")
    wo, position = geo.outputs["Incoming"], geo.outputs["Position"]
    sigma_t = nb.math("MULTIPLY", nb.attr("density", "Fac"), info.density_scale)

    s = sms_nodes(nb, wo) if mode != "single" else (0.0, 0.0, 0.0)
    if mode == "full":
        if info.format < 2 or not info.lights:
            raise SystemExit("load_lit_vdb: --mode full needs a format 2 lit VDB (light_depth_* "
                             "and sky_depth_* grids, metadata vdbscatter_lights); this file is "
                             f"format {info.format}: re-bake it, or use --mode ms")
        s = nb.vmath("ADD", direct_nodes(nb, info, wo, position), s)
    sigma_e = sigma_t
    if mode != "full":
        # The camera ray alone gathers the emission: Sms holds every order already, and a
        # ray scattered toward a lamp would otherwise gather it once more (about 2x here).
        sigma_e = nb.math("MULTIPLY", sigma_t, nb.new("ShaderNodeLightPath").outputs["Is Camera Ray"])
    emission_colour = nb.vmath("SCALE", nb.vmath("MULTIPLY", s, info.albedo), scale=sigma_e)
    emission = nb.new("ShaderNodeEmission")
    nb.feed(emission.inputs["Color"], emission_colour)
    emission.inputs["Strength"].default_value = 1.0

    # Volume Absorption: sigma_a = (1 - colour) * density.
    absorb = nb.new("ShaderNodeVolumeAbsorption")
    nb.feed(absorb.inputs["Density"], sigma_t)
    if mode == "full":
        absorb.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)  # sigma_a = sigma_t
        volume = nb.new("ShaderNodeAddShader")
        nb.links.new(emission.outputs[0], volume.inputs[0])
        nb.links.new(absorb.outputs[0], volume.inputs[1])
    else:
        # Volume Scatter: sigma_s = colour * density; absorption (1 - albedo) * density.
        absorb.inputs["Color"].default_value = tuple(info.albedo) + (1.0,)
        scatter = nb.new("ShaderNodeVolumeScatter")
        scatter.inputs["Color"].default_value = tuple(info.albedo) + (1.0,)
        scatter.inputs["Anisotropy"].default_value = info.g
        nb.feed(scatter.inputs["Density"], sigma_t)
        extinct = nb.new("ShaderNodeAddShader")
        nb.links.new(scatter.outputs[0], extinct.inputs[0])
        nb.links.new(absorb.outputs[0], extinct.inputs[1])
        volume = nb.new("ShaderNodeAddShader")
        nb.links.new(extinct.outputs[0], volume.inputs[0])
        nb.links.new(emission.outputs[0], volume.inputs[1])
    out = nb.new("ShaderNodeOutputMaterial", target="CYCLES")
    nb.links.new(volume.outputs[0], out.inputs["Volume"])
    return mat


# --------------------------------------------------------------------------- scene


def env_light(info):
    for light in info.scene.get("lights", []):
        if light.get("type") == "env":
            return light
    return None


def find_env_file(name, vdb_path):
    """The scene stores the env map's path as the bake was given it: try it from the current
    folder, then beside the lit VDB (the path, then its file name)."""
    here = os.path.dirname(os.path.abspath(vdb_path))
    for path in (name, os.path.join(here, name), os.path.join(here, os.path.basename(name))):
        if os.path.exists(path):
            return os.path.abspath(path)
    raise SystemExit(f"load_lit_vdb: cannot find the env map {name!r} of the baked scene: give --env-file")


def build_world(bpy, info, vdb_path, lights_volume, env_file=None):
    """The scene's sky as the world: a constant colour, or a lat-long map looked up in
    vdbscatter's convention (+Y up; direction (sin lon cos lat, sin lat, cos lon cos lat);
    pixel x at longitude -2 pi (x / (W - 1) - 1/2), row y at latitude -pi (y / (H - 1) - 1/2),
    row 0 on top). lights_volume False: only camera rays see it."""
    world = bpy.data.worlds.new("lit_vdb_world")
    bpy.context.scene.world = world
    world.use_nodes = True
    nt = world.node_tree
    nt.nodes.clear()
    nb = Nodes(nt)
    bg = nb.new("ShaderNodeBackground")
    out = nb.new("ShaderNodeOutputWorld")
    nb.links.new(bg.outputs[0], out.inputs[0])
    env = env_light(info)
    if env is None:
        bg.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    elif "file" in env and env["file"]:
        path = env_file or find_env_file(env["file"], vdb_path)
        img = bpy.data.images.load(path)
        img.colorspace_settings.name = "Linear" if "Linear" in [
            i.name for i in img.colorspace_settings.bl_rna.properties["name"].enum_items] else "Non-Color"
        w, h = img.size
        tex = nb.new("ShaderNodeTexImage", image=img, interpolation="Linear", extension="EXTEND")
        coord = nb.new("ShaderNodeTexCoord")
        dx, dy, dz = nb.separate(nb.vmath("NORMALIZE", coord.outputs["Generated"]))
        lon = nb.math("ARCTAN2", dx, dz)
        lat = nb.math("ARCSINE", dy)
        # texel x of longitude lon, then the texture coordinate of that texel's centre
        x = nb.math("MULTIPLY", nb.math("SUBTRACT", 0.5, nb.math("DIVIDE", lon, 2 * math.pi)), w - 1)
        y = nb.math("MULTIPLY", nb.math("SUBTRACT", 0.5, nb.math("DIVIDE", lat, math.pi)), h - 1)
        u = nb.math("DIVIDE", nb.math("ADD", x, 0.5), float(w))
        v = nb.math("SUBTRACT", 1.0, nb.math("DIVIDE", nb.math("ADD", y, 0.5), float(h)))
        nb.feed(tex.inputs["Vector"], nb.combine(u, v, 0.0))
        nb.links.new(tex.outputs["Color"], bg.inputs["Color"])
        bg.inputs["Strength"].default_value = float(env.get("scale", 1.0))
    else:
        bg.inputs["Color"].default_value = tuple(_rgb(env.get("color", [0, 0, 0]))) + (1.0,)
    vis = world.cycles_visibility
    for ray in ("diffuse", "glossy", "transmission", "scatter"):
        setattr(vis, ray, lights_volume)
    vis.camera = True
    return world


def add_lamps(bpy, info):
    from mathutils import Vector
    coll = bpy.context.scene.collection
    for i, light in enumerate(info.scene.get("lights", [])):
        kind = light.get("type")
        if kind == "sun":
            rgb = _rgb(light.get("irradiance", 1.0))
            data = bpy.data.lights.new(f"sun_{i}", type="SUN")
            data.angle = 0.0
            obj = bpy.data.objects.new(f"sun_{i}", data)
            # a sun lamp shines along its local -Z; its strength is irradiance in W/m^2
            obj.rotation_mode = "QUATERNION"
            obj.rotation_quaternion = Vector(_rgb(light["direction"])).normalized().to_track_quat("-Z", "Y")
        elif kind == "point":
            rgb = [v * POINT_WATTS_PER_INTENSITY for v in _rgb(light.get("intensity", 1.0))]
            data = bpy.data.lights.new(f"point_{i}", type="POINT")
            data.shadow_soft_size = 0.0
            obj = bpy.data.objects.new(f"point_{i}", data)
            obj.location = _rgb(light["position"])
        else:
            continue
        peak = max(rgb)
        data.energy = peak
        data.color = [v / peak for v in rgb] if peak > 0 else [0.0, 0.0, 0.0]
        data.cycles.cast_shadow = True
        coll.objects.link(obj)


def add_camera(bpy, pos, tgt, fov):
    from mathutils import Matrix, Vector
    f = (Vector(tgt) - Vector(pos)).normalized()
    up = Vector((0.0, 1.0, 0.0))
    if abs(f.dot(up)) > 0.999:
        up = Vector((0.0, 0.0, -1.0))
    right = f.cross(up).normalized()
    true_up = right.cross(f)
    data = bpy.data.cameras.new("camera")
    data.type = "PERSP"
    data.sensor_fit = "VERTICAL"
    data.angle_y = math.radians(fov)
    data.clip_start = 1e-4
    data.clip_end = 1e6
    obj = bpy.data.objects.new("camera", data)
    obj.matrix_world = Matrix((
        (right.x, true_up.x, -f.x, pos[0]),
        (right.y, true_up.y, -f.y, pos[1]),
        (right.z, true_up.z, -f.z, pos[2]),
        (0.0, 0.0, 0.0, 1.0)))
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.scene.camera = obj


def render_settings(bpy, args, mode, w, h):
    sc = bpy.context.scene
    sc.render.engine = "CYCLES"
    cy = sc.cycles
    cy.device = "CPU"
    cy.samples = args.spp
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    cy.seed = args.seed
    cy.use_animated_seed = False
    # Light paths: only volume events. volume_bounces = 1: the camera ray may scatter once
    # and the scattered ray then ends at the next lamp or sky it meets (single scattering,
    # measured in docs/handoff.md); the emission-absorption full mode scatters nothing.
    scatters = mode in ("ms", "single")
    cy.max_bounces = args.volume_bounces if scatters else 0
    cy.diffuse_bounces = 0
    cy.glossy_bounces = 0
    cy.transmission_bounces = 0
    cy.volume_bounces = args.volume_bounces if scatters else 0
    cy.transparent_max_bounces = 64
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = 0.0
    cy.volume_step_rate = args.step_rate
    cy.volume_preview_step_rate = args.step_rate
    cy.volume_max_steps = 4096
    cy.pixel_filter_type = "BOX"
    cy.filter_width = 0.01  # rays through pixel centres, as vdbscatter render
    cy.film_exposure = 1.0
    sc.render.film_transparent = False
    sc.render.resolution_x, sc.render.resolution_y = w, h
    sc.render.resolution_percentage = 100
    sc.render.use_compositing = False
    sc.render.use_sequencer = False
    if args.threads > 0:
        sc.render.threads_mode = "FIXED"
        sc.render.threads = args.threads
    sc.view_settings.view_transform = "Standard"
    sc.view_settings.look = "None"
    sc.view_settings.exposure = 0.0
    sc.view_settings.gamma = 1.0
    img = sc.render.image_settings
    img.file_format = "OPEN_EXR"
    img.color_mode = "RGB"
    img.color_depth = "32"
    img.exr_codec = "ZIP"
    sc.render.use_file_extension = False


def build_scene(bpy, args, info):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    volume = bpy.data.volumes.new("lit_vdb")
    volume.filepath = os.path.abspath(args.vdb)
    if not volume.grids.load():
        raise SystemExit(f"load_lit_vdb: Blender cannot read {args.vdb}: {volume.grids.error_message}")
    names = {g.name for g in volume.grids}
    need = {"density", "ms", "ms_l1x", "ms_l1y", "ms_l1z"}
    if args.mode == "full":
        need |= {e["grid"] for e in info.lights}
    missing = sorted(need - names)
    if missing:
        raise SystemExit(f"load_lit_vdb: {args.vdb} lacks the grids {', '.join(missing)}")
    volume.render.precision = "FULL"   # no half-float lookups
    volume.render.clipping = 0.0        # keep every active voxel
    volume.render.space = "OBJECT"
    volume.render.step_size = 0.0       # automatic: one voxel times the step rate
    obj = bpy.data.objects.new("lit_vdb", volume)
    # Cycles (3.4) samples voxel (i, j, k) at index (i + 1/2, j + 1/2, k + 1/2) of the grid's
    # transform, OpenVDB (and vdbscatter) at (i, j, k): move the object back by half a voxel
    # (measured: docs/handoff.md). Shading positions stay world positions.
    if args.half_voxel_shift:
        from mathutils import Vector
        m = volume.grids["density"].matrix_object
        obj.location = -((m @ Vector((0.5, 0.5, 0.5))) - (m @ Vector((0.0, 0.0, 0.0))))
    bpy.context.scene.collection.objects.link(obj)
    volume.materials.append(build_material(bpy, info, args.mode))
    if args.mode in ("ms", "single"):
        add_lamps(bpy, info)
        build_world(bpy, info, args.vdb, lights_volume=True, env_file=args.env_file)
    else:
        world = build_world(bpy, info, args.vdb, lights_volume=False, env_file=args.env_file)
        if args.background == "black":
            world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    pos, tgt, fov, w, h = camera_setup(args, info)
    add_camera(bpy, pos, tgt, fov)
    render_settings(bpy, args, args.mode, w, h)


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    args = parse_args(argv)
    info = LitInfo(read_vdb_metadata(args.vdb))
    if args.print_meta:
        print(json.dumps({k: v for k, v in info.meta.items() if isinstance(v, (str, int, float))}, indent=2))
        return
    if not args.out:
        raise SystemExit("load_lit_vdb: give --out OUT.exr")
    import bpy
    build_scene(bpy, args, info)
    if args.save_blend:
        bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(args.save_blend))
    bpy.context.scene.render.filepath = os.path.abspath(args.out)
    bpy.ops.render.render(write_still=True)
    print(f"load_lit_vdb: wrote {args.out} ({args.mode}, {args.spp} spp, seed {args.seed})")


if __name__ == "__main__":
    try:
        main()
    except SystemExit as e:
        if e.code not in (None, 0):
            print(e.code if isinstance(e.code, str) else f"exit {e.code}", file=sys.stderr)
            # blender -b -P keeps running after an exception in the script: leave with status
            os._exit(2 if isinstance(e.code, str) else int(e.code))
        raise
    except Exception:
        import traceback
        traceback.print_exc()
        os._exit(1)
