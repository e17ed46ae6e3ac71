#!/usr/bin/python3
"""An independent binary G-code (.bgcode) writer for tests, written from the published
specification (libbgcode doc/specifications.md), not from the reader it tests.

    bgcode_encode.py IN.gcode OUT.bgcode COMPRESSION ENCODING [--no-crc] [--no-spaces]
                     [--block-size N]

    bgcode_encode.py --heatshrink-decode IN OUT WINDOW_BITS LOOKAHEAD_BITS SIZE

    bgcode_encode.py --decode IN.bgcode OUT.gcode

--decode writes the G-code blocks' text only (CRC checked, decompressed, MeatPack decoded by
meatpack_decode below, written from Marlin's format, not from our reader).

COMPRESSION: 0 none, 1 Deflate (zlib), 2 Heatshrink 11/4, 3 Heatshrink 12/4 (own encoder below).
ENCODING of the G-code blocks: 0 text, 1 MeatPack (comments dropped), 2 MeatPack with comments
(own encoder below). Blocks: file metadata, printer metadata, a thumbnail, print metadata,
slicer metadata, then the G-code in blocks of about --block-size bytes cut at line ends.
"""
import struct
import sys
import zlib


def heatshrink_encode(data: bytes, window_bits: int, lookahead_bits: int) -> bytes:
    """LZSS as heatshrink encodes it: bits MSB first; 1 + 8 bits = a literal; 0 + window_bits
    (distance - 1) + lookahead_bits (count - 1) = a back-reference; zero bits pad the last byte."""
    bits = []

    def put(value, n):
        for i in range(n - 1, -1, -1):
            bits.append((value >> i) & 1)

    max_dist = 1 << window_bits
    max_len = 1 << lookahead_bits
    chains = {}  # 2-byte prefix -> positions, newest last (candidates for a match)
    i = 0
    n = len(data)

    def remember(k):
        if k + 1 < n:
            chains.setdefault(data[k:k + 2], []).append(k)

    while i < n:
        best_len, best_dist = 0, 0
        for j in reversed(chains.get(data[i:i + 2], [])[-64:]):
            dist = i - j
            if dist > max_dist:
                break
            length = 0
            # overlapping copies are allowed (the decoder copies byte by byte)
            while length < max_len and i + length < n and data[j + length] == data[i + length]:
                length += 1
            if length > best_len:
                best_len, best_dist = length, dist
                if length == max_len:
                    break
        if best_len >= 2:
            put(0, 1)
            put(best_dist - 1, window_bits)
            put(best_len - 1, lookahead_bits)
            for k in range(i, i + best_len):
                remember(k)
            i += best_len
        else:
            put(1, 1)
            put(data[i], 8)
            remember(i)
            i += 1
    while len(bits) % 8:
        bits.append(0)
    out = bytearray()
    for k in range(0, len(bits), 8):
        b = 0
        for bit in bits[k:k + 8]:
            b = (b << 1) | bit
        out.append(b)
    return bytes(out)


def heatshrink_decode(data: bytes, window_bits: int, lookahead_bits: int, size: int) -> bytes:
    """heatshrink's decoder as its library runs it: a circular window of 2**window_bits bytes,
    zero-filled at the start, the index read in two parts (its high window_bits - 8 bits, then
    8), output stopped at `size` bytes."""
    window = bytearray(1 << window_bits)
    mask = len(window) - 1
    head = 0
    pos = 0
    out = bytearray()

    def get(n):
        nonlocal pos
        if pos + n > len(data) * 8:
            return None
        v = 0
        for _ in range(n):
            v = (v << 1) | ((data[pos >> 3] >> (7 - (pos & 7))) & 1)
            pos += 1
        return v

    while len(out) < size:
        tag = get(1)
        if tag is None:
            break
        if tag:
            c = get(8)
            if c is None:
                break
            window[head & mask] = c
            head += 1
            out.append(c)
            continue
        hi = get(window_bits - 8) if window_bits > 8 else 0
        lo = get(min(window_bits, 8))
        count = get(lookahead_bits)
        if hi is None or lo is None or count is None:
            break
        back = ((hi << 8) | lo) + 1
        for _ in range(count + 1):
            c = window[(head - back) & mask]
            window[head & mask] = c
            head += 1
            out.append(c)
    if len(out) < size:
        raise SystemExit(f"heatshrink data ends after {len(out)} of {size} bytes")
    return bytes(out[:size])


