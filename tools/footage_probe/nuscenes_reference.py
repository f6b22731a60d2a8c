#!/usr/bin/env python3
"""Reference for hf_footage_probe on a nuScenes scene (standard library only).

Writes the scene's CAM_FRONT keyframes as a probe list (image path, seconds since the first frame, reference speed
from consecutive ego poses) and prints the calibrated camera's horizon row at cx, pitch, roll, height, yaw rates.
usage: nuscenes_reference.py DATAROOT SCENE_NAME OUT_LIST
"""
import json
import math
import os
import sys


def main():
    root, scene_name, out = sys.argv[1], sys.argv[2], sys.argv[3]
    table = lambda n: json.load(open(f"{root}/v1.0-mini/{n}.json"))
    scene = next(s for s in table("scene") if s["name"] == scene_name)
    samples = {s["token"]: s for s in table("sample")}
    cs = {c["token"]: c for c in table("calibrated_sensor")}
    ep = {e["token"]: e for e in table("ego_pose")}
    cam = {r["sample_token"]: r for r in table("sample_data")
           if r["is_key_frame"] and "/CAM_FRONT/" in "/" + r["filename"]}
    rows, tok = [], scene["first_sample_token"]
    while tok:
        rows.append(cam[tok])
        tok = samples[tok]["next"]
    c = cs[rows[0]["calibrated_sensor_token"]]
    w, x, y, z = c["rotation"]  # camera -> ego
    R = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
         [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
         [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    K = c["camera_intrinsic"]
    fx, cx, fy, cy = K[0][0], K[0][2], K[1][1], K[1][2]
    up = R[2]  # ego z in camera axes (third row of R = R^T e_z)
    horizon = cy - fy * up[2] / up[1]  # vanishing line of the ego x-y plane at column cx (includes roll)
    right = [R[i][0] for i in range(3)]
    down = [R[i][1] for i in range(3)]
    axis = [R[i][2] for i in range(3)]
    pitch = math.atan2(-axis[2], math.hypot(axis[0], axis[1]))
    roll = math.atan2(-right[2], -down[2])
    t0 = rows[0]["timestamp"] * 1e-6
    prev = None
    speeds, yaws = [], []
    with open(out, "w") as f:
        for r in rows:
            e = ep[r["ego_pose_token"]]
            t = r["timestamp"] * 1e-6
            qw, qx, qy, qz = e["rotation"]
            yaw = math.atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))
            ref = ""
            if prev:
                v = math.dist(e["translation"][:2], prev[0][:2]) / (t - prev[1])
                d = (yaw - prev[2] + math.pi) % (2 * math.pi) - math.pi
                speeds.append(v)
                yaws.append(d / (t - prev[1]))
                ref = f" {v:.4f}"
            f.write(f"{os.path.abspath(os.path.join(root, r['filename']))} {t - t0:.6f}{ref}\n")
            prev = (e["translation"], t, yaw)
    print(json.dumps({"frames": len(rows), "fx": fx, "fy": fy, "cx": cx, "cy": cy,
                      "height_m": c["translation"][2], "forward_m": c["translation"][0],
                      "horizon_y_at_cx": horizon, "pitch_deg": math.degrees(pitch), "roll_deg": math.degrees(roll),
                      "speed_mps": [round(v, 3) for v in speeds], "yaw_rate": [round(v, 3) for v in yaws]}, indent=1))


if __name__ == "__main__":
    main()
