"""A small OpenEXR writer for the command-line tests, in pure Python (independent of the
OpenEXR library the tool reads with): one part, scanlines, half or float channels,
uncompressed or ZIP."""
import struct
import zlib


def zip_block(raw):
    """OpenEXR's ZIP codec on one block: bytes split into even and odd halves, a delta
    predictor, then zlib; stored raw when that is not smaller."""
    t = raw[0::2] + raw[1::2]
    d = bytearray(t)
    for i in range(1, len(t)):
        d[i] = (t[i] - t[i - 1] + 128 + 256) & 0xFF
    packed = zlib.compress(bytes(d))
    return packed if len(packed) < len(raw) else raw


def write_exr(path, width, height, channels, half=False, origin=(0, 0), compression="none"):
    """channels: {name: flat list of width*height values}; scanline file, uncompressed or
    ZIP (blocks of 16 lines)."""
    names = sorted(channels)
    ptype, code = (1, "e") if half else (2, "f")
    lines = {"none": 1, "zip": 16}[compression]

    def attr(name, kind, data):
        return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(data)) + data

    x0, y0 = origin
    box = struct.pack("<iiii", x0, y0, x0 + width - 1, y0 + height - 1)
    chlist = b"".join(n.encode() + b"\0" + struct.pack("<iB3xii", ptype, 0, 1, 1) for n in names) + b"\0"
    header = b"\x76\x2f\x31\x01" + struct.pack("<i", 2)
    header += attr("channels", "chlist", chlist)
    header += attr("compression", "compression", b"\3" if compression == "zip" else b"\0")
    header += attr("dataWindow", "box2i", box)
    header += attr("displayWindow", "box2i", box)
    header += attr("lineOrder", "lineOrder", b"\0")
    header += attr("pixelAspectRatio", "float", struct.pack("<f", 1.0))
    header += attr("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0))
    header += attr("screenWindowWidth", "float", struct.pack("<f", 1.0))
    header += b"\0"
    chunks = []
    for y in range(0, height, lines):
        data = b"".join(struct.pack("<%d%s" % (width, code), *channels[n][width * yy: width * (yy + 1)])
                        for yy in range(y, min(y + lines, height)) for n in names)
        if compression == "zip":
            data = zip_block(data)
        chunks.append(struct.pack("<ii", y0 + y, len(data)) + data)
    offset = len(header) + 8 * len(chunks)
    table = b""
    for c in chunks:
        table += struct.pack("<Q", offset)
        offset += len(c)
    with open(path, "wb") as f:
        f.write(header + table + b"".join(chunks))
