#!/usr/bin/env python3
"""Render isir's built-in scenes with isir and with Mitsuba 3 (llvm_ad_rgb), the same image,
and compare the whole-process wall times and the images.

    python3 tools/mitsuba-compare/compare.py                      # every built-in scene, 600x400, 64 spp
    python3 tools/mitsuba-compare/compare.py --scenes 'tp4-*' --runs 5 --markdown
    python3 tools/mitsuba-compare/compare.py --path-lambert       # TP6 scenes, path tracers, Lambert
    python3 tools/mitsuba-compare/compare.py --self-test          # no Mitsuba needed

Each engine runs as its own process per render (isir: `isir render`; Mitsuba: this script with
`--mitsuba-worker`), so the times are those a user sees, imports, JIT, scene loading and BVH
building included. See README.md beside this file for the scene translation.
"""

from __future__ import annotations

import argparse
import fnmatch
import gzip
import json
import math
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

try:
    import tomllib
except ModuleNotFoundError:  # Python < 3.11
    tomllib = None

HERE = Path(__file__).resolve().parent
REPO = HERE.parent.parent
SCENES_DIR = REPO / "scenes"
MODELS_DIR = REPO / "crates" / "isir" / "data"
BUILTIN_MODELS = {
    "uvsphere": MODELS_DIR / "uvsphere.obj",
    "Bunny": MODELS_DIR / "Bunny.obj",
    "conference": MODELS_DIR / "conference" / "conference.obj.gz",
}
VARIANT = "llvm_ad_rgb"
# The most threads `isir render --threads` takes (MAX_THREADS in crates/isir-cli/src/main.rs).
ISIR_MAX_THREADS = 1024
# Half size of the rectangle that stands for an infinite plane, in units of the scene's size
# (the largest coordinate of its camera, lights and plane points): what lies further gets
# no light worth a tile mean. Not much more: Mitsuba's rectangle loses float precision at
# large scales (1e5 in the TP4 room made its walls 0.07% brighter than the same plane 20 wide).
PLANE_HALF_SIZE = 100.0
LLVM_CANDIDATES = [
    "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1",
    "/usr/lib/x86_64-linux-gnu/libLLVM-19.so",
    "/usr/lib/llvm-19/lib/libLLVM.so",
    "/usr/lib/x86_64-linux-gnu/libLLVM-18.so",
    "/usr/lib/x86_64-linux-gnu/libLLVM-17.so",
    "/usr/lib/x86_64-linux-gnu/libLLVM-16.so",
    "/usr/lib/x86_64-linux-gnu/libLLVM-15.so",
]
INSTALL_HINT = (
    "install Mitsuba 3 and an LLVM shared library for its llvm_ad_rgb variant:\n"
    "  pip install mitsuba            (3.x; this script was written against 3.9.1)\n"
    "  apt-get install libllvm19      (or another libLLVM >= 11)\n"
    "  export DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1   (if Dr.Jit does not find it)"
)


class Unsupported(Exception):
    """A scene Mitsuba 3 cannot express: skipped, with the reason."""


# ---------------------------------------------------------------------------------------------
# Small vector and matrix helpers (no numpy needed: --self-test runs without it)


def sub(a, b):
    return [a[i] - b[i] for i in range(3)]


def add(a, b):
    return [a[i] + b[i] for i in range(3)]


def scale(a, s):
    return [x * s for x in a]


def dot(a, b):
    return sum(a[i] * b[i] for i in range(3))


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def norm(a):
    return math.sqrt(dot(a, a))


def normalize(a):
    n = norm(a)
    if not n > 0 or not math.isfinite(n):
        raise Unsupported(f"cannot normalize the vector {a}")
    return [x / n for x in a]


def matrix_from_columns(x, y, z, t):
    """A 4x4 affine matrix (row-major rows) with columns x, y, z and translation t."""
    return [[x[i], y[i], z[i], t[i]] for i in range(3)] + [[0.0, 0.0, 0.0, 1.0]]


def matmul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)] for i in range(4)]


def transform_point(m, p):
    return [m[i][0] * p[0] + m[i][1] * p[1] + m[i][2] * p[2] + m[i][3] for i in range(3)]


def inverse3(m):
    """Inverse of the upper-left 3x3 block of m (a list of rows)."""
    a, b, c = m[0][:3], m[1][:3], m[2][:3]
    det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0])
    if det == 0:
        raise Unsupported("singular transform")
    cols = [cross(b, c), cross(c, a), cross(a, b)]  # rows of the adjugate's transpose
    return [[cols[j][i] / det for j in range(3)] for i in range(3)]


def transform_normal(m, n):
    """What Mitsuba does to a normal: the inverse transpose of the linear part."""
    inv = inverse3(m)
    return normalize([sum(inv[j][i] * n[j] for j in range(3)) for i in range(3)])


def look_at(origin, target, up):
    """Mitsuba's `Transform4f.look_at` (camera looks along local +z, local +x is the image's left)."""
    d = normalize(sub(target, origin))
    left = normalize(cross(up, d))
    new_up = cross(d, left)
    return matrix_from_columns(left, new_up, d, origin)


def rotation(axis, degrees):
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    if axis == 0:
        r = [[1, 0, 0], [0, c, -s], [0, s, c]]
    elif axis == 1:
        r = [[c, 0, s], [0, 1, 0], [-s, 0, c]]
    else:
        r = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
    return [row + [0.0] for row in r] + [[0.0, 0.0, 0.0, 1.0]]


def mesh_transform(t):
    """isir's `transform`: scale, then rotate about x, then y, then z (degrees), then translate."""
    s = float(t.get("scale", 1.0))
    rx, ry, rz = (float(v) for v in t.get("rotate", [0, 0, 0]))
    tx, ty, tz = (float(v) for v in t.get("translate", [0, 0, 0]))
    m = [[s, 0, 0, 0], [0, s, 0, 0], [0, 0, s, 0], [0, 0, 0, 1.0]]
    for axis, deg in ((0, rx), (1, ry), (2, rz)):
        m = matmul(rotation(axis, deg), m)
    m[0][3], m[1][3], m[2][3] = tx, ty, tz
    return m


# ---------------------------------------------------------------------------------------------
# The course's camera, for the self-test: where a world point lands on the image


