#!/usr/bin/env python3
"""Reference values for tests/app/io/test_external_files.cpp, computed by the established readers
(nibabel for NIfTI, pydicom for DICOM) on the test files Debian ships with them (python3-nibabel,
python3-pydicom). Run with those packages installed:  /usr/bin/python3 make_reference.py > reference.json
Per file: the image size, the RAS+ affine of voxel indices to world millimetres, and the sum, sum of
squares, minimum and maximum of the (rescaled) values of the volume compared - for 4D images, of
volume `frame`. Compressed DICOM that pydicom cannot decode without plugins is compared, by the C++
test, with the uncompressed file it was made from (lossless) instead."""
import json
import sys

import numpy as np

NIB = "nibabel/tests/data/"
DCM = "pydicom/data/test_files/"


def stats(a):
    a = np.asarray(a, dtype=np.float64)
    return {"sum": float(a.sum()), "sumsq": float((a * a).sum()), "min": float(a.min()), "max": float(a.max())}


def nifti(name, frame=0):
    import nibabel as nib
    im = nib.load(sys.argv[1] + "/" + NIB + name if len(sys.argv) > 1 else "/usr/lib/python3/dist-packages/" + NIB + name)
    data = im.get_fdata()
    if data.ndim == 4:
        data = data[..., frame]
    shape = list(data.shape) + [1] * (3 - data.ndim)
    r = {"file": NIB + name, "frame": frame, "dims": shape[:3], "affine": im.affine.tolist(),
         "frames": int(np.prod(im.shape[3:])) if len(im.shape) > 3 else 1}
    r.update(stats(data))
    return r


def dicom(name):
    import pydicom
    ds = pydicom.dcmread((sys.argv[1] + "/" if len(sys.argv) > 1 else "/usr/lib/python3/dist-packages/") + DCM + name)
    a = ds.pixel_array.astype(np.float64) * float(getattr(ds, "RescaleSlope", 1) or 1) + float(getattr(ds, "RescaleIntercept", 0) or 0)
    r = {"file": DCM + name, "frame": 0, "dims": [int(ds.Columns), int(ds.Rows), 1], "affine": None, "frames": 1,
         "transfer_syntax": str(ds.file_meta.TransferSyntaxUID)}
    r.update(stats(a.T))
    if not all(hasattr(ds, k) for k in ("ImageOrientationPatient", "ImagePositionPatient", "PixelSpacing")):
        return r  # no geometry to compare (the reader assumes one and says so)
    # RAS affine: DICOM's LPS with x and y negated; i along a row (row cosine), j down a column.
    iop = [float(v) for v in ds.ImageOrientationPatient]
    ipp = [float(v) for v in ds.ImagePositionPatient]
    ps = [float(v) for v in ds.PixelSpacing]  # row spacing (between rows), column spacing
    flip = np.diag([-1.0, -1.0, 1.0])
    row, col = flip @ np.array(iop[:3]), flip @ np.array(iop[3:])
    aff = np.eye(4)
    aff[:3, 0] = row * ps[1]
    aff[:3, 1] = col * ps[0]
    aff[:3, 2] = np.cross(row, col)  # one slice: its direction; the spacing is not compared
    aff[:3, 3] = flip @ np.array(ipp)
    r["affine"] = aff.tolist()
    return r


def main():
    out = []
    for name, frame in [("anatomical.nii", 0), ("example4d.nii.gz", 0), ("example4d.nii.gz", 1), ("example_nifti2.nii.gz", 1),
                        ("functional.nii", 7), ("standard.nii.gz", 0), ("reoriented_anat_moved.nii", 0)]:
        out.append(nifti(name, frame))
    for name in ["CT_small.dcm", "MR_small.dcm", "MR_small_bigendian.dcm", "MR_small_expb.dcm", "MR_small_implicit.dcm", "MR_small_padded.dcm",
                 "MR_small_RLE.dcm", "image_dfl.dcm"]:
        out.append(dicom(name))
    json.dump(out, sys.stdout, indent=1)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
