# Per-layer area (mm²) of a PrusaSlicer .sl1 archive: sum of grey levels / 255 × pixel area.
import sys, zipfile, zlib, struct, re
import numpy as np
def png_gray(data):
    assert data[:8] == b'\x89PNG\r\n\x1a\n'
    pos = 8; idat = b''; w = h = None
    while pos < len(data):
        n, = struct.unpack('>I', data[pos:pos+4]); typ = data[pos+4:pos+8]; body = data[pos+8:pos+8+n]
        if typ == b'IHDR':
            w, h, depth, ctype = struct.unpack('>IIBB', body[:10]); assert depth == 8 and ctype == 0, (depth, ctype)
        elif typ == b'IDAT': idat += body
        pos += 12 + n
    raw = np.frombuffer(zlib.decompress(idat), dtype=np.uint8).reshape(h, w + 1)
    if not raw[:, 0].any():  # filter "none" on every row (what PrusaSlicer 2.5 writes)
        return raw[:, 1:]
    out = np.zeros((h, w), dtype=np.int32); prev = np.zeros(w, dtype=np.int32)
    for y in range(h):
        f = raw[y, 0]; line = raw[y, 1:].astype(np.int32)
        if f == 0: cur = line
        elif f == 1:
            cur = np.cumsum(line) % 256  # Sub with bpp 1: running sum
        elif f == 2: cur = (line + prev) % 256
        else:
            cur = np.zeros(w, dtype=np.int32)
            for x in range(w):
                a = cur[x-1] if x else 0; b = prev[x]; c = prev[x-1] if x else 0
                if f == 3: p = (a + b) // 2
                else:
                    pa, pb, pc = abs(b - c), abs(a - c), abs(a + b - 2*c)
                    p = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                cur[x] = (line[x] + p) % 256
        out[y] = cur; prev = cur
    return out
z = zipfile.ZipFile(sys.argv[1]); px = float(sys.argv[2])
names = sorted(n for n in z.namelist() if n.endswith('.png') and re.search(r'\d{5}\.png$', n))
for n in names:
    g = png_gray(z.read(n))
    print(f"{g.sum(dtype=np.int64) / 255.0 * px * px:.4f}")