MP_CODES = "0123456789. \nGX"


def meatpack_encode(text: str, keep_comments: bool, no_spaces: bool) -> bytes:
    """Marlin's MeatPack: two 4-bit codes per byte (first character in the low nibble), 0xF =
    that character follows as a full byte; 0xFF 0xFF 0xFB turns packing on, 0xFF 0xFF 0xF7 the
    no-spaces mode (code 11 = 'E', spaces in commands dropped). A line's closing newline may sit
    in a low nibble with padding in the high one."""
    def code(ch):
        if no_spaces and ch == "E":
            return 11
        if no_spaces and ch == " ":
            return None
        k = MP_CODES.find(ch)
        return k if k >= 0 else None

    out = bytearray(b"\xff\xff\xfb")
    if no_spaces:
        out += b"\xff\xff\xf7"
    for line in text.splitlines():
        semi = line.find(";")
        if semi >= 0 and not keep_comments:
            line = line[:semi]
        line = line.strip()
        if not line:
            continue
        if no_spaces and not line.startswith(";"):
            cmd, sep, comment = line.partition(";")
            line = cmd.replace(" ", "") + sep + comment
        line += "\n"
        if len(line) % 2:
            line += " " if not no_spaces else "0"  # padding after the newline
        for a, b in zip(line[0::2], line[1::2]):
            ca, cb = code(a), code(b)
            if ca is not None and cb is not None:
                out.append(ca | (cb << 4))
            elif ca is None and cb is not None:
                out.append(0xF | (cb << 4))
                out.append(ord(a))
            elif ca is not None and cb is None:
                out.append(ca | 0xF0)
                out.append(ord(b))
            else:
                out.append(0xFF)
                out.append(ord(a))
                out.append(ord(b))
    return bytes(out)


G_PARAMETERS = "XYZEFIJRGPWHCA"


def meatpack_decode(data: bytes, state: dict) -> bytes:
    """Marlin's MeatPack decoder: 0xFF 0xFF <cmd> = a command (0xFB packing on, 0xFA off, 0xF9
    reset, 0xF7 / 0xF6 no-spaces on / off); packed bytes hold two 4-bit codes, the low nibble
    first; 0xF = that character follows as a full byte (the low one's before the high one's); a
    newline in the low nibble ends the byte. Spaces dropped in no-spaces mode are put back as
    the firmware's and PrusaSlicer's readers do: before a parameter letter of a line that starts
    with G, unless a space is already there. `state` carries the modes from block to block."""
    out = bytearray()
    packing, no_spaces = state.get("packing", False), state.get("no_spaces", False)
    g_line, prev = state.get("g_line", False), state.get("prev", 0x0A)

    def emit(ch):
        nonlocal g_line, prev
        c = chr(ch)
        if prev == 0x0A:
            g_line = c == "G"
        elif no_spaces and g_line and c in G_PARAMETERS and prev != 0x20:
            out.append(0x20)
        out.append(ch)
        prev = ch

    def code(n):
        if n == 11 and no_spaces:
            return ord("E")
        return ord(MP_CODES[n])

    i = 0
    n = len(data)
    while i < n:
        b = data[i]
        if b == 0xFF and i + 1 < n and data[i + 1] == 0xFF:
            cmd = data[i + 2]
            if cmd == 0xFB:
                packing = True
            elif cmd in (0xFA, 0xF9):
                packing = False
                if cmd == 0xF9:
                    no_spaces = False
            elif cmd == 0xF7:
                no_spaces = True
            elif cmd == 0xF6:
                no_spaces = False
            i += 3
            continue
        if not packing:
            emit(b)
            i += 1
            continue
        lo, hi = b & 0xF, b >> 4
        i += 1

        def take(nibble):  # a nibble's character, or the full byte that follows for 0xF
            nonlocal i
            if nibble != 0xF:
                return code(nibble)
            i += 1
            return data[i - 1]

        first = take(lo)
        if first == 0x0A and lo != 0xF:
            emit(first)
            continue
        second = take(hi)
        emit(first)
        emit(second)
    state.update(packing=packing, no_spaces=no_spaces, g_line=g_line, prev=prev)
    return bytes(out)


