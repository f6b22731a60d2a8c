#!/usr/bin/env python3
"""Independent, strict reader of a HazardForge KITTI tracking export (docs: FORMATS section 3).

Written from the KITTI tracking devkit's description of the label files, not from HazardForge's
exporter, so that the two can check each other. Usage:

    python3 read_kitti_tracking.py OUT_DIR     # prints a JSON summary, exits 1 on the first violation
    python3 read_kitti_tracking.py --self-test

label_02/SSSS.txt has one object per line, 17 space-separated fields (devkit order):
  frame track_id type truncated occluded alpha left top right bottom height width length x y z rotation_y
The box is in 0-based pixel coordinates, so it must lie within [0, width-1] x [0, height-1] of the frame's
image_02/SSSS/NNNNNN.png. Two deliberate narrowings of the devkit, both from HazardForge's format:
track ids are >= 0 (no DontCare rows with id -1); truncated is one of the tracking devkit's levels 0, 1,
2 (not the object benchmark's fraction). A label whose 3D box is unknown carries the devkit's
invalid values all together: alpha -10, dimensions -1, location -1000, rotation_y -10.
ttc_02/SSSS.txt has "frame track_id ttc_s" (ttc_s "nan" when not closing) for every labelled object.
Summary "frames" counts the PNG images of image_02.
"""
import json
import math
import os
import re
import shutil
import struct
import sys
import tempfile
import zlib

TYPES = {"Car", "Van", "Truck", "Pedestrian", "Person_sitting", "Cyclist", "Tram", "Misc", "DontCare"}
CALIB_SIZES = {"P0": 12, "P1": 12, "P2": 12, "P3": 12, "R_rect": 9, "R0_rect": 9,
               "Tr_velo_cam": 12, "Tr_velo_to_cam": 12, "Tr_imu_velo": 12, "Tr_imu_to_velo": 12}
# The devkit's "unknown" values (writeLabels.m defaults) for alpha, h w l, x y z, rotation_y, all together.
UNKNOWN_3D = [-10.0, -1.0, -1.0, -1.0, -1000.0, -1000.0, -1000.0, -10.0]
INT = re.compile(r"^[0-9]+$")
NUMBER = re.compile(r"^[-+]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][-+]?[0-9]+)?$")


class Violation(Exception):
    pass


def where(path, line):
    return "%s:%d" % (path, line) if line else path


def number(text, name, path, line):
    if not NUMBER.match(text) or not math.isfinite(float(text)):
        raise Violation("%s: %s %r is not a finite decimal number" % (where(path, line), name, text))
    return float(text)


def rounding_slack(text):
    """Half a unit in the last printed decimal: 3.141593 may be pi rounded to six decimals."""
    decimals = text.split(".")[1] if "." in text and "e" not in text.lower() else ""
    return 0.5 * 10.0 ** -len(decimals) if decimals else 1e-12


def integer(text, name, path, line):
    if not INT.match(text):
        raise Violation("%s: %s %r is not an integer >= 0" % (where(path, line), name, text))
    return int(text)


def png_size(path):
    with open(path, "rb") as f:
        head = f.read(24)
    if len(head) < 24 or head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
        raise Violation("%s: not a PNG file (no signature and IHDR chunk)" % path)
    return struct.unpack(">II", head[16:24])


def text_lines(path):
    with open(path, encoding="utf-8", newline="") as f:  # newline="": keep a "\r" to report it
        lines = f.read().split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    for n, line in enumerate(lines, 1):
        if not line.strip() or "\r" in line:
            raise Violation("%s: %s" % (where(path, n), "carriage return" if line.strip() else "empty line"))
    return list(enumerate(lines, 1))


