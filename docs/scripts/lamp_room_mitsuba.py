#!/usr/bin/env python3
"""Build the shared lamp-room scene in Mitsuba 3 from its glb and render it.

What it is for: checking what the shared reference `reference/lamp-room-ref.exr` does where the
perforated screen's alpha mask cuts holes (docs/LIGHTS.md, section lamp-room). Mitsuba 3's `path`
integrator tests the shadow rays of emitter sampling with `ray_test`, for which a `mask` BSDF is
an occluder even where its opacity is 0; a point or spot light is reached by those rays only, so
the screen's shadows come out solid. `volpath` walks its shadow rays through null-interface
surfaces, weighting them by `eval_null_transmission` (1 − opacity for `mask`), so the lamps'
light passes the holes as the reference README's convention ("no surface at all") says.

Needs: Python 3 with `pip install mitsuba numpy pillow` (Mitsuba 3.9.1 was used; drjit comes
with it). Nothing else: the glb is parsed here (no glTF library). The project's build and tests
do not use this script.

Run (from the repository root, shared material in ../shared or give the paths):

    python3 docs/scripts/lamp_room_mitsuba.py --integrator path    --spp 2048 --seed 7 -o path.exr
    python3 docs/scripts/lamp_room_mitsuba.py --integrator volpath --spp 6144 --seed 8 -o volpath.exr
    target/release/vlf-bake compare path.exr ../shared/reference/lamp-room-ref.exr

(the renders docs/LIGHTS.md reports: 134 s and 530 s on the loaded 2-core VM).

Options: --glb (default ../shared/scenes/lamp-room/lamp-room.glb), --variant (llvm_ad_rgb by
default; scalar_rgb gives the same images, slower), --size WxH (256x256), --max-depth (-1:
unlimited), --pass-spp (1024: samples per render pass, each pass its own seed, averaged).

`llvm_ad_rgb` needs an LLVM Dr.Jit can compile with: on the project's Debian 12 VM the system
libLLVM 15 aborts with "LLVM ERROR: Cannot select ... fminimum"; `apt-get install libllvm19` and
`export DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1` fix it (or use scalar_rgb).

Scene model, following reference/README.md's conventions:
* camera 0 of the glb (pinhole, yfov vertical, aspect 1), box pixel filter, linear RGB EXR;
* every triangle of the default scene with node transforms applied; NORMALs as shading normals
  (the sphere's are smooth; the flat meshes' equal their faces' normals);
* Lambert materials (metallic 0) `twosided` (surfaces reflect alike from both sides), albedo
  baseColorFactor × sRGB-decoded base colour texture, NEAREST sampling, REPEAT wrap;
* alphaMode MASK: a `mask` BSDF whose opacity is 1 where baseColorFactor.a × texture alpha ≥
  alphaCutoff and 0 elsewhere (NEAREST), around the material;
* KHR_lights_punctual: point → Mitsuba `point` with intensity = colour × intensity [W/sr];
  spot → Mitsuba `spot` along the node's −Z, cutoff_angle = outerConeAngle, beam_width =
  innerConeAngle (Mitsuba's linear falloff between them; the cone is hard here: 0.005 rad);
* no sky, no emissive surfaces.
"""

import argparse
import io
import json
import math
import os
import struct
import sys
import time

import numpy as np
from PIL import Image

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_GLB = os.path.normpath(
    os.path.join(HERE, "..", "..", "..", "shared", "scenes", "lamp-room", "lamp-room.glb"))


# ---------------------------------------------------------------------------------------------
# glb parsing (only what lamp-room uses: float/uint index accessors, TRS or matrix nodes)

COMPONENT = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32,
             5126: np.float32}
NCOMP = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


def read_glb(path):
    data = open(path, "rb").read()
    magic, _version, _length = struct.unpack("<4sII", data[:12])
    if magic != b"glTF":
        sys.exit(f"{path}: not a glb file")
    off = 12
    gltf, binary = None, None
    while off < len(data):
        clen, ctype = struct.unpack("<I4s", data[off:off + 8])
        chunk = data[off + 8:off + 8 + clen]
        if ctype == b"JSON":
            gltf = json.loads(chunk)
        elif ctype == b"BIN\0":
            binary = chunk
        off += 8 + clen
    return gltf, binary