def decode_file(src, dst):
    data = open(src, "rb").read()
    if data[:4] != b"GCDE":
        raise SystemExit("not a bgcode file")
    crc = struct.unpack_from("<H", data, 8)[0] == 1
    pos, text, state = 10, bytearray(), {}
    while pos < len(data):
        kind, compression, size = struct.unpack_from("<HHI", data, pos)
        head = 8
        stored = size
        if compression:
            stored = struct.unpack_from("<I", data, pos + 8)[0]
            head = 12
        params = 6 if kind == 5 else 2
        body = data[pos:pos + head + params + stored]
        if crc:
            want = struct.unpack_from("<I", data, pos + len(body))[0]
            if zlib.crc32(body) & 0xFFFFFFFF != want:
                raise SystemExit(f"CRC mismatch in the block at {pos}")
        encoding = struct.unpack_from("<H", body, head)[0]
        payload = body[head + params:]
        if compression == 1:
            payload = zlib.decompress(payload)
        elif compression in (2, 3):
            payload = heatshrink_decode(payload, 11 if compression == 2 else 12, 4, size)
        if kind == 1:
            text += meatpack_decode(payload, state) if encoding in (1, 2) else payload
        pos += len(body) + (4 if crc else 0)
    open(dst, "wb").write(bytes(text))


def block(kind, compression, params, payload, crc):
    if compression == 0:
        stored = payload
        header = struct.pack("<HHI", kind, 0, len(payload))
    else:
        if compression == 1:
            stored = zlib.compress(payload)
        else:
            stored = heatshrink_encode(payload, 11 if compression == 2 else 12, 4)
        header = struct.pack("<HHII", kind, compression, len(payload), len(stored))
    body = header + params + stored
    if crc:
        body += struct.pack("<I", zlib.crc32(body) & 0xFFFFFFFF)
    return body


def main(argv):
    if argv[1] == "--decode":
        decode_file(argv[2], argv[3])
        return
    if argv[1] == "--heatshrink-decode":
        data = open(argv[2], "rb").read()
        w, lk, size = int(argv[4]), int(argv[5]), int(argv[6])
        open(argv[3], "wb").write(heatshrink_decode(data, w, lk, size))
        return
    src, dst, compression, encoding = argv[1], argv[2], int(argv[3]), int(argv[4])
    crc = "--no-crc" not in argv
    no_spaces = "--no-spaces" in argv
    block_size = 4096
    if "--block-size" in argv:
        block_size = int(argv[argv.index("--block-size") + 1])
    text = open(src, encoding="ascii").read()
    out = bytearray(b"GCDE" + struct.pack("<IH", 1, 1 if crc else 0))
    ini = lambda pairs: "".join(f"{k}={v}\n" for k, v in pairs).encode()
    meta = struct.pack("<H", 0)
    out += block(0, compression, meta, ini([("Producer", "bgcode_encode.py")]), crc)
    out += block(3, compression, meta, ini([("printer_model", "TEST"), ("nozzle_diameter", "0.4")]), crc)
    png = b"\x89PNG\r\n\x1a\n" + bytes(range(64))  # opaque bytes: the reader skips thumbnails
    out += block(5, compression, struct.pack("<HHH", 0, 16, 16), png, crc)
    out += block(4, compression, meta, ini([("estimated printing time (normal mode)", "1m")]), crc)
    out += block(2, compression, meta, ini([("layer_height", "0.2")]), crc)
    lines = text.splitlines(keepends=True)
    chunks, cur = [], ""
    for line in lines:
        cur += line
        if len(cur) >= block_size:
            chunks.append(cur)
            cur = ""
    if cur:
        chunks.append(cur)
    for chunk in chunks:
        if encoding == 0:
            payload = chunk.encode("ascii")
        else:
            payload = meatpack_encode(chunk, keep_comments=encoding == 2, no_spaces=no_spaces)
        out += block(1, compression, struct.pack("<H", encoding), payload, crc)
    open(dst, "wb").write(out)


if __name__ == "__main__":
    main(sys.argv)