def course_screen_x(position, look_at_pt, up, fovy, aspect, p):
    """sx in [0,1] (0 = left) of the course camera's ray through p (SPEC.md, Camera)."""
    w = normalize(sub(position, look_at_pt))
    u = normalize(cross(up, w))
    v = cross(w, u)
    h = 2 * math.tan(math.radians(fovy) / 2)
    wd = h * aspect
    d = sub(p, position)
    # dir = topLeft + sx*u*wd - sy*v*h - position, topLeft - position = -w + v*h/2 - u*wd/2
    # so along u: (d.u)/(d.-w) = sx*wd - wd/2
    return ((dot(d, u) / dot(d, scale(w, -1))) + wd / 2) / wd


def mitsuba_screen_x(to_world, fovy, aspect, p):
    """sx in [0,1] (0 = left) of p seen by Mitsuba's `perspective` sensor with fov_axis y:
    the sensor looks along local +z and local +x maps to the image's left."""
    x_axis = [to_world[i][0] for i in range(3)]
    z_axis = [to_world[i][2] for i in range(3)]
    o = [to_world[i][3] for i in range(3)]
    d = sub(p, o)
    tan_x = math.tan(math.radians(fovy) / 2) * aspect
    return 0.5 - 0.5 * (dot(d, x_axis) / dot(d, z_axis)) / tan_x


# ---------------------------------------------------------------------------------------------
# TOML writing (the subset the scene files use), for the temporary copies isir renders


def toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ValueError(f"non-finite number {v}")
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{json.dumps(k)} = {toml_value(x)}" for k, x in v.items()) + " }"
    raise ValueError(f"cannot write {v!r} as TOML")


def toml_dumps(doc):
    out = []
    for key in ("render", "camera", "materials"):
        if key in doc:
            out.append(f"[{key}]")
            out += [f"{json.dumps(k)} = {toml_value(v)}" for k, v in doc[key].items()]
            out.append("")
    for key in ("objects", "lights"):
        for item in doc.get(key, []):
            out.append(f"[[{key}]]")
            out += [f"{json.dumps(k)} = {toml_value(v)}" for k, v in item.items()]
            out.append("")
    extra = set(doc) - {"render", "camera", "materials", "objects", "lights"}
    if extra:
        raise ValueError(f"unknown top-level keys {sorted(extra)}")
    return "\n".join(out)


def write_atomic(path: Path, data: bytes):
    tmp = path.with_name(path.name + f".tmp{os.getpid()}")
    tmp.write_bytes(data)
    os.replace(tmp, path)


# ---------------------------------------------------------------------------------------------
# Scene translation: isir TOML -> Mitsuba 3 dict (JSON-serialisable; the worker turns
# {"__matrix__": rows} into a ScalarTransform4f)

DEFAULT_RENDER = {"width": 600, "height": 400, "spp": 1, "integrator": "direct", "light_samples": 1, "max_depth": 5}
WHITE = [1.0, 1.0, 1.0]


def rgb(c):
    return {"type": "rgb", "value": [float(x) for x in c]}


def cache_dir() -> Path:
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return base / "isir" / "mitsuba-compare"


def plain_obj(path: Path) -> Path:
    """Mitsuba reads no gzip: a .obj.gz is unpacked once into the cache (whole, then renamed)."""
    if path.suffix != ".gz":
        return path
    out = cache_dir() / path.name[:-3]
    if not out.exists() or out.stat().st_mtime < path.stat().st_mtime:
        out.parent.mkdir(parents=True, exist_ok=True)
        with gzip.open(path, "rb") as f:
            write_atomic(out, f.read())
    return out


def obj_facts(path: Path):
    """(has vertex normals, [material names used], mtllib paths) of an OBJ file."""
    has_vn, used, libs = False, [], []
    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "rt", encoding="utf-8", errors="replace") as f:
        for line in f:
            if line.startswith("vn "):
                has_vn = True
            elif line.startswith("usemtl"):
                name = line[6:].strip()
                if name not in used:
                    used.append(name)
            elif line.startswith("mtllib"):
                libs.append(path.parent / line[6:].strip())
    return has_vn, used, libs


def mtl_kd(libs, name):
    for lib in libs:
        if not lib.exists():
            continue
        current = None
        for line in lib.read_text(encoding="utf-8", errors="replace").splitlines():
            parts = line.split()
            if not parts:
                continue
            if parts[0] == "newmtl":
                current = " ".join(parts[1:])
            elif parts[0] == "Kd" and current == name:
                return [float(x) for x in parts[1:4]]
    return None


class Translation:
    """A scene translated for Mitsuba, with what is known about its fidelity."""

    def __init__(self):
        self.mitsuba = None  # the dict for load_dict
        self.exact = True  # same physics: the images are compared
        self.notes = []  # why not exact, and other remarks
        self.isir_integrator = ""
        self.mitsuba_integrator = ""

    def approx(self, why):
        self.exact = False
        if why not in self.notes:
            self.notes.append(why)


def material_kind(m):
    return m.get("type", "color")


