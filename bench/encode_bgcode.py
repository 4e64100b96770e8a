#!/usr/bin/env python3
"""Encodes a PrusaSlicer text G-code file as binary G-code (.bgcode v1), the way
PrusaSlicer 2.7+ writes it: CRC32 on every block, the file/printer/print metadata taken
from the text's comments, the config block (`; prusaslicer_config = begin ... end`) as
deflated slicer metadata, and the G-code in blocks of at most 64 KiB of text, each
MeatPack-encoded (comment lines kept, "no spaces" on) and heatshrink 12/4 compressed.

It exists because the PrusaSlicer of Debian 12 (2.5) cannot write binary G-code: it makes
a long .bgcode with a text twin for bench/bgcode_bench.cpp from any PrusaSlicer text file.

    prusa-slicer --load samples/configs/ender3_prusaslicer.ini --export-gcode -o big.gcode part.stl
    bench/encode_bgcode.py big.gcode big.bgcode
    PRINTTWIN_BENCH_GCODE=big.gcode PRINTTWIN_BENCH_BGCODE=big.bgcode build/bench/bgcode_bench

Written from the format's description (libbgcode's specification), not from its code.
"""
import struct
import sys
import zlib

WINDOW_BITS, LOOKAHEAD_BITS = 12, 4
BLOCK_TEXT = 65535
PRINTER_KEYS = ("printer_model", "filament_type", "nozzle_diameter", "bed_temperature",
                "brim_width", "fill_density", "layer_height", "temperature", "ironing",
                "support_material", "max_layer_z", "extruder_colour")
PRINT_KEYS = ("filament used [mm]", "filament used [cm3]", "filament used [g]",
              "filament cost", "total filament used [g]", "total filament cost",
              "estimated printing time (normal mode)", "estimated printing time (silent mode)",
              "estimated first layer printing time (normal mode)",
              "estimated first layer printing time (silent mode)")


def heatshrink(data: bytes) -> bytes:
    """LZSS bit stream, MSB first: 1 + 8 bits per literal, 0 + offset-1 + count-1 per
    back-reference; matches found through the last 16 positions of each 3-byte prefix."""
    window, longest = 1 << WINDOW_BITS, 1 << LOOKAHEAD_BITS
    out = bytearray()
    acc = nbits = 0
    chains = {}
    i, n = 0, len(data)
    while i < n:
        best_len = best_off = 0
        key = data[i:i + 3]
        if len(key) == 3:
            for p in reversed(chains.get(key, ())):
                if i - p > window:
                    break
                length = 3
                while length < longest and i + length < n and data[p + length] == data[i + length]:
                    length += 1
                if length > best_len:
                    best_len, best_off = length, i - p
                    if length == longest:
                        break
        if best_len >= 3:
            acc = (acc << (1 + WINDOW_BITS + LOOKAHEAD_BITS)) | ((best_off - 1) << LOOKAHEAD_BITS) | (best_len - 1)
            nbits += 1 + WINDOW_BITS + LOOKAHEAD_BITS
            step = best_len
        else:
            acc = (acc << 9) | 0x100 | data[i]
            nbits += 9
            step = 1
        for k in range(i, min(i + step, n - 2)):
            chain = chains.setdefault(data[k:k + 3], [])
            chain.append(k)
            if len(chain) > 16:
                del chain[0]
        i += step
        while nbits >= 8:
            nbits -= 8
            out.append((acc >> nbits) & 0xFF)
        acc &= (1 << nbits) - 1
    if nbits:
        out.append((acc << (8 - nbits)) & 0xFF)
    return bytes(out)


CODES = {c: i for i, c in enumerate("0123456789.")}
CODES.update({"E": 11, "\n": 12, "G": 13, "X": 14})  # "no spaces": code 11 is 'E'


def meatpack(text: str) -> bytes:
    """MeatPack with comment lines kept and "no spaces" on: G lines lose their spaces,
    every line its inline comment; comment lines go as plain bytes (packing off)."""
    out = bytearray(b"\xff\xff\xfb\xff\xff\xf7")
    packing = True
    for line in text.split("\n"):
        if line.startswith(";"):
            if packing:
                out += b"\xff\xff\xfa"
                packing = False
            out += (line + "\n").encode()
            continue
        line = line.split(";", 1)[0].rstrip()
        if not line:
            continue
        if line[0] == "G":
            line = line.replace(" ", "")
        line += "\n"
        if not packing:
            out += b"\xff\xff\xfb"
            packing = True
        for k in range(0, len(line), 2):
            a = line[k]
            b = line[k + 1] if k + 1 < len(line) else "\n"
            ca, cb = CODES.get(a), CODES.get(b)
            if ca is not None and cb is not None:
                out.append(ca | (cb << 4))
            elif ca is not None:
                out += bytes([ca | 0xF0]) + b.encode()
            elif cb is not None:
                out += bytes([0x0F | (cb << 4)]) + a.encode()
            else:
                out += b"\xff" + a.encode() + b.encode()
    return bytes(out)


def block(kind: int, compression: int, params: bytes, data: bytes) -> bytes:
    stored = {0: lambda d: d, 1: zlib.compress, 3: heatshrink}[compression](data)
    head = struct.pack("<HHI", kind, compression, len(data))
    if compression:
        head += struct.pack("<I", len(stored))
    body = head + params + stored
    return body + struct.pack("<I", zlib.crc32(body))


def ini(pairs) -> bytes:
    return "".join(f"{k}={v}\n" for k, v in pairs).encode()


def main(src: str, dst: str) -> None:
    text = open(src, encoding="utf-8", errors="replace").read()
    config_at = text.find("; prusaslicer_config = begin")
    if config_at < 0:
        sys.exit(f"{src}: no '; prusaslicer_config = begin' block: not a PrusaSlicer file")
    body, config = text[:config_at], text[config_at:]
    settings, comments = [], {}
    for line in config.splitlines()[1:]:
        if line.startswith("; prusaslicer_config = end"):
            break
        if line.startswith("; ") and " = " in line:
            key, value = line[2:].split(" = ", 1)
            settings.append((key.strip(), value.strip()))
    for line in text.splitlines():
        if line.startswith("; ") and " = " in line:
            key, value = line[2:].split(" = ", 1)
            comments.setdefault(key.strip(), value.strip())
    producer = "PrusaSlicer"
    if text.startswith("; generated by "):
        producer = text.split("\n", 1)[0][len("; generated by "):].split(" on ")[0]
    setting = dict(settings)
    printer = [(k, comments.get(k, setting.get(k))) for k in PRINTER_KEYS
               if comments.get(k, setting.get(k)) is not None]
    printed = [(k, comments[k]) for k in PRINT_KEYS if k in comments]
    out = bytearray(b"GCDE" + struct.pack("<IH", 1, 1))
    out += block(0, 0, struct.pack("<H", 0), ini([("Producer", producer)]))
    out += block(3, 0, struct.pack("<H", 0), ini(printer))
    out += block(4, 1, struct.pack("<H", 0), ini(printed))
    out += block(2, 1, struct.pack("<H", 0), ini(settings))
    at = 0
    while at < len(body):
        end = min(len(body), at + BLOCK_TEXT)
        if end < len(body):
            end = body.rfind("\n", at, end) + 1 or end
        out += block(1, 3, struct.pack("<H", 2), meatpack(body[at:end]))
        at = end
    with open(dst, "wb") as f:
        f.write(out)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: encode_bgcode.py TEXT.gcode OUT.bgcode")
    main(sys.argv[1], sys.argv[2])