def read_labels(path, image_dir):
    boxes, types, sizes = {}, {}, {}
    for n, line in text_lines(path):
        f = line.split(" ")  # single spaces: a doubled or trailing space makes an empty field
        if len(f) != 17:
            raise Violation("%s: %d fields, a KITTI tracking label has 17" % (where(path, n), len(f)))
        frame, track = integer(f[0], "frame", path, n), integer(f[1], "track_id", path, n)
        if f[2] not in TYPES:
            raise Violation("%s: type %r is not one of %s" % (where(path, n), f[2], ", ".join(sorted(TYPES))))
        if types.setdefault(track, f[2]) != f[2]:
            raise Violation("%s: track %d is %s here but %s before"
                            % (where(path, n), track, f[2], types[track]))
        if f[3] not in ("0", "1", "2"):
            raise Violation("%s: truncated %r is not 0, 1 or 2 (the tracking devkit's truncation levels)"
                            % (where(path, n), f[3]))
        if f[4] not in ("0", "1", "2", "3"):
            raise Violation("%s: occluded %r is not 0, 1, 2 or 3" % (where(path, n), f[4]))
        names = {5: "alpha", 6: "left", 7: "top", 8: "right", 9: "bottom", 10: "height", 11: "width",
                 12: "length", 13: "x", 14: "y", 15: "z", 16: "rotation_y"}
        v = {i: number(f[i], name, path, n) for i, name in names.items()}
        if [v[i] for i in (5, 10, 11, 12, 13, 14, 15, 16)] != UNKNOWN_3D:
            for i in (5, 16):
                if abs(v[i]) > math.pi + rounding_slack(f[i]):
                    raise Violation("%s: %s %s is outside [-pi, pi]" % (where(path, n), names[i], f[i]))
            for i in (10, 11, 12):
                if v[i] <= 0:
                    raise Violation("%s: dimension %s %s is not > 0" % (where(path, n), names[i], f[i]))
        left, top, right, bottom = v[6], v[7], v[8], v[9]
        if not (left < right and top < bottom):
            raise Violation("%s: box %s needs left < right and top < bottom" % (where(path, n), f[6:10]))
        image = os.path.join(image_dir, "%06d.png" % frame)
        if image not in sizes:
            if not os.path.isfile(image):
                raise Violation("%s: frame %d has no image %s" % (where(path, n), frame, image))
            sizes[image] = png_size(image)
        width, height = sizes[image]
        if left < 0 or top < 0 or right > width - 1 or bottom > height - 1:
            raise Violation("%s: box %s leaves the %dx%d image %s (0-based pixel coordinates: right <= %d,"
                            " bottom <= %d)" % (where(path, n), f[6:10], width, height, image, width - 1,
                                                height - 1))
        frame_boxes = boxes.setdefault(str(frame), {})
        if str(track) in frame_boxes:
            raise Violation("%s: track %d appears twice in frame %d" % (where(path, n), track, frame))
        frame_boxes[str(track)] = [left, top, right, bottom]
    return boxes, types


def read_calib(path):
    if not os.path.isfile(path):
        raise Violation("%s: calibration file missing" % path)
    found = {}
    for n, line in text_lines(path):
        key, _, rest = line.partition(" ")
        key = key.rstrip(":")
        values = [number(v, key, path, n) for v in rest.split()]
        if key in CALIB_SIZES and len(values) != CALIB_SIZES[key]:
            raise Violation("%s: %s has %d numbers, expected %d" % (where(path, n), key, len(values),
                                                                    CALIB_SIZES[key]))
        found[key] = values
    if "P2" not in found:
        raise Violation("%s: no P2 line (the left colour camera's 3x4 projection)" % path)


def read_ttc(path, boxes, types):
    if not os.path.isfile(path):
        raise Violation("%s: TTC sidecar missing" % path)
    seen = set()
    for n, line in text_lines(path):
        f = line.split(" ")
        if len(f) != 3:
            raise Violation("%s: %d fields, expected 'frame track_id ttc_s'" % (where(path, n), len(f)))
        frame, track = str(integer(f[0], "frame", path, n)), str(integer(f[1], "track_id", path, n))
        if f[2] != "nan" and number(f[2], "ttc_s", path, n) < 0:
            raise Violation("%s: ttc_s %s is negative" % (where(path, n), f[2]))
        if track not in boxes.get(frame, {}):
            raise Violation("%s: no label for frame %s track %s" % (where(path, n), frame, track))
        if (frame, track) in seen:
            raise Violation("%s: frame %s track %s listed twice" % (where(path, n), frame, track))
        seen.add((frame, track))
    for frame, tracks in boxes.items():
        for track in tracks:
            if (frame, track) not in seen and types[int(track)] != "DontCare":
                raise Violation("%s: no TTC line for frame %s track %s" % (path, frame, track))


def read_export(out):
    training = os.path.join(out, "training")
    label_dir = os.path.join(training, "label_02")
    if not os.path.isdir(label_dir):
        raise Violation("%s: no label_02 folder" % label_dir)
    names = sorted(os.listdir(label_dir))
    for name in names:
        if not re.match(r"^[0-9]{4}\.txt$", name):
            raise Violation("%s: not a SSSS.txt label file" % os.path.join(label_dir, name))
    listed = {}
    sequences_txt = os.path.join(out, "sequences.txt")
    if not os.path.isfile(sequences_txt):
        raise Violation("%s: missing" % sequences_txt)
    for n, line in text_lines(sequences_txt):
        f = line.split()
        if len(f) != 4 or not re.match(r"^[0-9]{4}$", f[0]):
            raise Violation("%s: expected 'SSSS folder kind object_class'" % where(sequences_txt, n))
        listed[f[0]] = f
    summary = {"sequences": 0, "frames": 0, "labels": 0, "boxes": {}}
    for name in names:
        sequence = name[:4]
        if sequence not in listed:
            raise Violation("%s: sequence %s is not listed" % (sequences_txt, sequence))
        image_dir = os.path.join(training, "image_02", sequence)
        boxes, types = read_labels(os.path.join(label_dir, name), image_dir)
        read_calib(os.path.join(training, "calib", name))
        read_ttc(os.path.join(training, "ttc_02", name), boxes, types)
        summary["sequences"] += 1
        summary["frames"] += len([p for p in os.listdir(image_dir) if p.endswith(".png")])
        summary["labels"] += sum(len(t) for t in boxes.values())
        summary["boxes"][sequence] = boxes
    return summary


