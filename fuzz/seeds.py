#!/usr/bin/env python3
"""Writes starting inputs for the reader fuzz targets into fuzz/corpus/<target>/: small valid
files of each kind (a session zip with EXR layers and an embedded OBJ, scenes, OBJ meshes,
presets with a PNG tip, EXR images, a MERL header), so that the fuzzers start from the
formats' structure instead of finding it byte by byte. Run from anywhere:
python3 fuzz/seeds.py"""

import io
import pathlib
import struct
import zipfile
import zlib

FUZZ = pathlib.Path(__file__).resolve().parent
ROOT = FUZZ.parent
CORPUS = FUZZ / "corpus"


def exr(width, height, channels, pixel):
    """An uncompressed scan-line OpenEXR image of 32-bit float channels (sorted by name, as
    the format requires); pixel(x, y) gives the values in that order."""
    channels = sorted(channels)

    def attribute(name, kind, value):
        return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value

    chlist = b"".join(c.encode() + b"\0" + struct.pack("<iBBBBii", 2, 0, 0, 0, 0, 1, 1) for c in channels) + b"\0"
    box = struct.pack("<iiii", 0, 0, width - 1, height - 1)
    header = b"".join([
        attribute("channels", "chlist", chlist),
        attribute("compression", "compression", b"\0"),
        attribute("dataWindow", "box2i", box),
        attribute("displayWindow", "box2i", box),
        attribute("lineOrder", "lineOrder", b"\0"),
        attribute("pixelAspectRatio", "float", struct.pack("<f", 1.0)),
        attribute("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0)),
        attribute("screenWindowWidth", "float", struct.pack("<f", 1.0)),
    ]) + b"\0"
    start = 8 + len(header) + 8 * height
    lines, offset = [], start
    for y in range(height):
        data = b"".join(
            struct.pack("<f", pixel(x, y)[c]) for c in range(len(channels)) for x in range(width)
        )
        lines.append(struct.pack("<ii", y, len(data)) + data)
    offsets = []
    for line in lines:
        offsets.append(offset)
        offset += len(line)
    return (b"\x76\x2f\x31\x01" + struct.pack("<I", 2) + header
            + b"".join(struct.pack("<Q", o) for o in offsets) + b"".join(lines))


def png(width, height, grey):
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    raw = b"".join(b"\0" + bytes(grey(x, y) for x in range(width)) for y in range(height))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def write(target, name, data):
    folder = CORPUS / target
    folder.mkdir(parents=True, exist_ok=True)
    (folder / name).write_bytes(data if isinstance(data, bytes) else data.encode())


TETRA = "v 0 0 1\nv 0.94 0 -0.33\nv -0.47 0.82 -0.33\nv -0.47 -0.82 -0.33\nf 1 3 2\nf 1 4 3\nf 1 2 4\nf 2 3 4\n"
SCENE = """object = "sphere"
resolution = 4
shadows = true
tangent_reference = [1.0, 0.0, 0.0]

[light]
elevation_deg = 45.0
azimuth_deg = 30.0

[camera]
projection = "orthographic"
fov_deg = 30.0
yaw_deg = 0.0
pitch_deg = 0.0
"""
MANIFEST = """format_version = 1
active_view = 0

[brush]
kind = "round"
size = 40.0
hardness = 0.8
opacity = 1.0
flow = 1.0
spacing = 0.15
colour = [0.5, 0.5, 0.5]
pressure_size = true
pressure_flow = false

[basis]
components = 20
materials = 300
regularization = "auto"
policy = "mean"
"""


def session(views):
    out = io.BytesIO()
    manifest = MANIFEST
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
        for i, (scene, obj) in enumerate(views, start=1):
            manifest += f'\n[[views]]\nname = "View {i}"\nmuted = false\nbase_dir = ""\n'
            z.writestr(f"views/{i}/scene.toml", scene)
            z.writestr(f"views/{i}/colour.exr", exr(4, 4, "RGB", lambda x, y: (0.1 * x, 0.2, 3.0 * y)))
            z.writestr(f"views/{i}/coverage.exr", exr(4, 4, "Y", lambda x, y: (0.25 * (x % 2),)))
            if obj:
                z.writestr(f"views/{i}/object.obj", TETRA)
        z.writestr("session.toml", manifest)
    return out.getvalue()


write("session_zip", "sphere.burnish", session([(SCENE, False)]))
write("session_zip", "two-views.burnish", session([(SCENE, False), (SCENE.replace('"sphere"', '"meshes/tetra.obj"'), True)]))

for path in (ROOT / "assets").rglob("*.toml"):
    write("scene_toml", path.name, path.read_text())
write("scene_toml", "small.toml", SCENE)
write("scene_toml", "perspective.toml", SCENE.replace('"orthographic"', '"perspective"'))

for path in (ROOT / "assets").rglob("*.obj"):
    write("obj_mesh", path.name, path.read_bytes())
write("obj_mesh", "tetra.obj", TETRA)
write("obj_mesh", "quads.obj", "o a\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\ng b\nv 0 0 1\nf -1 -2 -3\n")

tip = png(8, 8, lambda x, y: 255 - 30 * abs(x - 4))
for path in (ROOT / "brushes").glob("*.toml"):
    text = path.read_text()
    write("brush_preset", path.name, text.encode() + (b"\0" + tip if "tip" in text else b""))
write("brush_preset", "tip.toml", b'name = "Tip"\ntip = "t.png"\n[brush]\nsize = 9.0\n\0' + tip)

write("exr_table", "rgb.exr", exr(3, 2, "RGB", lambda x, y: (x, y, 0.5)))
write("exr_table", "rgba.exr", exr(2, 2, "ABGR", lambda x, y: (1.0, 0.1, 0.2, 0.3)))

def layers(side, colour, coverage):
    """The paint_layers input: the side byte, a split byte that lands exactly between the two
    layers (the target splits at byte * len / 255), then the layers."""
    rest = colour + coverage
    for split in range(256):
        if split * len(rest) // 255 == len(colour):
            return bytes([side - 1, split]) + rest
    # No byte lands exactly: pad the coverage layer until one does.
    return layers(side, colour, coverage + b"\0")


write("paint_layers", "layers", layers(4, exr(4, 4, "RGB", lambda x, y: (0.5, 1.0, 2.0)), exr(4, 4, "Y", lambda x, y: (0.5,))))
write("paint_layers", "png", bytes([3, 0]) + png(4, 4, lambda x, y: 40 * x))

write("merl_binary", "header", struct.pack("<iii", 90, 90, 180) + struct.pack("<ddd", 0.1, -1.0, 2.0))
print("seeds written under", CORPUS)
