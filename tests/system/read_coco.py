#!/usr/bin/env python3
"""Independent, strict reader of a HazardForge COCO export (docs: FORMATS section 4).

Written from the COCO data format's published description (cocodataset.org, "Data format", object
detection), not from HazardForge's exporter, so that the two can check each other. Usage:

    python3 read_coco.py OUT_DIR     # prints a JSON summary, exits 1 on the first violation
    python3 read_coco.py --self-test

OUT_DIR/annotations.json holds info, licenses, images, annotations and categories. image: id (int),
file_name (str), width, height (int); annotation: id, image_id, category_id (int), bbox [x, y, width,
height] measured from the image's top-left corner, area (number), iscrowd (0 or 1); category: id (int),
name (str). HazardForge adds track_id (int >= 0) and ttc_s (number or null) to each annotation, and uses
COCO's own ids for the classes it names. Image files are OUT_DIR/images/FILE_NAME, JPEGs whose frame
header (SOF0/SOF1/SOF2) must give the listed width and height.
"""
import json
import math
import os
import re
import shutil
import struct
import sys
import tempfile

EDGE = 1e-3  # pixels a box may pass the image edge by: float32 boxes add up with rounding errors
COCO_IDS = {"person": 1, "bicycle": 2, "car": 3, "motorcycle": 4, "bus": 6, "truck": 8}


class Violation(Exception):
    pass


def is_int(v):
    return isinstance(v, int) and not isinstance(v, bool)


def is_number(v):
    return (is_int(v) or isinstance(v, float)) and math.isfinite(v)