def write_png(path, width, height):
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    rows = b"".join(b"\x00" + bytes([90, 120, 150]) * width for _ in range(height))
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)  # 8-bit RGB
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(rows))
                + chunk(b"IEND", b""))


def self_test():
    def build(root):
        t = os.path.join(root, "training")
        for d in ("image_02/0000", "label_02", "calib", "ttc_02"):
            os.makedirs(os.path.join(t, d))
        for frame in (0, 1):
            write_png(os.path.join(t, "image_02/0000/%06d.png" % frame), 64, 48)
        with open(os.path.join(t, "label_02/0000.txt"), "w") as f:
            f.write("0 0 Car 0 0 -1.57 10.00 12.00 40.00 30.00 1.50 1.70 4.20 0.50 1.60 12.00 -1.530000\n"
                    "1 0 Car 1 1 3.141593 20.00 14.00 63.00 47.00 1.50 1.70 4.20 0.40 1.60 9.00 -3.14\n"
                    "1 3 Pedestrian 0 0 -10 2 3 8 20 -1 -1 -1 -1000 -1000 -1000 -10\n")
        with open(os.path.join(t, "calib/0000.txt"), "w") as f:
            for key, count in (("P0:", 12), ("P1:", 12), ("P2:", 12), ("P3:", 12), ("R_rect", 9),
                               ("Tr_velo_cam", 12), ("Tr_imu_velo", 12)):
                f.write(key + " " + " ".join(["1.0"] * count) + "\n")
        with open(os.path.join(t, "ttc_02/0000.txt"), "w") as f:
            f.write("0 0 nan\n1 0 1.9\n1 3 nan\n")
        with open(os.path.join(root, "sequences.txt"), "w") as f:
            f.write("0000 cut_in_0001/scenario cut_in car\n")

    def edit(root, rel, old, new):
        path = os.path.join(root, rel)
        with open(path) as f:
            text = f.read()
        assert old in text, (rel, old)
        with open(path, "w") as f:
            f.write(text.replace(old, new, 1))

    broken = [("box past the image", "training/label_02/0000.txt", "63.00 47.00", "64.00 47.00", "leaves"),
              ("16 fields", "training/label_02/0000.txt", " -3.14\n", "\n", "16 fields"),
              ("track id -1", "training/label_02/0000.txt", "1 0 Car", "1 -1 Car", "track_id"),
              ("alpha past pi", "training/label_02/0000.txt", "3.141593", "3.15", "alpha"),
              ("half-unknown 3D box", "training/label_02/0000.txt", "-1 -1 -1 -1000", "1 1 1 -1000", "alpha"),
              ("TTC names no label", "training/ttc_02/0000.txt", "1 0 1.9", "1 7 1.9", "no label"),
              ("P2 short", "training/calib/0000.txt", "P2: 1.0 ", "P2: ", "P2 has 11")]
    root = tempfile.mkdtemp(prefix="kitti_tracking_selftest_")
    try:
        build(root)
        summary = read_export(root)
        assert summary["labels"] == 3 and summary["frames"] == 2, summary
        assert summary["boxes"]["0000"]["1"]["0"] == [20.0, 14.0, 63.0, 47.0], summary
        for what, rel, old, new, expected in broken:
            shutil.rmtree(root)
            build(root)
            edit(root, rel, old, new)
            try:
                read_export(root)
            except Violation as v:
                assert expected in str(v), (what, str(v))
                print("self-test: rejected (%s): %s" % (what, v), file=sys.stderr)
            else:
                raise AssertionError("accepted a broken export: " + what)
        shutil.rmtree(root)
        build(root)
        os.remove(os.path.join(root, "training/image_02/0000/000001.png"))
        try:
            read_export(root)
            raise AssertionError("accepted a label without an image")
        except Violation as v:
            assert "has no image" in str(v), str(v)
    finally:
        shutil.rmtree(root, ignore_errors=True)
    print("self-test passed")
    return 0


def main(argv):
    if len(argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    if argv[1] == "--self-test":
        return self_test()
    try:
        summary = read_export(argv[1])
    except (Violation, OSError, UnicodeDecodeError) as error:
        print("read_kitti_tracking: %s" % error, file=sys.stderr)
        return 1
    print(json.dumps(summary, sort_keys=True))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
