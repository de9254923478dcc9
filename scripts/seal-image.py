#!/usr/bin/env python3
"""Seal a firmware ELF: write the CRC-32 of its flash image into IMAGE_SEAL.

The firmware checks the image against this seal at start-up and again in
the background (firmware/src/stm32/diagnostics.rs). The image runs from the
flash origin to the end of `.data`'s load image; gaps read as erased flash
(0xFF) and the seal word itself counts as 0xFFFFFFFF.

    scripts/seal-image.py ELF            seal in place
    scripts/seal-image.py --check ELF    exit 1 unless the seal matches
"""
import struct
import sys
import zlib

FLASH = (0x0800_0000, 0x0810_0000)
MAGIC = struct.pack('<II', 0x4C4D_5345, 0x414C_2121)
UNSEALED = 0xFFFF_FFFF


def fail(msg):
    print(f'seal-image: {msg}', file=sys.stderr)
    sys.exit(1)


def parse(data):
    if data[:4] != b'\x7fELF' or data[4] != 1:
        fail('not a 32-bit ELF file')
    phoff, shoff = struct.unpack_from('<II', data, 0x1C)
    phentsize, phnum, shentsize, shnum, shstrndx = struct.unpack_from('<HHHHH', data, 0x2A)
    segments = []
    for i in range(phnum):
        typ, off, vaddr, paddr, filesz = struct.unpack_from('<IIIII', data, phoff + i * phentsize)
        if typ == 1 and filesz and FLASH[0] <= paddr < FLASH[1]:  # PT_LOAD in flash
            segments.append((off, vaddr, paddr, filesz))
    symbols = {}
    sections = [struct.unpack_from('<IIIIIIIIII', data, shoff + i * shentsize) for i in range(shnum)]
    for sh in sections:
        if sh[1] == 2:  # SHT_SYMTAB
            strtab = sections[sh[6]]
            for k in range(sh[5] // 16):
                name, value = struct.unpack_from('<II', data, sh[4] + k * 16)
                end = data.index(b'\0', strtab[4] + name)
                symbols[data[strtab[4] + name:end].decode()] = value
    return segments, symbols


def image(data, segments, seal_addr):
    start = FLASH[0]
    end = max(p + n for _, _, p, n in segments)
    img = bytearray(b'\xff' * (end - start))
    for off, _, paddr, n in segments:
        img[paddr - start:paddr - start + n] = data[off:off + n]
    at = seal_addr - start
    img[at:at + 4] = struct.pack('<I', UNSEALED)
    return img


def main():
    check = sys.argv[1:2] == ['--check']
    args = sys.argv[2:] if check else sys.argv[1:]
    if len(args) != 1:
        fail(__doc__.strip().splitlines()[-2].strip())
    path = args[0]
    data = bytearray(open(path, 'rb').read())
    segments, symbols = parse(data)
    if 'IMAGE_SEAL' not in symbols:
        fail(f'{path}: no IMAGE_SEAL symbol')
    base = symbols['IMAGE_SEAL']
    seal_addr = base + 8
    for off, vaddr, _, n in segments:
        if vaddr <= base and seal_addr + 4 <= vaddr + n:
            seal_off = off + seal_addr - vaddr
            break
    else:
        fail(f'{path}: IMAGE_SEAL is not in a flash load segment')
    if data[seal_off - 8:seal_off] != MAGIC:
        fail(f'{path}: IMAGE_SEAL magic not found at its symbol')
    img = image(data, segments, seal_addr)
    expected_end = symbols['__sidata'] + symbols['__edata'] - symbols['__sdata']
    if FLASH[0] + len(img) != expected_end:
        fail(f'{path}: image ends at {FLASH[0] + len(img):#x}, the firmware reads to {expected_end:#x}')
    crc = zlib.crc32(img)
    stored, = struct.unpack_from('<I', data, seal_off)
    if check:
        if stored != crc:
            fail(f'{path}: seal {stored:#010x} does not match the image ({crc:#010x})')
        print(f'{path}: seal {crc:#010x} matches {len(img)} B')
        return
    struct.pack_into('<I', data, seal_off, crc)
    open(path, 'wb').write(data)
    print(f'{path}: sealed {len(img)} B, CRC-32 {crc:#010x}')


main()
