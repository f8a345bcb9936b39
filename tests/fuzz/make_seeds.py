#!/usr/bin/env python3
"""Writes the fuzzers' seed corpus (tests/fuzz/corpus/): tiny valid inputs for each reader, made
here so that no data file of unknown origin is committed. Run from anywhere; rewrites the files."""
import gzip
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))


def out(kind, name, data):
    d = os.path.join(HERE, "corpus", kind)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(data)


def nifti1(dims, datatype, bitpix, voxels, sform=True):
    """NIfTI-1 single file (.nii): 348-byte header, 4-byte extension flag, data at 352."""
    h = bytearray(348)
    struct.pack_into("<i", h, 0, 348)
    dim = [3, dims[0], dims[1], dims[2], 1, 1, 1, 1]
    struct.pack_into("<8h", h, 40, *dim)
    struct.pack_into("<h", h, 70, datatype)
    struct.pack_into("<h", h, 72, bitpix)
    struct.pack_into("<8f", h, 76, 1.0, 0.8, 0.8, 2.5, 0, 0, 0, 0)
    struct.pack_into("<f", h, 108, 352.0)  # vox_offset
    struct.pack_into("<f", h, 112, 1.0)  # scl_slope
    struct.pack_into("<f", h, 116, 0.0)  # scl_inter
    struct.pack_into("<h", h, 252, 0)  # qform_code
    struct.pack_into("<h", h, 254, 1 if sform else 0)  # sform_code
    struct.pack_into("<4f", h, 280, 0.8, 0, 0, -10)
    struct.pack_into("<4f", h, 296, 0, 0.8, 0, -20)
    struct.pack_into("<4f", h, 312, 0, 0, 2.5, 5)
    h[344:348] = b"n+1\0"
    return bytes(h) + b"\0\0\0\0" + voxels


def dicom_slice(k, rows=6, cols=5):
    """A CT slice, Explicit VR Little Endian, int16 pixels."""
    def el(group, elem, vr, value):
        if isinstance(value, str):
            value = value.encode()
            if len(value) % 2:
                value += b"\0" if vr == "UI" else b" "
        if vr in ("OB", "OW", "SQ", "UN", "UT"):
            return struct.pack("<HH2sHI", group, elem, vr.encode(), 0, len(value)) + value
        return struct.pack("<HH2sH", group, elem, vr.encode(), len(value)) + value

    us = lambda v: struct.pack("<H", v)
    sop = "1.2.826.0.1.3680043.10.543.7.%d" % (k + 1)
    meta = (el(0x0002, 0x0001, "OB", b"\0\1") + el(0x0002, 0x0002, "UI", "1.2.840.10008.5.1.4.1.1.2") +
            el(0x0002, 0x0003, "UI", sop) + el(0x0002, 0x0010, "UI", "1.2.840.10008.1.2.1"))
    meta = el(0x0002, 0x0000, "UL", struct.pack("<I", len(meta))) + meta
    pixels = b"".join(struct.pack("<h", (i * 37 + k * 11) % 400 - 100) for i in range(rows * cols))
    body = (el(0x0008, 0x0016, "UI", "1.2.840.10008.5.1.4.1.1.2") + el(0x0008, 0x0018, "UI", sop) +
            el(0x0008, 0x0060, "CS", "CT") + el(0x0018, 0x0050, "DS", "2.5") +
            el(0x0020, 0x000D, "UI", "1.2.826.0.1.3680043.10.543.1") +
            el(0x0020, 0x000E, "UI", "1.2.826.0.1.3680043.10.543.2") + el(0x0020, 0x0013, "IS", str(k + 1)) +
            el(0x0020, 0x0032, "DS", "-10\\-20\\%g" % (5 + 2.5 * k)) + el(0x0020, 0x0037, "DS", "1\\0\\0\\0\\1\\0") +
            el(0x0028, 0x0002, "US", us(1)) + el(0x0028, 0x0004, "CS", "MONOCHROME2") +
            el(0x0028, 0x0010, "US", us(rows)) + el(0x0028, 0x0011, "US", us(cols)) +
            el(0x0028, 0x0030, "DS", "0.8\\0.8") + el(0x0028, 0x0100, "US", us(16)) + el(0x0028, 0x0101, "US", us(16)) +
            el(0x0028, 0x0102, "US", us(15)) + el(0x0028, 0x0103, "US", us(1)) + el(0x0028, 0x1052, "DS", "-1024") +
            el(0x0028, 0x1053, "DS", "1") + el(0x7FE0, 0x0010, "OW", pixels))
    return b"\0" * 128 + b"DICM" + meta + body


