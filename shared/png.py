"""A minimal PNG codec, standard library only: 8-bit grey or RGB, one IDAT chunk, no row filtering.

Photos (the world's camera, the emulated device) and the lander's traverse map are written with it, so no
process needs an imaging library for them (importing one cost the lander 0.7 s at its first map).
"""

from __future__ import annotations

import struct
import zlib

from schemas.wire_limits import MAX_IMAGE_SIDE

SIGNATURE = b"\x89PNG\r\n\x1a\n"
COLOUR_TYPES = {1: 0, 3: 2}  # channels -> PNG colour type: grey, RGB


def encode(width: int, height: int, pixels: bytes, channels: int = 3, level: int = 6) -> bytes:
    """``pixels``: ``height`` rows of ``width * channels`` bytes, top row first."""
    stride = width * channels
    if channels not in COLOUR_TYPES or width <= 0 or height <= 0 or len(pixels) != height * stride:
        raise ValueError(f"a {width} x {height} PNG with {channels} channel(s) needs {height * stride} bytes, "
                         f"got {len(pixels)}")
    raw = b"".join(b"\x00" + pixels[row * stride:(row + 1) * stride] for row in range(height))
    header = struct.pack(">IIBBBBB", width, height, 8, COLOUR_TYPES[channels], 0, 0, 0)
    return SIGNATURE + _chunk(b"IHDR", header) + _chunk(b"IDAT", zlib.compress(raw, level)) + _chunk(b"IEND", b"")


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)


def decode(data: bytes) -> tuple[int, int, int, bytes]:
    """(width, height, channels, pixels) of a PNG as ``encode`` writes it; anything else is a ValueError."""
    if not data.startswith(SIGNATURE):
        raise ValueError("not a PNG: the signature is missing")
    chunks = _read_chunks(data)
    if [kind for kind, _ in chunks] != [b"IHDR", b"IDAT", b"IEND"]:
        raise ValueError(f"unsupported PNG layout {[k.decode('latin-1') for k, _ in chunks]}: "
                         "expected IHDR, IDAT, IEND")
    header = chunks[0][1]
    if len(header) != 13:
        raise ValueError("PNG IHDR chunk has the wrong length")
    width, height, depth, colour, compression, filtering, interlace = struct.unpack(">IIBBBBB", header)
    channels = {v: k for k, v in COLOUR_TYPES.items()}.get(colour)
    if depth != 8 or channels is None or (compression, filtering, interlace) != (0, 0, 0) or not width or not height:
        raise ValueError(f"unsupported PNG format (bit depth {depth}, colour type {colour}, interlace "
                         f"{interlace}): only 8-bit grey or RGB without interlacing is read")
    if width > MAX_IMAGE_SIDE or height > MAX_IMAGE_SIDE:
        raise ValueError(f"a {width} x {height} PNG is larger than any camera's ({MAX_IMAGE_SIDE} pixels a side)")
    stride = width * channels
    try:  # unpacked no further than the header says: a small file must not expand to gigabytes
        raw = zlib.decompressobj().decompress(chunks[1][1], height * (1 + stride) + 1)
    except zlib.error as exc:
        raise ValueError(f"PNG image data is corrupt: {exc}") from None
    if len(raw) != height * (1 + stride):
        raise ValueError(f"PNG image data has {len(raw)} bytes, expected {height * (1 + stride)}")
    rows = [raw[row * (1 + stride):(row + 1) * (1 + stride)] for row in range(height)]
    if any(row[0] for row in rows):
        raise ValueError("PNG rows use a filter other than 0 (None): not written by this codec")
    return width, height, channels, b"".join(row[1:] for row in rows)


def _read_chunks(data: bytes) -> list[tuple[bytes, bytes]]:
    """Split a PNG after its signature into (type, data) chunks, checking lengths and CRCs."""
    chunks, pos = [], len(SIGNATURE)
    while pos < len(data):
        if pos + 12 > len(data):
            raise ValueError("PNG is truncated inside a chunk header")
        (length,) = struct.unpack(">I", data[pos:pos + 4])
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + length]
        if len(body) != length or pos + 12 + length > len(data):
            raise ValueError(f"PNG chunk {kind!r} is truncated")
        (crc,) = struct.unpack(">I", data[pos + 8 + length:pos + 12 + length])
        if crc != zlib.crc32(kind + body) & 0xFFFFFFFF:
            raise ValueError(f"PNG chunk {kind!r} fails its CRC check")
        chunks.append((kind, body))
        pos += 12 + length
    return chunks