def buffer_view_bytes(gltf, binary, index):
    bv = gltf["bufferViews"][index]
    start = bv.get("byteOffset", 0)
    return bv, binary[start:start + bv["byteLength"]]


def accessor(gltf, binary, index):
    acc = gltf["accessors"][index]
    bv, raw = buffer_view_bytes(gltf, binary, acc["bufferView"])
    dtype = np.dtype(COMPONENT[acc["componentType"]])
    n = NCOMP[acc["type"]]
    stride = bv.get("byteStride", dtype.itemsize * n)
    start = acc.get("byteOffset", 0)
    out = np.empty((acc["count"], n), dtype)
    for i in range(acc["count"]):
        o = start + i * stride
        out[i] = np.frombuffer(raw[o:o + dtype.itemsize * n], dtype)
    if acc.get("normalized"):
        out = out.astype(np.float64) / np.iinfo(dtype).max
    return out if n > 1 else out[:, 0]


def quat_matrix(q):
    x, y, z, w = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def local_matrix(node):
    if "matrix" in node:
        return np.array(node["matrix"], dtype=np.float64).reshape(4, 4).T  # column-major
    m = np.eye(4)
    s = np.array(node.get("scale", [1, 1, 1]), dtype=np.float64)
    m[:3, :3] = quat_matrix(node.get("rotation", [0, 0, 0, 1])) @ np.diag(s)
    m[:3, 3] = node.get("translation", [0, 0, 0])
    return m


def walk_nodes(gltf):
    """(node, world matrix) for every node reachable from the default scene."""
    scene = gltf["scenes"][gltf.get("scene", 0)]
    stack = [(i, np.eye(4)) for i in scene["nodes"]]
    while stack:
        i, parent = stack.pop()
        node = gltf["nodes"][i]
        world = parent @ local_matrix(node)
        yield node, world
        stack.extend((c, world) for c in node.get("children", []))