def jpeg_size(path):
    """(width, height) from the first SOF0/SOF1/SOF2 frame header."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:2] != b"\xff\xd8":
        raise Violation("%s: not a JPEG (no SOI marker)" % path)
    i = 2
    while i + 4 <= len(data):
        if data[i] != 0xFF:
            raise Violation("%s: byte %d is not a marker" % (path, i))
        marker = data[i + 1]
        if marker == 0xFF:  # fill byte
            i += 1
            continue
        if marker == 0x01 or 0xD0 <= marker <= 0xD7:  # standalone markers
            i += 2
            continue
        length = struct.unpack(">H", data[i + 2:i + 4])[0]
        if marker in (0xC0, 0xC1, 0xC2):
            if length < 8 or i + 9 > len(data):
                raise Violation("%s: truncated frame header" % path)
            height, width = struct.unpack(">HH", data[i + 5:i + 9])
            return width, height
        if marker in (0xDA, 0xD9):
            break
        i += 2 + length
    raise Violation("%s: no baseline or progressive frame header (SOF0/SOF1/SOF2) before the scan" % path)


def need(obj, key, check, what, where):
    if not isinstance(obj, dict):
        raise Violation("%s is not a JSON object" % where)
    if key not in obj:
        raise Violation("%s has no %r" % (where, key))
    if not check(obj[key]):
        raise Violation("%s: %r is %r, expected %s" % (where, key, obj[key], what))
    return obj[key]


def unique_ids(items, section, path):
    ids = {}
    for n, item in enumerate(items):
        where = "%s: %s[%d]" % (path, section, n)
        item_id = need(item, "id", is_int, "an integer", where)
        if item_id in ids:
            raise Violation("%s: id %d already used by %s[%d]" % (where, item_id, section, ids[item_id]))
        ids[item_id] = n
    return ids


def read_export(out):
    path = os.path.join(out, "annotations.json")
    try:
        with open(path, encoding="utf-8") as f:
            doc = json.load(f)
    except (OSError, ValueError) as error:
        raise Violation("%s: %s" % (path, error))
    need(doc, "info", lambda v: isinstance(v, dict), "an object", path)
    need(doc, "licenses", lambda v: isinstance(v, list), "a list", path)
    for key in ("images", "annotations", "categories"):
        need(doc, key, lambda v: isinstance(v, list), "a list", path)
    images, annotations, categories = doc["images"], doc["annotations"], doc["categories"]

    category_ids = unique_ids(categories, "categories", path)
    for n, c in enumerate(categories):
        name = need(c, "name", lambda v: isinstance(v, str) and v, "a name", "%s: categories[%d]" % (path, n))
        if name in COCO_IDS and c["id"] != COCO_IDS[name]:
            raise Violation("%s: categories[%d]: %s has id %d, COCO's is %d"
                            % (path, n, name, c["id"], COCO_IDS[name]))

    image_ids, by_id, files = unique_ids(images, "images", path), {}, {}
    for n, im in enumerate(images):
        where = "%s: images[%d]" % (path, n)
        name = need(im, "file_name", lambda v: isinstance(v, str) and v, "a file name", where)
        width = need(im, "width", lambda v: is_int(v) and v > 0, "an integer > 0", where)
        height = need(im, "height", lambda v: is_int(v) and v > 0, "an integer > 0", where)
        if name in files:
            raise Violation("%s: file_name %s already used by images[%d]" % (where, name, files[name]))
        files[name] = n
        if not re.match(r"^[0-9]{4}_[0-9]{6}\.jpg$", name) or im.get("sequence", name[:4]) != name[:4]:
            raise Violation("%s: file_name %s is not SSSS_NNNNNN.jpg of its sequence %r"
                            % (where, name, im.get("sequence")))
        file_path = os.path.join(out, "images", name)
        if not os.path.isfile(file_path):
            raise Violation("%s: image file %s is missing" % (where, file_path))
        if jpeg_size(file_path) != (width, height):
            raise Violation("%s: %s is %dx%d, the entry says %dx%d"
                            % ((where, file_path) + jpeg_size(file_path) + (width, height)))
        by_id[im["id"]] = im
    listed = set(files)
    for name in sorted(os.listdir(os.path.join(out, "images"))):
        if name not in listed:
            raise Violation("%s: not listed in %s" % (os.path.join(out, "images", name), path))

    boxes = {im["file_name"]: [] for im in images}
    unique_ids(annotations, "annotations", path)
    tracks = set()
    for n, a in enumerate(annotations):
        where = "%s: annotations[%d]" % (path, n)
        image_id = need(a, "image_id", lambda v: v in image_ids if is_int(v) else False,
                        "the id of an image", where)
        category_id = need(a, "category_id", lambda v: v in category_ids if is_int(v) else False,
                           "the id of a category", where)
        bbox = need(a, "bbox", lambda v: isinstance(v, list) and len(v) == 4 and all(map(is_number, v)),
                    "[x, y, width, height]", where)
        area = need(a, "area", is_number, "a number", where)
        need(a, "iscrowd", lambda v: is_int(v) and v in (0, 1), "0 or 1", where)
        track = need(a, "track_id", lambda v: is_int(v) and v >= 0, "an integer >= 0", where)
        need(a, "ttc_s", lambda v: v is None or (is_number(v) and v >= 0), "null or a number >= 0", where)
        x, y, w, h = bbox
        im = by_id[image_id]
        if w <= 0 or h <= 0:
            raise Violation("%s: bbox %s has no area" % (where, bbox))
        if x < 0 or y < 0 or x + w > im["width"] + EDGE or y + h > im["height"] + EDGE:
            raise Violation("%s: bbox %s leaves the %dx%d image %s"
                            % (where, bbox, im["width"], im["height"], im["file_name"]))
        if abs(area - w * h) > 1e-6 * w * h:
            raise Violation("%s: area %r is not width*height %r" % (where, area, w * h))
        if (image_id, track) in tracks:
            raise Violation("%s: track %d appears twice in image %d" % (where, track, image_id))
        tracks.add((image_id, track))
        boxes[im["file_name"]].append([x, y, w, h, category_id, track])
    return {"images": len(images), "annotations": len(annotations), "boxes": boxes}


def baseline_jpeg(width, height):
    """A decodable mid-grey baseline JPEG (one component, every DCT coefficient zero)."""
    def segment(marker, payload):
        return b"\xff" + bytes([marker]) + struct.pack(">H", len(payload) + 2) + payload
    blocks = ((width + 7) // 8) * ((height + 7) // 8)
    bits = "00" * blocks  # per block: DC difference category 0 (code "0"), then end-of-block (code "0")
    bits += "1" * (-len(bits) % 8)
    scan = bytes(int(bits[i:i + 8], 2) for i in range(0, len(bits), 8))
    one_code = bytes([1] + [0] * 15) + b"\x00"  # one 1-bit code for symbol 0
    return (b"\xff\xd8" + segment(0xE0, b"JFIF\x00\x01\x01\x00\x00\x01\x00\x01\x00\x00")
            + segment(0xDB, b"\x00" + b"\x01" * 64)
            + segment(0xC0, struct.pack(">BHHB", 8, height, width, 1) + b"\x01\x11\x00")
            + segment(0xC4, b"\x00" + one_code) + segment(0xC4, b"\x10" + one_code)
            + segment(0xDA, b"\x01\x01\x00\x00\x3f\x00") + scan + b"\xff\xd9")


def self_test():
    def build(root, mutate=None):
        os.makedirs(os.path.join(root, "images"))
        for frame in (0, 1):
            with open(os.path.join(root, "images", "0000_%06d.jpg" % frame), "wb") as f:
                f.write(baseline_jpeg(64, 48))
        doc = {"info": {"description": "self-test"}, "licenses": [],
               "categories": [{"id": 1, "name": "person"}, {"id": 3, "name": "car"}],
               "images": [{"id": i + 1, "file_name": "0000_%06d.jpg" % i, "width": 64, "height": 48,
                           "sequence": "0000", "frame": i} for i in (0, 1)],
               "annotations": [{"id": 1, "image_id": 1, "category_id": 3, "bbox": [10.5, 12, 20, 18.25],
                                "area": 365.0, "iscrowd": 0, "track_id": 0, "ttc_s": None},
                               {"id": 2, "image_id": 2, "category_id": 1, "bbox": [40, 8, 24, 40],
                                "area": 960, "iscrowd": 0, "track_id": 1, "ttc_s": 1.9}]}
        if mutate:
            mutate(doc, root)
        with open(os.path.join(root, "annotations.json"), "w") as f:
            json.dump(doc, f)

    def jpeg_size_wrong(doc, root):
        with open(os.path.join(root, "images", "0000_000001.jpg"), "wb") as f:
            f.write(baseline_jpeg(64, 40))

    broken = [("box past the edge", lambda d, r: d["annotations"][1]["bbox"].__setitem__(0, 40.01), "leaves"),
              ("file name", lambda d, r: d["images"][1].__setitem__("sequence", "0001"), "SSSS_NNNNNN"),
              ("area not w*h", lambda d, r: d["annotations"][0].__setitem__("area", 366.0), "area"),
              ("unknown image", lambda d, r: d["annotations"][1].__setitem__("image_id", 9), "image_id"),
              ("duplicate id", lambda d, r: d["annotations"][1].__setitem__("id", 1), "already used"),
              ("iscrowd true", lambda d, r: d["annotations"][0].__setitem__("iscrowd", True), "iscrowd"),
              ("car id 2", lambda d, r: d["categories"][1].__setitem__("id", 2), "COCO's is 3"),
              ("JPEG size", jpeg_size_wrong, "the entry says")]
    root = tempfile.mkdtemp(prefix="coco_selftest_")
    try:
        good = os.path.join(root, "good")
        build(good)
        summary = read_export(good)
        assert summary["annotations"] == 2 and summary["images"] == 2, summary
        assert summary["boxes"]["0000_000000.jpg"] == [[10.5, 12, 20, 18.25, 3, 0]], summary
        for n, (what, mutate, expected) in enumerate(broken):
            bad = os.path.join(root, "bad%d" % n)
            build(bad, mutate)
            try:
                read_export(bad)
            except Violation as v:
                assert expected in str(v), (what, str(v))
                print("self-test: rejected (%s): %s" % (what, v), file=sys.stderr)
            else:
                raise AssertionError("accepted a broken export: " + what)
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
    except (Violation, OSError) as error:
        print("read_coco: %s" % error, file=sys.stderr)
        return 1
    print(json.dumps(summary, sort_keys=True))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
