#!/usr/bin/env python3
"""Reference client for the HazardForge system-under-test line protocol, version 1.

This is a protocol skeleton, not a perception system: it has no image library,
so it never detects anything. Every reply has no detections, "ttc_s": null,
"warning": false and "brake": false. Use it as a starting point for your own
client, or to check that the tool and a program can talk to each other.

You do not run it yourself: `hazardforge test` starts it. A system file's
node `system` names it (docs/testing-a-system.md):
    stage: external_program
    params: {command: [python3, sut_client.py]}
The tool writes one JSON line per frame on stdin and reads one JSON line per
frame from stdout. Anything written to stderr goes to the tool's log file.
In "raw" mode each frame line is followed by exactly "bytes" bytes of BGR
pixels; this client reads and discards them so the next line is found.
Standard library only (Python 3).
"""
import json
import sys


def fail(message):
    sys.stderr.write("sut_client: " + message + "\n")
    sys.exit(2)


def read_exactly(stream, count):
    chunks, left = [], count
    while left > 0:
        chunk = stream.read(left)
        if not chunk:
            fail("stdin ended %d bytes short of a %d-byte raw frame" % (left, count))
        chunks.append(chunk)
        left -= len(chunk)
    return b"".join(chunks)


def main():
    stdin, stdout = sys.stdin.buffer, sys.stdout.buffer
    try:
        hello = json.loads(stdin.readline().decode("utf-8"))
    except ValueError as error:
        fail("the first line is not JSON: %s" % error)
    if not isinstance(hello, dict) or hello.get("type") != "hello":
        fail("the first line is not a hello message")
    if hello.get("protocol") != 1:
        fail("protocol %r is not supported (this client speaks 1)" % hello.get("protocol"))
    raw = hello.get("frames") == "raw"
    for line in iter(stdin.readline, b""):
        if not line.strip():
            continue
        try:
            message = json.loads(line.decode("utf-8"))
        except ValueError as error:
            fail("a frame line is not JSON: %s" % error)
        if not isinstance(message, dict) or message.get("type") != "frame":
            continue
        if "frame" not in message:
            fail("a frame line has no frame number")
        if raw:
            count = message.get("bytes")
            if not isinstance(count, int) or count < 0:
                fail("raw frame %r has no byte count" % message.get("frame"))
            read_exactly(stdin, count)  # the pixels; a real client would look at them
        reply = {"frame": message["frame"], "detections": [], "ttc_s": None,
                 "warning": False, "brake": False}
        stdout.write(json.dumps(reply).encode("utf-8") + b"\n")
        stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
