#!/usr/bin/env python3
"""Reference for hf_footage_probe on a nuScenes scene (standard library only).

Writes the scene's CAM_FRONT keyframes as a probe list (image path, seconds since the first frame, reference speed
from consecutive ego poses) and prints the calibrated camera's horizon row at cx, pitch, roll, height, yaw rates.
With --lever it also prints, per keyframe pair, what the poses and the calibration say the lever-arm scale
(plugins/source/common/lever_arm.cpp) would see: the turn, the camera's direction of travel in the previous ego
axes, the rear axle's own direction minus half the turn (its crab), and the chord the lever-arm model gives from
those exact values against the poses' chord.
usage: nuscenes_reference.py DATAROOT SCENE_NAME OUT_LIST [--lever]
"""
import json
import math
import os
import sys


def rotation(q):
    w, x, y, z = q
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]


def lever_arm_chord(turn, heading, lever):
    """The chord the rear axle drove, as lever_arm.cpp solves it (None when the pair does not fix it)."""
    den = math.sin(heading - 0.5 * turn)
    num = lever * (math.sin(turn) * math.cos(heading) + (1 - math.cos(turn)) * math.sin(heading))
    return num / den if abs(den) > 1e-9 and num / den > 0 else None


def lever_check(poses, cam_translation):
    """poses: [(R, translation)] per keyframe; prints the per-pair table and the model's error on the bends."""
    mul = lambda M, v: [sum(M[i][j] * v[j] for j in range(3)) for i in range(3)]
    mul_t = lambda M, v: [sum(M[j][i] * v[j] for j in range(3)) for i in range(3)]
    lever = cam_translation[0]
    print("pair turn_deg camera_heading_deg rear_axle_crab_deg chord_m model_chord_m model_error")
    errors = []
    for k in range(1, len(poses)):
        (R0, p0), (R1, p1) = poses[k - 1], poses[k]
        c0 = [a + b for a, b in zip(p0, mul(R0, cam_translation))]
        c1 = [a + b for a, b in zip(p1, mul(R1, cam_translation))]
        d = mul_t(R0, [a - b for a, b in zip(c1, c0)])
        o = mul_t(R0, [a - b for a, b in zip(p1, p0)])
        turn = (math.atan2(R1[1][0], R1[0][0]) - math.atan2(R0[1][0], R0[0][0]) + math.pi) % (2 * math.pi) - math.pi
        heading = math.atan2(d[1], d[0])
        chord = math.dist(p0[:2], p1[:2])
        model = lever_arm_chord(turn, heading, lever) if abs(turn) >= math.radians(2) else None
        if model:
            errors.append(model / chord - 1)
        print(f"{k} {math.degrees(turn):.3f} {math.degrees(heading):.3f} "
              f"{math.degrees(math.atan2(o[1], o[0]) - turn / 2):+.3f} {chord:.3f} "
              + (f"{model:.3f} {100 * (model / chord - 1):+.1f}%" if model else "- -"))
    if errors:
        a = sorted(abs(e) for e in errors)
        print(f"pairs turning >= 2 deg: {len(errors)}, model error median |{100 * a[len(a) // 2]:.1f}| %, "
              f"range {100 * min(errors):+.1f} .. {100 * max(errors):+.1f} %")


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
    R = rotation(c["rotation"])  # camera -> ego
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
    if "--lever" in sys.argv[4:]:
        lever_check([(rotation(ep[r["ego_pose_token"]]["rotation"]), ep[r["ego_pose_token"]]["translation"])
                     for r in rows], c["translation"])


if __name__ == "__main__":
    main()
