#!/usr/bin/env python3
"""Recompress a gzip (or plain) file as BGZF, the blocked gzip of htslib's `bgzip`.

Every member holds at most 65,280 bytes of data and says its own size in a `BC` extra
field, so a reader finds the members without inflating them and can inflate them on every
thread (`isir::io::input`); any gzip reader still reads the file as before (members one
after the other). The built-in conference room is shipped so:

    python3 tools/bgzf.py crates/isir/data/conference/conference.obj.gz

rewrites the file in place (through a temporary file, then a rename); the data inside is
the same bytes, which the script checks before replacing anything.
"""
import gzip
import os
import struct
import sys
import tempfile
import zlib

BLOCK = 0xFF00  # bgzip's block: its members stay under 64 KiB even if incompressible
EOF_MEMBER = bytes.fromhex("1f8b08040000000000ff0600424302001b0003000000000000000000")


def bgzf(data: bytes, level: int = 9) -> bytes:
    out = bytearray()
    for i in range(0, len(data), BLOCK):
        block = data[i : i + BLOCK]
        c = zlib.compressobj(level, zlib.DEFLATED, -15, 9)
        deflated = c.compress(block) + c.flush()
        size = 18 + len(deflated) + 8
        assert size <= 1 << 16, "a member over 64 KiB"
        out += b"\x1f\x8b\x08\x04\0\0\0\0\0\xff" + struct.pack("<H", 6) + b"BC" + struct.pack("<HH", 2, size - 1)
        out += deflated + struct.pack("<II", zlib.crc32(block) & 0xFFFFFFFF, len(block))
    return bytes(out + EOF_MEMBER)


def main() -> None:
    if len(sys.argv) != 2:
        sys.exit("usage: bgzf.py FILE.gz")
    path = sys.argv[1]
    with open(path, "rb") as f:
        raw = f.read()
    data = gzip.decompress(raw) if raw[:2] == b"\x1f\x8b" else raw
    out = bgzf(data)
    if gzip.decompress(out) != data:
        sys.exit(f"{path}: the BGZF bytes do not inflate to the data; nothing written")
    fd, tmp = tempfile.mkstemp(dir=os.path.dirname(os.path.abspath(path)), prefix=".bgzf-")
    with os.fdopen(fd, "wb") as f:
        f.write(out)
    os.chmod(tmp, 0o644)
    os.replace(tmp, path if raw[:2] == b"\x1f\x8b" else path + ".gz")
    print(f"{path}: {len(data)} bytes in {len(out)} bytes of BGZF ({len(raw)} before)")


if __name__ == "__main__":
    main()
