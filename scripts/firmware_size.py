#!/usr/bin/env python3
"""Flash and static RAM of a firmware ELF: the allocated sections summed
(flash: everything placed in flash plus .data's load image; RAM: what is
placed in SRAM). Prints `FLASH RAM` in bytes, or with --vars
`FLASH=…` and `RAM=…` lines."""
import struct
import sys

vars_out = sys.argv[1:2] == ['--vars']
path = sys.argv[2] if vars_out else sys.argv[1]
data = open(path, 'rb').read()
assert data[:4] == b'\x7fELF', 'not an ELF file'
shoff, = struct.unpack_from('<I', data, 0x20)
shentsize, shnum, shstrndx = struct.unpack_from('<HHH', data, 0x2e)


def sec(i):
    return struct.unpack_from('<IIIIIIIIII', data, shoff + i * shentsize)


names = sec(shstrndx)[4]
flash = ram = 0
for i in range(shnum):
    name_off, typ, flags, addr, off, size = sec(i)[:6]
    name = data[names + name_off:data.index(b'\0', names + name_off)].decode()
    if flags & 2:  # SHF_ALLOC
        if 0x08000000 <= addr < 0x08100000:
            flash += size
        elif 0x20000000 <= addr < 0x20020000:
            ram += size
        if name == '.data':
            flash += size
if vars_out:
    print(f'FLASH={flash}')
    print(f'RAM={ram}')
else:
    print(flash, ram)
