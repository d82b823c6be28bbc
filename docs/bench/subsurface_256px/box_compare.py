"""relMSE and mean of an image against a reference over all pixels and over the translucent
pixels: those where MASK.exr (a Photon render with --exr-layer V --passes) has a non-zero
Subsurface pass, less a 1-pixel rim.

Usage: .venv/bin/python docs/bench/subsurface_256px/box_compare.py IMAGE.exr REF.exr MASK.exr
"""
import sys
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scenes" / "blender"))
import numpy as np
from refimage import read_exr, rel_mse
img, ref, mask = read_exr(sys.argv[1]), read_exr(sys.argv[2]), read_exr(sys.argv[3], ("V.Subsurface.R", "V.Subsurface.G", "V.Subsurface.B"))
m = mask.sum(axis=2) > 1e-4
# erode by one pixel so the box's silhouette (filter-mixed with the floor) is out
e = m.copy(); e[1:] &= m[:-1]; e[:-1] &= m[1:]; e[:, 1:] &= m[:, :-1]; e[:, :-1] &= m[:, 1:]
box = lambda a: a[e][None]
print(f"all relMSE {rel_mse(img, ref):.5f} mean {img.mean()/ref.mean()-1:+.2%} | box ({e.sum()} px) relMSE {rel_mse(box(img), box(ref)):.5f} mean {img[e].mean()/ref[e].mean()-1:+.2%} RGB " + " ".join(f"{img[e][:,c].mean()/ref[e][:,c].mean()-1:+.2%}" for c in range(3)))
