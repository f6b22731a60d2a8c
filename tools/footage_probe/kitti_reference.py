#!/usr/bin/env python3
"""Reference horizon for hf_footage_probe on KITTI (standard library only): where the Velodyne's x-y plane vanishes
through Tr_velo_to_cam, R0_rect and P2. usage: kitti_reference.py CALIB_TXT (KITTI tracking format)."""
import json
import math
import sys


def main():
    m = {}
    for line in open(sys.argv[1]):
        if ":" in line:
            k, v = line.split(":", 1)
            m[k.strip()] = [float(x) for x in v.split()]
    P = [m["P2"][i * 4:(i + 1) * 4] for i in range(3)]
    R0 = [m["R0_rect"][i * 3:(i + 1) * 3] for i in range(3)]
    Tr = [m["Tr_velo_to_cam"][i * 4:(i + 1) * 4] for i in range(3)]
    mul = lambda A, v: [sum(A[i][j] * v[j] for j in range(len(v))) for i in range(len(A))]

    def vanish(d):  # a direction in velodyne axes -> pixel of its point at infinity
        c = mul(R0, [sum(Tr[i][j] * d[j] for j in range(3)) for i in range(3)])
        p = mul(P, c + [0.0])
        return p[0] / p[2], p[1] / p[2]

    fx, cx, cy = P[0][0], P[0][2], P[1][2]
    f = vanish([1, 0, 0])
    a, b = vanish([1, 1, 0]), vanish([1, -1, 0])
    slope = (a[1] - b[1]) / (a[0] - b[0])
    horizon = f[1] + slope * (cx - f[0])
    roll = math.atan(-slope * fx / P[1][1])
    pitch = math.atan((cy - horizon) * math.cos(roll) / P[1][1])
    print(json.dumps({"forward_vanishing_point": f, "horizon_y_at_cx": horizon, "horizon_slope": slope,
                      "pitch_deg": math.degrees(pitch), "roll_deg": math.degrees(roll)}, indent=1))


if __name__ == "__main__":
    main()