def srgb_to_linear(c):
    c = np.asarray(c, dtype=np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


# ---------------------------------------------------------------------------------------------
# Mitsuba scene


def material_bsdf(mi, gltf, binary, mat_index, stats):
    mat = gltf["materials"][mat_index]
    pbr = mat.get("pbrMetallicRoughness", {})
    factor = np.array(pbr.get("baseColorFactor", [1, 1, 1, 1]), dtype=np.float64)
    if pbr.get("metallicFactor", 1.0) > 0.01:
        sys.exit(f"material {mat.get('name')}: only Lambert (metallic ≤ 0.01) is modelled here")
    tex_info = pbr.get("baseColorTexture")
    rgba = None
    if tex_info is not None:
        if tex_info.get("texCoord", 0) != 0:
            sys.exit("only texCoord 0 is modelled here")
        tex = gltf["textures"][tex_info["index"]]
        sampler = gltf["samplers"][tex["sampler"]] if "sampler" in tex else {}
        if sampler.get("magFilter") != 9728 or sampler.get("wrapS", 10497) != 10497 \
                or sampler.get("wrapT", 10497) != 10497:
            sys.exit("only NEAREST / REPEAT texture samplers are modelled here")
        image = gltf["images"][tex["source"]]
        _, png = buffer_view_bytes(gltf, binary, image["bufferView"])
        rgba = np.array(Image.open(io.BytesIO(png)).convert("RGBA"), dtype=np.float64) / 255.0
    if rgba is None:
        reflectance = {"type": "rgb", "value": factor[:3].tolist()}
    else:
        albedo = srgb_to_linear(rgba[..., :3]) * factor[:3]
        reflectance = {"type": "bitmap", "data": mi.TensorXf(albedo.astype(np.float32)), "raw": True,
                       "filter_type": "nearest", "wrap_mode": "repeat"}
    bsdf = {"type": "twosided", "material": {"type": "diffuse", "reflectance": reflectance}}
    if mat.get("alphaMode") == "MASK":
        cutoff = mat.get("alphaCutoff", 0.5)
        alpha = factor[3] * (rgba[..., 3] if rgba is not None else np.ones((1, 1)))
        opacity = (alpha >= cutoff).astype(np.float32)[..., None]
        stats.append(f"mask '{mat.get('name')}': {opacity.size} texels, "
                     f"{100 * (1 - opacity.mean()):.1f} % cut (no surface)")
        bsdf = {"type": "mask",
                "opacity": {"type": "bitmap", "data": mi.TensorXf(opacity), "raw": True,
                            "filter_type": "nearest", "wrap_mode": "repeat"},
                "material": bsdf}
    elif mat.get("alphaMode") == "BLEND":
        stats.append(f"material '{mat.get('name')}': BLEND rendered opaque")
    return bsdf


def build_scene_dict(mi, glb, args, stats):
    gltf, binary = read_glb(glb)
    width, height = (int(x) for x in args.size.lower().split("x"))
    scene = {"type": "scene",
             "integrator": {"type": args.integrator, "max_depth": args.max_depth}}
    lights = gltf.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])
    n_cam = 0
    for node, world in walk_nodes(gltf):
        rot = world[:3, :3]
        pos = world[:3, 3]
        if "camera" in node and node["camera"] == args.camera:
            cam = gltf["cameras"][node["camera"]]["perspective"]
            fwd = rot @ np.array([0.0, 0.0, -1.0])
            up = rot @ np.array([0.0, 1.0, 0.0])
            scene["sensor"] = {
                "type": "perspective", "fov_axis": "y", "fov": math.degrees(cam["yfov"]),
                "near_clip": cam.get("znear", 0.01), "far_clip": cam.get("zfar", 1000.0),
                "to_world": mi.ScalarTransform4f().look_at(
                    origin=pos.tolist(), target=(pos + fwd).tolist(), up=up.tolist()),
                "sampler": {"type": "independent", "sample_count": args.spp, "seed": args.seed},
                "film": {"type": "hdrfilm", "width": width, "height": height,
                         "rfilter": {"type": "box"}, "pixel_format": "rgb",
                         "component_format": "float32"},
            }
            n_cam += 1
        ext = node.get("extensions", {}).get("KHR_lights_punctual")
        if ext is not None:
            light = lights[ext["light"]]
            rgb = (np.array(light.get("color", [1, 1, 1])) * light.get("intensity", 1.0)).tolist()
            if "range" in light:
                stats.append("light range ignored")
            if light["type"] == "point":
                scene[f"light{ext['light']}"] = {
                    "type": "point", "position": pos.tolist(),
                    "intensity": {"type": "rgb", "value": rgb}}
            elif light["type"] == "spot":
                spot = light.get("spot", {})
                outer = spot.get("outerConeAngle", math.pi / 4)
                inner = spot.get("innerConeAngle", 0.0)
                d = rot @ np.array([0.0, 0.0, -1.0])
                d /= np.linalg.norm(d)
                helper_up = [0.0, 1.0, 0.0] if abs(d[1]) < 0.9 else [1.0, 0.0, 0.0]
                scene[f"light{ext['light']}"] = {
                    "type": "spot", "intensity": {"type": "rgb", "value": rgb},
                    "cutoff_angle": math.degrees(outer), "beam_width": math.degrees(inner),
                    "to_world": mi.ScalarTransform4f().look_at(
                        origin=pos.tolist(), target=(pos + d).tolist(), up=helper_up)}
            else:
                sys.exit(f"light type {light['type']} not modelled here")
        if "mesh" in node:
            mesh = gltf["meshes"][node["mesh"]]
            normal_matrix = np.linalg.inv(rot).T
            flip = np.linalg.det(rot) < 0
            for p_i, prim in enumerate(mesh["primitives"]):
                if prim.get("mode", 4) != 4:
                    sys.exit("only triangle lists are modelled here")
                attr = prim["attributes"]
                p = accessor(gltf, binary, attr["POSITION"]).astype(np.float64)
                p = p @ rot.T + pos
                idx = accessor(gltf, binary, prim["indices"]).astype(np.uint32).reshape(-1, 3)
                if flip:
                    idx = idx[:, ::-1]
                has_n = "NORMAL" in attr
                has_uv = "TEXCOORD_0" in attr
                m = mi.Mesh(f"{mesh['name']}_{p_i}", vertex_count=len(p), face_count=len(idx),
                            has_vertex_normals=has_n, has_vertex_texcoords=has_uv)
                params = mi.traverse(m)
                params["vertex_positions"] = p.astype(np.float32).ravel()
                params["faces"] = idx.ravel()
                if has_n:
                    n = accessor(gltf, binary, attr["NORMAL"]).astype(np.float64) @ normal_matrix.T
                    n /= np.linalg.norm(n, axis=1, keepdims=True)
                    params["vertex_normals"] = n.astype(np.float32).ravel()
                    # How far the NORMALs are from the faces' own normals (flat meshes: ~0).
                    fn = np.cross(p[idx[:, 1]] - p[idx[:, 0]], p[idx[:, 2]] - p[idx[:, 0]])
                    fn /= np.linalg.norm(fn, axis=1, keepdims=True)
                    dev = max(np.abs(np.abs(np.sum(n[idx[:, k]] * fn, axis=1)) - 1).max()
                              for k in range(3))
                    stats.append(f"mesh '{mesh['name']}': {len(idx)} triangles, NORMALs "
                                 f"{'smooth' if dev > 1e-4 else 'flat'} (max 1−|n·n_face| {dev:.1e})")
                if has_uv:
                    uv = accessor(gltf, binary, attr["TEXCOORD_0"]).astype(np.float32)
                    # glTF's UV origin is the image's top-left, as Mitsuba's bitmap lookup
                    # (whose OBJ/PLY loaders flip v to get there): passed unchanged.
                    params["vertex_texcoords"] = uv.ravel()
                params.update()
                bsdf = material_bsdf(mi, gltf, binary, prim.get("material", 0), stats) \
                    if "material" in prim else \
                    {"type": "twosided", "material": {"type": "diffuse"}}
                m.set_bsdf(mi.load_dict(bsdf))
                scene[f"{mesh['name']}_{p_i}".replace(" ", "_")] = m
    if n_cam != 1:
        sys.exit(f"camera {args.camera} not found once in the default scene")
    return scene


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--glb", default=DEFAULT_GLB)
    ap.add_argument("--integrator", default="path", choices=["path", "volpath", "prbvolpath"])
    ap.add_argument("--spp", type=int, default=1024)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--max-depth", type=int, default=-1)
    ap.add_argument("--camera", type=int, default=0)
    ap.add_argument("--size", default="256x256")
    ap.add_argument("--pass-spp", type=int, default=1024, help="samples per render pass")
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("-o", "--output", required=True, help="EXR to write")
    args = ap.parse_args()

    import mitsuba as mi
    mi.set_variant(args.variant)
    stats = []
    scene_dict = build_scene_dict(mi, args.glb, args, stats)
    for s in stats:
        print(s)
    scene = mi.load_dict(scene_dict)
    # Rendered in passes of at most --pass-spp samples (a wavefront of 256² × 8192 lanes would
    # not fit in memory), each with its own seed, and averaged: the same estimator.
    passes = max(1, -(-args.spp // args.pass_spp))
    if args.spp % passes:
        sys.exit(f"--spp {args.spp} is not a multiple of its {passes} passes")
    t0 = time.time()
    image = 0.0
    for i in range(passes):
        part = mi.render(scene, seed=args.seed * 1000 + i, spp=args.spp // passes)
        image = image + np.array(part, dtype=np.float64)  # forces evaluation (llvm is lazy)
    image = (image / passes).astype(np.float32)
    dt = time.time() - t0
    mi.Bitmap(image[..., :3]).write(args.output)
    print(f"{args.integrator}, {args.spp} spp, seed {args.seed}, {args.variant}: "
          f"{dt:.1f} s rendering → {args.output}; mean RGB {image[..., :3].mean(axis=(0, 1))}")


if __name__ == "__main__":
    main()