def main():
    i16 = b"".join(struct.pack("<h", (i * 53) % 900 - 300) for i in range(4 * 3 * 2))
    out("nifti", "int16-4x3x2.nii", nifti1((4, 3, 2), 4, 16, i16))
    out("nifti", "int16-4x3x2.nii.gz", gzip.compress(nifti1((4, 3, 2), 4, 16, i16), mtime=0))
    out("nifti", "uint8-labels-3x3x3.nii", nifti1((3, 3, 3), 2, 8, bytes(i % 5 for i in range(27)), sform=False))
    out("nifti", "float32-2x2x2.nii", nifti1((2, 2, 2), 16, 32, b"".join(struct.pack("<f", v * 0.5) for v in range(8))))
    # NRRD: attached headers, raw and gzip, LPS with directions, a list axis, no space.
    hdr = (b"NRRD0004\ntype: short\ndimension: 3\nspace: left-posterior-superior\nsizes: 4 3 2\n"
           b"space directions: (0.8,0,0) (0,0.8,0) (0,0,2.5)\nkinds: domain domain domain\nendian: little\n")
    out("nrrd", "lps-raw.nrrd", hdr + b"encoding: raw\nspace origin: (1,2,3)\n\n" + i16)
    out("nrrd", "lps-gzip.nrrd", hdr + b"encoding: gzip\nspace origin: (1,2,3)\n\n" + gzip.compress(i16, mtime=0))
    out("nrrd", "list-float.nrrd", b"NRRD0004\ntype: float\ndimension: 4\nspace: right-anterior-superior\nsizes: 2 2 2 2\n"
        b"space directions: none (1,0,0) (0,1,0) (0,0,1)\nkinds: list domain domain domain\nendian: little\nencoding: raw\n\n"
        + b"".join(struct.pack("<f", v * 0.25) for v in range(16)))
    out("nrrd", "nospace-uint8.nrrd", b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 3 3 3\nspacings: 1 1 2\nencoding: ascii\n\n"
        + b" ".join(str(i % 5).encode() for i in range(27)) + b"\n")
    # MetaImage: one file, raw and zlib, an oblique grid, 4D with channels, big-endian 2D.
    mha = (b"ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
           b"TransformMatrix = 0 1 0 -1 0 0 0 0 1\nOffset = 1 2 3\nElementSpacing = 0.8 0.8 2.5\nDimSize = 4 3 2\n"
           b"ElementType = MET_SHORT\n")
    out("metaimage", "oblique-raw.mha", mha + b"ElementDataFile = LOCAL\n" + i16)
    out("metaimage", "oblique-zlib.mha", mha.replace(b"DimSize", b"CompressedData = True\nDimSize") + b"ElementDataFile = LOCAL\n"
        + zlib.compress(i16))
    out("metaimage", "4d-channels.mha", b"NDims = 4\nDimSize = 2 2 1 2\nElementNumberOfChannels = 2\nElementType = MET_FLOAT\n"
        b"ElementDataFile = LOCAL\n" + b"".join(struct.pack("<f", v * 0.25) for v in range(16)))
    out("metaimage", "msb-2d.mha", b"ObjectType = Image\nNDims = 2\nDimSize = 3 2\nElementByteOrderMSB = True\nElementType = MET_USHORT\n"
        b"ElementDataFile = LOCAL\n" + b"".join(struct.pack(">H", v * 1000) for v in range(6)))
    # The DICOM fuzzer splits its input into files at "\n--slice--\n": a one- and a two-slice series.
    sep = b"\n--slice--\n"
    out("dicom", "one-slice.dcm", dicom_slice(0))
    out("dicom", "two-slices.bin", dicom_slice(0) + sep + dicom_slice(1))
    out("script", "minimal.json", b'{"format": "handson-session", "version": 1, "events": []}')
    out("script", "touches-and-ui.json", b'{"format": "handson-session", "version": 1, "volume": {"source": "phantom"}, '
        b'"viewport": [64, 48], "mode": "select", "camera": {"target": [0, 0, 0], "distance": 500, "azimuth_deg": 90, '
        b'"elevation_deg": 0, "roll_deg": 0, "fov_deg": 35}, "events": [{"t": 0, "touch": "down", "id": 1, "x": 10, "y": 12}, '
        b'{"t": 0.1, "touch": "move", "id": 1, "x": 14, "y": 12, "pressure": 0.5}, {"t": 0.2, "touch": "up", "id": 1, "x": 14, "y": 12}, '
        b'{"t": 0.3, "ui": "handle-status", "value": "1:fixed"}, {"t": 0.4, "ui": "undo"}, {"t": 0.5, "ui": "export"}]}')


if __name__ == "__main__":
    main()
