"""One-time conversion of DAIR's articulated elbow tosses into `elbow_tosses.csv.gz`.

Not imported by physval: kept so that the packaged file can be made again from the source
and checked against it. The source is the DAIRLab/dair_pll repository (BSD 3-Clause), tag
v0.0.2, folder `assets/contactnets_elbow/`: 541 files `<n>.pt`, each one toss saved by
`torch.save` as a (samples, 15) float64 tensor in dair_pll's state order

    [qw qx qy qz | x y z | theta | wx wy wz | vx vy vz | dtheta]

(dair_pll's helpers/copy_contactnets_dataset.py, which made them from the ContactNets
elbow data: quaternion of the base link `elbow_1`, body to world, scalar first; position
of that link's origin, which is its centre of mass, in metres (the ContactNets files were
in half-widths of 0.05 m, multiplied out there); the hinge angle in rad; the base link's
angular velocity in its BODY frame (dair_pll's FloatingBaseSpace; its Drake converter turns
it into the world frame); the base link's velocity in the world frame; the hinge rate).
Samples are 1/148 s apart (the ContactNets capture; dair_pll's DT = 0.0068 s rounds it).

It reads the files without PyTorch: a `.pt` file is a zip holding a pickle that names its
storages, and the storages as raw little-endian bytes; a restricted unpickler rebuilds the
one float64 tensor (anything else in a file is refused). Usage:

    python cases/data/convert_elbow.py DAIR_PLL_CHECKOUT/assets/contactnets_elbow \\
        cases/data/elbow_toss/elbow_tosses.csv.gz

Columns written (one row per sample, SI units): toss, step, t, x, y, z, qw, qx, qy, qz,
theta, vx, vy, vz, wx, wy, wz, dtheta; toss ids are the file numbers; values rounded as
DECIMALS says, below the capture's own precision. 2.7 MB for the 541 tosses.
"""
from __future__ import annotations

import gzip
import io
import pickle
import sys
import zipfile
from pathlib import Path

import numpy as np

SAMPLE_PERIOD = 1.0 / 148.0
COLUMNS = ("toss", "step", "t", "x", "y", "z", "qw", "qx", "qy", "qz", "theta",
           "vx", "vy", "vz", "wx", "wy", "wz", "dtheta")
# dair_pll's order -> ours: (quaternion, position, angle, body angular velocity, velocity, rate)
SOURCE = {"qw": 0, "qx": 1, "qy": 2, "qz": 3, "x": 4, "y": 5, "z": 6, "theta": 7,
          "wx": 8, "wy": 9, "wz": 10, "vx": 11, "vy": 12, "vz": 13, "dtheta": 14}


# Digits kept after the decimal point: 0.01 mm for positions (rounding's standard deviation
# 3e-6 m, 20 times below the capture's noise: samples depart from a quadratic through their
# 5 neighbours by a median 0.06 mm), 1e-5 for quaternions and the hinge angle (that noise
# is 0.03 deg = 5e-4 rad), 1 mm/s and 1e-3 rad/s for the rates (finite differences over
# 1/148 s of those positions: ~0.01 m/s of noise).
DECIMALS = {"x": 5, "y": 5, "z": 5, "qw": 5, "qx": 5, "qy": 5, "qz": 5, "theta": 5,
            "vx": 3, "vy": 3, "vz": 3, "wx": 3, "wy": 3, "wz": 3, "dtheta": 3}


class _Storage:
    """A storage the pickle names: its key in the archive and its element count."""

    def __init__(self, key: str, numel: int):
        self.key, self.numel = key, numel


def _rebuild_tensor_v2(storage, offset, size, stride, requires_grad=False, hooks=None, metadata=None):
    return ("tensor", storage, offset, tuple(size), tuple(stride))


class _Unpickler(pickle.Unpickler):
    """Only what a saved float64 tensor needs; any other global is refused."""

    def find_class(self, module, name):
        if (module, name) == ("torch._utils", "_rebuild_tensor_v2"):
            return _rebuild_tensor_v2
        if (module, name) == ("torch", "DoubleStorage"):
            return "float64"
        if (module, name) == ("collections", "OrderedDict"):
            return dict
        raise pickle.UnpicklingError(f"{module}.{name}: not part of a saved float64 tensor")

    def persistent_load(self, pid):
        kind, dtype, key, _location, numel = pid
        if kind != "storage" or dtype != "float64":
            raise pickle.UnpicklingError(f"storage {pid!r}: expected a float64 storage")
        return _Storage(str(key), int(numel))


def _fixed(value: float, decimals: int) -> str:
    """`value` with `decimals` digits after the point, trailing zeros dropped ("-0" as "0")."""
    text = f"{value:.{decimals}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def read_pt(path: Path) -> np.ndarray:
    """The float64 tensor a `torch.save` file holds, as a numpy array."""
    with zipfile.ZipFile(path) as z:
        names = z.namelist()
        root = names[0].split("/")[0]
        kind, storage, offset, size, stride = _Unpickler(io.BytesIO(z.read(f"{root}/data.pkl"))).load()
        flat = np.frombuffer(z.read(f"{root}/data/{storage.key}"), "<f8")
    if len(flat) != storage.numel:
        raise ValueError(f"{path}: storage holds {len(flat)} values, the pickle says {storage.numel}")
    return np.lib.stride_tricks.as_strided(flat[offset:], size, [s * 8 for s in stride]).copy()


def convert(folder: Path) -> str:
    """The CSV text of every toss in `folder`, in file-number order."""
    lines = [",".join(COLUMNS)]
    for f in sorted(folder.glob("*.pt"), key=lambda p: int(p.stem)):
        a = read_pt(f)
        if a.ndim != 2 or a.shape[1] != 15:
            raise ValueError(f"{f}: shape {a.shape}, expected (samples, 15)")
        for step, row in enumerate(a):
            values = [_fixed(row[SOURCE[c]], DECIMALS[c]) for c in COLUMNS[3:]]
            lines.append(f"{int(f.stem)},{step},{step * SAMPLE_PERIOD:.6f}," + ",".join(values))
    return "\n".join(lines) + "\n"


def main(argv: list[str]) -> int:
    if len(argv) != 2:
        print(__doc__.split("Usage:")[1].split("Columns")[0].strip(), file=sys.stderr)
        return 2
    text = convert(Path(argv[0]))
    with gzip.GzipFile(argv[1], "wb", compresslevel=9, mtime=0) as fh:  # mtime 0: the same bytes every time
        fh.write(text.encode())
    print(f"{argv[1]}: {text.count(chr(10)) - 1} samples, {Path(argv[1]).stat().st_size} bytes")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