def translate(doc, scene_path: Path, width, height, spp) -> Translation:
    """The Mitsuba 3 scene of an isir scene document (parsed TOML), at width x height, spp."""
    tr = Translation()
    render = {**DEFAULT_RENDER, **doc.get("render", {})}
    cam = {"position": [0, 0, 0], "look_at": [0, 0, 1], "up": [0, 1, 0], "fovy": 60, **doc.get("camera", {})}
    materials = doc.get("materials", {})
    objects = doc.get("objects", [])
    lights = doc.get("lights", [])
    integrator = render["integrator"]

    # ---- Which materials the objects use (None: the course's default white ColorMaterial) ----
    used = []
    for o in objects:
        if o.get("type") == "implicit":
            raise Unsupported("implicit surfaces (sphere-traced SDFs, TP7) have no Mitsuba 3 shape")
        name = o.get("material")
        if name is not None and name not in materials:
            raise Unsupported(f"object {o.get('name', '?')} names an unknown material {name!r}")
        used.append(materials[name] if name is not None else {"type": "color", "color": WHITE})
    kinds = {material_kind(m) for m in used}
    diffuse_like = {"lambert", "matte", "plastic", "cook-torrance"}
    # The course's ColorMaterial returns the colour as the BRDF, no 1/pi; Mitsuba's diffuse is
    # colour/pi. Direct lighting and Whitted: scale the lights by pi when every non-specular
    # material is a ColorMaterial, else give ColorMaterials a reflectance of pi*colour. The
    # path tracer treats ColorMaterial as Lambert with albedo = colour (isir warns): no scaling.
    light_scale = 1.0
    color_scale = 1.0
    if integrator in ("direct", "whitted") and "color" in kinds:
        if kinds & diffuse_like:
            color_scale = math.pi
            tr.notes.append("ColorMaterial as diffuse with reflectance pi*colour")
        else:
            light_scale = math.pi
            tr.notes.append("lights x pi for ColorMaterial")

    def bsdf(m):
        kind = material_kind(m)
        color = [float(x) for x in m.get("color", WHITE)]
        if kind == "color":
            return {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": rgb(scale(color, color_scale))}}
        if kind == "lambert":
            return {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": rgb(color)}}
        if kind == "matte":
            if float(m.get("sigma", 0.0)) != 0.0:
                tr.approx("approximate material: Oren-Nayar as diffuse (Mitsuba 3 has no Oren-Nayar)")
            return {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": rgb(color)}}
        if kind == "plastic":
            s = float(m.get("shininess", 32))
            tr.approx("approximate material: Phong/Blinn-Phong plastic as roughplastic (Beckmann, alpha = sqrt(2/(s+2)))")
            return {
                "type": "twosided",
                "bsdf": {
                    "type": "roughplastic",
                    "distribution": "beckmann",
                    "alpha": math.sqrt(2.0 / (s + 2.0)),
                    "diffuse_reflectance": rgb(scale(color, 0.7)),
                    "specular_reflectance": rgb(scale([float(x) for x in m.get("specular", WHITE)], 0.3)),
                    "nonlinear": False,
                },
            }
        if kind == "cook-torrance":
            tr.approx("approximate material: Cook-Torrance as principled (GGX, roughness and metallic as given)")
            return {
                "type": "principled",
                "base_color": rgb(color),
                "metallic": float(m.get("metalness", 0.0)),
                "roughness": float(m.get("roughness", 0.5)),
            }
        if kind == "mirror":
            return {"type": "twosided", "bsdf": {"type": "conductor", "material": "none"}}
        if kind == "transparent":
            return {"type": "dielectric", "int_ior": float(m.get("ior", 1.3)), "ext_ior": 1.0}
        raise Unsupported(f"material type {kind!r}")

    extent = [abs(float(x)) for x in cam["position"]]
    extent += [abs(float(x)) for o in objects if o.get("type") == "plane" for x in o.get("point", [0, 0, 0])]
    extent += [abs(float(x)) for light in lights for k in ("position", "corner") for x in light.get(k, [])]
    plane_half_size = PLANE_HALF_SIZE * max([1.0] + [e for e in extent if math.isfinite(e)])

    scene = {"type": "scene"}
    for i, (o, m) in enumerate(zip(objects, used)):
        kind = o.get("type")
        key = f"o{i:03d}_{o.get('name', kind)}"
        if kind == "sphere":
            shape = {"type": "sphere", "center": [float(x) for x in o.get("center", [0, 0, 0])], "radius": float(o.get("radius", 1.0))}
        elif kind == "plane":
            p = [float(x) for x in o.get("point", [0, 0, 0])]
            n = [float(x) for x in o.get("normal", [0, 1, 0])]
            shape = {"type": "rectangle", "to_world": {"__matrix__": plane_matrix(p, n, plane_half_size)}}
        elif kind == "mesh":
            if "model" in o:
                if o["model"] not in BUILTIN_MODELS:
                    raise Unsupported(f"unknown built-in model {o['model']!r}")
                path = BUILTIN_MODELS[o["model"]]
            else:
                path = (scene_path.parent / o["file"]).resolve()
            name = path.name.lower()
            if name.endswith((".gltf", ".glb", ".gltf.gz", ".glb.gz")):
                raise Unsupported("glTF meshes (Mitsuba 3 reads OBJ and PLY)")
            if name.endswith((".obj", ".obj.gz")):
                has_vn, mtls, libs = obj_facts(path)
                shape = {"type": "obj", "filename": str(plain_obj(path))}
                if o.get("material") is None:
                    # The file's own materials: one ColorMaterial per material, from Kd.
                    if len(mtls) > 1:
                        raise Unsupported(f"{path.name} uses {len(mtls)} materials (one Mitsuba shape per material not done)")
                    kd = mtl_kd(libs, mtls[0]) if mtls else None
                    m = {"type": "color", "color": kd if kd is not None else WHITE}
            elif name.endswith((".ply", ".ply.gz")):
                if name.endswith(".gz"):
                    raise Unsupported("gzipped PLY")
                has_vn = True  # Mitsuba uses a PLY's normals when it has some, as isir does
                shape = {"type": "ply", "filename": str(path)}
            else:
                raise Unsupported(f"mesh file {path.name}")
            # isir: flat, or smooth with the file's normals, else face normals. Mitsuba would
            # compute smooth normals for a file without any.
            shape["face_normals"] = bool(o.get("flat", False)) or not has_vn
            if "transform" in o:
                shape["to_world"] = {"__matrix__": mesh_transform(o["transform"])}
        else:
            raise Unsupported(f"object type {kind!r}")
        shape["bsdf"] = bsdf(m)
        scene[key] = shape

    for i, light in enumerate(lights):
        kind = light.get("type")
        color = [float(x) for x in light.get("color", WHITE)]
        power = float(light.get("power", 100.0))
        radiance = scale(color, power * light_scale)
        if kind == "point":
            scene[f"light{i:02d}"] = {"type": "point", "position": [float(x) for x in light["position"]], "intensity": rgb(radiance)}
        elif kind == "quad":
            corner, u, v = ([float(x) for x in light[k]] for k in ("corner", "u", "v"))
            if abs(dot(u, v)) > 1e-6 * norm(u) * norm(v):
                tr.approx("approximate light: a quad light with non-perpendicular edges")
            scene[f"light{i:02d}"] = {
                "type": "rectangle",
                "to_world": {"__matrix__": quad_matrix(corner, u, v)},
                # The emitter's own surface: black, so that it reflects nothing.
                "bsdf": {"type": "diffuse", "reflectance": rgb([0, 0, 0])},
                "emitter": {"type": "area", "radiance": rgb(radiance)},
            }
        else:
            raise Unsupported(f"light type {kind!r}")

    # ---- Integrator ----
    n_light = max(1, int(render["light_samples"]))
    depth = max(1, int(render["max_depth"]))
    tr.isir_integrator = integrator
    if integrator == "ray-cast":
        scene["integrator"] = {"type": "isir_raycast"}
        tr.mitsuba_integrator = "isir_raycast (this script's: albedo x |cos|)"
    elif integrator == "direct":
        scene["integrator"] = {"type": "direct", "emitter_samples": n_light, "bsdf_samples": 0, "hide_emitters": True}
        tr.isir_integrator = f"direct, {n_light} light sample{'s' if n_light > 1 else ''}"
        tr.mitsuba_integrator = f"direct, emitter_samples {n_light}, bsdf_samples 0"
    elif integrator == "whitted":
        scene["integrator"] = {"type": "path", "max_depth": depth + 1, "hide_emitters": True}
        tr.isir_integrator = f"whitted, depth {depth}"
        tr.mitsuba_integrator = f"path, max_depth {depth + 1}"
        if kinds - {"mirror", "transparent"}:
            tr.approx("approximate integrator: Whitted has no diffuse interreflection, Mitsuba's path does")
    elif integrator == "path":
        scene["integrator"] = {"type": "path", "max_depth": depth + 1, "hide_emitters": True}
        tr.isir_integrator = f"path, depth {depth}"
        tr.mitsuba_integrator = f"path, max_depth {depth + 1}"
    else:
        raise Unsupported(f"integrator {integrator!r}")

    scene["sensor"] = {
        "type": "perspective",
        "fov": float(cam["fovy"]),
        "fov_axis": "y",
        "to_world": {"__matrix__": look_at(*([float(x) for x in cam[k]] for k in ("position", "look_at", "up")))},
        "sampler": {"type": "independent", "sample_count": int(spp)},
        "film": {
            "type": "hdrfilm",
            "width": int(width),
            "height": int(height),
            "rfilter": {"type": "box"},  # isir averages its samples per pixel
            "pixel_format": "rgb",
            "component_format": "float32",
        },
    }
    tr.mitsuba = scene
    return tr


def plane_matrix(p, n, half_size):
    """A rectangle through p with normal n, half_size on each side: isir's infinite plane."""
    n = normalize(n)
    helper = [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0]
    t1 = normalize(cross(helper, n))
    t2 = cross(n, t1)  # (t1, t2, n) right-handed: the rectangle's normal is n
    return matrix_from_columns(scale(t1, half_size), scale(t2, half_size), n, p)


def quad_matrix(corner, u, v):
    """Mitsuba's `rectangle` ([-1,1]^2 at z = 0, emitting towards its normal +z) onto the
    course's quad light: local x along v, y along u, so the normal is along v x u = -(u x v),
    the side the course's quad light shines to."""
    centre = add(corner, scale(add(u, v), 0.5))
    n = normalize(cross(v, u))
    return matrix_from_columns(scale(v, 0.5), scale(u, 0.5), n, centre)


def to_mitsuba(obj, mi):
    """The JSON form back into what load_dict takes."""
    if isinstance(obj, dict):
        if set(obj) == {"__matrix__"}:
            return mi.ScalarTransform4f(obj["__matrix__"])
        return {k: to_mitsuba(v, mi) for k, v in obj.items()}
    if isinstance(obj, list):
        return [to_mitsuba(v, mi) for v in obj]
    return obj


# ---------------------------------------------------------------------------------------------
# The Mitsuba side, in its own process


def setup_llvm_env():
    """Dr.Jit finds libLLVM itself on most systems; when it would not, point it at a known one."""
    if os.environ.get("DRJIT_LIBLLVM_PATH"):
        return
    for c in LLVM_CANDIDATES:
        if os.path.exists(c):
            os.environ["DRJIT_LIBLLVM_PATH"] = c
            return


def register_raycast(mi, dr):
    class RayCast(mi.SamplingIntegrator):
        """isir's ray-cast: the material's flat colour times max(dot(n, -dir), 0), with n the
        shading normal turned towards the viewer (the course flips it by the ray)."""

        def __init__(self, props):
            super().__init__(props)

        def sample(self, scene, sampler, ray, medium=None, active=True):
            si = scene.ray_intersect(ray, active)
            valid = si.is_valid()
            albedo = si.bsdf(ray).eval_diffuse_reflectance(si, valid)
            n = si.sh_frame.n
            n = dr.select(dr.dot(si.n, ray.d) > 0, -n, n)
            cos = dr.maximum(dr.dot(n, -ray.d), 0.0)
            return dr.select(valid, albedo * cos, 0.0), valid, []

    mi.register_integrator("isir_raycast", lambda props: RayCast(props))


def mitsuba_worker(scene_json: str, out: str, threads: int | None, seed: int) -> int:
    setup_llvm_env()
    import drjit as dr
    import mitsuba as mi

    mi.set_variant(VARIANT)
    if threads:
        dr.set_thread_count(threads)
    mi.set_log_level(mi.LogLevel.Warn)
    register_raycast(mi, dr)
    with open(scene_json, encoding="utf-8") as f:
        desc = json.load(f)
    scene = mi.load_dict(to_mitsuba(desc, mi))
    image = mi.render(scene, seed=seed)
    if threads == 1:
        # Mitsuba 3.9's EXR writer waits forever on a one-thread pool; the render is done.
        dr.set_thread_count(2)
    tmp = out + f".tmp{os.getpid()}.exr"
    mi.Bitmap(image).write(tmp)
    os.replace(tmp, out)
    return 0


def probe_mitsuba() -> str | None:
    """None when Mitsuba's llvm variant renders, else what went wrong."""
    code = (
        "import drjit as dr, mitsuba as mi\n"
        f"mi.set_variant('{VARIANT}')\n"
        "x = dr.arange(mi.Float, 8) * 2\n"
        "dr.eval(x)\n"
        "assert float(dr.sum(x)[0] if hasattr(dr.sum(x), '__getitem__') else dr.sum(x)) == 56.0\n"
    )
    env = dict(os.environ)
    if not env.get("DRJIT_LIBLLVM_PATH"):
        for c in LLVM_CANDIDATES:
            if os.path.exists(c):
                env["DRJIT_LIBLLVM_PATH"] = c
                break
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    if r.returncode == 0:
        return None
    err = (r.stderr or r.stdout).strip().splitlines()
    last = err[-1] if err else f"exit code {r.returncode}"
    if "No module named" in last and "mitsuba" in last:
        return "Mitsuba is not installed (python3 cannot import mitsuba)"
    if "drjit" in last.lower() or "llvm" in "\n".join(err).lower():
        return f"Mitsuba's {VARIANT} variant cannot start (no usable libLLVM?): {last}"
    return f"Mitsuba's {VARIANT} variant failed: {last}"


# ---------------------------------------------------------------------------------------------
# Images


def read_exr(path):
    import mitsuba as mi
    import numpy as np

    if not mi.variant():
        mi.set_variant("scalar_rgb")
    a = np.array(mi.Bitmap(str(path)), dtype=np.float64)
    if a.ndim == 2:
        a = a[:, :, None]
    return a[:, :, :3]


def compare_images(a, b, grid=8, k=5.0, rel_floor=0.005):
    """Do two renders of the same expectation agree? Per tile of a grid x grid split and
    channel, the difference of the means against its standard error, estimated from the
    per-pixel differences (independent samples in every pixel: the tile mean of the
    difference has standard error sd(a - b) / sqrt(pixels)). A tile agrees when
    |mean(a) - mean(b)| <= k * SE, or when it is within rel_floor of the larger mean plus
    a hair (1e-3 of the image's mean), so that near-noiseless tiles are not held to float
    rounding. k = 5: with 64 tiles x 3 channels, a 5-sigma false alarm is ~1e-4 per image.
    Returns (agree, summary, worst) where worst describes the tile furthest outside."""
    import numpy as np

    if a.shape != b.shape:
        return False, f"sizes differ: {a.shape[1]}x{a.shape[0]} vs {b.shape[1]}x{b.shape[0]}", None
    if not (np.isfinite(a).all() and np.isfinite(b).all()):
        return False, "non-finite pixels", None
    h, w, _ = a.shape
    ys = np.linspace(0, h, grid + 1).astype(int)
    xs = np.linspace(0, w, grid + 1).astype(int)
    image_mean = max(a.mean(), b.mean(), 1e-12)
    hair = 1e-3 * image_mean
    worst, worst_score = None, -1.0
    for ty in range(grid):
        for tx in range(grid):
            ta = a[ys[ty] : ys[ty + 1], xs[tx] : xs[tx + 1]].reshape(-1, 3)
            tb = b[ys[ty] : ys[ty + 1], xs[tx] : xs[tx + 1]].reshape(-1, 3)
            n = ta.shape[0]
            if n < 2:
                continue
            for c in range(3):
                ma, mb = ta[:, c].mean(), tb[:, c].mean()
                diff = abs(ma - mb)
                se = (ta[:, c] - tb[:, c]).std(ddof=1) / math.sqrt(n)
                allowed = max(k * se, rel_floor * max(ma, mb)) + hair
                score = diff / allowed
                if score > worst_score:
                    worst_score = score
                    worst = {
                        "tile": (ty, tx),
                        "channel": "RGB"[c],
                        "isir": ma,
                        "mitsuba": mb,
                        "ratio": ma / mb if mb > 0 else float("inf") if ma > 0 else 1.0,
                        "z": diff / se if se > 0 else float("inf") if diff > hair else 0.0,
                        "score": score,
                    }
    ma, mb = a.mean(), b.mean()
    whole = (ma - mb) / mb if mb > 0 else 0.0
    agree = worst_score <= 1.0
    if agree:
        summary = f"agree (worst tile {worst['z']:.1f} sigma, image means {whole:+.2%})"
    else:
        wt = worst
        summary = (
            f"DIFFER: tile row {wt['tile'][0]} col {wt['tile'][1]} ({wt['channel']}) isir {wt['isir']:.4g} "
            f"vs Mitsuba {wt['mitsuba']:.4g}, ratio {wt['ratio']:.3f}, {wt['z']:.1f} sigma; image means {whole:+.2%}"
        )
    return agree, summary, worst


def write_side_by_side(a, b, path):
    """isir | Mitsuba, sRGB PNG, for looking at."""
    import mitsuba as mi
    import numpy as np

    gap = np.ones((a.shape[0], 4, 3))
    both = np.concatenate([a, gap, b], axis=1).astype(np.float32)
    bmp = mi.Bitmap(np.ascontiguousarray(both), mi.Bitmap.PixelFormat.RGB)
    bmp.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, True).write(str(path))


# ---------------------------------------------------------------------------------------------
# Driver


def builtin_scene_names(isir, shown):
    """The names `isir scenes` lists; shown is the binary's path as the user gave it."""
    try:
        r = subprocess.run([isir, "scenes"], capture_output=True, text=True, errors="replace")
    except OSError as e:
        sys.exit(f"compare.py: error: `{shown} scenes` could not run: {e.strerror}")
    if r.returncode != 0:
        how = f"exit {r.returncode}" if r.returncode > 0 else f"killed by signal {-r.returncode}"
        err = r.stderr.strip().splitlines()
        sys.exit(f"compare.py: error: `{shown} scenes` failed ({how})" + (f": {err[-1]}" if err else ""))
    names = [line.split()[0] for line in r.stdout.splitlines() if line.strip()]
    if not names:
        sys.exit(f"compare.py: error: `{shown} scenes` listed no scene: is it isir?")
    return names


def select_scenes(patterns, names):
    if not patterns:
        return list(names)
    chosen = []
    for pat in patterns:
        if pat.endswith(".toml"):
            # A scene file that is not there, or not TOML, is an error now rather than a
            # skipped row at the end (as a misspelled built-in name is).
            if not Path(pat).is_file():
                sys.exit(f"compare.py: error: no scene file {pat}")
            try:
                load_toml(Path(pat))
            except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as e:
                sys.exit(f"compare.py: error: {pat}: {getattr(e, 'strerror', None) or e}")
            chosen.append(pat)
            continue
        hits = [n for n in names if fnmatch.fnmatchcase(n, pat)]
        if not hits:
            sys.exit(f"compare.py: error: no built-in scene matches {pat!r} (`isir scenes` lists them)")
        chosen += [h for h in hits if h not in chosen]
    return chosen


def load_toml(path: Path):
    with open(path, "rb") as f:
        return tomllib.load(f)


def prepare(name, args, work: Path, path_lambert: bool):
    """(label, isir toml path, mitsuba json path, translation) for one scene."""
    src = Path(name) if name.endswith(".toml") else SCENES_DIR / f"{name}.toml"
    if not src.exists():
        raise Unsupported(f"no scene file {src}")
    doc = load_toml(src)
    label = src.stem
    render = doc.setdefault("render", {})
    if path_lambert:
        # The TP6 room with isir's path tracer and Mitsuba's: Oren-Nayar -> Lambert in both,
        # one light sample per vertex in both (Mitsuba's path takes one emitter sample).
        render["integrator"] = "path"
        render["light_samples"] = 1
        for key, m in doc.get("materials", {}).items():
            if m.get("type") == "matte":
                doc["materials"][key] = {"type": "lambert", "color": m.get("color", WHITE)}
        label += " (path, Lambert)"
    # The course's background is not a light: black where nothing is hit, in both.
    render["background"] = [0.0, 0.0, 0.0]
    render["display"] = "linear-clamp"
    for o in doc.get("objects", []):
        if "file" in o:
            o["file"] = str((src.parent / o["file"]).resolve())
    tr = translate(doc, src, args.width, args.height, args.spp)
    stem = label.replace(" ", "_").replace("(", "").replace(")", "").replace(",", "")
    toml_path = work / f"{stem}.toml"
    write_atomic(toml_path, toml_dumps(doc).encode())
    json_path = work / f"{stem}.mitsuba.json"
    write_atomic(json_path, json.dumps(tr.mitsuba, indent=1).encode())
    return label, stem, toml_path, json_path, tr


def run_timed(cmd, env=None):
    t0 = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    dt = time.perf_counter() - t0
    if r.returncode != 0:
        raise RuntimeError(f"`{' '.join(cmd)}` failed (exit {r.returncode}):\n{r.stderr.strip()}")
    return dt


def fmt_s(x):
    return f"{x:.2f}" if x >= 1 else f"{x:.3f}"


def fmt_times(ts):
    med = statistics.median(ts)
    if len(ts) == 1:
        return f"{fmt_s(med)} s"
    return f"{fmt_s(med)} s ({fmt_s(min(ts))}–{fmt_s(max(ts))})"


def main_compare(args) -> int:
    if tomllib is None:
        sys.exit("compare.py: error: needs Python 3.11 or newer (tomllib)")
    # Run by its absolute path (not resolved: messages show the path as given).
    shown = args.isir or str(REPO / "target" / "release" / "isir")
    isir = os.path.abspath(shown)
    if not os.path.exists(isir):
        sys.exit(f"compare.py: error: no isir binary at {shown}: run `cargo build --release` or give --isir PATH")
    if not (os.path.isfile(isir) and os.access(isir, os.X_OK)):
        sys.exit(f"compare.py: error: {shown} is not an executable file (--isir takes the isir binary)")
    # --out: checked now; made once the scenes are known to exist (before any render).
    keep = Path(args.out) if args.out else None
    if keep and keep.exists() and not keep.is_dir():
        sys.exit(f"compare.py: error: --out {args.out} exists and is not a directory")
    try:
        import numpy  # noqa: F401
    except ModuleNotFoundError:
        sys.exit("compare.py: error: numpy is missing: pip install numpy")
    why = probe_mitsuba()
    if why:
        print(f"compare.py: error: {why}\n{INSTALL_HINT}", file=sys.stderr)
        return 3
    setup_llvm_env()

    names = builtin_scene_names(isir, shown)
    patterns = [p for s in (args.scenes or []) for p in s.replace(",", " ").split()]
    if args.path_lambert and not patterns:
        patterns = ["tp6-*"]
    scenes = select_scenes(patterns, names)
    if keep:
        try:
            keep.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            sys.exit(f"compare.py: error: --out {args.out}: cannot make the directory: {e.strerror}")
        if not os.access(keep, os.W_OK | os.X_OK):
            sys.exit(f"compare.py: error: --out {args.out}: the directory is not writable")

    rows, failures = [], 0
    work = Path(tempfile.mkdtemp(prefix="isir-mitsuba-"))
    try:
        for name in scenes:
            try:
                label, stem, toml_path, json_path, tr = prepare(name, args, work, args.path_lambert)
            except Unsupported as e:
                print(f"{name}: skipped: {e}", flush=True)
                rows.append({"label": name, "skipped": str(e)})
                continue
            isir_exr, mts_exr = work / f"{stem}.isir.exr", work / f"{stem}.mitsuba.exr"
            isir_cmd = [isir, "render", str(toml_path), "-o", str(isir_exr), "--width", str(args.width),
                        "--height", str(args.height), "--spp", str(args.spp)]
            mts_cmd = [sys.executable, str(Path(__file__).resolve()), "--mitsuba-worker", str(json_path), str(mts_exr),
                       "--seed", "0"]
            if args.threads:
                isir_cmd += ["--threads", str(args.threads)]
                mts_cmd += ["--threads", str(args.threads)]
            print(f"{label}: isir {tr.isir_integrator} | Mitsuba {tr.mitsuba_integrator}"
                  + (f" [{'; '.join(tr.notes)}]" if tr.notes else ""), flush=True)
            try:
                # Warm-up, untimed: Mitsuba's kernel cache, the file cache of both.
                run_timed(isir_cmd)
                run_timed(mts_cmd)
                ti, tm = [], []
                for _ in range(args.runs):
                    ti.append(run_timed(isir_cmd))
                    tm.append(run_timed(mts_cmd))
            except RuntimeError as e:
                print(f"{label}: error: {e}", file=sys.stderr, flush=True)
                rows.append({"label": label, "skipped": "a render failed (see above)"})
                failures += 1
                continue
            a, b = read_exr(isir_exr), read_exr(mts_exr)
            if tr.exact:
                agree, summary, _ = compare_images(a, b)
                if not agree:
                    failures += 1
            else:
                agree, summary = None, "approximate material (images not compared)" if any(
                    n.startswith("approximate material") for n in tr.notes) else "approximate integrator (images not compared)"
            if keep:
                for p in (isir_exr, mts_exr, toml_path, json_path):
                    shutil.copy(p, keep / p.name)
                write_side_by_side(a, b, keep / f"{stem}.side-by-side.png")
            ratio = statistics.median(ti) / statistics.median(tm)
            rr = [x / y for x, y in zip(ti, tm)]
            print(f"    isir {fmt_times(ti)}   Mitsuba {fmt_times(tm)}   isir/Mitsuba {ratio:.2f}"
                  + (f" ({min(rr):.2f}–{max(rr):.2f})" if len(rr) > 1 else "") + f"   {summary}", flush=True)
            rows.append({"label": label, "tr": tr, "ti": ti, "tm": tm, "ratio": ratio, "rr": rr, "summary": summary})
    finally:
        shutil.rmtree(work, ignore_errors=True)

    print()
    print_table(rows, args)
    return 1 if failures else 0


def print_table(rows, args):
    head = ["scene", "isir integrator", "Mitsuba integrator", "isir", "Mitsuba 3 llvm_ad_rgb", "isir / Mitsuba time", "images"]
    body = []
    for r in rows:
        if "skipped" in r:
            body.append([r["label"], "", "", "", "", "", f"skipped: {r['skipped']}"])
            continue
        rr = r["rr"]
        ratio = f"{r['ratio']:.2f}" + (f" ({min(rr):.2f}–{max(rr):.2f})" if len(rr) > 1 else "")
        body.append([r["label"], r["tr"].isir_integrator, r["tr"].mitsuba_integrator, fmt_times(r["ti"]), fmt_times(r["tm"]), ratio,
                     r["summary"]])
    title = f"{args.width}×{args.height}, {args.spp} spp, {args.runs} timed run{'s' if args.runs > 1 else ''} each" + (
        f", {args.threads} thread{'s' if args.threads > 1 else ''}" if args.threads else "")
    if args.markdown:
        print(f"{title}; whole-process wall time, median (range)\n")
        print("| " + " | ".join(head) + " |")
        print("| " + " | ".join("---" for _ in head) + " |")
        for row in body:
            print("| " + " | ".join(c.replace("|", "\\|") for c in row) + " |")
    else:
        print(title)
        widths = [max(len(h), *(len(row[i]) for row in body)) if body else len(h) for i, h in enumerate(head)]
        print("  ".join(h.ljust(w) for h, w in zip(head, widths)))
        for row in body:
            print("  ".join(c.ljust(w) for c, w in zip(row, widths)))


# ---------------------------------------------------------------------------------------------
# Self-test: the translation on hand-computed cases, without Mitsuba


def self_test() -> int:
    failures = []

    def check(what, got, want, tol=1e-9):
        flat_g = got if isinstance(got, list) else [got]
        flat_w = want if isinstance(want, list) else [want]
        if len(flat_g) != len(flat_w) or any(abs(g - w) > tol for g, w in zip(flat_g, flat_w)):
            failures.append(f"{what}: got {got}, want {want}")

    # Camera at (0,0,-6) looking along +z: Mitsuba's look_at has columns left = up x dir = +x,
    # up = +y, dir = +z, origin (0,0,-6).
    m = look_at([0, 0, -6], [0, 0, 1], [0, 1, 0])
    check("look_at rows", [x for row in m for x in row], [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, -6, 0, 0, 0, 1])
    # The SPEC's consequence: world +x is on the left of the image, in both cameras, at the
    # same place: (1,0,0) from 6 away, aspect 1.5, fovy 60: sx = 0.5 - (1/6)/(2*1.5*tan 30°).
    want = 0.5 - (1 / 6) / (2 * 1.5 * math.tan(math.radians(30)))
    check("course sx of +x", course_screen_x([0, 0, -6], [0, 0, 1], [0, 1, 0], 60, 1.5, [1, 0, 0]), want)
    check("mitsuba sx of +x", mitsuba_screen_x(m, 60, 1.5, [1, 0, 0]), want)
    # TP1 camera 4 (a turned camera) and the TP4 conference camera: same screen x in both.
    for pos, at, p in (([4, -1, 0], [-1, -1, 2], [0, 0, 3]), ([-250, 500, 330], [0, 350, 100], [100, 300, 0])):
        mm = look_at(pos, at, [0, 1, 0])
        check(f"screen x of {p} from {pos}", mitsuba_screen_x(mm, 60, 1.5, p), course_screen_x(pos, at, [0, 1, 0], 60, 1.5, p), 1e-9)

    # TP3's quad light: corner (1,10,2), u (-2,0,0), v (0,0,2). u x v = (0,4,0): it shines
    # down (-y). The rectangle: centre (0,10,3), local x -> v/2, y -> u/2, normal -> (0,-1,0).
    q = quad_matrix([1, 10, 2], [-2, 0, 0], [0, 0, 2])
    check("quad centre", [q[i][3] for i in range(3)], [0, 10, 3])
    check("quad normal", transform_normal(q, [0, 0, 1]), [0, -1, 0])
    corners = sorted(tuple(round(x, 9) for x in transform_point(q, [sx, sy, 0])) for sx in (-1, 1) for sy in (-1, 1))
    check("quad corners", [x for c in corners for x in c], [x for c in sorted([(1, 10, 2), (-1, 10, 2), (1, 10, 4), (-1, 10, 4)]) for x in c])
    # TP6's tilted quad: u (-2,0,0), v (0,1,2): u x v = (0,4,-2), it shines along (0,-2,1)/sqrt 5.
    q6 = quad_matrix([1, 5, -2], [-2, 0, 0], [0, 1, 2])
    check("tilted quad normal", transform_normal(q6, [0, 0, 1]), [0, -2 / math.sqrt(5), 1 / math.sqrt(5)])
    # Mitsuba's rectangle area: |dp/du| |dp/dv| over [-1,1]^2 = 4 |v/2| |u/2| = |u| |v|.
    check("quad area", 4 * norm([q6[i][0] for i in range(3)]) * norm([q6[i][1] for i in range(3)]), 2 * math.sqrt(5))

    # Light conversion of a ColorMaterial scene under direct lighting: radiance x pi.
    doc = {
        "render": {"integrator": "direct", "light_samples": 16},
        "materials": {"Red": {"type": "color", "color": [1, 0, 0]}},
        "objects": [{"type": "plane", "point": [0, -2, 0], "normal": [0, 1, 0], "material": "Red"}],
        "lights": [{"type": "point", "position": [1, 10, 1], "power": 100},
                   {"type": "quad", "corner": [1, 10, 2], "u": [-2, 0, 0], "v": [0, 0, 2], "power": 40}],
    }
    tr = translate(doc, SCENES_DIR / "x.toml", 160, 120, 4)
    check("point intensity", tr.mitsuba["light00"]["intensity"]["value"], [100 * math.pi, 100 * math.pi, 100 * math.pi])
    check("quad radiance", tr.mitsuba["light01"]["emitter"]["radiance"]["value"], [40 * math.pi] * 3)
    check("colour reflectance", tr.mitsuba["o000_plane"]["bsdf"]["bsdf"]["reflectance"]["value"], [1, 0, 0])
    check("plane normal", transform_normal(tr.mitsuba["o000_plane"]["to_world"]["__matrix__"], [0, 0, 1]), [0, 1, 0])
    integ = tr.mitsuba["integrator"]
    if (integ["type"], integ["emitter_samples"], integ["bsdf_samples"], integ["hide_emitters"]) != ("direct", 16, 0, True):
        failures.append(f"direct integrator: {integ}")
    if not tr.exact:
        failures.append(f"a ColorMaterial scene is exact: {tr.notes}")
    # The path tracer: ColorMaterial is Lambert with albedo = colour, no scaling; depth + 1.
    doc["render"] = {"integrator": "path", "max_depth": 5}
    tr = translate(doc, SCENES_DIR / "x.toml", 160, 120, 4)
    check("path: point intensity", tr.mitsuba["light00"]["intensity"]["value"], [100.0] * 3)
    if tr.mitsuba["integrator"] != {"type": "path", "max_depth": 6, "hide_emitters": True}:
        failures.append(f"path integrator: {tr.mitsuba['integrator']}")
    # Mixed Color and Lambert under direct lighting: the ColorMaterial takes pi*colour instead.
    doc["render"] = {"integrator": "direct"}
    doc["materials"]["L"] = {"type": "lambert", "color": [0.5, 0.5, 0.5]}
    doc["objects"].append({"type": "sphere", "material": "L"})
    tr = translate(doc, SCENES_DIR / "x.toml", 160, 120, 4)
    check("mixed: point intensity", tr.mitsuba["light00"]["intensity"]["value"], [100.0] * 3)
    check("mixed: colour reflectance", tr.mitsuba["o000_plane"]["bsdf"]["bsdf"]["reflectance"]["value"], [math.pi, 0, 0])
    # Oren-Nayar is approximate; implicit surfaces are refused.
    doc["materials"]["L"] = {"type": "matte", "sigma": 0.6}
    if translate(doc, SCENES_DIR / "x.toml", 160, 120, 4).exact:
        failures.append("Oren-Nayar counted as exact")
    doc["objects"].append({"type": "implicit", "sdf": {"sdf": "sphere", "radius": 1}})
    try:
        translate(doc, SCENES_DIR / "x.toml", 160, 120, 4)
        failures.append("an implicit surface was translated")
    except Unsupported:
        pass
    # A mesh transform: scale 2, rotate 90° about y, translate (1,2,3): (1,0,0) -> (0,0,-2) + t.
    check("mesh transform", transform_point(mesh_transform({"scale": 2, "rotate": [0, 90, 0], "translate": [1, 2, 3]}), [1, 0, 0]),
          [1, 2, 1], 1e-9)
    # The temporary TOML copies read back the same.
    if tomllib is not None:
        d = {"render": {"width": 8, "background": [0.0, 0.0, 0.0]}, "materials": {"a b": {"type": "lambert", "color": [1, 0.5, 0]}},
             "objects": [{"type": "mesh", "file": "/x/\"q\".obj", "transform": {"scale": 1.5}}]}
        if tomllib.loads(toml_dumps(d)) != d:
            failures.append(f"TOML round trip: {tomllib.loads(toml_dumps(d))}")
    # Tile comparison (numpy only): the same expectation agrees, a 10% brighter tile does not.
    try:
        import numpy as np
    except ModuleNotFoundError:
        np = None
    if np is not None:
        rng = np.random.default_rng(1)
        base = np.ones((64, 96, 3)) * 0.4
        a = base + rng.normal(0, 0.02, base.shape)
        b = base + rng.normal(0, 0.02, base.shape)
        if not compare_images(a, b)[0]:
            failures.append(f"noisy equal images differ: {compare_images(a, b)[1]}")
        b[8:16, 12:24] *= 1.1
        ok, summary, worst = compare_images(a, b)
        if ok or worst["tile"] != (1, 1):
            failures.append(f"a 10% brighter tile was not found: {summary}")

    for f in failures:
        print(f"self-test: FAIL: {f}")
    print(f"self-test: {'ok' if not failures else f'{len(failures)} failure(s)'}")
    return 1 if failures else 0


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scenes", action="append", help="built-in scene names or globs (comma or space separated; repeatable), or .toml files "
                   "(default: every scene `isir scenes` lists; with --path-lambert: tp6-*)")
    p.add_argument("--spp", type=int, default=64, help="samples per pixel (default: %(default)s)")
    p.add_argument("--width", type=int, default=600, help="image width in pixels (default: %(default)s)")
    p.add_argument("--height", type=int, default=400, help="image height in pixels (default: %(default)s)")
    p.add_argument("--runs", type=int, default=3,
                   help="timed runs of each engine, interleaved (after one untimed warm-up each) (default: %(default)s)")
    p.add_argument("--isir", help="the isir binary (default: target/release/isir in this repository)")
    p.add_argument("--threads", type=int,
                   help=f"threads for both engines, 1 to {ISIR_MAX_THREADS} (default: each engine's own, one per core)")
    p.add_argument("--markdown", action="store_true", help="print the table as Markdown")
    p.add_argument("--path-lambert", action="store_true", help="the TP6 scenes with both path tracers, Lambert materials")
    p.add_argument("--out", help="keep the images, scene copies and isir|Mitsuba PNGs in this directory, made if missing "
                   "(default: keep nothing)")
    p.add_argument("--self-test", action="store_true", help="check the scene translation (no Mitsuba needed)")
    p.add_argument("--mitsuba-worker", nargs=2, metavar=("SCENE.json", "OUT.exr"), help=argparse.SUPPRESS)
    p.add_argument("--seed", type=int, default=0, help=argparse.SUPPRESS)
    args = p.parse_args()
    for name in ("spp", "width", "height", "runs"):
        if getattr(args, name) < 1:
            p.error(f"--{name} must be at least 1")
    if args.threads is not None and not 1 <= args.threads <= ISIR_MAX_THREADS:
        p.error(f"--threads must be from 1 to {ISIR_MAX_THREADS} (isir's limit), not {args.threads}")
    if args.self_test:
        return self_test()
    if args.mitsuba_worker:
        return mitsuba_worker(args.mitsuba_worker[0], args.mitsuba_worker[1], args.threads, args.seed)
    return main_compare(args)


if __name__ == "__main__":
    sys.exit(main())
