"""Renders Burnish's sphere scene with Mitsuba 3 and a measured (.bsdf) material.

Used by tests/export.rs: the scene is SCENE.md's default with an orthographic camera on +z
seeing [-1, 1]^2, a unit sphere at the origin and one directional light of irradiance pi
(so a pixel shows pi * f_r * cos(theta_l), as `burnish render` does).

usage: render_sphere.py VARIANT BSDF OUT.exr RESOLUTION SPP ELEVATION_DEG AZIMUTH_DEG
"""
import math
import sys

import mitsuba as mi


def main():
    variant, bsdf, out = sys.argv[1], sys.argv[2], sys.argv[3]
    resolution, spp = int(sys.argv[4]), int(sys.argv[5])
    elevation, azimuth = math.radians(float(sys.argv[6])), math.radians(float(sys.argv[7]))
    mi.set_variant(variant)
    # SCENE.md: the direction toward the light; Mitsuba wants the direction light travels.
    light = [
        math.cos(elevation) * math.sin(azimuth),
        math.sin(elevation),
        math.cos(elevation) * math.cos(azimuth),
    ]
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0},
        "sensor": {
            "type": "orthographic",
            "to_world": mi.ScalarTransform4f().look_at(
                origin=[0, 0, 5], target=[0, 0, 0], up=[0, 1, 0]
            ),
            "film": {
                "type": "hdrfilm",
                "width": resolution,
                "height": resolution,
                "pixel_format": "rgb",
                "rfilter": {"type": "box"},
            },
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "sphere": {
            "type": "sphere",
            "center": [0, 0, 0],
            "radius": 1.0,
            "bsdf": {"type": "measured", "filename": bsdf},
        },
        "light": {
            "type": "directional",
            "direction": [-c for c in light],
            "irradiance": {"type": "rgb", "value": [math.pi] * 3},
        },
    })
    image = mi.render(scene)
    mi.Bitmap(image).write(out)


if __name__ == "__main__":
    main()
