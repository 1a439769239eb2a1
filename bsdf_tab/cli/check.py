"""``bsdf-tab check LUT``: the LUT doctor (:mod:`bsdf_tab.doctor`).

Reads a LUT (EXR, KTX2, DDS, PNG, ``.npy``, or a C/C++/JS array file with ``--shape``),
identifies what it is against exact tables baked on the fly, and prints the best match, its
error and where, and the mistakes it sees; ``--json`` prints the report as one JSON object,
``--heatmap PNG`` writes the error map.
"""

from __future__ import annotations

import argparse
import json
import sys

from .common import CliError, quiet_warp

NAME = "check"
#: what the handler imports (``main.preload``: with the garbage collector paused)
IMPORTS = ("bsdf_tab.doctor",)
HELP = "identify a LUT file and report what is wrong with it (the LUT doctor)"


def _shape(text: str | None) -> tuple[int, ...] | None:
    """``--shape H,W[,C]`` (one-line CliError when malformed: argparse's own errors print the usage)."""
    if text is None:
        return None
    try:
        shape = tuple(int(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise CliError(f"--shape: give integers separated by commas (32,32 or 16,16,2), got {text!r}") from None
    if not 1 <= len(shape) <= 3 or min(shape) < 1:
        raise CliError(f"--shape: give 1 to 3 positive sizes, got {text!r}")
    return shape


def configure(parser: argparse.ArgumentParser) -> None:
    from ..doctor import ARRAY_VALUES

    parser.add_argument("lut", help="the LUT file: .exr, .ktx2, .dds, .png, .npy, or a C/C++/JS array file")
    parser.add_argument("--json", action="store_true", help="print the report as one JSON object")
    parser.add_argument("--heatmap", metavar="PNG", help="write a heatmap of |file - best match| to this PNG")
    parser.add_argument("--shape", metavar="H,W[,C]", help="shape of an array file's numbers (32,32 or 16,16,2)")
    parser.add_argument("--array-values", default="float", metavar="|".join(ARRAY_VALUES),
                        help="how an array file's numbers are read (float; half: IEEE binary16 bit patterns; "
                             "unorm8, unorm16: integers / 255, / 65535)")
    parser.add_argument("--axes", metavar="NAME[,NAME[,NAME]]",
                        help="the axes you believe the file has, its first axis first (mu,roughness; "
                             "ior,mu,roughness for a 3-D table; roughness for a 1-D average): "
                             "the report says if the data disagrees")
    parser.add_argument("--array-name", metavar="NAME",
                        help="in a C/C++/JS file that initializes several arrays, the one to read "
                             "(e.g. brdf_ggx in eevee_lut.cc)")


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from ..doctor import check_lut

    quiet_warp(args)
    path = Path(args.lut)
    if not path.is_file():
        raise CliError(f"LUT file not found: {path}")
    expect = None
    if args.axes:
        expect = [a.strip() for a in args.axes.split(",")]
        if not 1 <= len(expect) <= 3 or not all(expect):
            raise CliError(f"--axes: give 1 to 3 names, the file's first axis first (mu,roughness), "
                           f"got {args.axes!r}")
    report = check_lut(path, shape=_shape(args.shape), array_values=args.array_values, expect_axes=expect,
                       heatmap=args.heatmap, array_name=args.array_name)
    if args.json:
        print(json.dumps(report.to_dict(), allow_nan=False))
    else:
        print(report.text())
        if args.heatmap:
            print(f"  heatmap: {args.heatmap}", file=sys.stderr)
    return 0
