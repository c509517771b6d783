#!/usr/bin/env python3
"""Write `kalibr_pyyaml.yaml`: a three-camera camchain in Kalibr's layout, written by another YAML
writer than spmcal's — PyYAML's `safe_dump`, as Kalibr itself writes its camchains (keys sorted,
so `T_cn_cnm1` first; lists of numbers in flow style, `T_cn_cnm1` as a block of flow rows; floats
as Python's shortest repr, `1.0e-05` for 1e-05; Kalibr's `rostopic` and `cam_overlaps` beside).

tests/pixel_sessions.rs reads it and checks every number against the values below, which it
holds too. Run from anywhere: python3 tests/data/camchain/make_camchain.py
"""
import math
import os

import yaml

HERE = os.path.dirname(os.path.abspath(__file__))


def rotation(axis_angle):
    """Rodrigues' formula: the rotation matrix of the rotation vector `axis_angle` (rad)."""
    angle = math.sqrt(sum(c * c for c in axis_angle))
    x, y, z = (c / angle for c in axis_angle)
    c, s, v = math.cos(angle), math.sin(angle), 1.0 - math.cos(angle)
    return [
        [c + x * x * v, x * y * v - z * s, x * z * v + y * s],
        [y * x * v + z * s, c + y * y * v, y * z * v - x * s],
        [z * x * v - y * s, z * y * v + x * s, c + z * z * v],
    ]


def transform(axis_angle, translation):
    r = rotation(axis_angle)
    return [r[0] + [translation[0]], r[1] + [translation[1]], r[2] + [translation[2]], [0.0, 0.0, 0.0, 1.0]]


def camera(intrinsics, model, coefficients, topic, overlaps, to_previous=None):
    out = {
        "camera_model": "pinhole",
        "intrinsics": intrinsics,
        "distortion_model": model,
        "distortion_coeffs": coefficients,
        "resolution": [752, 480],
        "rostopic": topic,
        "cam_overlaps": overlaps,
    }
    if to_previous is not None:
        out["T_cn_cnm1"] = transform(*to_previous)
    return out


chain = {
    "cam0": camera([458.654, 457.296, 367.215, 248.375], "radtan", [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05], "/cam0/image_raw", [1]),
    "cam1": camera([457.587, 456.134, 379.999, 255.238], "radtan", [-0.28368365, 0.07451284, -0.00010473, -3.55590700e-05], "/cam1/image_raw", [0, 2],
                   ([0.0141, -0.0003, 0.0023], [-0.110073808127187, 0.000399121547014, -0.000853702503357])),
    "cam2": camera([460.0, 459.5, 370.25, 250.75], "equidistant", [0.01, -0.002, 1.0e-05, 0.0], "/cam2/image_raw", [1],
                   ([-0.02, 0.35, 0.001], [0.2, -0.01, 0.03])),
}

with open(os.path.join(HERE, "kalibr_pyyaml.yaml"), "w") as f:
    yaml.safe_dump(chain, f, default_flow_style=None)
print("wrote kalibr_pyyaml.yaml")
