"""The gallery: pictures of the shared datasets (../shared/data), each made by one `dvr render` command,
written to docs/images/gallery-NAME.png, and docs/gallery.md, which shows them with their commands.

    python benchmarks/gallery.py [--data-dir ../shared/data] [--size 512] [--only NAME ...]

The commands are run in-process through the CLI's own entry point, so what the page shows is what made
each picture.  A picture whose data is missing is skipped; the page is written whole either way (its
text depends only on the list below).  The CT bunny takes about 20 s to load (bzip2).
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from dvr_gl.bench import picks

REPO = Path(__file__).resolve().parent.parent
DATA = "../shared/data"  # how the commands name the data folder: beside the repository, from its root
SIZE = 512

# The lobster's shell: a tent over its CT values 100..140 (the lobster bench's transfer function).
LOBSTER = "[[0,0,0,0,0],[100,0.9,0.4,0.2,0],[120,0.9,0.4,0.2,0.6],[140,0.9,0.5,0.3,0],[255,0,0,0,0]]"
# The blunt fin's density (0.19..4.98, world units about 24 across): the shock in front of the fin bright,
# the slow flow faint; opacity per 2.4 units (a tenth of the mesh's diagonal).
BLUNTFIN = ("[[0.19,0.27,0.0,0.33,0],[0.9,0.13,0.57,0.55,0.02],[1.3,0.37,0.79,0.38,0.15],"
            "[3.2,0.99,0.91,0.14,0.6],[4.98,1,1,0.6,0.8]]")
# the default mesh renderer (projected tetrahedra), named in the command so that the page says which drew it
MESH_RENDERER = picks.baseline("mesh")

# name, caption, data file (under DATA; None: a built-in demo), the command's other arguments
PICTURES = [
    ("demo", "The built-in demo (`dvr render --demo`, no data needed): the 3D Shepp-Logan head phantom seen from "
     "above, unshaded: a faint ivory skull around a translucent blue brain, in which the two ventricles "
     "show as a darker hollow and the largest lesion as an orange ellipse; the small lesions hardly show. The "
     "lesions' colour is given by value and gradient magnitude (a 2D transfer function, drawn where the gradient "
     "is low), so the skull's soft inner edge, which passes through the lesions' values, draws no line along "
     "the rim.",
     None, ["--demo"]),
    ("cthead", "CThead (University of North Carolina; Stanford volume archive), the `ct-bone-ivory` preset. "
     "Its slices are stored from the top of the head down, so `--up=-z` stands it upright.",
     "regular/cthead.nhdr", ["--transfer-function", "ct-bone-ivory", "--rescale-intercept", "-1024", "--up=-z",
                             "--shading"]),
    ("cthead-skin", "CThead again, the `ct-skin` preset: skin and soft tissue over faint bone.",
     "regular/cthead.nhdr", ["--transfer-function", "ct-skin", "--rescale-intercept", "-1024", "--up=-z",
                             "--shading"]),
    ("bunny", "The Stanford CT bunny (512 x 512 x 361, int16), `ct-bone-ivory`; the scanner's table cut away by a "
     "cropping box (`renderer.clipping.box`, world units).",
     "large/bunny_ct.nhdr", ["--transfer-function", "ct-bone-ivory", "--rescale-intercept", "-1024", "--up=-z",
                             "--azimuth", "300", "--shading",
                             "--set", "renderer.clipping.box=[[0,0,0],[173,125,181]]"]),
    ("lobster", "The lobster CT (VolVis; The Volume Library, non-commercial use only), its shell as a tent "
     "over the CT values 100 to 140, seen from above.",
     "regular/lobster.nhdr", ["--set", f"transfer_function.points={LOBSTER}", "--shading", "--azimuth", "200",
                              "--elevation", "60", "--distance", "420"]),
    ("mni152", "The MNI ICBM152 2009 T1 template (McConnell Brain Imaging Centre, MNI; NIfTI), seen from the "
     "patient's left: the file's orientation puts the patient upright.",
     "regular/MNI152_2009_template.nii.gz", ["--view", "left", "--shading", "--distance", "480"]),
    ("bluntfin", "NASA's blunt fin as 187,395 tetrahedra, rendered by `projected-tetrahedra` (exact visibility "
     "order): the density's shock ahead of the fin.",
     "unstructured/bluntfin_tets.vtk", ["--renderer", MESH_RENDERER, "--azimuth", "30", "--elevation",
                                        "35", "--set", f"transfer_function.points={BLUNTFIN}",
                                        "--set", "transfer_function.unit_distance=2.4"]),
]


def arguments(name: str, data: str, extra: list[str], data_dir: str = DATA, size: int = SIZE) -> list[str]:
    """The `dvr render` arguments for one picture (without `dvr render`)."""
    volume = ["--volume", f"{data_dir}/{data}"] if data else []
    return [*volume, *extra, "--size", str(size), "-o", f"docs/images/gallery-{name}.png"]


def markdown() -> str:
    """docs/gallery.md: every picture with its caption and command."""
    lines = ["# Gallery", "",
             "Pictures of the shared datasets (`../shared/data`, beside the repository; its README says where "
             "each comes from and on what terms), each made by the command under it, run from the "
             "repository's root. `python benchmarks/gallery.py` makes them all again and writes this page.",
             ""]
    for name, caption, data, extra in PICTURES:
        lines += [f"## {name}", "", f"![{name}](images/gallery-{name}.png)", "", caption, "", "```sh",
                  shlex.join(["dvr", "render", *arguments(name, data, extra)]), "```", ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data-dir", default=str(REPO.parent / "shared" / "data"))
    parser.add_argument("--size", type=int, default=SIZE)
    parser.add_argument("--only", nargs="*", help="these pictures only (names: %s)" % ", ".join(p[0] for p in PICTURES))
    args = parser.parse_args(argv)
    sys.path.insert(0, str(REPO))
    from dvr_gl.apps.cli import main as dvr

    for name, _, data, extra in PICTURES:
        if args.only and name not in args.only:
            continue
        if data and not (Path(args.data_dir) / data).exists():
            print(f"{name}: {args.data_dir}/{data} not found, skipped")
            continue
        render = arguments(name, data, extra, args.data_dir, args.size)
        render[-1] = str(REPO / render[-1])
        if dvr(["render", *render, "--overwrite"]) != 0:
            return 1
    (REPO / "docs" / "gallery.md").write_text(markdown(), encoding="utf-8")
    print(f"wrote {REPO / 'docs' / 'gallery.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
